#include "problem.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_map>

#include "error.hpp"

namespace ltl {

namespace {

void require(bool ok, const std::string& key, const std::string& message) {
  if (!ok) throw KeyError(key, message);
}

// A facet as its sorted corner nodes (2, 3 or 4 of them; the unused entries -1).
using FacetKey = std::array<int, 4>;
struct FacetKeyHash {
  std::size_t operator()(const FacetKey& k) const {
    std::size_t h = 0;
    for (int a : k) h = h * 1000003u ^ static_cast<std::size_t>(a + 1);
    return h;
  }
};

// For each of `facets`, how many cells of the mesh have it as a facet: 1 on the boundary of the
// mesh, 2 inside it, 0 if its corners are no cell's facet. One pass over every cell's facets,
// looked up in a table of the asked facets alone: memory O(#asked), not a table of every facet
// of the mesh (which held about 360 B per cell, on every rank under mpirun).
std::vector<int> cells_per_facet(const Mesh& mesh, const std::vector<FacetKey>& facets) {
  // Corner-node lists of each cell's facets, in gmsh local numbering.
  static const std::vector<std::vector<int>> tri = {{0, 1}, {1, 2}, {2, 0}};
  static const std::vector<std::vector<int>> hex = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                    {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  static const std::vector<std::vector<int>> tet = {{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}};
  const auto& local = mesh.dim == 2 ? tri : mesh.nodes_per_cell() == 10 ? tet : hex;
  std::unordered_map<FacetKey, int, FacetKeyHash> count;
  for (const FacetKey& k : facets) count.emplace(k, 0);
  for (int c = 0; c < mesh.num_cells(); ++c)
    for (const auto& f : local) {
      FacetKey key = {-1, -1, -1, -1};
      for (std::size_t a = 0; a < f.size(); ++a) key[a] = mesh.cells(c, f[a]);
      std::sort(key.begin(), key.begin() + f.size());
      const auto it = count.find(key);
      if (it != count.end()) ++it->second;
    }
  std::vector<int> out;
  out.reserve(facets.size());
  for (const FacetKey& k : facets) out.push_back(count.at(k));
  return out;
}

// Mean size of the facets of a boundary part: length (2-D), square root of the area (3-D,
// quadrilaterals or triangles from their corners).
double mean_facet_size(const Mesh& mesh, const Mesh::Boundary& b) {
  double sum = 0;
  const Eigen::Index nf = b.facets.rows();
  for (Eigen::Index f = 0; f < nf; ++f) {
    auto x = [&](int k) { return Eigen::Vector3d(mesh.X.row(b.facets(f, k)).transpose()); };
    auto x3 = [&](int k) {
      Eigen::Vector3d v = Eigen::Vector3d::Zero();
      v.head(mesh.dim) = mesh.X.row(b.facets(f, k)).transpose();
      return v;
    };
    if (mesh.dim == 2) {
      sum += (mesh.X.row(b.facets(f, 1)) - mesh.X.row(b.facets(f, 0))).norm();
    } else {
      const bool quad = b.facets.cols() == 4 || b.facets.cols() >= 8;
      const double area = quad ? 0.5 * (x(2) - x(0)).cross(x(3) - x(1)).norm()
                               : 0.5 * (x3(1) - x3(0)).cross(x3(2) - x3(0)).norm();
      sum += std::sqrt(area);
    }
  }
  return nf > 0 ? sum / static_cast<double>(nf) : 0.0;
}

// The mean size of the contact facets of every obstacle (weighted by their counts; the one
// group's mean with one obstacle); 0 when no contact group exists in the mesh.
double mean_contact_facet_size(const Problem& p) {
  double sum = 0, n = 0;
  for (const ContactCondition& cc : p.contacts) {
    if (!p.mesh.has_boundary(cc.group)) continue;
    const Mesh::Boundary& b = p.mesh.boundary(cc.group);
    const double nf = static_cast<double>(b.facets.rows());
    sum += nf * mean_facet_size(p.mesh, b);
    n += nf;
  }
  return n > 0 ? sum / n : 0.0;
}

// Mean cell size (|bounding box| / #cells)^(1/dim), for a problem without contact.
double mean_cell_size(const Mesh& mesh) {
  const Eigen::VectorXd ext = mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff();
  return std::pow(ext.prod() / std::max(1, mesh.num_cells()), 1.0 / mesh.dim);
}

std::string direction_name(Eigen::Vector3d t, int dim) {
  int k = 0;
  t.cwiseAbs().maxCoeff(&k);
  if (t(k) < 0) t = -t;  // the sign of a free direction is arbitrary: show its positive form
  std::ostringstream s;
  s << "(";
  for (int i = 0; i < dim; ++i) s << (i ? ", " : "") << (std::abs(t(i)) < 1e-12 ? 0.0 : t(i));
  s << ")";
  for (int i = 0; i < dim; ++i)
    if (std::abs(std::abs(t(i)) - 1) < 1e-9)
      s << ", the "
        << "xyz"[i] << " direction";
  return s.str();
}

}  // namespace

double LoadRamp::factor(int p, double dt) const {
  switch (kind) {
    case Kind::Linear:
      return std::min(p * dt / ramp_time, 1.0);
    case Kind::Table:
      return table.empty() ? 1.0 : table[std::min<std::size_t>(p, table.size()) - 1];
    default:
      return 1.0;
  }
}

double default_Rq(const Problem& p) {
  const double C = p.material.C1 + (p.material.incompressible() ? p.material.C2 : 0.0);
  return (p.mesh.dim == 2 ? 6 : 8) * C;
}

void derive_algorithm_defaults(Problem& p, bool has_R, bool has_q, bool has_q_c) {
  AlgorithmParams& a = p.algorithm;
  const double C = p.material.C1 + (p.material.incompressible() ? p.material.C2 : 0.0);
  a.q_derived = !has_q;
  a.R_derived = !has_R;
  a.q_c_derived = !has_q_c;
  if (!has_q) a.q = 2 * C;
  if (!has_R) a.R = default_Rq(p) / a.q;
  if (!(a.R_min > 0)) a.R_min = std::min(a.R, default_Rq(p) / a.q);
  if (!has_q_c) {
    a.h = mean_contact_facet_size(p);
    if (!(a.h > 0)) a.h = mean_cell_size(p.mesh);
    if (!(a.h > 0)) a.h = 1;  // a degenerate mesh: validate() and the mesh checks report it
    a.q_c = a.q / ((p.mesh.dim == 2 ? 1 : 3) * a.h);
    // With glue the local contact step (4.7) also holds the glue stiffness kappa = 1/eps: with
    // R q_c well below kappa, beta jumps between 0 and 1 from one iteration to the next and the
    // iteration stalls (a glued block pulled off the plane, kappa = 1e9 Pa/m: q / h = 4e7 Pa/m
    // hits the cap, q_c >= 1.5e8 converges). R q_c >= kappa: as stiff as the glue.
    for (const ContactCondition& cc : p.contacts)  // the stiffest glue of the obstacles
      if (cc.adhesion.kappa > 0) a.q_c = std::max(a.q_c, cc.adhesion.kappa / a.R);
  }
}

std::string describe_algorithm(const AlgorithmParams& a) {
  std::ostringstream s;
  s << "R = " << a.R
    << (a.R_derived ? " (derived: R q = 6 (C1 + C2) in 2-D, 8 (C1 + C2) in 3-D)" : "")
    << ", q = " << a.q << " Pa" << (a.q_derived ? " (derived: 2 (C1 + C2))" : "")
    << ", q_c = " << a.q_c << " Pa/m";
  if (a.q_c_derived)
    s << " (derived: q / h in 2-D, q / (3 h) in 3-D, h = " << a.h
      << " m the mean contact facet size; with glue at least kappa / R)";
  s << "; solver "
    << (a.solver == NonlinearSolver::Newton ? "newton (ALG2, then Newton: newton.hpp)" : "alg2");
  return s.str();
}

namespace {

// A symmetry condition u_c = 0 holds on a plane (a straight line in 2-D): on a curved part it is
// another condition than the user means; on the contact surface it clamps the tangential motion
// there, as a [[fixed]] group would (refused too). A plane of another direction than x_c = const
// is allowed: it is a roller support (one component held), not a symmetry.
void check_symmetry_planes(const Problem& problem) {
  const Mesh& mesh = problem.mesh;
  const double size = (mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff()).maxCoeff();
  for (const auto& d : problem.dirichlet) {
    if (d.components.size() != 1) continue;  // [[fixed]], [[displacement]]: every component
    for (const ContactCondition& cc : problem.contacts)
      if (d.group == cc.group)
        throw KeyError(d.origin, cat("group '", d.group,
                                     "' is both a symmetry plane and the contact surface (a "
                                     "symmetry condition there clamps the sliding, as [[fixed]] "
                                     "would)"));
    // The distance of the nodes from the plane (line) that fits them best: the direction of
    // least spread of their coordinates.
    const std::vector<int> nodes = mesh.boundary_nodes(d.group, d.origin);
    Eigen::MatrixXd x(static_cast<Eigen::Index>(nodes.size()), mesh.dim);
    for (std::size_t i = 0; i < nodes.size(); ++i) x.row(i) = mesh.X.row(nodes[i]);
    const Eigen::RowVectorXd mean = x.colwise().mean();
    x.rowwise() -= mean;
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(x.transpose() * x);
    const double off = (x * es.eigenvectors().col(0)).cwiseAbs().maxCoeff();
    require(off <= 1e-8 * size, d.origin,
            cat("group '", d.group, "' is not ", mesh.dim == 2 ? "straight" : "plane",
                " (its nodes are up to ", off, " m off the best ", mesh.dim == 2 ? "line" : "plane",
                " through them): a symmetry condition holds on a plane only; for a curved part "
                "use [[fixed]] or [[displacement]]"));
  }
}

/// The global matrix (4.5) K = 2 C1 L + R q Gbar^T |O| Gbar + R q_c M^T |G| M adds terms whose
/// scales are 2 C1, R q and R q_c h (h the mean contact facet size; per unit area of a cell, the
/// force of a unit strain). Far apart (C1 = 1e99 Pa, or R = 1e-300), the smaller ones vanish in
/// round-off beside the larger and the factorization fails as if a rigid motion were free, or
/// ALG2 cannot converge: refused when a ratio is outside [1e-10, 1e14] (the figures use 0.3..30;
/// R = 1e12 with q = 1 MPa, 1e12, is still run, and reported not in equilibrium).
void check_stiffness_balance(const Problem& problem) {
  const AlgorithmParams& a = problem.algorithm;
  const double C1 = problem.material.C1;
  const double h = a.h > 0 ? a.h : mean_contact_facet_size(problem);
  const bool contact = mean_contact_facet_size(problem) > 0;  // a contact group in the mesh
  // The laws in principal stretches derive C1 from their shear modulus: named as given.
  const MaterialModel model = problem.material.model;
  const std::string modulus =
      model == MaterialModel::Ogden || model == MaterialModel::Gent ? "material.mu" : "material.C1";
  const auto balanced = [](double ratio) { return ratio >= 1e-10 && ratio <= 1e14; };
  const auto blame = [&](double of_q) {
    // The parameter furthest from its own scale: R (about 1..10), or C1 against q.
    if (std::abs(std::log10(a.R)) >= std::abs(std::log10(of_q))) return std::string("algorithm.R");
    return a.q_derived || C1 < 1e-3 || C1 > 1e13 ? modulus : std::string("algorithm.q");
  };
  const double Rq = a.R * a.q;
  const std::string values = cat(modulus == "material.C1" ? "material.C1 = " : "C1 = mu / 2 = ", C1,
                                 " Pa, algorithm.R = ", a.R, ", algorithm.q = ", a.q, " Pa");
  const std::string fix =
      cat("; leave R, q, q_c out to get the derived values R q = 6 (C1 + C2) (2-D), 8 (C1 + C2) "
          "(3-D), or check the units of ",
          modulus);
  require(balanced(Rq / (2 * C1)), blame(a.q / (2 * C1)),
          cat("the stiffnesses of the global matrix (4.5) are out of balance: R q = ", Rq,
              " Pa is ", Rq / (2 * C1), " times 2 C1 = ", 2 * C1, " Pa (", values,
              "); outside [1e-10, 1e14] the smaller term is lost in round-off (an "
              "ill-conditioned matrix, not a free rigid motion)",
              fix));
  if (contact && h > 0)
    require(balanced(a.R * a.q_c * h / (2 * C1)),
            a.q_c_derived ? blame(a.q / (2 * C1)) : "algorithm.q_c",
            cat("the contact term of the global matrix (4.5) is out of balance: R q_c h = ",
                a.R * a.q_c * h, " Pa (algorithm.q_c = ", a.q_c, " Pa/m, h = ", h,
                " m the mean contact facet size) is ", a.R * a.q_c * h / (2 * C1),
                " times 2 C1 = ", 2 * C1, " Pa (", values,
                "); outside [1e-10, 1e14] the smaller term is lost in round-off (an "
                "ill-conditioned matrix, not a free rigid motion)",
                fix));
}

}  // namespace

/// A prescribed displacement may move its support by at most this many times the size of the
/// body (the diagonal of its bounding box): beyond, a wrong unit or a factor table gone wrong.
constexpr double kMaxSupportMotion = 1000;

/// The largest load factor (1, or the largest |entry| of a table) times each load and each
/// prescribed displacement: a load beyond 1e100 (the limit of every real value) or a support
/// moved by more than kMaxSupportMotion times the size of the body is refused, naming the keys,
/// instead of diverging (NaN, or a residual blow-up) at the first step.
void check_load_factor_scale(const Problem& problem) {
  const Mesh& mesh = problem.mesh;
  double factor = 1;
  for (double f : problem.ramp.table) factor = std::max(factor, std::abs(f));
  const double size =
      mesh.num_nodes() ? (mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff()).norm() : 0;
  if (!(size > 0)) return;
  // Named by the factor when a table makes the value large, else by the value's own key.
  const auto key = [&](const std::string& origin) {
    return factor > 1 ? std::string("load.factor") : origin;
  };
  const auto with = [&](const std::string& what) {
    return factor > 1 ? cat("with the largest factor, ", factor, ", ", what, " ") : std::string();
  };
  const double body = problem.body_force.norm() * factor;
  require(body <= 1e100, key("load.body_force"),
          cat(with("load.body_force"), "is ", body, " N/m^3: above 1e100"));
  for (const auto& t : problem.tractions) {
    const double g = (t.g.value.norm() + t.g.gradient.norm() * size) * factor;
    require(g <= 1e100, key(t.origin), cat(with(t.origin), "reaches ", g, " Pa: above 1e100"));
  }
  for (const auto& d : problem.dirichlet) {
    double u = 0;
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      x.head(mesh.dim) = mesh.X.row(node).transpose();
      u = std::max(u, d.field(x).norm());
    }
    u *= factor;
    std::string origin = d.origin;
    const std::size_t dot = origin.rfind(".group");
    if (dot != std::string::npos && dot + 6 == origin.size()) origin.replace(dot, 6, ".value");
    require(u <= kMaxSupportMotion * size, key(origin),
            cat(with(origin), "moves its support by up to ", u, " m, more than ", kMaxSupportMotion,
                " times the size of the body (", size, " m); check the value and its unit"));
  }
}

/// Two supports ([[fixed]], [[symmetry]], [[displacement]]) that prescribe different values of
/// one displacement component at a node (a group fixed twice, a symmetry plane through a support
/// that moves across it) cannot both hold: the iteration used to run to its cap. Refused, naming
/// both conditions, the node and the two values.
void check_conflicting_supports(const Problem& problem) {
  const Mesh& mesh = problem.mesh;
  struct Given {
    double value;
    const DirichletCondition* by;
  };
  std::vector<std::array<std::optional<Given>, 3>> at(mesh.num_nodes());
  const double size =
      mesh.num_nodes() ? (mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff()).norm() : 0;
  for (const auto& d : problem.dirichlet)
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      x.head(mesh.dim) = mesh.X.row(node).transpose();
      const Eigen::Vector3d u = d.field(x);
      for (int c : d.components) {
        std::optional<Given>& g = at[node][c];
        if (!g) {
          g = Given{u(c), &d};
          continue;
        }
        require(
            std::abs(g->value - u(c)) <= 1e-12 * std::max(size, std::abs(u(c))), d.origin,
            cat("prescribes u_", "xyz"[c], " = ", u(c), " m at node ", node, " (", mesh.X(node, 0),
                ", ", mesh.X(node, 1), mesh.dim == 3 ? cat(", ", mesh.X(node, 2)) : "", "), where ",
                g->by->origin, " prescribes ", g->value,
                " m: two supports cannot both hold; give each node one value"));
      }
    }
}

