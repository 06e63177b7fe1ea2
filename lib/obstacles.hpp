// Several rigid obstacles (paper_notes/obstacles.md): the local contact step (4.7) of each
// obstacle on its own points, and the exact projection onto two half-spaces, the frictionless
// step (6.6)-(6.7) of a point held by two planes at once.
//
// The points of several obstacles are those of each, one after the other
// (ContactPoints::offset): a node of two obstacles' contact groups is two contact points, one per
// plane, each with its own e_s, lambda_c_s (and beta_s). The local step (4.7) is then separable
// by obstacle, and each obstacle's is section 6's, (6.1)-(6.8), with its own plane, gap and
// glue. At a fixed point, e_s = ubar_s for both copies of a shared node, so that ubar_s lies in
// both half-spaces and sum_k lambda_c_k is in the normal cone of their intersection: ubar_s is
// then the projection project_two_planes() of ubar_s - (sum_k lambda_c_k) / (2 R q_c), the
// frictionless step of one e_s held by both planes (tested: Obstacles.*).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "adhesion.hpp"
#include "contact_points.hpp"
#include "contact_step.hpp"

namespace ltl {

/// [LTL87 (6.7), two planes] The Euclidean projection of x onto the intersection of the
/// half-spaces {e : N1 . e <= g1} and {e : N2 . e <= g2} (N1, N2 unit; 2-D: third entries zero).
/// By cases: x itself when it is in both; else its projection onto one plane when that lands in
/// the other half-space; else the nearest point of the edge N1 . e = g1, N2 . e = g2 (a line in
/// 3-D, a point in 2-D):
///   e = x - a N1 - b N2,  [1 c; c 1] (a, b) = (N1 . x - g1, N2 . x - g2),  c = N1 . N2,
/// with a, b >= 0 (the multipliers of the two planes). Parallel planes (|c| = 1): the half-space
/// of the smaller gap (same direction), or the slab between them (opposite; its midplane when
/// the slab is empty).
Eigen::Vector3d project_two_planes(const Eigen::Vector3d& x, const Eigen::Vector3d& N1, double g1,
                                   const Eigen::Vector3d& N2, double g2);

/// [LTL87 (4.7), sec. 6] The local contact step of several obstacles: obstacle k's ContactStep
/// on rows offset[k] .. offset[k + 1] - 1 of the stacked point arrays (its own plane, gaps,
/// glue and kernel). One obstacle: exactly ContactStep.
class ContactSteps {
 public:
  /// obstacles[k]: the points of obstacle k (Discretization::obstacle_points(), which must
  /// outlive this); adhesion[k]: its glue, dt set; Rqc = R q_c > 0 (one for all obstacles).
  ContactSteps(const std::vector<ContactPoints>& obstacles, const std::vector<Adhesion>& adhesion,
               double Rqc);

  /// ContactStep::solve on each obstacle's rows: (4.7), Gauss-Seidel within each obstacle; only
  /// the stacked rows first <= s < end (end < 0: all).
  void solve(ConstMatRef ubar, ConstMatRef lambda_c, ConstVecRef beta_prev, MatRef e, VecRef beta,
             int sweeps = 1, int first = 0, int end = -1) const;
  /// The adhesion part of J_p (2.2), summed over the obstacles (ContactStep::energy).
  double energy(ConstMatRef e, ConstVecRef beta, ConstVecRef beta_prev) const;
  void set_Rqc(double Rqc);
  /// True when some obstacle is glued (Adhesion::glued).
  bool glued() const;
  int size() const { return static_cast<int>(steps_.size()); }
  const ContactStep& operator[](int k) const { return steps_[k]; }
  /// The first row of obstacle k in the stacked arrays; offset(size()) = #points.
  int offset(int k) const { return offset_[k]; }

 private:
  std::vector<ContactStep> steps_;
  std::vector<int> offset_;
};

}  // namespace ltl
