// The local adhesion / contact step (4.7), solved point by point as in section 6, (6.1)-(6.8).
//
// Unknowns per contact point s (a node, or a facet with P0 values): e_s (the paper's h, a vector),
// beta_s in [0,1], and the multiplier lambda_c_s. The rigid support is a plane with unit normal N
// pointing INTO the obstacle (away from the body); the unilateral condition is e_s . N <= g_s, with
// g_s the initial gap at the point (node or facet centre) (g_s = 0 for a body glued to the support:
// then this is e.n <= 0, (4.11)). The contact pressure on the body is p_s = -lambda_c_s . N (>= 0
// at convergence).
//
// Glue is parametrized by kappa = 1/eps >= 0 (kappa = 0: no glue). On point s, with the other
// points' beta frozen (relaxation, Gauss-Seidel in point order), the paper's (6.1)-(6.2) is
//
//   min over e.N <= g, gamma in [0,1]:
//     (R q_c / 2)|e|^2 - a.e + (kappa/2) gamma^2 |e|^2 + (aa/2) gamma^2 - b gamma
//
//   a  = R q_c ubar_s - lambda_c_s                                              (6.3)
//   aa = k_ss / dt                                                              (6.4)
//   b  = w - sum_{s' != s} k_ss' (beta_s' - beta_prev_s') / dt + k_ss beta_prev_s / dt  (6.5)
//
// where k_ss' approximates  integral over G_s' of d(x_s - y) dy  for the kernel
// d(y) = d0 exp(-d0 |y|) (1.6), by the paper's centre-point rule or the exact Galerkin integral
// (adhesion_kernel.hpp), stored sparse: the pairs within the cutoff of adhesion_kernel.hpp (the
// dropped mass of a row is below kKernelCutoffTol of the kernel's mass), nothing without
// dissipation (d0 = 0). Memory is linear in #points.
//
// Eliminating e gives e = projection of a / (R q_c + kappa gamma^2) onto {e.N <= g}  (6.6)-(6.7)
// and a scalar problem in gamma over [0,1] (6.8), solved by taking the best of the end points and
// of every interior stationary point.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>

#include "adhesion.hpp"
#include "contact_points.hpp"

namespace ltl {

/// The per-point arrays of the local step, as whole matrices or as the rows of one obstacle in
/// the points of several (Discretization::points(), ContactPoints::offset): no copy.
using ConstMatRef = const Eigen::Ref<const Eigen::MatrixXd>&;
using MatRef = Eigen::Ref<Eigen::MatrixXd>;
using ConstVecRef = const Eigen::Ref<const Eigen::VectorXd>&;
using VecRef = Eigen::Ref<Eigen::VectorXd>;

/// Result of one point problem (6.1).
struct PointSolution {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();  ///< only the first dim entries are used
  double beta = 1.0;
};

class ContactStep {
 public:
  /// Precomputes the sparse kernel matrix k (#points x #points, no entries when d0 = 0).
  /// Rqc = R * q_c > 0. Reads points.N normalized (normal()). Throws std::invalid_argument on
  /// inconsistent data. Keeps a reference to `points`, which must outlive the step (the
  /// discretization owns them; a temporary is refused at compile time).
  ContactStep(const ContactPoints& points, const Adhesion& adhesion, double Rqc);
  ContactStep(ContactPoints&&, const Adhesion&, double) = delete;

  /// [LTL87 (6.1)-(6.8)] One point: minimize the functional above given a, aa, b.
  /// a and N: only the first dim entries are read (N of unit length); gap may be any real.
  /// Ties between equal minima are broken towards the larger gamma (glue stays). When the
  /// reduced objective (6.8) does not depend on gamma at all (e.g. kappa = 0 and aa = b = 0, the
  /// pure contact case), beta is arbitrary and beta_current (the point's current beta) is
  /// returned unchanged.
  static PointSolution solve_point(const Eigen::Vector3d& a, double aa, double b, double Rqc,
                                   double kappa, const Eigen::Vector3d& N, double gap, int dim,
                                   double beta_current = 1.0);