/// The largest |alpha_p| of an Ogden term accepted: t^alpha_p overflows or vanishes at moderate
/// stretches beyond it (t = 10: 1e100); fits of rubber use |alpha_p| < 30.
constexpr double kMaxOgdenExponent = 100;

void Problem::validate() const {
  const int dim = mesh.dim;
  // Material [LTL87 (1.5), sec. 8].
  // Ogden, Gent (paper_notes/materials.md): each term stable (mu_p alpha_p > 0), |alpha_p| at
  // most kMaxOgdenExponent, mu > 0, J_m > 0; checked before C1 (= mu / 2, derived from them), so
  // that the message names the keys given.
  for (std::size_t i = 0; i < material.ogden.size(); ++i) {
    const OgdenTerm& t = material.ogden[i];
    require(t.alpha != 0 && t.mu * t.alpha > 0,
            cat("material.mu[", i, "], material.alpha[", i, "]"),
            cat("= ", t.mu, " Pa, ", t.alpha,
                ": each Ogden term needs alpha_p != 0 and mu_p alpha_p > 0"));
    require(std::abs(t.alpha) <= kMaxOgdenExponent, cat("material.alpha[", i, "]"),
            cat("= ", t.alpha, ": |alpha_p| must be at most ", kMaxOgdenExponent,
                " (t^alpha_p overflows or vanishes at moderate stretches t; rubber fits use "
                "|alpha_p| < 30)"));
  }
  if (material.model == MaterialModel::Gent) {
    require(std::isfinite(material.mu) && material.mu > 0, "material.mu",
            cat("= ", material.mu, " Pa: the Gent shear modulus must be > 0"));
    require(std::isfinite(material.Jm) && material.Jm > 0, "material.Jm",
            cat("= ", material.Jm, material.Jm == 0 ? " (or not given)" : "",
                ": must be > 0 (the locking limit of |F|^2 - 3)"));
  }
  const bool principal =
      material.model == MaterialModel::Ogden || material.model == MaterialModel::Gent;
  require(std::isfinite(material.C1) && material.C1 > 0, principal ? "material.mu" : "material.C1",
          cat("= ", material.C1,
              " Pa: must be > 0 (it is the coefficient of |F|^2 and the "
              "global Laplacian (4.5))"));
  require(std::isfinite(material.C2) && material.C2 >= 0, "material.C2",
          cat("= ", material.C2, " Pa: must be >= 0"));
  require(std::isfinite(material.C3) && material.C3 >= 0, "material.C3",
          cat("= ", material.C3, " Pa: must be >= 0"));
  // Algorithm [LTL87 (3.2)-(3.3), (4.3), (7.10)].
  const AlgorithmParams& a = algorithm;
  require(std::isfinite(a.R) && a.R > 0, "algorithm.R", cat("= ", a.R, ": must be > 0"));
  require(std::isfinite(a.q) && a.q > 0, "algorithm.q", cat("= ", a.q, " Pa: must be > 0"));
  require(std::isfinite(a.q_c) && a.q_c > 0, "algorithm.q_c",
          cat("= ", a.q_c, " Pa/m: must be > 0"));
  check_stiffness_balance(*this);
  if (a.update == Update::BermudezMoreno) {
    require(a.rho > 0.5 && a.rho <= 1, "algorithm.rho",
            cat("= ", a.rho, ": the Bermudez-Moreno update (7.10) needs 1/2 < rho <= 1"));
    require(a.sweeps == 1, "algorithm.sweeps",
            cat("= ", a.sweeps,
                ": the Bermudez-Moreno update (7.7)-(7.10) does one block "
                "relaxation per iteration; set sweeps = 1"));
  } else {
    require(a.rho > 0 && a.rho < 2, "algorithm.rho",
            cat("= ", a.rho, ": the Uzawa update (4.3) needs 0 < rho < 2"));
  }
  require(a.sweeps >= 1, "algorithm.sweeps", cat("= ", a.sweeps, ": must be >= 1"));
  require(a.depth >= 1 && a.depth <= 16, "algorithm.depth",
          cat("= ", a.depth, ": the Anderson history must hold 1 ... 16 differences"));
  require(a.contact_sweeps >= 1, "algorithm.contact_sweeps",
          cat("= ", a.contact_sweeps, ": must be >= 1"));
  // The residuals are relative: tol >= 1 accepts any iterate.
  require(std::isfinite(a.tol) && a.tol > 0 && a.tol < 1, "algorithm.tol",
          cat("= ", a.tol, ": must be in (0, 1) (a relative residual)"));
  require(a.max_iter >= 1, "algorithm.max_iter", cat("= ", a.max_iter, ": must be >= 1"));
  require(std::isfinite(a.blowup) && a.blowup > 1, "algorithm.blowup",
          cat("= ", a.blowup, ": must be > 1 and finite"));
  require(
      std::isfinite(a.max_force_residual) && a.max_force_residual > 0 && a.max_force_residual < 1,
      "algorithm.max_force_residual",
      cat("= ", a.max_force_residual, ": must be in (0, 1) (relative to the largest load)"));
  // Time stepping (2.1)-(2.2).
  require(std::isfinite(time.dt) && time.dt > 0, "time.dt", cat("= ", time.dt, " s: must be > 0"));
  require(time.steps >= 1 && time.steps <= 999999, "time.steps",
          cat("= ", time.steps, ": must be in 1..999999"));
  require(
      std::isfinite(time.dt * time.steps) && time.dt * time.steps < 1e100, "time.dt",
      cat("= ", time.dt, " s: the final time dt * steps = ", time.dt * time.steps, " s overflows"));
  require(body_force.allFinite(), "load.body_force", "must be finite");
  if (ramp.kind == LoadRamp::Kind::Linear)
    require(std::isfinite(ramp.ramp_time) && ramp.ramp_time > 0, "load.ramp_time",
            cat("= ", ramp.ramp_time, " s: must be > 0"));
  if (ramp.kind == LoadRamp::Kind::Table) {
    require(!ramp.table.empty(), "load.factor", "ramp = \"table\" needs at least one factor");
    for (double f : ramp.table) require(std::isfinite(f), "load.factor", "must be finite");
    require(static_cast<int>(ramp.table.size()) <= time.steps, "load.factor",
            cat("has ", ramp.table.size(), " entries but time.steps = ", time.steps,
                ": one factor per step (the last one holds after the table); to stop early use "
                "--stop-after"));
  }
  for (const auto& t : tractions)
    require(t.g.value.allFinite() && t.g.gradient.allFinite(), t.origin, "must be finite");
  for (const auto& d : dirichlet)
    require(d.field.value.allFinite() && d.field.gradient.allFinite(), d.origin, "must be finite");
  require(mesh.X.allFinite(), "mesh", "the mesh has non-finite node coordinates");

  // Boundary conditions and loads refer to existing boundary parts.
  for (const auto& d : dirichlet) {
    mesh.boundary(d.group, d.origin);
    for (int c : d.components)
      require(c >= 0 && c < dim, d.origin, cat("component ", c, " does not exist in ", dim, "-D"));
  }
  for (const auto& t : tractions) mesh.boundary(t.group, t.origin);
  check_load_factor_scale(*this);
  check_conflicting_supports(*this);

  for (const ContactCondition& cc : contacts) {
    const auto& b = mesh.boundary(cc.group, cc.key("group"));
    require(b.facets.rows() > 0, cc.key("group"), cat("'", cc.group, "' has no facets"));
    require(cc.plane_point.allFinite(), cc.key("plane_point"), "must be finite");
    require(cc.plane_normal.allFinite(), cc.key("plane_normal"), "must be finite");
    require(std::isfinite(cc.adhesion.w) && std::isfinite(cc.adhesion.kappa) &&
                std::isfinite(cc.adhesion.d0),
            std::isfinite(cc.adhesion.w) ? cc.key(std::isfinite(cc.adhesion.kappa) ? "d0" : "kappa")
                                         : cc.key("w"),
            "must be finite");
    require(cc.beta0 >= 0 && cc.beta0 <= 1, cc.key("beta0"),
            cat("= ", cc.beta0, ": the adhesion intensity must be in [0, 1]"));
    require(cc.adhesion.w >= 0, cc.key("w"), cat("= ", cc.adhesion.w, " J/m^2: must be >= 0"));
    require(cc.adhesion.kappa >= 0, cc.key("kappa"),
            cat("= ", cc.adhesion.kappa,
                " Pa/m: kappa = 1/eps must be >= 0 (eps < 0 is not a "
                "glue)"));
    require(cc.adhesion.d0 >= 0, cc.key("d0"), cat("= ", cc.adhesion.d0, " 1/m: must be >= 0"));
    require(std::abs(cc.plane_normal.norm() - 1) < 1e-12, cc.key("plane_normal"),
            "must be a unit vector");
    require(!(cc.adhesion.exact_kernel && cc.adhesion.d0 > 0 && discretization.nodal_contact),
            cc.key("kernel"),
            "= \"exact\" integrates the kernel over facets: it needs discretization.contact = "
            "\"facet-mean\" (the nodal contact has no facets)");
    // Every contact facet must lie on the boundary of the mesh (a facet of exactly one cell).
    const int corners = dim == 2 ? 2 : mesh.nodes_per_facet() == 6 ? 3 : 4;
    std::vector<FacetKey> keys(b.facets.rows(), FacetKey{-1, -1, -1, -1});
    for (Eigen::Index f = 0; f < b.facets.rows(); ++f) {
      for (int k = 0; k < corners; ++k) keys[f][k] = b.facets(f, k);
      std::sort(keys[f].begin(), keys[f].begin() + corners);
    }
    const std::vector<int> cells = cells_per_facet(mesh, keys);
    for (Eigen::Index f = 0; f < b.facets.rows(); ++f) {
      const FacetKey& key = keys[f];
      require(cells[f] == 1, cc.key("group"),
              cat("'", cc.group, "' facet ", f, " (nodes ", key[0], ", ", key[1],
                  corners > 2 ? ", ..." : "",
                  ") is not on the boundary of the body: the contact "
                  "surface must be part of the boundary"));
    }
    // Contact facets must not be fixed: the body is glued, not clamped, there.
    for (const auto& d : dirichlet)
      if (d.group == cc.group && static_cast<int>(d.components.size()) == dim)
        throw KeyError(d.origin,
                       cat("group '", d.group, "' is both fixed and the contact surface"));
  }
  check_shared_glue();
  if (contacts.size() > 1 && algorithm.solver == NonlinearSolver::Newton)
    for (const ContactCondition& cc : contacts)
      require(!(cc.adhesion.kappa > 0), "algorithm.solver",
              cat("= \"newton\" with ", contacts.size(), " obstacles, ", cc.origin,
                  " glued (kappa > 0): the Newton phase holds the glue of one obstacle only; "
                  "set algorithm.solver = \"alg2\" (paper_notes/obstacles.md)"));
  if (!contacts.empty()) check_sliding();
  check_symmetry_planes(*this);
}

