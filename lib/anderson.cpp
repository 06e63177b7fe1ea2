#include "anderson.hpp"

#include <cmath>

#include "error.hpp"
#include "mpi_comm.hpp"

namespace ltl {

Anderson::Anderson(Eigen::Index n, int m, double cap, Eigen::Index distributed)
    : m_(m), distributed_(distributed), cap_(cap) {
  if (m < 1 || m > max_depth)
    throw Error(cat("algorithm.depth = ", m, ": must be in 1 ... ", max_depth));
  dF_.resize(n, m);
  dG_.resize(n, m);
  f_.resize(n);
  f_prev_.resize(n);
  g_prev_.resize(n);
  step_.resize(n);
}

// Walker & Ni (2011), Algorithm AA with mixing 1; the small least-squares problem through its
// normal equations with a relative Tikhonov shift 1e-12 trace (m <= 16 columns). Extrapolates
// only with a full history of m differences, and bounds the step (see anderson.hpp).
int Anderson::step(const Eigen::VectorXd& x, Eigen::VectorXd& g) {
  f_ = g - x;
  if (have_previous_) {
    dF_.col(next_) = f_ - f_prev_;
    dG_.col(next_) = g - g_prev_;
    next_ = (next_ + 1) % m_;
    columns_ = std::min(columns_ + 1, m_);
  }
  f_prev_ = f_;
  g_prev_ = g;
  have_previous_ = true;
  if (columns_ < m_) return 0;  // (re)filling the history: the plain iterate
  const int k = columns_;
  inner_products(k);
  const double shift = 1e-12 * gram_.trace() + 1e-300;
  gram_.diagonal().array() += shift;
  gamma_ = gram_.ldlt().solve(rhs_);
  if (!gamma_.allFinite()) return 0;
  // Step bound: the extrapolation x_{k+1} - G(x_k) = -dG gamma is at most `cap` ||f_k||.
  step_.noalias() = dG_.leftCols(k) * gamma_;
  const double ratio = norm(step_) / (cap_ * norm(f_));
  g -= ratio > 1 ? step_ / ratio : step_;
  return k;
}

void Anderson::inner_products(int k) {
  gram_.resize(k, k);
  rhs_.resize(k);
  const Eigen::Index n = f_.size(), nd = distributed_;
  if (nd == 0) {
    gram_.noalias() = dF_.leftCols(k).transpose() * dF_.leftCols(k);
    rhs_.noalias() = dF_.leftCols(k).transpose() * f_;
    return;
  }
  // The distributed head summed over the ranks (k^2 + k values, one reduction), then the
  // replicated tail once.
  double buffer[max_depth * max_depth + max_depth];
  Eigen::Map<Eigen::MatrixXd> G(buffer, k, k);
  Eigen::Map<Eigen::VectorXd> r(buffer + k * k, k);
  G.noalias() = dF_.topLeftCorner(nd, k).transpose() * dF_.topLeftCorner(nd, k);
  r.noalias() = dF_.topLeftCorner(nd, k).transpose() * f_.head(nd);
  mpi::sum(buffer, k * k + k);
  gram_ = G;
  rhs_ = r;
  gram_.noalias() += dF_.bottomLeftCorner(n - nd, k).transpose() * dF_.bottomLeftCorner(n - nd, k);
  rhs_.noalias() += dF_.bottomLeftCorner(n - nd, k).transpose() * f_.tail(n - nd);
}

double Anderson::norm(const Eigen::VectorXd& v) const {
  if (distributed_ == 0) return v.norm();
  double h = v.head(distributed_).squaredNorm();
  mpi::sum(&h, 1);
  return std::sqrt(h + v.tail(v.size() - distributed_).squaredNorm());
}

bool SafeguardedAnderson::reject(double merit, bool ok, IterationRecord& rec, StepReport& report) {
  if (!extrapolated_) return false;
  extrapolated_ = false;
  const bool rejected = !(ok && merit <= merit_before_);
  rec.accelerated = rejected ? -1 : 1;
  ++(rejected ? report.rejected : report.accepted);
  if (rejected) aa_.restart();
  return rejected;
}

bool SafeguardedAnderson::extrapolate(const Eigen::VectorXd& x, Eigen::VectorXd& g, double merit) {
  extrapolated_ = aa_.step(x, g) > 0;
  if (extrapolated_) merit_before_ = merit;
  return extrapolated_;
}

}  // namespace ltl
