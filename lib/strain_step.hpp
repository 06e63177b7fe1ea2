// The local strain step (4.6), solved element by element as in section 5, (5.2)-(5.8).
//
// On one element, given D = R q (I + Gbar u) - lambda (the "local loading" of section 5),
// find E minimizing
//
//     J(E) = (R q / 2) |E|^2 + What(E) - D : E,      What(E) = W(E) - C1 |E|^2,
//
// over all E (compressible law, det E > 0) or over det E = 1 (incompressible law).
// C1 never enters: it lives in the global Laplacian (4.5).
//
// Method [LTL87 (5.4)-(5.8)]: signed SVD D = Q diag(d) R^T with Q, R rotations (the sign, if
// any, carried by the smallest singular value), E = Q diag(t) R^T, and t minimizes a function of
// 1-3 scalars, solved by Newton in log variables s_i = ln t_i with a line search.
//
// Plane strain (dim 2): E is the in-plane 2x2 block, E33 = 1.
#pragma once

#include <Eigen/Dense>

#include "material.hpp"
#include "signed_svd.hpp"

namespace ltl {

class StrainStep {
 public:
  /// Rq = R * q > 0 (checked by the caller).
  StrainStep(const Material& material, double Rq);

  /// [LTL87 (4.6), (5.2)-(5.8)] Minimizer of J over the admissible set. Returns false when the
  /// scalar Newton iteration did not reach round-off (E then holds the best iterate).
  /// Allocation-free; safe to call concurrently from several threads.
  bool solve(const Eigen::Matrix2d& D, Eigen::Matrix2d& E) const;
  bool solve(const Eigen::Matrix3d& D, Eigen::Matrix3d& E) const;

  /// J(E) as above (for tests and diagnostics); +inf outside the admissible set.
  double objective(const Eigen::Matrix2d& D, const Eigen::Matrix2d& E) const;
  double objective(const Eigen::Matrix3d& D, const Eigen::Matrix3d& E) const;

  const Material& material() const { return material_; }
  double Rq() const { return Rq_; }

 private:
  Material material_;
  double Rq_;
};

}  // namespace ltl
