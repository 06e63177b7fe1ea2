// Signed singular value decomposition [LTL87 (5.4)], the first step of the local strain
// problem (4.6) (strain_step.cpp): A = Q diag(d) R^T with Q, R rotations (det = +1), |d|
// sorted decreasing, and the sign of det A carried by the smallest value only.
//
// 2x2 in closed form; 3x3 by a fast path (one eigenvector of A^T A, completed to rotations, the
// remaining 2x2 block in closed form) with two robust fallbacks checked at round-off
// (closed-form eigenvectors + Givens QR, then cyclic Jacobi). Fixed-size Eigen types only: no
// allocation, safe to call concurrently from OpenMP threads.
#pragma once

#include <Eigen/Dense>

namespace ltl {

/// Signed SVD [LTL87 (5.4)]: A = Q diag(d) R^T with det Q = det R = +1, |d| sorted decreasing,
/// and a negative sign (when det A < 0) on the smallest value only. Backward stable:
/// |A - Q diag(d) R^T| = O(eps |A|).
void signed_svd(const Eigen::Matrix2d& A, Eigen::Matrix2d& Q, Eigen::Vector2d& d,
                Eigen::Matrix2d& R);
void signed_svd(const Eigen::Matrix3d& A, Eigen::Matrix3d& Q, Eigen::Vector3d& d,
                Eigen::Matrix3d& R);

}  // namespace ltl
