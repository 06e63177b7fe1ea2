// Adaptive R (algorithm.adaptive_R): the augmentation R of ALG2 (4.1)-(4.5) chosen during the
// iteration by residual balancing, with a safeguard against the rotated branch of the local
// strain step. Its own object: the Solver asks it for the next R at each check and
// re-factorizes K (4.5) when the answer differs.
#pragma once

#include "problem.hpp"
#include "state.hpp"

namespace ltl {

class AdaptiveR {
 public:
  explicit AdaptiveR(const AlgorithmParams& a) : a_(a) {}

  /// A new time step: a lowering of the last step is no longer watched.
  void start_step() { lowered_ = false; }

  /// [residual balancing] The R that balances r_G and r_B after iteration rec, given R in use
  /// (R itself: no change); never below the floor (R_min, or R, and an undone lowering's R).
  double balanced(const IterationRecord& rec, double R) const;

  /// At the check after iteration rec (every adapt_every iterations), with R in use and the
  /// number of factorizations so far: the R to use next (R itself: no change, nothing
  /// re-factorized). The safeguard of a lowered R may restore s to the best iterate since the
  /// lowering (and return the R before it).
  double next(const IterationRecord& rec, double R, int factorizations, State& s);

 private:
  AlgorithmParams a_;
  // Whether R was last lowered, the R before, the best merit since, its iteration and iterate;
  // the floor left by an undone lowering.
  bool lowered_ = false;
  double R_before_lowering_ = 0, best_merit_ = 0, R_floor_ = 0;
  int best_n_ = 0;
  State best_;
};

}  // namespace ltl
