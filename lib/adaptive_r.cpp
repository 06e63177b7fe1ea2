// Adaptive R (adaptive_r.hpp).
#include "adaptive_r.hpp"

#include <algorithm>

namespace ltl {

// Residual balancing [Boyd et al. 2011, sec. 3.4.1, for ADMM]: r_B is the primal residual and
// R r_G the dual one (the change of the local variables priced at R q, in the units of r_B).
// R grows when the constraint lags, and shrinks when the local variables still move, by a factor
// 2 when the two are more than 10 apart; never below R_min (the local step's physical branch).
double AdaptiveR::balanced(const IterationRecord& rec, double R) const {
  constexpr double mu = 10, tau = 2;
  const double R_min = std::max(a_.R_min > 0 ? a_.R_min : a_.R, R_floor_);
  if (rec.r_B > mu * R * rec.r_G) return tau * R;
  if (R * rec.r_G > mu * rec.r_B) return std::max(R / tau, std::min(R_min, R));
  return R;
}

// The safeguard of a lowered R: a smaller R q can put the local strain step on a rotated branch
// under high stresses (paper_notes/section3-4.md), where the iteration stalls and then drifts
// away. Since the last lowering the best iterate (by merit, at the checks) is kept; when no check
// has improved on it for 10 checks, that iterate is restored, R goes back to its value before the
// lowering and stays at or above it for the rest of the run.
double AdaptiveR::next(const IterationRecord& rec, double R, int factorizations, State& s) {
  const int n = rec.n;
  const double merit = rec.r_G + rec.r_B;
  const bool may_factorize = factorizations <= a_.max_refactorizations;
  if (lowered_) {
    if (merit < best_merit_) {
      best_merit_ = merit, best_n_ = n;
      best_ = s;
    } else if (n - best_n_ >= 10 * a_.adapt_every && may_factorize) {
      s = best_;
      R_floor_ = R_before_lowering_;
      lowered_ = false;
      return R_before_lowering_;
    }
  }
  if (!may_factorize) return R;
  const double next = balanced(rec, R);
  if (next == R) return R;
  if (next < R) {
    lowered_ = true;
    R_before_lowering_ = R;
    best_merit_ = merit, best_n_ = n;
    best_ = s;
  } else {
    lowered_ = false;
  }
  return next;
}

}  // namespace ltl
