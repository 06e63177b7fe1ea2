#include "problem.hpp"

#include <cmath>
#include <map>
#include <set>

#include "error.hpp"

namespace ltl {

namespace {

void require(bool ok, const std::string& key, const std::string& message) {
  if (!ok) throw KeyError(key, message);
}

// Facets (as sorted corner-node sets) that belong to exactly one cell: the boundary of the mesh.
std::set<std::vector<int>> boundary_facet_keys(const Mesh& mesh) {
  // Corner-node lists of each cell's facets, in gmsh local numbering.
  static const std::vector<std::vector<int>> tri = {{0, 1}, {1, 2}, {2, 0}};
  static const std::vector<std::vector<int>> hex = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                    {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  static const std::vector<std::vector<int>> tet = {{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}};
  const auto& local = mesh.dim == 2 ? tri : mesh.nodes_per_cell() == 10 ? tet : hex;
  std::map<std::vector<int>, int> count;
  for (int c = 0; c < mesh.num_cells(); ++c)
    for (const auto& f : local) {
      std::vector<int> key;
      for (int a : f) key.push_back(mesh.cells(c, a));
      std::sort(key.begin(), key.end());
      ++count[key];
    }
  std::set<std::vector<int>> out;
  for (const auto& [key, n] : count)
    if (n == 1) out.insert(key);
  return out;
}

}  // namespace

void Problem::validate() const {
  const int dim = mesh.dim;
  // Material [LTL87 (1.5), sec. 8].
  require(std::isfinite(material.C1) && material.C1 > 0, "material.C1",
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

  if (contact) {
    const ContactCondition& cc = *contact;
    const auto& b = mesh.boundary(cc.group, "contact.group");
    require(b.facets.rows() > 0, "contact.group", cat("'", cc.group, "' has no facets"));
    require(cc.plane_point.allFinite(), "contact.plane_point", "must be finite");
    require(cc.plane_normal.allFinite(), "contact.plane_normal", "must be finite");
    require(std::isfinite(cc.adhesion.w) && std::isfinite(cc.adhesion.kappa) &&
                std::isfinite(cc.adhesion.d0),
            std::isfinite(cc.adhesion.w)
                ? std::isfinite(cc.adhesion.kappa) ? "contact.d0" : "contact.kappa"
                : "contact.w",
            "must be finite");
    require(cc.beta0 >= 0 && cc.beta0 <= 1, "contact.beta0",
            cat("= ", cc.beta0, ": the adhesion intensity must be in [0, 1]"));
    require(cc.adhesion.w >= 0, "contact.w", cat("= ", cc.adhesion.w, " J/m^2: must be >= 0"));
    require(cc.adhesion.kappa >= 0, "contact.kappa",
            cat("= ", cc.adhesion.kappa,
                " Pa/m: kappa = 1/eps must be >= 0 (eps < 0 is not a "
                "glue)"));
    require(cc.adhesion.d0 >= 0, "contact.d0", cat("= ", cc.adhesion.d0, " 1/m: must be >= 0"));
    require(std::abs(cc.plane_normal.norm() - 1) < 1e-12, "contact.plane_normal",
            "must be a unit vector");
    require(!(cc.adhesion.exact_kernel && cc.adhesion.d0 > 0 && discretization.nodal_contact),
            "contact.kernel",
            "= \"exact\" integrates the kernel over facets: it needs discretization.contact = "
            "\"facet-mean\" (the nodal contact has no facets)");
    // Every contact facet must lie on the boundary of the mesh.
    const auto boundary_keys = boundary_facet_keys(mesh);
    const int corners = dim == 2 ? 2 : mesh.nodes_per_facet() == 6 ? 3 : 4;
    for (Eigen::Index f = 0; f < b.facets.rows(); ++f) {
      std::vector<int> key;
      for (int k = 0; k < corners; ++k) key.push_back(b.facets(f, k));
      std::sort(key.begin(), key.end());
      require(boundary_keys.count(key) > 0, "contact.group",
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
}

}  // namespace ltl
