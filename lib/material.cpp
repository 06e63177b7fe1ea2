// Stored energy functions of the paper and their first derivatives (see material.hpp).
#include "material.hpp"

#include <cmath>
#include <limits>

#include "cofactor.hpp"

namespace ltl {

namespace {

Eigen::Matrix3d embed(const Eigen::Matrix2d& F2) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F.topLeftCorner<2, 2>() = F2;
  return F;
}

}  // namespace

std::string Material::name() const {
  return model == MaterialModel::MooneyRivlin ? "MooneyRivlin" : "Compressible";
}

/// [LTL87 (1.5)] W = C1 (|F|^2 - 3) + C2 (|adj F|^2 - 3);
/// [LTL87 sec. 8, Fig 3] W = C1 (|F|^2 - 3) + C3 J^2 - C3 - 2 (C1 + C3) ln J, J = det F.
double Material::W(const Eigen::Matrix3d& F) const {
  const double I1 = F.squaredNorm();
  if (model == MaterialModel::MooneyRivlin) {
    // |adj F|^2 = |cof F|^2 (= I2), from the cofactor columns: the textbook form
    // ((tr C)^2 - tr C^2) / 2 loses eps |F|^2 relative accuracy at large stretch.
    const double I2 = cofactor<3>(F).squaredNorm();
    return C1 * (I1 - 3.0) + C2 * (I2 - 3.0);
  }
  const double J = F.determinant();
  if (!(J > 0.0)) return std::numeric_limits<double>::infinity();
  return C1 * (I1 - 3.0) + C3 * J * J - C3 - 2.0 * (C1 + C3) * std::log(J);
}

/// dW/dF: Mooney-Rivlin 2 C1 F + C2 dI2/dF with dI2/dF = 2 (|F|^2 F - F F^T F), evaluated from
/// the cofactor columns c_k = f_{k+1} x f_{k+2} as column k = 2 (c_{k+1} x f_{k+2} +
/// f_{k+1} x c_{k+2}) (indices mod 3), which avoids the cancellation of the textbook form;
/// compressible 2 C1 F + (2 C3 J - 2 (C1 + C3) / J) cof F   (dJ/dF = cof F).
Eigen::Matrix3d Material::dW(const Eigen::Matrix3d& F) const {
  if (model == MaterialModel::MooneyRivlin) {
    const Eigen::Matrix3d c = cofactor<3>(F);
    Eigen::Matrix3d dI2;
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      dI2.col(k) = 2.0 * (c.col(k1).cross(F.col(k2)) + F.col(k1).cross(c.col(k2)));
    }
    return 2.0 * C1 * F + C2 * dI2;
  }
  const double J = F.determinant();
  if (!(J > 0.0)) {
    return Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return 2.0 * C1 * F + (2.0 * C3 * J - 2.0 * (C1 + C3) / J) * cofactor<3>(F);
}

double Material::W(const Eigen::Matrix2d& F2) const {
  return W(embed(F2));
}

Eigen::Matrix2d Material::dW(const Eigen::Matrix2d& F2) const {
  return dW(embed(F2)).topLeftCorner<2, 2>();
}

/// d/dt dW(F + t H): Mooney-Rivlin 2 C1 H + 2 C2 (2 (F : H) F + |F|^2 H - H F^T F - F H^T F
/// - F F^T H), the derivative of dI2/dF = 2 (|F|^2 F - F F^T F); compressible
/// 2 C1 H + phi'(J) (cof F : H) cof F + phi(J) dcof F[H], phi(J) = 2 C3 J - 2 (C1 + C3) / J, with
/// dcof F[H] column k = h_{k+1} x f_{k+2} + f_{k+1} x h_{k+2}.
Eigen::Matrix3d Material::d2W(const Eigen::Matrix3d& F, const Eigen::Matrix3d& H) const {
  if (model == MaterialModel::MooneyRivlin) {
    const Eigen::Matrix3d C = F.transpose() * F;
    const Eigen::Matrix3d dI2 = 2.0 * (2.0 * F.cwiseProduct(H).sum() * F + F.squaredNorm() * H -
                                       H * C - F * H.transpose() * F - F * F.transpose() * H);
    return 2.0 * C1 * H + C2 * dI2;
  }
  const double J = F.determinant();
  if (!(J > 0.0)) return Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const Eigen::Matrix3d c = cofactor<3>(F);
  const Eigen::Matrix3d dc = cofactor_derivative<3>(F, H);
  const double phi = 2.0 * C3 * J - 2.0 * (C1 + C3) / J;
  const double dphi = 2.0 * C3 + 2.0 * (C1 + C3) / (J * J);
  return 2.0 * C1 * H + dphi * c.cwiseProduct(H).sum() * c + phi * dc;
}

Eigen::Matrix2d Material::d2W(const Eigen::Matrix2d& F2, const Eigen::Matrix2d& H2) const {
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  H.topLeftCorner<2, 2>() = H2;
  return d2W(embed(F2), H).topLeftCorner<2, 2>();
}

double Material::plane_strain_sigma33(const Eigen::Matrix2d& F2, const Eigen::Matrix2d& P2) const {
  const Eigen::Matrix3d dW3 = dW(embed(F2));  // of the law itself, not of a split of it
  const double J = F2.determinant();
  double p = 0;
  if (incompressible()) {
    const Eigen::Matrix2d cof2 = cofactor<2>(F2);  // J F2^{-T}
    p = (dW3.topLeftCorner<2, 2>() - P2).cwiseProduct(cof2).sum() / cof2.squaredNorm();
  }
  return (dW3(2, 2) - p * J) / J;
}

}  // namespace ltl
