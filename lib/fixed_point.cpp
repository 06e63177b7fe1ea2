// The fixed-point driver (fixed_point.hpp).
#include "fixed_point.hpp"

#include <optional>

#include "anderson.hpp"
#include "iteration.hpp"

namespace ltl {

void drive(FixedPointMap& map, const AlgorithmParams& alg, StepReport& report,
           const std::function<void(const IterationRecord&)>& progress) {
  IterationPolicy policy(alg, report, progress);
  const auto in_equilibrium = [&map] { return map.equilibrium_error(); };
  // Anderson with the safeguard that can only help (anderson.hpp, SafeguardedAnderson).
  std::optional<SafeguardedAnderson> anderson;
  Eigen::VectorXd x, g;
  if (alg.acceleration == Acceleration::Anderson) {
    anderson.emplace(map.packed_size(), alg.depth, map.packed_distributed());
    x.resize(map.packed_size());
    g.resize(map.packed_size());
  }
  const int n0 = report.iterations;  // iterations of earlier phases of the step
  for (int n = n0 + 1;; ++n) {
    if (anderson) map.pack(x);
    int failures = 0;
    IterationRecord rec = map.apply(failures);
    rec.n = n;
    const double merit = rec.r_G + rec.r_B;
    const bool reject =
        anderson && anderson->reject(merit, failures == 0 && map.finite(), rec, report);
    if (!reject) report.strain_failures += failures;
    policy.record(rec);
    if (reject) {
      map.restore_plain();  // the plain iterate G(x^{n-1})
      if (policy.capped(n)) break;
      continue;
    }
    if (policy.stop(rec, map.finite(), in_equilibrium)) break;
    if (map.after_iteration(rec)) {
      if (anderson) anderson->restart();
      continue;
    }
    if (anderson) {
      map.pack(g);
      if (anderson->extrapolate(x, g, merit)) {
        map.keep_plain();
        map.unpack(g);
      }
    }
  }
}

}  // namespace ltl