void Problem::check_shared_glue() const {
  const auto glued = [](const ContactCondition& cc) { return cc.adhesion.kappa > 0; };
  for (std::size_t a = 0; a < contacts.size(); ++a)
    for (std::size_t b = a + 1; b < contacts.size(); ++b) {
      const ContactCondition &A = contacts[a], &B = contacts[b];
      if (!glued(A) && !glued(B)) continue;
      // The contact points of each: nodes (nodal contact) or facets as sorted node sets.
      std::set<std::vector<int>> pa;
      const auto points = [&](const ContactCondition& cc) {
        std::vector<std::vector<int>> out;
        if (discretization.nodal_contact) {
          for (int n : mesh.boundary_nodes(cc.group, cc.key("group"))) out.push_back({n});
        } else {
          const auto& F = mesh.boundary(cc.group, cc.key("group")).facets;
          for (Eigen::Index f = 0; f < F.rows(); ++f) {
            std::vector<int> key;
            for (Eigen::Index k = 0; k < F.cols(); ++k) key.push_back(F(f, k));
            std::sort(key.begin(), key.end());
            out.push_back(key);
          }
        }
        return out;
      };
      for (const auto& k : points(A)) pa.insert(k);
      for (const auto& k : points(B))
        if (pa.count(k))
          throw KeyError(
              glued(B) ? B.key("kappa") : A.key("kappa"),
              cat("obstacles ", A.origin, " (group '", A.group, "') and ", B.origin, " (group '",
                  B.group, "') share the contact ", k.size() == 1 ? "node " : "facet of nodes ",
                  k[0], k.size() > 1 ? ", ..." : "", " at (", mesh.X(k[0], 0), ", ",
                  mesh.X(k[0], 1), mesh.dim == 3 ? cat(", ", mesh.X(k[0], 2)) : std::string(),
                  ") and one of them is glued: the glued local step (6.1)-(6.8) has one beta and "
                  "one plane per point, and at a point of two obstacles it is not defined here; "
                  "glue neither at a shared point (paper_notes/obstacles.md)"));
    }
}

