// The cofactor matrix and its derivative, for 2 x 2 and 3 x 3 tensors (one definition for the
// material laws, mean-det incompressibility (2.7) and the Newton tangent).
#pragma once

#include <Eigen/Dense>

namespace ltl {

/// cof A = det(A) A^{-T}, written without the inverse (so it holds for singular A too), so that
/// d det A / dA = cof A. In 3-D column k is a_{k+1} x a_{k+2}, the columns a_k of A.
template <int d>
Eigen::Matrix<double, d, d> cofactor(const Eigen::Matrix<double, d, d>& A) {
  Eigen::Matrix<double, d, d> C;
  if constexpr (d == 2) {
    C << A(1, 1), -A(1, 0), -A(0, 1), A(0, 0);
  } else {
    C.col(0) = A.col(1).cross(A.col(2));
    C.col(1) = A.col(2).cross(A.col(0));
    C.col(2) = A.col(0).cross(A.col(1));
  }
  return C;
}

/// d/dt cof(A + t H) at t = 0, the second derivative of det: cof H in 2-D (cof is linear);
/// in 3-D column k is h_{k+1} x a_{k+2} + a_{k+1} x h_{k+2}.
template <int d>
Eigen::Matrix<double, d, d> cofactor_derivative(const Eigen::Matrix<double, d, d>& A,
                                                const Eigen::Matrix<double, d, d>& H) {
  if constexpr (d == 2) {
    return cofactor<2>(H);
  } else {
    Eigen::Matrix3d C;
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      C.col(k) = H.col(k1).cross(A.col(k2)) + A.col(k1).cross(H.col(k2));
    }
    return C;
  }
}

}  // namespace ltl
