// The numbers printed by the Fig 3 and Fig 4 drivers at their last step: where the glue has
// broken, how far the bar has lifted off its support, and which step was the hardest.
#pragma once

#include <algorithm>
#include <cstdio>
#include <functional>

#include "cli.hpp"
#include "fe.hpp"

namespace ltl::figures {

/// Prints the peel summary of `name`; `extra(facets, opening)` (optional) prints more lines
/// before the hardest step.
inline void peel_report(
    const char* name, const Problem& problem, const RunSummary& run,
    const std::function<void(const FacetOperators&, const Eigen::VectorXd&)>& extra = {}) {
  const State& s = run.state;
  const auto& contact = *problem.contact;
  const FacetOperators facets = facet_operators(problem.mesh, problem.mesh.boundary(contact.group));
  const Eigen::VectorXd N = contact.plane_normal.head(problem.mesh.dim).normalized();

  // Debonding front: the largest facet-centre x1 where less than half the glue links survive.
  int broken = 0;
  double front = -1;
  for (int f = 0; f < facets.size(); ++f)
    if (s.beta(f) < 0.5) ++broken, front = std::max(front, facets.centre(0, f));

  // Opening (lift-off) of a facet: its contact displacement along -N, away from the support
  // [LTL87 (4.11): e.n <= 0 on Gamma_c, here n = N].
  const Eigen::VectorXd opening = -(s.e.transpose() * N);
  int f_max = 0;
  opening.maxCoeff(&f_max);

  std::printf("%s at t = %g s (step %d):\n", name, run.last_step * problem.time.dt, run.last_step);
  if (front >= 0)
    std::printf("  debonding front (largest x1 with beta < 0.5): %.4f m; %d of %d facets\n", front,
                broken, facets.size());
  else
    std::printf("  debonding front (largest x1 with beta < 0.5): none\n");
  std::printf("  beta: min %.3g, max %.3g\n", s.beta.minCoeff(), s.beta.maxCoeff());
  std::printf("  maximum opening e.(-N): %.4g m at x1 = %.4f m\n", opening(f_max),
              facets.centre(0, f_max));
  if (extra) extra(facets, opening);
  // The hardest step is the one where the peel runs away.
  const auto hardest = std::max_element(run.iterations.begin(), run.iterations.end());
  if (hardest != run.iterations.end()) {
    const int p = run.first_step + static_cast<int>(hardest - run.iterations.begin());
    std::printf("  hardest step: %d (t = %g s), %d iterations\n", p, p * problem.time.dt, *hardest);
  }
}

}  // namespace ltl::figures