// A frictionless contact plane blocks only the normal displacement; the global matrix (4.5)
// stays regular (its contact term R q_c M^T M holds every component of ubar - e), so a sliding
// motion that no Dirichlet data removes is not caught by the factorization: the iteration then
// wanders along it. The sliding motions are u = t + theta N x (x - c) with t . N = 0 (and, in
// 3-D, a rotation about the normal); a Dirichlet component c at node x_i removes those with
// u_c(x_i) != 0. Refused when the remaining space is not {0}, unless glue holds the surface.
//
// Several obstacles (paper_notes/obstacles.md): the rigid motions u = t + omega x (x - c) (3 in
// 2-D, 6 in 3-D) whose normal component N_k . u vanishes at every node of each frictionless
// obstacle's group, every component at a glued one's, and every prescribed component: the
// null space of those rows is refused as above, naming the motion.
void Problem::check_sliding() const {
  if (contacts.size() > 1) return check_sliding_obstacles();
  if (contacts.empty()) return;
  const ContactCondition& cc = contacts.front();
  if (cc.adhesion.kappa > 0 && cc.beta0 > 0) return;  // glued: the glue holds every component
  const int dim = mesh.dim;
  const Eigen::Vector3d N = cc.plane_normal;
  // An orthonormal basis T of the plane (dim - 1 vectors).
  Eigen::Vector3d t1 = Eigen::Vector3d::Zero(), t2 = Eigen::Vector3d::Zero();
  if (dim == 2) {
    t1 << -N(1), N(0), 0;
  } else {
    int k = 0;
    N.cwiseAbs().minCoeff(&k);
    t1 = N.cross(Eigen::Vector3d::Unit(k)).normalized();
    t2 = N.cross(t1);
  }
  const int np = dim == 2 ? 1 : 3;  // parameters: a1 (2-D); a1, a2, theta (3-D)
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  c.head(dim) = mesh.X.colwise().mean().transpose();
  const double L =
      std::max(1e-300, (mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff()).maxCoeff());
  // A^T A accumulated over the Dirichlet rows (np x np): its null space is the free motion.
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  for (const auto& d : dirichlet)
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      x.head(dim) = mesh.X.row(node).transpose();
      const Eigen::Vector3d r = N.cross(x - c) / L;  // rotation about the normal, per theta
      for (int comp : d.components) {
        Eigen::Vector3d row = Eigen::Vector3d::Zero();
        row(0) = t1(comp);
        if (dim == 3) row(1) = t2(comp), row(2) = r(comp);
        AtA += row * row.transpose();
      }
    }
  const Eigen::MatrixXd M = AtA.topLeftCorner(np, np);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(M);
  const double scale = std::max(1.0, M.diagonal().maxCoeff());
  for (int k = 0; k < np; ++k) {
    if (es.eigenvalues()(k) > 1e-10 * scale) continue;
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    // The free motion: a translation along the plane, or a rotation about its normal.
    Eigen::Vector3d t = v(0) * t1;
    if (dim == 3) t += v(1) * t2;
    std::string what;
    if (t.norm() > 1e-6)
      what = cat("slide along the contact plane in the direction ",
                 direction_name(t.normalized(), dim));
    else
      what = cat("turn about the normal of the contact plane");
    throw KeyError(
        cc.key("group"),
        cat("'", cc.group, "': the body is free to ", what,
            ": a frictionless contact plane (no glue: kappa = 0 or beta0 = 0) blocks only "
            "the normal displacement, and no [[fixed]], [[symmetry]] or [[displacement]] "
            "condition removes this rigid motion; add one (e.g. a [[symmetry]] plane "
            "with that component) or glue the surface"));
  }
}

