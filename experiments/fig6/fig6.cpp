//               LTL87 Figure 6: a three-dimensional gutter hanging over a plane
//
// Paper:    Le Tallec & Lotfi (1987), section 8, Figure 6 (lost; no caption survives). The
//           text: "a three dimensional gutter, of length 20., of thickness .2, of internal
//           radius 1., hanged over the solid plane y = -3. It is made of a Mooney-Rivlin
//           material, with C1 = 50 kPa, C2 = 0, and is subjected on its above face to a
//           vertical surface loading of 0.5 kPa. For symmetry reasons, only one fourth of the
//           body was computed, using 270 H8 hexaedra, and 70 iterations of algorithm
//           (4.1)-(4.4) for a total CPU time of 108 mn on a DPS 8/Multics."
//
// Make:     make fig6
// Run:      build/experiments/fig6 experiments/fig6/fig6.toml -o results/fig6.h5
//           /usr/bin/python3 figures/fig6.py results/fig6.h5 results/fig6.png
//
// Problem:  pure contact (w = 1/eps = d = 0, one step P = 1), 3-D; the half tube
//           1 <= r <= 1.2 m, x2 <= 0, |x1| <= 10 m; the quarter x1 in [0, 10], x3 >= 0 is
//           computed. Find a local minimum u over K of                   [LTL87 (2.1)-(2.2)]
//
//             J(v) = int_Omega W(I + grad v) - int_inner g.v,  g = (0, -500, 0) Pa (dead)
//             K: det(I + grad v) = 1 in Omega; x2 + v2 >= -3 on the outer face Gamma_c;
//                u = 0 on the end x1 = 10 (clamped); u1 = 0 on x1 = 0, u3 = 0 on x3 = 0
//                (symmetry)                                                          (1.1)
//             W(F) = C1 (|F|^2 - 3), C1 = 50 kPa (Mooney-Rivlin (1.5) with C2 = 0)
//
//        cross-section (x3, x2)                side view (x1, x2), whole body
//               x2                                     x2
//       --------+--------  rim x2 = 0        //+=======+=======+//  ends x1 = -10, 10
//       \       |       /  inner r = 1 m:      |   g = 500 Pa    |   clamped
//        \      |      /   g = 500 Pa down     +-------+---------+
//         '-----+-----'    outer r = 1.2 m:            |
//               |          Gamma_c                     |
//      /////////+/////////  plane x2 = -3    //////////+////////////  plane x2 = -3
//
// Writes:   results/fig6.h5 (+ results/fig6.xdmf), layout in lib/results.hpp; prints the
//           sag, the contact zone (contact points, area) and the contact force against the load.

#include <algorithm>
#include <cstdio>

#include "cli.hpp"
#include "fe.hpp"
#include "measures.hpp"

// The configuration experiments/fig6/fig6.toml meshes the quarter with 270 H8 hexahedra (2
// through the thickness, 9 around the quarter arc, 15 along the half length) and uses R = 5,
// q = q_c = 100 kPa (Fig 5's choice scaled to this material, 2 C1). As in Fig 5 the local
// contact step (4.7) is a projection onto e.N <= g per contact point [LTL87 (6.6)-(6.7)]; the
// contact points are the nodes of the outer face (discretization.contact = "nodal", the default;
// "facet-mean" is the paper's P0 choice, see paper_notes/discretization.md):
//
//   iterate (4.1) global solve for u, (4.2) local steps in E per cell (4.6, det E = 1) and in e
//   per contact point (4.7), (4.3) multiplier update, until (4.4); one step only.
//
// Numbers for the whole body are four times those of the computed quarter (nodal weights on the
// symmetry planes are half weights, so that 4 x quarter is the whole body).

namespace {

void report(const ltl::Solver& solver, const ltl::RunSummary& run) {
  const ltl::Problem& problem = solver.problem();
  const ltl::State& s = run.state;
  const ltl::Mesh& mesh = problem.mesh;
  // The measures (lib/measures.hpp) over the solver's contact points, and the applied load
  // along the plane's normal N (downward): the consistent nodal loads summed.
  const ltl::ContactMeasures m = ltl::contact_measures(solver.discretization(), s, 0);
  const double load = ltl::load_along_normal(solver.problem(), solver.external_load());

  // The sag: the largest downward displacement, and where it happens.
  int n_sag = 0;
  const double sag = (-s.u.col(1)).maxCoeff(&n_sag);

  std::printf("fig6 (computed quarter; whole body = 4 x quarter):\n");
  std::printf("  maximum sag -u2: %.4f m at X = (%.3f, %.3f, %.3f)\n", sag, mesh.X(n_sag, 0),
              mesh.X(n_sag, 1), mesh.X(n_sag, 2));
  std::printf(
      "  contact points (%s) in contact: %d of %d; contact area %.4g m^2 (whole body %.4g "
      "m^2)\n",
      problem.discretization.nodal_contact ? "nodes" : "facets", m.in_contact, m.points, m.area,
      4 * m.area);
  std::printf("  peak contact pressure: %.4g Pa\n", m.p_max);
  std::printf(
      "  contact force: %.5g N (whole body %.5g N); load on the quarter %.5g N "
      "(fraction carried by the plane %.3f)\n",
      m.force, 4 * m.force, load, load > 0 ? m.force / load : 0.0);
  std::printf("  largest nodal penetration of the plane: %.4g m\n", m.penetration);
  if (!run.iterations.empty()) std::printf("  iterations: %d (paper: 70)\n", run.iterations[0]);
}

}  // namespace

// The recipe (lib/cli.hpp, lib/simulation.hpp): load -> discretize and precompute -> solve the
// time steps, each written as soon as it converges -> measure.
static void solve_and_report(const ltl::CommandLine& cmd) {
  const ltl::Problem problem = ltl::load_problem(cmd);             // the configuration, validated
  const ltl::RunOptions options = ltl::run_options(cmd, problem);  // -o or results/fig6.h5
  ltl::Solver solver{ltl::Discretization(problem)};  // discretize; K with R q factorized once (4.5)
  const ltl::RunSummary run = ltl::run(solver, options);  // (2.1): ALG2 per step, written at once
  report(solver, run);
  ltl::print_newton_beside(problem, run);  // the same state by Newton, its iterations
}

// Errors: one line on stderr, exit status 1; bad usage: 2.
int main(int argc, char** argv) {
  return ltl::guarded_main(argc, argv, "fig6", "experiments/fig6/fig6.toml", solve_and_report);
}
