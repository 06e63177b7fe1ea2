// Anderson acceleration (type II, "Anderson mixing" with mixing parameter 1) of a fixed-point
// iteration x -> G(x) [Walker & Ni 2011, SIAM J. Numer. Anal. 49(4)]: with the residual
// f = G(x) - x and the last m differences dF_j = f_{j+1} - f_j, dG_j = G(x_{j+1}) - G(x_j),
//   gamma = argmin || f_k - dF gamma ||,   x_{k+1} = G(x_k) - dG gamma.
// The history is a preallocated ring of m columns: no allocation after construction.
//
// Two choices (their measurements on ALG2: paper_notes/performance.md, "Anderson acceleration"):
// - extrapolate only once the history holds m differences (after a start or a restart the plain
//   iterates refill it): a one- or two-column secant step on a map contracting at 0.999 per
//   iteration jumps ~1/(1 - 0.999) times the residual and is rejected;
// - bound the extrapolation, ||x_{k+1} - G(x_k)|| <= cap ||f_k|| (gamma scaled down): unbounded,
//   the safeguard rejects most tries.
#pragma once

#include <Eigen/Dense>

#include "state.hpp"

namespace ltl {

class Anderson {
 public:
  static constexpr int max_depth = 16;

  /// n unknowns, depth m (1 <= m <= max_depth), step bound cap (see above). Over MPI ranks
  /// (mpi_comm.hpp) the first `distributed` unknowns are this rank's share of a vector split over
  /// the ranks: their inner products are summed over the ranks; the others are the same on every
  /// rank and counted once. With distributed = 0 (one process) every inner product is local.
  Anderson(Eigen::Index n, int m, double cap = 10, Eigen::Index distributed = 0);

  /// Appends the pair (x_k, G(x_k)) and overwrites g with the accelerated iterate x_{k+1}
  /// (g unchanged while the history holds fewer than m differences). Returns the number of
  /// differences used (0: g is the plain iterate).
  int step(const Eigen::VectorXd& x, Eigen::VectorXd& g);

  /// Forgets the history (after a rejected iterate).
  void restart() {
    columns_ = 0;
    have_previous_ = false;
  }
  int columns() const { return columns_; }

 private:
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, max_depth, max_depth>;
  using SmallVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, max_depth, 1>;
  /// The inner products of the step (the Gram matrix and dF^T f), summed over the ranks for the
  /// distributed entries (one reduction).
  void inner_products(int k);
  /// The Euclidean norm of a vector of n unknowns, over the ranks like the inner products.
  double norm(const Eigen::VectorXd& v) const;
  int m_;
  Eigen::Index distributed_ = 0;
  int columns_ = 0, next_ = 0;
  bool have_previous_ = false;
  Eigen::MatrixXd dF_, dG_;
  double cap_;
  Eigen::VectorXd f_, f_prev_, g_prev_, step_;
  Small gram_;
  SmallVec rhs_, gamma_;
};

/// The safeguard that makes Anderson acceleration "one that can only help", shared by ALG2
/// (alg2.cpp) and the Signorini solver (signorini.cpp): an accelerated iterate is kept only when
/// the merit r_G + r_B of the iteration that follows it does not exceed the merit of the iterate
/// it was extrapolated from (and that iteration went well); otherwise the caller goes back to
/// the plain iterate and the history restarts. Per iteration n of a fixed-point loop:
///
///   pack(state, x);  iterate;  rec = its residuals
///   if (aa.reject(merit, ok, rec, report)) { state = plain; continue; }
///   if (stop) break;
///   pack(state, g);  if (aa.extrapolate(x, g, merit)) { plain = state; unpack(g, state); }
class SafeguardedAnderson {
 public:
  SafeguardedAnderson(Eigen::Index n, int depth, Eigen::Index distributed = 0)
      : aa_(n, depth, 10, distributed) {}

  /// After an iteration with merit `merit` (ok: no failed local step, finite iterate): when it
  /// started from an accelerated iterate, marks rec.accelerated (+1 kept, -1 rejected) and counts
  /// it in report.accepted / report.rejected. True when rejected (the history is then restarted).
  bool reject(double merit, bool ok, IterationRecord& rec, StepReport& report);
  /// After a kept iteration that did not stop: x the packed iterate it started from, g the packed
  /// iterate it produced, overwritten with the accelerated one when the history is full. True
  /// when g was overwritten (the caller keeps its plain iterate and unpacks g).
  bool extrapolate(const Eigen::VectorXd& x, Eigen::VectorXd& g, double merit);
  /// Forgets the history (a new time step, a new R).
  void restart() {
    aa_.restart();
    extrapolated_ = false;
  }

 private:
  Anderson aa_;
  bool extrapolated_ = false;  ///< is the current iterate an accelerated one?
  double merit_before_ = 0;    ///< the merit of the iterate it was extrapolated from
};

}  // namespace ltl