void Problem::check_sliding_obstacles() const {
  const int dim = mesh.dim, np = dim == 2 ? 3 : 6;  // (t, theta) in 2-D, (t, omega) in 3-D
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  c.head(dim) = mesh.X.colwise().mean().transpose();
  const double L =
      std::max(1e-300, (mesh.X.colwise().maxCoeff() - mesh.X.colwise().minCoeff()).maxCoeff());
  // d u(x) / d parameters: 3 x np, u = t + omega x (x - c) / L (2-D: omega = theta e3).
  const auto motion = [&](int node) {
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    x.head(dim) = mesh.X.row(node).transpose();
    const Eigen::Vector3d r = (x - c) / L;
    Eigen::MatrixXd D = Eigen::MatrixXd::Zero(3, np);
    D.block(0, 0, dim, dim).setIdentity();
    if (dim == 2) {
      D(0, 2) = -r(1), D(1, 2) = r(0);
    } else {  // omega x r = -[r]x omega
      D.block(0, 3, 3, 3) << 0, r(2), -r(1), -r(2), 0, r(0), r(1), -r(0), 0;
    }
    return D;
  };
  Eigen::MatrixXd AtA = Eigen::MatrixXd::Zero(np, np);
  const auto add = [&](const Eigen::RowVectorXd& row) { AtA += row.transpose() * row; };
  for (const auto& d : dirichlet)
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      const Eigen::MatrixXd D = motion(node);
      for (int comp : d.components) add(D.row(comp));
    }
  for (const ContactCondition& cc : contacts) {
    const bool glued = cc.adhesion.kappa > 0 && cc.beta0 > 0;
    for (int node : mesh.boundary_nodes(cc.group, cc.key("group"))) {
      const Eigen::MatrixXd D = motion(node);
      if (glued)
        for (int i = 0; i < dim; ++i) add(D.row(i));
      else
        add(cc.plane_normal.transpose() * D);
    }
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(AtA);
  const double scale = std::max(1.0, AtA.diagonal().maxCoeff());
  if (es.eigenvalues()(0) > 1e-10 * scale) return;
  const Eigen::VectorXd v = es.eigenvectors().col(0);
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  t.head(dim) = v.head(dim);
  const std::string what =
      t.norm() > 1e-6 ? cat("translate in the direction ", direction_name(t.normalized(), dim))
                      : std::string("turn rigidly");
  std::string groups;
  for (const ContactCondition& cc : contacts)
    groups += cat(groups.empty() ? "" : ", ", cc.origin, " '", cc.group, "'");
  throw KeyError("contact", cat("the body is free to ", what, " along every obstacle (", groups,
                                "): a frictionless plane blocks only its normal displacement, and "
                                "no [[fixed]], [[symmetry]] or [[displacement]] condition removes "
                                "this rigid motion; add one or glue a surface"));
}

}  // namespace ltl
