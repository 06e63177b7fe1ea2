// Stored energy functions W(F) of the paper, with their first derivatives.
//
//   [LTL87 (1.5)] incompressible Mooney-Rivlin:
//       W(F) = C1 (|F|^2 - 3) + C2 (|adj F|^2 - 3),  det F = 1;
//   [LTL87 sec. 8, Fig 3] compressible law:
//       W(F) = C1 (|F|^2 - 3) + C3 (det F)^2 - C3 - 2 (C1 + C3) ln det F.
//
// Plane strain embeds a 2x2 in-plane gradient as F = diag(F2, 1).
#pragma once

#include <Eigen/Dense>
#include <string>

namespace ltl {

enum class MaterialModel {
  MooneyRivlin,  ///< incompressible (det F = 1), parameters C1, C2   [LTL87 (1.5)]
  Compressible   ///< parameters C1, C3                              [LTL87 sec. 8]
};

struct Material {
  MaterialModel model = MaterialModel::MooneyRivlin;
  double C1 = 0.0;  ///< Pa, coefficient of |F|^2 (lives in the global Laplacian, (2.5))
  double C2 = 0.0;  ///< Pa, coefficient of |adj F|^2 (Mooney-Rivlin)
  double C3 = 0.0;  ///< Pa, volumetric coefficient (compressible law)

  /// Incompressible Mooney-Rivlin (1.5) with moduli C1, C2 (Pa).
  static Material mooney_rivlin(double C1, double C2) {
    return {MaterialModel::MooneyRivlin, C1, C2, 0.0};
  }
  /// The compressible law of section 8 with moduli C1, C3 (Pa).
  static Material compressible(double C1, double C3) {
    return {MaterialModel::Compressible, C1, 0.0, C3};
  }

  bool incompressible() const { return model == MaterialModel::MooneyRivlin; }
  std::string name() const;

  /// W(F) for a 3x3 F. For the compressible law, +inf when det F <= 0. The incompressible law
  /// returns the Mooney-Rivlin expression without checking det F = 1 (the constraint is the
  /// caller's).
  double W(const Eigen::Matrix3d& F) const;
  /// dW/dF (first Piola-Kirchhoff stress without the pressure term).
  Eigen::Matrix3d dW(const Eigen::Matrix3d& F) const;
  /// Plane strain: W(diag(F2, 1)) and the in-plane block of dW.
  double W(const Eigen::Matrix2d& F2) const;
  Eigen::Matrix2d dW(const Eigen::Matrix2d& F2) const;
  /// [LTL87 (1.5), sec. 8] The second derivative in direction H, d/dt dW(F + t H) at t = 0 (the
  /// consistent tangent of the Newton phase, newton.hpp); plane strain: H = diag(H2, 0), the
  /// in-plane block. NaN for the compressible law when det F <= 0.
  Eigen::Matrix3d d2W(const Eigen::Matrix3d& F, const Eigen::Matrix3d& H) const;
  Eigen::Matrix2d d2W(const Eigen::Matrix2d& F2, const Eigen::Matrix2d& H2) const;

  /// [LTL87 (1.5), (1.1)] Plane strain: the out-of-plane Cauchy stress sigma33 of a state with
  /// in-plane gradient F2 and in-plane first Piola-Kirchhoff stress P2 (e.g. the solver's
  /// P = 2 C1 E - lambda). With F = diag(F2, 1) and J = det F2, the 3-D stress of the law is
  ///   P = dW/dF(F) - p cof F          (incompressible, p the pressure of det F = 1; 0 otherwise),
  /// cof F = diag(cof F2, J). The pressure is read off the in-plane part, in the least-squares
  /// sense: p = (dW2(F2) - P2) : cof F2 / |cof F2|^2 (exact when P2 is the law's stress), and
  ///   sigma33 = P33 F33 / J = (dW/dF(F)_33 - p J) / J.
  /// Mooney-Rivlin: dW/dF_33 = 2 C1 + 2 C2 |F2|^2; compressible: 2 C1 + 2 C3 J^2 - 2 (C1 + C3).
  /// It is not zero (F33 = 1 is held by this stress); planar tension F2 = diag(l, 1/l) with
  /// sigma22 = 0 gives sigma33 = 2 C1 (1 - l^-2) + 2 C2 (l^2 - 1).
  double plane_strain_sigma33(const Eigen::Matrix2d& F2, const Eigen::Matrix2d& P2) const;
};

}  // namespace ltl
