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
#include "measures.hpp"

// The configuration experiments/fig5/fig5.toml gives the paper's data: mesh (122 P2 triangles;
// the paper had 120 Ruas elements), material, body force, the plane, and R = 5, q = q_c = 1000
// read in kPa. With w = 0 and 1/eps = 0 the local step (4.7) reduces to a projection of the
// contact displacement e onto the half-space e.N <= g [LTL87 (6.6)-(6.7)], g the initial gap of
// each contact point to the plane, and the multiplier lambda_c is the contact traction:
//
//   iterate (4.1) global solve for u, (4.2) local steps in E per cell (4.6, det E = 1) and in e
//   per contact point (4.7), (4.3) multiplier update, until (4.4); one step only.
//
// Discretization (paper_notes/discretization.md): det E = 1 per cell on the mean gradient; the
// C2 term, which on det F = 1 in plane strain is C2 (|F|^2 + 1), joins C1 in the global
// quadratic on the full gradient; non-penetration at every node of the contact surface. The
// paper's choices (C2 on cell means, contact on facet means) are discretization.c2 = "cell-mean"
// and discretization.contact = "facet-mean": they do not converge under refinement.

namespace {

void report(const ltl::Solver& solver, const ltl::RunSummary& run) {
  const ltl::Problem& problem = solver.problem();
  const ltl::State& s = run.state;
  const ltl::Mesh& mesh = problem.mesh;
  // The measures (lib/measures.hpp, one definition each) over the solver's contact points: the
  // nodes of the contact surface (default) or its facets (discretization.contact = "facet-mean").
  const ltl::ContactMeasures m = ltl::contact_measures(solver.discretization(), s, 0);

  // The weight of the half cylinder (per unit length): |f| |Omega|.
  const double weight = problem.body_force.head(mesh.dim).norm() * solver.discretization().volume();

  // The drop of the top of the cylinder: u2 at the node (0, 1).
  const int top = ltl::node_at(mesh, Eigen::Vector2d(0, 1));

  std::printf("fig5 (half cylinder, per metre of length):\n");
  std::printf("  contact points (%s) in contact: %d of %d\n",
              problem.discretization.nodal_contact ? "nodes" : "facets", m.in_contact, m.points);
  std::printf(
      "  contact half-width: a_edge %.4f m (outermost node carrying contact), a_moment "
      "%.4f m (2 sqrt(M2/M0))\n",
      m.a_edge, m.a_moment);
  std::printf("  peak contact pressure: %.4g Pa\n", m.p_max);
  std::printf("  contact force: %.5g N/m, weight of the half cylinder: %.5g N/m (ratio %.4f)\n",
              m.force, weight, m.force / weight);
  std::printf("  drop of the top (u2 at (0, 1)): %.4f m\n", -s.u(top, 1));
  std::printf("  largest nodal penetration of the plane: %.4g m\n", m.penetration);
  if (!run.iterations.empty()) std::printf("  iterations: %d (paper: 40)\n", run.iterations[0]);
}

}  // namespace

// The recipe (lib/cli.hpp, lib/simulation.hpp): load -> discretize and precompute -> solve the
// time steps, each written as soon as it converges -> measure.
static void solve_and_report(const ltl::CommandLine& cmd) {
  const ltl::Problem problem = ltl::load_problem(cmd);             // the configuration, validated
  const ltl::RunOptions options = ltl::run_options(cmd, problem);  // -o or results/fig5.h5
  ltl::Solver solver{ltl::Discretization(problem)};  // discretize; K with R q factorized once (4.5)
  const ltl::RunSummary run = ltl::run(solver, options);  // (2.1): ALG2 per step, written at once
  report(solver, run);                                    // the figure's numbers
  ltl::print_newton_beside(problem, run);  // the same state by Newton, its iterations
}

// Errors: one line on stderr, exit status 1; bad usage: 2.
int main(int argc, char** argv) {
  return ltl::guarded_main(argc, argv, "fig5", "experiments/fig5/fig5.toml", solve_and_report);
}
