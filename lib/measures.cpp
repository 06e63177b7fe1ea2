#include "measures.hpp"

#include <algorithm>
#include <cmath>

#include "admissibility.hpp"
#include "error.hpp"
#include "mpi_comm.hpp"

namespace ltl {

Eigen::VectorXi contact_set(const Eigen::VectorXd& p) {
  const double p_max = p.size() ? p.maxCoeff() : 0.0;
  Eigen::VectorXi in(p.size());
  for (int i = 0; i < p.size(); ++i) in(i) = p(i) > kContactThreshold * p_max ? 1 : 0;
  return in;
}

namespace {
/// The row of u at node n: n itself when u is whole (at null), else n's position in the rank's
/// layer (-1: not there).
Eigen::Index u_row_of(int n, const IterateRows* at) {
  return at ? mpi::position_in(*at->nodes, n) : n;
}

/// f(i, A.row(i)) for the points i a rank computes (its own, or every point), then A made whole:
/// the largest over the ranks (each point's row is one rank's, -inf elsewhere; collective).
template <class F>
Eigen::MatrixXd on_points(int n_points, int cols, const IterateRows* at, F&& f) {
  const bool split = at && at->points;
  Eigen::MatrixXd A = Eigen::MatrixXd::Constant(n_points, cols, split ? -INFINITY : 0.0);
  if (split)
    for (int i : *at->points) f(i, A.row(i));
  else
    for (int i = 0; i < n_points; ++i) f(i, A.row(i));
  if (split) mpi::max(A.data(), A.size());
  return A;
}
}  // namespace

namespace {
/// The rows of A (#layer rows) at the nodes `nodes`, from the ranks whose layer holds them
/// (collective: the largest over the ranks, -inf where a rank has none).
Eigen::MatrixXd layer_rows_at(const Eigen::MatrixXd& A, const std::vector<int>& nodes,
                              const IterateRows* at) {
  Eigen::MatrixXd U =
      Eigen::MatrixXd::Constant(static_cast<Eigen::Index>(nodes.size()), A.cols(), -INFINITY);
  for (std::size_t k = 0; k < nodes.size(); ++k)
    if (const Eigen::Index row = u_row_of(nodes[k], at); row >= 0)
      U.row(static_cast<Eigen::Index>(k)) = A.row(row);
  mpi::max(U.data(), U.size());
  return U;
}
}  // namespace

Eigen::MatrixXd u_at_nodes(const State& s, const std::vector<int>& nodes, const IterateRows* at) {
  if (!at) return s.u(nodes, Eigen::all);
  return layer_rows_at(s.u, nodes, at);
}

Eigen::MatrixXd X_at_nodes(const Mesh& mesh, const std::vector<int>& nodes, const IterateRows* at) {
  if (!at || !at->X) return mesh.X(nodes, Eigen::all);
  return layer_rows_at(*at->X, nodes, at);
}

namespace {
/// The rows of `mean` times a nodal array, on the points a rank computes (on_points, with u's
/// rows `at`): row i starts at zero and add(w, r, n, row) adds each term, w = mean(i, n) at the
/// node n, u's row r, in the order of the row-major product. `what` names the caller in the
/// error of a node off the rank's layer.
template <class Add>
Eigen::MatrixXd point_sums(const ContactPoints& pts, int cols, const IterateRows* at,
                           const char* what, Add&& add) {
  return on_points(pts.size(), cols, at, [&](int i, auto row) {
    row.setZero();
    for (SpMatR::InnerIterator it(pts.mean, i); it; ++it) {
      const int n = static_cast<int>(it.col());
      const Eigen::Index r = u_row_of(n, at);
      if (r < 0)
        throw Error(cat(what, ": contact point ", i, "'s node ", n, " is not on the rank's layer"));
      add(it.value(), r, n, row);
    }
  });
}
}  // namespace

Eigen::MatrixXd point_reference(const ContactPoints& pts, const Mesh& mesh, const IterateRows* at) {
  if (!at || !at->X) return pts.mean * mesh.X;
  return point_sums(pts, pts.dim, at, "point_reference",
                    [&](double w, Eigen::Index r, int, auto& row) { row += w * at->X->row(r); });
}

Eigen::MatrixXd point_means(const ContactPoints& pts, const State& s, const IterateRows* at) {
  if (!at) return pts.mean * s.u;
  return point_sums(pts, static_cast<int>(s.u.cols()), at, "point_means",
                    [&](double w, Eigen::Index r, int, auto& row) { row += w * s.u.row(r); });
}

ContactMeasures contact_measures(const Discretization& d, const State& s, int axis, int k,
                                 const IterateRows* at) {
  ContactMeasures m;
  const Problem& pb = d.problem();
  if (pb.contacts.empty() || !d.points() || k < 0 || k >= d.num_obstacles()) return m;
  const ContactPoints& points = *d.points();
  // Obstacle k's rows of the points (all of them with one obstacle).
  const int r0 = points.offset[k], r1 = points.offset[k + 1];
  // The deformed contact points, and for each the largest deformed coordinate along `axis` of
  // its nodes (x = X + u), on the ranks whose layer holds them with `at`.
  const Eigen::MatrixXd xp = point_reference(points, pb.mesh, at) + point_means(points, s, at);
  const Eigen::MatrixXd edge = on_points(points.size(), 1, at, [&](int i, auto row) {
    row(0) = -INFINITY;
    for (SpMatR::InnerIterator it(points.mean, i); it; ++it) {
      const Eigen::Index r = u_row_of(static_cast<int>(it.col()), at);
      if (r >= 0)
        row(0) =
            std::max(row(0), X_at(pb.mesh, at, static_cast<int>(it.col()), r, axis) + s.u(r, axis));
    }
  });
  const Eigen::VectorXd p = d.contact_pressure(s);  // nominal contact pressure
  const Eigen::VectorXd f = d.contact_forces(s);    // point forces
  const Eigen::VectorXi in = contact_set(p.segment(r0, r1 - r0));
  m.points = r1 - r0;
  m.p_max = m.points ? p.segment(r0, r1 - r0).maxCoeff() : 0.0;
  double M0 = 0, M2 = 0;
  for (int i = r0; i < r1; ++i) {
    m.force += f(i);
    m.resultant.head(pb.mesh.dim) += points.area(i) * s.lambda_c.row(i).transpose();
    if (!in(i - r0)) continue;
    ++m.in_contact;
    m.area += points.area(i);
    m.a_edge = std::max(m.a_edge, edge(i, 0));
    M0 += points.area(i) * p(i);
    M2 += points.area(i) * p(i) * xp(i, axis) * xp(i, axis);
  }
  m.a_moment = M0 > 0 ? 2 * std::sqrt(M2 / M0) : 0.0;
  m.penetration = penetration_of(d, s, k, at);
  return m;
}

Eigen::VectorXd opening(const Problem& pb, const State& s) {
  if (pb.contacts.empty()) return Eigen::VectorXd(0);
  const Eigen::VectorXd N = pb.contacts.front().plane_normal.head(pb.mesh.dim).normalized();
  return -(s.e * N);
}

PeelMeasures peel_measures(const Problem& pb, const ContactPoints& points, const State& s,
                           int axis) {
  PeelMeasures m;
  m.points = points.size();
  if (pb.contacts.empty() || s.beta.size() != points.size() || m.points == 0) return m;
  for (int i = 0; i < m.points; ++i) {
    const double x = points.centre(axis, i);
    if (s.beta(i) < kDebondedBeta) {
      ++m.broken;
      m.front = std::isnan(m.front) ? x : std::max(m.front, x);
    }
    if (s.beta(i) < kDamagedBeta)
      m.damage_front = std::isnan(m.damage_front) ? x : std::max(m.damage_front, x);
  }
  m.beta_min = s.beta.minCoeff();
  m.beta_max = s.beta.maxCoeff();
  m.beta_l2 = std::sqrt(points.area.dot(s.beta.cwiseAbs2()) / points.area.sum());
  // -e . N_k per point: each point's own obstacle with several (ContactPoints::normals).
  const Eigen::VectorXd o = points.obstacles() > 1
                                ? Eigen::VectorXd(-s.e.cwiseProduct(points.normals).rowwise().sum())
                                : opening(pb, s);
  m.max_opening = o.maxCoeff(&m.max_opening_at);
  m.max_opening_x = points.centre(axis, m.max_opening_at);
  return m;
}

StepMeasures step_measures(const Discretization& d, const State& s, int axis,
                           const IterateRows* at) {
  StepMeasures m;
  const Problem& pb = d.problem();
  const ContactPoints* points = d.points();
  m.max_displacement = s.u.size() ? s.u.rowwise().norm().maxCoeff() : 0.0;
  if (at) mpi::max(&m.max_displacement, 1);  // the largest over the ranks' layers
  if (pb.contacts.empty() || !points) return m;
  m.contact = contact_measures(d, s, axis, 0, at);
  for (int k = 1; k < d.num_obstacles(); ++k)
    m.obstacles.push_back(contact_measures(d, s, axis, k, at));
  // The contact set per point, each obstacle's against its own peak pressure.
  const Eigen::VectorXd p = d.contact_pressure(s);
  m.in_contact.resize(p.size());
  for (int k = 0; k < d.num_obstacles(); ++k) {
    const int r0 = points->offset[k], n = points->offset[k + 1] - r0;
    m.in_contact.segment(r0, n) = contact_set(p.segment(r0, n));
  }
  const bool glued = std::any_of(pb.contacts.begin(), pb.contacts.end(),
                                 [](const ContactCondition& c) { return c.adhesion.kappa > 0; });
  if (glued && s.beta.size() == points->size() && points->size() > 0)
    m.peel = peel_measures(pb, *points, s, axis);
  return m;
}

std::vector<StoredMeasure> stored_measures(const StepMeasures& m, int dim) {
  const bool plane = dim == 2;
  const std::string force = plane ? "N/m" : "N", area = plane ? "m" : "m^2";
  std::vector<StoredMeasure> out = {
      {"max_displacement", m.max_displacement, "m", "max over nodes of |u|"}};
  // Several obstacles: obstacle 0 under the names of one, obstacle k >= 1 suffixed "_k"; and the
  // resultant force of each on the body, for the balance of forces.
  const int n_obstacles = m.contact ? 1 + static_cast<int>(m.obstacles.size()) : 0;
  for (int k = 0; k < n_obstacles; ++k) {
    const ContactMeasures* c = k == 0 ? &*m.contact : &m.obstacles[k - 1];
    const std::string sfx = k == 0 ? "" : cat("_", k),
                      of = k == 0 ? "" : cat(" (obstacle ", k, ")");
    if (k > 0) {
      out.insert(
          out.end(),
          {{"contact_points" + sfx, double(c->points), "1", "number of contact points" + of},
           {"in_contact_count" + sfx, double(c->in_contact), "1", "points in the contact set" + of},
           {"p_max" + sfx, c->p_max, "Pa", "peak nominal contact pressure max p" + of},
           {"contact_force" + sfx, c->force, force,
            "sum over the contact points of w p (plane strain: per metre of depth)" + of},
           {"contact_area" + sfx, c->area, area,
            "sum of the weights w of the points in the contact set" + of},
           {"contact_penetration" + sfx, c->penetration, "m",
            "max over the contact surface's nodes of (x - p0) . N" + of}});
    }
    if (n_obstacles > 1)
      for (int i = 0; i < dim; ++i)
        out.push_back({cat("contact_resultant_", "xyz"[i], sfx), c->resultant(i), force,
                       cat("component ", "xyz"[i],
                           " of the force of the obstacle on the body, sum w lambda_c", of)});
  }
  if (const auto& c = m.contact) {
    const std::string set = cat(
        "the contact set (p > kContactThreshold * p_max, kContactThreshold = ", kContactThreshold,
        "; p = -lambda_c . N per contact point)");
    out.insert(out.end(),
               {{"contact_points", double(c->points), "1", "number of contact points"},
                {"in_contact_count", double(c->in_contact), "1", "points in " + set},
                {"p_max", c->p_max, "Pa", "peak nominal contact pressure max p"},
                {"contact_force", c->force, force,
                 "sum over the contact points of w p (plane strain: per metre of depth)"},
                {"contact_area", c->area, area, "sum of the weights w of the points in " + set},
                {"a_edge", c->a_edge, "m",
                 "contact half-width: largest deformed x1 of a node carrying a point in " + set},
                {"a_moment", c->a_moment, "m",
                 "contact half-width 2 sqrt(M2 / M0), M0 = sum w p, M2 = sum w p x1^2 over " + set},
                {"contact_penetration", c->penetration, "m",
                 "max over the contact surface's nodes of (x - p0) . N (> 0: inside the "
                 "obstacle)"}});
  }
  if (const auto& p = m.peel) {
    out.insert(
        out.end(),
        {{"broken", double(p->broken), "1",
          cat("contact points with beta < kDebondedBeta = ", kDebondedBeta, " (glue broken)")},
         {"front", p->front, "m",
          cat("debonding front: largest reference x1 of a contact point with beta < kDebondedBeta "
              "= ",
              kDebondedBeta, "; NaN if none")},
         {"damage_front", p->damage_front, "m",
          cat("damage front: largest reference x1 of a contact point with beta < kDamagedBeta = ",
              kDamagedBeta, "; NaN if none")},
         {"beta_min", p->beta_min, "1", "min of beta over the contact points"},
         {"beta_max", p->beta_max, "1", "max of beta over the contact points"},
         {"beta_l2", p->beta_l2, "1", "sqrt(sum w beta^2 / sum w) over the contact points"},
         {"max_opening", p->max_opening, "m",
          "largest opening max e . (-N) over the contact points ((4.11); > 0: lifted off)"},
         {"max_opening_x", p->max_opening_x, "m",
          "reference x1 of the contact point of the largest opening"}});
  }
  return out;
}

int node_at(const Mesh& mesh, const Eigen::VectorXd& X) {
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if ((mesh.X.row(n).transpose() - X).norm() < 1e-9) return n;
  throw Error(cat(mesh.source, ": no mesh node at X = (", X.transpose(), ")"));
}

double load_along_normal(const Problem& pb, const Eigen::MatrixXd& f_ext) {
  if (pb.contacts.empty()) return 0;
  return (f_ext * pb.contacts.front().plane_normal.head(pb.mesh.dim)).sum();
}

double largest_load(const Eigen::MatrixXd& f_ext, double load_scale) {
  return std::abs(load_scale) * f_ext.cwiseAbs().maxCoeff();
}

Eigen::MatrixXd equilibrium_residual(const Discretization& d, const Eigen::MatrixXd& f_ext,
                                     const State& s, double load_scale) {
  const CellOperators& c = d.cells();
  const double C1 = d.split().C1;
  Eigen::MatrixXd r;
  if (d.partial()) {
    // The held cells' part, run by run with Gbar^T |O_e| in place of GbarT_vol (no per-cell
    // array of the whole mesh), summed over the ranks (collective):
    //   Gbar^T |O_e| [2 C1 (E - Gbar u) - lambda] + 2 C1 L u,
    // E and lambda whole or on the held cells' rows (Discretization::cell_row); mean-det's
    // fluctuation force in the same sum (one array, one reduction).
    const int dim = d.dim();
    r = d.held_cell_forces(
        s.u,
        [&](int c0, int n, int at, Eigen::MatrixXd& T) {
          const Eigen::Index row = d.cell_row(s.E, c0, at);
          T = 2 * C1 * (s.E.middleRows(row, dim * n) - T) - s.lambda.middleRows(row, dim * n);
        },
        &s);
    r -= load_scale * f_ext;
  } else {
    const Eigen::MatrixXd GU = c.Gbar * s.u;
    r = c.GbarT_vol * d.piola(s) + 2 * C1 * (c.laplacian * s.u - c.GbarT_vol * GU) -
        load_scale * f_ext;
  }
  SpMatR work;  // meanT_area, made again on a rank's discretization (contact_points.hpp)
  if (d.points()) r -= d.points()->meanT_area_of(work) * s.lambda_c;
  if (d.mean_det() && !d.partial()) r -= d.fluctuation_force(s);  // folded above on some cells
  return r;
}

ResidualRows equilibrium_residual_rows(const Discretization& d, const Eigen::MatrixXd* f_ext,
                                       const State& s, double load_scale, const IterateRows* at) {
  ResidualRows out;
  if (at && !d.partial())
    throw Error("equilibrium_residual_rows: an iterate on a rank's rows needs the rank's cells");
  if (!d.partial()) {
    out.r = equilibrium_residual(d, f_ext ? *f_ext : d.dead_load(), s, load_scale);
    return out;
  }
  // The rank's cells' part on their nodes (the operators' columns), as in equilibrium_residual,
  // summed on the ranks' blocks of the nodes.
  const int dim = d.dim();
  const double C1 = d.split().C1;
  const std::vector<int> offset = mpi::blocks(d.num_nodes(), mpi::size());
  const int n0 = offset[mpi::rank()];
  const ContactPoints* pts = d.points();
  const bool points_on_rows = pts && at && at->points;  // its points' terms, before the sum
  {
    Eigen::MatrixXd f = d.held_cell_forces_on_columns(
        s.u,
        [&](int c0, int n, int k, Eigen::MatrixXd& T) {
          const Eigen::Index row = d.cell_row(s.E, c0, k);
          T = 2 * C1 * (s.E.middleRows(row, dim * n) - T) - s.lambda.middleRows(row, dim * n);
        },
        &s, at ? at->column_row : nullptr);
    if (points_on_rows) {  // M^T |G| lambda_c of the rank's points at their nodes' columns
      const std::vector<int>& node = d.cells().node;
      for (int p : *at->points)
        for (SpMat::InnerIterator it(pts->meanT_area_by_point, p); it; ++it) {
          const int j = mpi::position_in(node, static_cast<int>(it.row()));
          if (j < 0)
            throw Error(cat("equilibrium_residual_rows: contact point ", p, "'s node ", it.row(),
                            " is not a node of the rank's cells"));
          f.row(j) -= it.value() * s.lambda_c.row(p);
        }
    }
    mpi::sum_rows_to_blocks(f, d.cells().node, offset, out.r);
  }
  out.first = n0;
  const Eigen::Index nb = out.r.rows();
  if (f_ext) {
    out.r -= load_scale * f_ext->middleRows(n0, nb);
  } else {  // the dead loads of the block's loaded nodes (sorted)
    const std::vector<int>& loaded = d.loaded_nodes();
    for (std::size_t k = 0; k < loaded.size(); ++k)
      if (loaded[k] >= n0 && loaded[k] < n0 + nb)
        out.r.row(loaded[k] - n0) -= load_scale * d.loaded_rows().row(static_cast<Eigen::Index>(k));
  }
  // The contact term M^T |G| lambda_c (4.5) on the block's rows, from the entries kept by point
  // on some cells (contact_points.hpp), point by point: for each row the points in increasing
  // order, as the row-major product sums them.
  if (pts && !points_on_rows) {
    Eigen::MatrixXd c = Eigen::MatrixXd::Zero(nb, dim);
    const SpMat& by_point = pts->meanT_area_by_point;
    for (int f = 0; f < by_point.outerSize(); ++f)
      for (SpMat::InnerIterator it(by_point, f); it; ++it)
        if (it.row() >= n0 && it.row() < n0 + nb)
          c.row(it.row() - n0) += it.value() * s.lambda_c.row(f);
    out.r -= c;
  }
  return out;
}

namespace {
/// The largest |equilibrium_residual| over the free dofs, and over the fixed ones (the largest
/// reaction): over the ranks' blocks of the nodes on a rank's cells (equilibrium_residual_rows).
struct FreeAndFixed {
  double free = 0, reaction = 0;
};
FreeAndFixed residual_free_and_fixed(const Discretization& d, const Eigen::MatrixXd* f_ext,
                                     const State& s, double load_scale,
                                     const IterateRows* at = nullptr) {
  ResidualRows rows = equilibrium_residual_rows(d, f_ext, s, load_scale, at);
  Eigen::MatrixXd& r = rows.r;
  const int n0 = rows.first, n1 = rows.first + static_cast<int>(r.rows());
  FreeAndFixed m;
  const auto& fixed = d.dirichlet().fixed;
  for (int c = 0; c < d.dim(); ++c)
    for (int i : fixed[c])
      if (i >= n0 && i < n1)
        m.reaction = std::max(m.reaction, std::abs(r(i - n0, c))), r(i - n0, c) = 0;
  m.free = r.size() ? r.cwiseAbs().maxCoeff() : 0.0;
  if (d.partial()) {  // the largest over the ranks' blocks
    double both[2] = {m.free, m.reaction};
    mpi::max(both, 2);
    m.free = both[0];
    m.reaction = both[1];
  }
  return m;
}
}  // namespace

double largest_load(const Discretization& d, double load_scale) {
  return std::abs(load_scale) * d.largest_dead_load();
}

namespace {
/// The loads' largest nodal value: f_ext's, or (null) the discretization's dead loads'.
double largest_of_loads(const Discretization& d, const Eigen::MatrixXd* f_ext, double load_scale) {
  return f_ext ? largest_load(*f_ext, load_scale) : largest_load(d, load_scale);
}

EquilibriumMeasure measure_under(const Discretization& d, const Eigen::MatrixXd* f_ext,
                                 const State& s, double load_scale,
                                 const IterateRows* at = nullptr) {
  EquilibriumMeasure m;
  const double load = largest_of_loads(d, f_ext, load_scale);
  m.force_residual =
      residual_free_and_fixed(d, f_ext, s, load_scale, at).free / (load > 0 ? load : 1.0);
  if (d.problem().material.incompressible()) {
    // The constraint as discretized: det E_e = 1 (det-mean) or det E_e + c_e(u) = 1 (mean-det).
    // On a rank's cells (a discretization of some cells), the largest over the ranks; E whole
    // or on the held cells' rows (Discretization::cell_row).
    const Eigen::VectorXd c = d.fluctuation_det(s.u, at ? at->column_row : nullptr);
    const std::vector<int>& held = d.held_cells();
    const int dim = d.dim();
    for (int at = 0; at < static_cast<int>(held.size()); ++at) {
      const int e = held[at];
      const double det = s.E.block(d.cell_row(s.E, e, at), 0, dim, dim).determinant();
      m.det_error = std::max(m.det_error, std::abs(det + c(at) - 1));
    }
    if (d.partial()) mpi::max(&m.det_error, 1);
  }
  if (d.points()) m.penetration = std::max(0.0, max_penetration(d, s, at));
  m.det_min = min_det_F(d, s.u, nullptr, nullptr, at ? at->nodes : nullptr);
  return m;
}
}  // namespace

EquilibriumMeasure equilibrium_measure(const Discretization& d, const Eigen::MatrixXd& f_ext,
                                       const State& s, double load_scale) {
  return measure_under(d, &f_ext, s, load_scale);
}

EquilibriumMeasure equilibrium_measure(const Discretization& d, const State& s, double load_scale,
                                       const IterateRows* at) {
  return measure_under(d, nullptr, s, load_scale, at);
}

namespace {
/// Has this rank released the mesh's positions (Mesh::release_X; every rank of a distributed run
/// alike)?
bool X_released(const Discretization& d) {
  return d.problem().mesh.X.rows() == 0 && d.num_nodes() > 0;
}

/// penetration_of with u's rows at the layer's nodes (IterateRows::nodes, sorted; at null: u
/// whole): the group's nodes among them alone. X from IterateRows::X, or on a rank that has
/// released the mesh's from its part (Discretization::part(): the group's nodes of its cells).
double penetration_at(const Discretization& d, const State& s, int k, const IterateRows* at) {
  const Problem& pb = d.problem();
  double pen = -INFINITY;
  if (k < 0 || k >= static_cast<int>(pb.contacts.size())) return pen;
  const ContactCondition& cc = pb.contacts[k];
  const int dim = pb.mesh.dim;
  const Eigen::VectorXd N = cc.plane_normal.head(dim);
  const Eigen::VectorXd p0 = cc.plane_point.head(dim);
  const bool part = X_released(d) && !(at && at->X);
  for (int n : pb.mesh.boundary_nodes(cc.group)) {
    const Eigen::Index row = u_row_of(n, at);
    const int j = part ? mpi::position_in(d.cells().node, n) : n;  // X's row
    if (row < 0 || j < 0) continue;
    double depth = 0;  // (X + u - p0) . N
    for (int c = 0; c < dim; ++c) {
      const double X = part ? d.part().X(j, c) : X_at(pb.mesh, at, n, row, c);
      depth += (X + s.u(row, c) - p0(c)) * N(c);
    }
    pen = std::max(pen, depth);
  }
  return pen;
}

double penetration_at(const Discretization& d, const State& s, const IterateRows* at) {
  double pen = -INFINITY;
  for (int k = 0; k < static_cast<int>(d.problem().contacts.size()); ++k)
    pen = std::max(pen, penetration_at(d, s, k, at));
  return pen;
}
}  // namespace

double penetration_of(const Discretization& d, const State& s, int k, const IterateRows* at) {
  double pen = penetration_at(d, s, k, at);
  if (at || X_released(d)) mpi::max(&pen, 1);  // the largest over the ranks' layers or parts
  return pen;
}

double max_penetration(const Discretization& d, const State& s, const IterateRows* at) {
  double pen = penetration_at(d, s, at);
  if (at || X_released(d)) mpi::max(&pen, 1);
  return pen;
}

namespace {
/// equilibrium_error under f_ext (null: the dead loads), s whole or, with `at`, a rank's iterate
/// on its ghost layer's rows.
double error_under(const Discretization& d, const Eigen::MatrixXd* f_ext, const State& s,
                   double load_scale, const IterateRows* at = nullptr) {
  const int dim = d.dim();
  const FreeAndFixed r = residual_free_and_fixed(d, f_ext, s, load_scale, at);
  const int* u_row = at ? at->column_row : nullptr;
  const double h = std::pow(d.volume() / d.num_cells(), 1.0 / dim);
  double scale = largest_of_loads(d, f_ext, load_scale);
  if (!(scale > 0)) scale = r.reaction;
  if (!(scale > 0)) scale = d.split().C1 * std::pow(h, dim - 1);
  double err = r.free / scale;
  // The strains of the stress above are those of u: E_e = I + Gbar_e u (the constraint B = 0 of
  // (3.2)), and for an incompressible law det(I + Gbar_e u) + c_e(u) = 1 on u itself.
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;  // no heap
  const Small I = Small::Identity(dim, dim);
  const bool incompressible = d.problem().material.incompressible();
  const Eigen::VectorXd c = incompressible
                                ? d.fluctuation_det(s.u, u_row)  // the held cells', in order
                                : Eigen::VectorXd::Zero(d.held_cells().size());
  // The cells whose Gbar this rank holds (all unless partial), run by run (Gbar u of the run),
  // the largest over the ranks.
  Eigen::MatrixXd GU;
  mpi::for_each_run(d.held_cells(), [&](int c0, int n, int k0) {
    GU.resize(dim * n, dim);
    mean_gradients(d.cells(), k0, n, s.u, GU, u_row);
    const Eigen::Index row = d.cell_row(s.E, c0, k0);  // E whole or on the held cells' rows
    for (int k = 0; k < n; ++k) {
      const Small F = I + GU.middleRows(dim * k, dim);
      err = std::max(err, (F - s.E.middleRows(row + dim * k, dim)).cwiseAbs().maxCoeff());
      if (incompressible) err = std::max(err, std::abs(F.determinant() + c(k0 + k) - 1));
    }
  });
  // The penetration at u's nodes (with `at` the rank's layer's: every contact node is on some
  // rank's layer), the largest over the ranks.
  double pen = penetration_at(d, s, at);
  if (d.partial()) {
    double both[2] = {err, pen};
    mpi::max(both, 2);
    err = both[0];
    pen = both[1];
  }
  return std::max(err, pen / std::pow(d.volume(), 1.0 / dim));
}
}  // namespace

double equilibrium_error(const Discretization& d, const Eigen::MatrixXd& f_ext, const State& s,
                         double load_scale) {
  return error_under(d, &f_ext, s, load_scale);
}

double equilibrium_error(const Discretization& d, const State& s, double load_scale) {
  return error_under(d, nullptr, s, load_scale);
}

double equilibrium_error(const Discretization& d, const State& s, double load_scale,
                         const IterateRows& at) {
  return error_under(d, nullptr, s, load_scale, &at);  // a rank's cells (else an Error)
}

}  // namespace ltl
