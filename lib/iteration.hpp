// The iteration policy of ALG2 [LTL87 (4.4)], shared by the finite-elasticity solver (alg2.cpp)
// and the Signorini solver (signorini.cpp): every iteration's record goes into the step's
// history and to the progress callback; the step is converged when r_G + r_B < tol (stopping =
// "paper") or when the state is in equilibrium (stopping = "equilibrium"); a NaN, a
// residual above blowup x the first residual, or the iteration cap end it unconverged, with
// report.status saying which.
#pragma once

#include <chrono>
#include <cmath>
#include <functional>

#include "problem.hpp"
#include "state.hpp"

namespace ltl {

/// stopping = "equilibrium": the equilibrium error (an assembly of the nodal forces, about as
/// costly as an iteration) is evaluated once r_G + r_B is below kEquilibriumGate, at every
/// kEquilibriumEvery-th iteration and whenever r_G + r_B < tol (measured on Fig 5: evaluated at
/// every iteration it doubled the solver's time).
inline constexpr double kEquilibriumGate = 1e-3;
inline constexpr int kEquilibriumEvery = 10;

class IterationPolicy {
 public:
  using Progress = std::function<void(const IterationRecord&)>;

  /// alg: tol, blowup and max_iter are read. report and progress (may be empty) must outlive
  /// the policy; the wall clock of the records starts here.
  IterationPolicy(const AlgorithmParams& alg, StepReport& report, const Progress& progress);

  /// Records iteration rec.n: its wall time since the start, the history, the count, progress.
  void record(IterationRecord& rec);
  /// After record(): true when the step ends here (report.converged and report.status set):
  /// NaN in r_G + r_B or in the iterate (finite = false), blow-up, convergence (r_G + r_B < tol;
  /// or with alg.stopping = Equilibrium, equilibrium() <= alg.force_tol when it is a number, when
  /// it is due: kEquilibriumGate, kEquilibriumEvery), stagnation
  /// (the best r_G + r_B not lowered by 1 % in max(alg.stagnation_window, half the step's
  /// iterations) iterations; status starts with "stagnated"), or the cap.
  bool stop(const IterationRecord& rec, bool finite,
            const std::function<double()>& equilibrium = nullptr);
  /// The cap alone (for an iterate the acceleration safeguard rejected): true when n reached it.
  bool capped(int n);

 private:
  const AlgorithmParams& alg_;
  StepReport& report_;
  const Progress& progress_;
  std::chrono::steady_clock::time_point start_;
  double first_ = -1;  ///< the first residual r_G + r_B of the step
  double best_ = -1;   ///< the best r_G + r_B, and the iteration it was last lowered by 1 %
  int best_n_ = 0, start_n_ = 0;
  double equilibrium_error_ =
      NAN;  ///< the last equilibrium error evaluated (stopping = Equilibrium)
};

}  // namespace ltl
