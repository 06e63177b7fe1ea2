// Several rigid obstacles; see obstacles.hpp and paper_notes/obstacles.md.
#include "obstacles.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ltl {

using Eigen::Vector3d;

Vector3d project_two_planes(const Vector3d& x, const Vector3d& N1, double g1, const Vector3d& N2,
                            double g2) {
  const double r1 = N1.dot(x) - g1, r2 = N2.dot(x) - g2;  // > 0: outside that half-space
  if (r1 <= 0 && r2 <= 0) return x;                       // inside both
  const double c = N1.dot(N2);
  const double tol = 1e-12 * (x.norm() + std::abs(g1) + std::abs(g2));
  if (1 - std::abs(c) <= 1e-12) {  // parallel planes
    if (c > 0) return g1 <= g2 ? ContactStep::project(x, N1, g1) : ContactStep::project(x, N2, g2);
    // N2 = -N1: the slab -g2 <= N1 . e <= g1 (its midplane when empty).
    const double lo = -g2, hi = g1, t = N1.dot(x);
    const double target = lo <= hi ? std::clamp(t, lo, hi) : 0.5 * (lo + hi);
    return x + (target - t) * N1;
  }
  // On one plane: the projection onto that half-space, if it lands in the other.
  if (r1 > 0) {
    const Vector3d y = ContactStep::project(x, N1, g1);
    if (N2.dot(y) <= g2 + tol) return y;
  }
  if (r2 > 0) {
    const Vector3d y = ContactStep::project(x, N2, g2);
    if (N1.dot(y) <= g1 + tol) return y;
  }
  // On the edge of both: e = x - a N1 - b N2 with N1 . e = g1, N2 . e = g2.
  const double det = 1 - c * c;
  const double a = (r1 - c * r2) / det, b = (r2 - c * r1) / det;
  Vector3d e = x - a * N1 - b * N2;
  // One correction removes the round-off O(eps |x|) when |x| >> |e| (as ContactStep::project).
  const double s1 = N1.dot(e) - g1, s2 = N2.dot(e) - g2;
  e -= ((s1 - c * s2) / det) * N1 + ((s2 - c * s1) / det) * N2;
  return e;
}

ContactSteps::ContactSteps(const std::vector<ContactPoints>& obstacles,
                           const std::vector<Adhesion>& adhesion, double Rqc) {
  if (obstacles.size() != adhesion.size())
    throw std::invalid_argument("ContactSteps: one Adhesion per obstacle");
  steps_.reserve(obstacles.size());
  offset_ = {0};
  for (std::size_t k = 0; k < obstacles.size(); ++k) {
    steps_.emplace_back(obstacles[k], adhesion[k], Rqc);
    offset_.push_back(offset_.back() + obstacles[k].size());
  }
}

void ContactSteps::solve(ConstMatRef ubar, ConstMatRef lambda_c, ConstVecRef beta_prev, MatRef e,
                         VecRef beta, int sweeps, int first, int end) const {
  if (steps_.size() == 1)
    return steps_.front().solve(ubar, lambda_c, beta_prev, e, beta, sweeps, first, end);
  if (end < 0) end = offset_.back();
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    const int r0 = offset_[k], m = offset_[k + 1] - r0;
    const int lo = std::max(first, r0) - r0, hi = std::min(end, r0 + m) - r0;
    if (lo >= hi) continue;
    steps_[k].solve(ubar.middleRows(r0, m), lambda_c.middleRows(r0, m), beta_prev.segment(r0, m),
                    e.middleRows(r0, m), beta.segment(r0, m), sweeps, lo, hi);
  }
}

double ContactSteps::energy(ConstMatRef e, ConstVecRef beta, ConstVecRef beta_prev) const {
  if (steps_.size() == 1) return steps_.front().energy(e, beta, beta_prev);
  double E = 0;
  for (std::size_t k = 0; k < steps_.size(); ++k) {
    const int r0 = offset_[k], m = offset_[k + 1] - r0;
    E += steps_[k].energy(e.middleRows(r0, m), beta.segment(r0, m), beta_prev.segment(r0, m));
  }
  return E;
}

void ContactSteps::set_Rqc(double Rqc) {
  for (ContactStep& s : steps_) s.set_Rqc(Rqc);
}

bool ContactSteps::glued() const {
  return std::any_of(steps_.begin(), steps_.end(),
                     [](const ContactStep& s) { return s.adhesion().glued(); });
}

}  // namespace ltl