  /// [LTL87 (6.7)] Euclidean projection of x onto the half-space {e : e.N <= gap} (N unit).
  /// Returns x itself when it is feasible; otherwise x - (x.N - gap) N, so e.N = gap up to
  /// round-off. Idempotent up to round-off.
  static Eigen::Vector3d project(const Eigen::Vector3d& x, const Eigen::Vector3d& N, double gap);

  /// [LTL87 (6.2)] J_c(e, gamma) = (Rqc/2)|e|^2 - a.e + (kappa/2) gamma^2 |e|^2
  ///                               + (aa/2) gamma^2 - b gamma  (no constraint check).
  static double point_objective(const Eigen::Vector3d& a, double aa, double b, double Rqc,
                                double kappa, const Eigen::Vector3d& e, double gamma);

  /// [LTL87 (6.8)] min over e.N <= gap of J_c(e, gamma), i.e. J_c at e from (6.6)-(6.7). This is
  /// half the paper's (6.8) functional when gap = 0.
  static double reduced_objective(const Eigen::Vector3d& a, double aa, double b, double Rqc,
                                  double kappa, const Eigen::Vector3d& N, double gap, int dim,
                                  double gamma);

  /// [LTL87 (4.7), sec. 6] `sweeps` Gauss-Seidel sweeps over the points in order.
  ///   ubar:      #points x dim like u, the current displacement u^n at the points
  ///   lambda_c:  #points x dim, current multiplier
  ///   beta_prev: #points, beta at the previous time step (beta_{p-1})
  ///   e, beta:   in: current iterate, out: updated.
  /// Only the points first <= s < end are updated (end < 0: all; each run of consecutive
  /// indices of a rank's points when the points are distributed, which is exact without
  /// dissipation, where they are independent).
  /// Allocation-free. O(nnz(k)) per sweep: O(#points x neighbours within the cutoff).
  void solve(ConstMatRef ubar, ConstMatRef lambda_c, ConstVecRef beta_prev, MatRef e, VecRef beta,
             int sweeps = 1, int first = 0, int end = -1) const;

  /// The adhesion part of J_p (2.2) on the discrete surface, for given e, beta:
  ///   sum_s |G_s| [ (kappa/2) beta_s^2 |e_s|^2 - w beta_s ]
  ///   + (1/(2 dt)) sum_s sum_s' |G_s| k_ss' (beta_s - beta_prev_s)(beta_s' - beta_prev_s')
  /// (+inf if some beta is outside [0,1] or some e violates e.N <= g beyond round-off).
  double energy(ConstMatRef e, ConstVecRef beta, ConstVecRef beta_prev) const;

  /// [LTL87 (4.7), (4.10)] The whole functional minimized by the local step:
  ///   sum_s |G_s| [ (Rqc/2)|e_s|^2 - a_s.e_s ] + energy(e, beta, beta_prev),
  /// a_s = Rqc ubar_s - lambda_c_s (6.3). Every point update of solve() does not increase it.
  double local_objective(ConstMatRef ubar, ConstMatRef lambda_c, ConstVecRef beta_prev,
                         ConstMatRef e, ConstVecRef beta) const;

  /// A new augmentation R q_c > 0 (adaptive R); the kernel does not depend on it.
  void set_Rqc(double Rqc);

  /// [LTL87 (6.4)-(6.5)] The kernel k_ss' (sparse, adhesion_kernel_sparse()): row s holds the
  /// points s' within the cutoff of s; |G_s| k_ss' is symmetric. Empty when d0 = 0.
  const Eigen::SparseMatrix<double>& kernel() const { return k_; }
  /// Bytes held by the kernel (values and indices of k and its transpose, and the diagonal).
  double kernel_bytes() const;
  const ContactPoints& points() const { return *points_; }
  /// The unit normal of the obstacle plane (points().N normalized), dim entries.
  Eigen::VectorXd normal() const { return N3_.head(points_->dim); }
  const Adhesion& adhesion() const { return adhesion_; }

 private:
  const ContactPoints* points_;
  Adhesion adhesion_;
  double Rqc_;
  Eigen::SparseMatrix<double> k_;
  Eigen::SparseMatrix<double> kt_;  ///< k_ transposed: column s holds row s of k, for the sweep
  Eigen::VectorXd kdiag_;           ///< k_ss
  Eigen::Vector3d N3_;              ///< N padded to 3 entries
};

}  // namespace ltl
