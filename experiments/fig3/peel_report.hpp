// The numbers printed by the Fig 3 and Fig 4 drivers at their last step: where the glue has
// broken, how far the bar has lifted off its support, and which step was the hardest.
#pragma once

#include <algorithm>
#include <cstdio>
#include <functional>

#include "cli.hpp"
#include "fe.hpp"
#include "measures.hpp"

namespace ltl::figures {

/// Prints the peel summary of `name`; `extra(facets, opening)` (optional) prints more lines
/// before the hardest step.
inline void peel_report(
    const char* name, const Solver& solver, const RunSummary& run,
    const std::function<void(const ContactPoints&, const Eigen::VectorXd&)>& extra = {}) {
  const Problem& problem = solver.problem();
  const State& s = run.state;
  // The measures (lib/measures.hpp, one definition each) over the solver's contact points, which
  // carry beta: the facets of the contact surface (discretization.contact = "facet-mean", as in
  // the paper) or its nodes.
  const ContactPoints& facets = *solver.discretization().points();
  const PeelMeasures m = peel_measures(problem, facets, s, 0);
  const Eigen::VectorXd opening = ltl::opening(problem, s);  // -e . N per point, (4.11)

  std::printf("%s at t = %g s (step %d):\n", name, run.last_step * problem.time.dt, run.last_step);
  if (m.broken > 0)
    std::printf("  debonding front (largest x1 with beta < %g): %.4f m; %d of %d facets\n",
                kDebondedBeta, m.front, m.broken, m.points);
  else
    std::printf("  debonding front (largest x1 with beta < %g): none\n", kDebondedBeta);
  std::printf("  beta: min %.3g, max %.3g\n", m.beta_min, m.beta_max);
  std::printf("  maximum opening e.(-N): %.4g m at x1 = %.4f m\n", m.max_opening, m.max_opening_x);
  if (extra) extra(facets, opening);
  // The hardest step is the one where the peel runs away.
  const auto hardest = std::max_element(run.iterations.begin(), run.iterations.end());
  if (hardest != run.iterations.end()) {
    const int p = run.first_step + static_cast<int>(hardest - run.iterations.begin());
    std::printf("  hardest step: %d (t = %g s), %d iterations\n", p, p * problem.time.dt, *hardest);
  }
}

}  // namespace ltl::figures
