//                      LTL87 Figure 3: a compressible bar peeled off its support
//
// Paper:    Le Tallec & Lotfi (1987), section 8, Figure 3. The figure is lost; its caption
//           survives as "RAPPORT= 0.2000E02" (displacements magnified x20). The text: "The
//           obtained numerical solution is represented in Fig. 3, is quite similar to the small
//           strains one of GUIDOUCHE and POINT."
//
// Readings: the paper does not say where the bar is fixed nor on which face and in which
//           direction g2 = 10 (1 - x1) kPa acts. experiments/fig3/fig3.toml is reading R3
//           (fixed at x1 = 1, top face PRESSED DOWN), the only one of the readings study
//           (`make readings`, paper_notes/readings.md) whose displacements stay at the
//           millimetre size the caption's x20 implies; fig3_literal.toml is the literal
//           reading R1 (pulled up, drawn below), which peels off to metre displacements.
//           The same driver runs both; `make fig3` draws results/fig3.png and fig3_literal.png.
//
// Make:     make fig3
// Run:      build/experiments/fig3 experiments/fig3/fig3.toml -o results/fig3.h5
//           /usr/bin/python3 figures/fig3.py results/fig3.h5 results/fig3.png
//
// Problem:  plane strain, the bar [0,1] x [0,0.2] m glued (beta_0 = 1) on a rigid support
//           x2 = 0, fixed at x1 = 1, pulled up on its top face; for p = 1..160, t_p = 5 p s,
//           find a local minimum {u_p, beta_p} over K of                       [LTL87 (2.1)]
//
//             J_p(v, gamma) = int_Omega W(I + grad v) - int_top g.v
//                           + int_Gc ( gamma^2 |v|^2 / (2 eps) - w gamma )
//                           + 1/(2 dt) int_Gc int_Gc d(x - y) [gamma - beta_{p-1}](x)
//                                                             [gamma - beta_{p-1}](y)  (2.2)
//             K: 0 <= gamma <= 1, v.n <= 0 on Gc, v = 0 on x1 = 1                  (1.1)
//             W(F) = C1 (|F|^2 - 3) + C3 (det F)^2 - C3 - 2 (C1 + C3) ln det F,
//                    C1 = C3 = 187.5 kPa  (E = 1000 kPa, nu = 0.33 in small strains)
//             d(y) = d0 exp(-d0 |y|), d0 = 1000 /m; w = 0.01 J/m^2; eps = 1e-9 m/Pa  (1.6)
//             g = (0, 10 (1 - x1)) kPa
//
//                    g2 = 10 (1 - x1) kPa, upward
//               ^    ^    ^    ^    ^    ^    .    .
//        x2   +-------------------------------------+//
//         ^   |                                     |//  Gamma_1: u = 0
//         |   |                bar                  |//
//         |   +-------------------------------------+//
//         +--> x1 ///// glue beta, Gamma_c: x2 = 0 /////   rigid support
//         free end x1 = 0                      x1 = 1
//
// Writes:   results/fig3.h5 (mesh, and per step u, E, lambda, stresses, beta, e, lambda_c,
//           contact pressure, gap, iteration history; layout in lib/results.hpp) with
//           results/fig3.xdmf beside it for ParaView; prints the debonding front and the
//           largest opening at t = 800 s.

#include <algorithm>
#include <cstdio>

#include "cli.hpp"
#include "peel_report.hpp"

// The experiment is entirely in experiments/fig3/fig3.toml: mesh (28 x 3 rectangles split into
// 168 P2 triangles, 28 contact segments, as in the paper), material, the fixed end, the
// traction, the glue, and the algorithm (R = 8, q = 2 C1, dt = 5 s, two block-relaxation sweeps
// per multiplier update, the paper's variant; q_c = 1/eps = 1e9 Pa/m as in the paper, 3e7 Pa/m in
// the literal reading, a choice explained in that configuration). The library does the rest:
//
//   for each time step p (backward Euler in beta, [LTL87 (2.1)-(2.2)]), starting from step
//   p - 1, iterate ALG2 until the change of the local unknowns and the constraint residual
//   are small [LTL87 (4.4)]:
//     (4.1) global step: one Poisson-like solve for u with the matrix factorized once (4.5);
//     (4.2) local steps: the strain E per cell (4.6) and, per contact facet, the contact
//           displacement e and the adhesion intensity beta (4.7), (6.1)-(6.8);
//     (4.3) multiplier update of lambda (strains) and lambda_c (contact tractions).
//
// What to expect: the glue first yields slowly near the free end x1 = 0 (beta decreases over a
// few steps, the dissipation (1.3) slowing it down), then the peel runs away within a single
// step and the bar lifts off its support.

namespace {

// The numbers of the figure, from the state at the last step: where the glue has broken and
// how far the bar has lifted off its support.
void report(const ltl::Solver& solver, const ltl::RunSummary& run) {
  ltl::figures::peel_report("fig3", solver, run);
}

}  // namespace

// The recipe (lib/cli.hpp, lib/simulation.hpp): load -> discretize and precompute -> solve the
// time steps, each written as soon as it converges -> measure.
static void solve_and_report(const ltl::CommandLine& cmd) {
  const ltl::Problem problem = ltl::load_problem(cmd);             // the configuration, validated
  const ltl::RunOptions options = ltl::run_options(cmd, problem);  // -o or results/fig3.h5
  ltl::Solver solver{ltl::Discretization(problem)};  // discretize; K with R q factorized once (4.5)
  const ltl::RunSummary run = ltl::run(solver, options);  // (2.1): ALG2 per step, written at once
  report(solver, run);                                    // the figure's numbers
  ltl::print_newton_beside(problem, run);  // the same steps by Newton, its iterations
}

// Errors: one line on stderr, exit status 1; bad usage: 2.
int main(int argc, char** argv) {
  return ltl::guarded_main(argc, argv, "fig3", "experiments/fig3/fig3.toml", solve_and_report);
}
