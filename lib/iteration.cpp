// The iteration policy [LTL87 (4.4)] (iteration.hpp).
#include "iteration.hpp"

#include <algorithm>
#include <cmath>

#include "error.hpp"

namespace ltl {

IterationPolicy::IterationPolicy(const AlgorithmParams& alg, StepReport& report,
                                 const Progress& progress)
    : alg_(alg), report_(report), progress_(progress), start_(std::chrono::steady_clock::now()) {}

void IterationPolicy::record(IterationRecord& rec) {
  rec.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  report_.history.push_back(rec);
  report_.iterations = rec.n;
  if (progress_) progress_(rec);
}

bool IterationPolicy::capped(int n) {
  if (n < alg_.max_iter) return false;
  report_.status = cat(
      "iteration cap reached (", alg_.max_iter, " iterations) without convergence",
      std::isnan(equilibrium_error_)
          ? ""
          : cat(" (equilibrium error ", equilibrium_error_, " > force_tol ", alg_.force_tol, ")"));
  return true;
}

bool IterationPolicy::stop(const IterationRecord& rec, bool finite,
                           const std::function<double()>& equilibrium) {
  const double r = rec.r_G + rec.r_B;
  if (!std::isfinite(r) || !finite) {
    report_.status = "NaN in the iterate";
    return true;
  }
  if (first_ < 0) first_ = std::max(r, 1e-300);
  if (r > alg_.blowup * first_ && rec.n > 1) {
    report_.status = cat("residual blow-up (r_G + r_B = ", r, " > ", alg_.blowup,
                         " x the first residual ", first_, ")");
    return true;
  }
  // (4.4) the paper's test on the iterate's changes, or (4.5) the state in equilibrium.
  bool converged = r < alg_.tol;
  if (alg_.stopping == Stopping::Equilibrium && equilibrium) {
    const bool due = r < kEquilibriumGate && (rec.n % kEquilibriumEvery == 0 || r < alg_.tol);
    const double e = due ? equilibrium() : NAN;  // NaN also: a map without the measure
    if (!std::isnan(e)) equilibrium_error_ = e;
    if (!std::isnan(e) || !due) converged = e <= alg_.force_tol;  // false when NaN
  }
  if (converged) {
    report_.converged = true;
    report_.status = "converged";
    return true;
  }
  if (best_ < 0) start_n_ = rec.n - 1;
  if (best_ < 0 || r < 0.99 * best_) best_ = r, best_n_ = rec.n;
  // The window grows with the step (half its iterations so far): a slow evolution that still
  // gains 1 % now and then is not stopped, a residual stuck for good is.
  const int window = std::max(alg_.stagnation_window, (rec.n - start_n_) / 2);
  if (rec.n - best_n_ >= window) {
    report_.status = cat("stagnated: r_G + r_B = ", r, " has not decreased by 1 % in ", window,
                         " iterations (best ", best_, ")");
    return true;
  }
  return capped(rec.n);
}

}  // namespace ltl
