// The one nonlinear-solve driver of the package for fixed-point maps x -> G(x): ALG2's
// (4.1)-(4.3) / (7.7)-(7.10) (alg2.cpp) and the Signorini iteration of section 7 (signorini.cpp)
// run under the same policy, written once here:
//
//   for n = 1, 2, ...
//     x = pack(iterate);  apply the map once;  rec = its residuals r_G, r_B      (4.4)
//     Anderson's safeguard: an accelerated iterate whose successor is worse is undone
//     stop on NaN, blow-up, stagnation, the cap, or convergence: r_G + r_B < tol (4.4), or
//     with stopping = "equilibrium" the map's equilibrium error at most force_tol (IterationPolicy)
//     the map's own check (adaptive R): a changed map restarts the acceleration
//     Anderson: g = pack(iterate); the accelerated iterate replaces the plain one
//
// The map says how to apply itself and how to read and write its iterate as one vector; the
// driver owns acceleration, safeguard and stopping. The Newton phase (newton.hpp) is the
// second phase of a step, after this one.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <limits>

#include "problem.hpp"
#include "state.hpp"

namespace ltl {

class FixedPointMap {
 public:
  virtual ~FixedPointMap() = default;
  /// Length of the packed iterate (the part Anderson extrapolates), scaled so that its
  /// Euclidean norm is the norm of r_G + r_B.
  virtual Eigen::Index packed_size() const = 0;
  /// Over MPI ranks: how many leading entries of the packed iterate are this rank's share of a
  /// vector split over the ranks (Anderson sums their inner products over the ranks); the rest
  /// is the same on every rank. 0 on one process.
  virtual Eigen::Index packed_distributed() const { return 0; }
  virtual void pack(Eigen::VectorXd& z) const = 0;
  virtual void unpack(const Eigen::VectorXd& z) = 0;
  /// One application of the map to the current iterate, in place: the record's r_G, r_B and
  /// timings; `failures` counts local problems that failed in it.
  virtual IterationRecord apply(int& failures) = 0;
  /// Is the iterate the last apply() produced finite (asked right after apply())?
  virtual bool finite() const = 0;
  /// Keeps the current (plain) iterate before it is replaced by an accelerated one, and goes
  /// back to it when the safeguard rejects that one.
  virtual void keep_plain() = 0;
  virtual void restore_plain() = 0;
  /// After an iteration that was kept and did not stop: true when the map itself changed (e.g.
  /// adaptive R re-factorized K); the acceleration history then restarts.
  virtual bool after_iteration(const IterationRecord&) { return false; }
  /// The equilibrium error of the current iterate (measures.hpp, equilibrium_error), the test of
  /// stopping = "equilibrium"; NaN for a map that has none (it then stops on r_G + r_B < tol).
  virtual double equilibrium_error() const { return std::numeric_limits<double>::quiet_NaN(); }
};

/// Iterates `map` from its current iterate under alg's policy (tol, blowup, max_iter,
/// acceleration, depth), appending every iteration to report (history, counts, status,
/// converged) and calling progress (may be empty). Never throws on divergence.
void drive(FixedPointMap& map, const AlgorithmParams& alg, StepReport& report,
           const std::function<void(const IterationRecord&)>& progress);

}  // namespace ltl
