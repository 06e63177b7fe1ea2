//                 LTL87 Figure 5: a Mooney-Rivlin cylinder resting on a plane
//
// Paper:    Le Tallec & Lotfi (1987), section 8, Figure 5 (lost; no caption survives). The
//           text: "a cylinder of radius unity, made of a Mooney-Rivlin material, with
//           C1 = 435 kPa, C2 = 65 kPa, at rest on a flat plane, and subjected to a vertical body
//           force of 400 kN/m^3. The result was obtained after 40 iterations of algorithm
//           (4.1)-(4.4) with R = 5, q = q_c = 1000. and with 120 finite elements of Ruas type
//           for approximating half the cylinder."
//
// Make:     make fig5
// Run:      build/experiments/fig5 experiments/fig5/fig5.toml -o results/fig5.h5
//           /usr/bin/python3 figures/fig5.py results/fig5.h5 results/fig5.png
//
// Problem:  pure contact (w = 1/eps = d = 0, one step P = 1), plane strain, the half disc
//           x1 >= 0 of radius 1 m by symmetry; find a local minimum u over K of
//                                                                       [LTL87 (2.1)-(2.2)]
//             J(v) = int_Omega W(I + grad v) - int_Omega f.v,   f = (0, -400) kN/m^3
//             K: det(I + grad v) = 1 in Omega; x2 + v2 >= -1 on Gamma_c (the lower quarter
//                circle may not cross the plane); v1 = 0 on x1 = 0 (symmetry)        (1.1)
//             W(F) = C1 (|F|^2 - 3) + C2 (|adj F|^2 - 3), C1 = 435 kPa, C2 = 65 kPa  (1.5)
//
//                     x2
//                     |
//                  .--+--.          f = (0, -400) kN/m^3
//                /    |    \        (a dead load)
//               |     O-----|--> x1  only the half x1 >= 0 is computed
//                \    |    /         Gamma_c: the lower quarter circle
//                  '--+--'
//          ///////////+///////////  rigid plane x2 = -1, touched at one point at rest
//
// Writes:   results/fig5.h5 (+ results/fig5.xdmf), layout in lib/results.hpp; prints the
//           contact half-width, the peak pressure, the contact force against the weight, and
//           the drop of the top of the cylinder.

#include <algorithm>
#include <cstdio>

#include "cli.hpp"
#include "error.hpp"
#include "fe.hpp"

// The configuration experiments/fig5/fig5.toml gives the paper's data: mesh (122 P2 triangles;
// the paper had 120 Ruas elements), material, body force, the plane, and R = 5, q = q_c = 1000
// read in kPa. With w = 0 and 1/eps = 0 the local step (4.7) reduces to a projection of the
// contact displacement e onto the half-space e.N <= g [LTL87 (6.6)-(6.7)], g the initial gap of
// each facet centre to the plane, and the multiplier lambda_c is the contact traction:
//
//   iterate (4.1) global solve for u, (4.2) local steps in E per cell (4.6, det E = 1) and in e
//   per contact facet (4.7), (4.3) multiplier update, until (4.4); one step only.
//
// Both constraints are imposed on means: det E = 1 per cell on the mean gradient, and the
// non-penetration per facet on the mean displacement (one multiplier per facet). Nodes of a
// P2 facet can therefore cross the plane while the facet mean does not; the report says by how
// much.

namespace {

void report(const ltl::Problem& problem, const ltl::RunSummary& run) {
  const ltl::State& s = run.state;
  const ltl::Mesh& mesh = problem.mesh;
  const auto& contact = *problem.contact;
  const auto& boundary = mesh.boundary(contact.group);
  const ltl::FacetOperators facets = ltl::facet_operators(mesh, boundary);
  const Eigen::VectorXd N = contact.plane_normal.head(mesh.dim).normalized();
  const Eigen::VectorXd p0 = contact.plane_point.head(mesh.dim);
  const Eigen::MatrixXd x = mesh.X + s.u;  // deformed positions, #nodes x dim

  // Contact pressure p = -lambda_c . N per facet (a nominal traction, per reference length); a
  // facet is in contact where p exceeds round-off.
  const Eigen::VectorXd p = -(s.lambda_c.transpose() * N);
  const double p_max = p.maxCoeff();
  int in_contact = 0;
  double force = 0, a = 0;
  for (int f = 0; f < facets.size(); ++f) {
    if (!(p(f) > 1e-6 * p_max)) continue;
    ++in_contact;
    force += p(f) * facets.area(f);
    // The contact half-width: the deformed x1 of the outer end vertex of the outermost facet
    // in contact (columns 0, 1 of a P2 edge are its end vertices).
    for (int k = 0; k < 2; ++k) a = std::max(a, x(boundary.facets(f, k), 0));
  }

  // The weight of the half cylinder (per unit length): |f| |Omega|.
  const double area = ltl::cell_operators(mesh).vol.sum();
  const double weight = problem.body_force.head(mesh.dim).norm() * area;

  // The drop of the top of the cylinder: u2 at the node (0, 1).
  int top = -1;
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if ((mesh.X.row(n) - Eigen::RowVector2d(0, 1)).norm() < 1e-9) top = n;
  if (top < 0) throw ltl::Error("fig5: the mesh has no node at (0, 1)");

  // How far the contact nodes go through the plane, (x - p0).N > 0 [LTL87 (4.11) in the mean].
  double penetration = 0;
  for (int f = 0; f < facets.size(); ++f)
    for (int k = 0; k < boundary.facets.cols(); ++k)
      penetration = std::max(penetration, (x.row(boundary.facets(f, k)).transpose() - p0).dot(N));

  std::printf("fig5 (half cylinder, per metre of length):\n");
  std::printf("  facets in contact: %d of %d\n", in_contact, facets.size());
  std::printf(
      "  contact half-width a: %.4f m (outer end of the outermost facet in contact;\n"
      "    facets are %.3f m long)\n",
      a, facets.area(0));
  std::printf("  peak contact pressure: %.4g Pa\n", p_max);
  std::printf("  contact force: %.5g N/m, weight of the half cylinder: %.5g N/m (ratio %.4f)\n",
              force, weight, force / weight);
  std::printf("  drop of the top (u2 at (0, 1)): %.4f m\n", -s.u(top, 1));
  std::printf("  largest nodal penetration of the plane: %.4g m\n", penetration);
  if (!run.iterations.empty()) std::printf("  iterations: %d (paper: 40)\n", run.iterations[0]);
}

}  // namespace

int main(int argc, char** argv) {
  return ltl::cli_main(argc, argv, {"fig5", "experiments/fig5/fig5.toml", report});
}
