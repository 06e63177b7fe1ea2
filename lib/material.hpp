// Stored energy functions W(F) of the paper, with their first derivatives.
//
//   [LTL87 (1.5)] incompressible Mooney-Rivlin:
//       W(F) = C1 (|F|^2 - 3) + C2 (|adj F|^2 - 3),  det F = 1;
//   [LTL87 sec. 8, Fig 3] compressible law:
//       W(F) = C1 (|F|^2 - 3) + C3 (det F)^2 - C3 - 2 (C1 + C3) ln det F.
//
// and two incompressible laws in the principal stretches t_1, t_2, t_3 of F (det F = 1), beside
// (1.5) in the same local step (4.6) (paper_notes/materials.md):
//   Ogden with N terms:  W = sum_p mu_p / alpha_p (t_1^alpha_p + t_2^alpha_p + t_3^alpha_p - 3),
//                        initial shear modulus mu = (1/2) sum_p mu_p alpha_p;
//   Gent:                W = -(mu J_m / 2) ln(1 - (|F|^2 - 3) / J_m),  |F|^2 < 3 + J_m.
// Ogden with one term alpha = 2 is neo-Hookean (C1 = mu_1 / 2), with two terms (2, 2 C1),
// (-2, -2 C2) Mooney-Rivlin (1.5); Gent tends to neo-Hookean (C1 = mu / 2) as J_m -> inf.
//
// Plane strain embeds a 2x2 in-plane gradient as F = diag(F2, 1).
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

namespace ltl {

enum class MaterialModel {
  MooneyRivlin,  ///< incompressible (det F = 1), parameters C1, C2   [LTL87 (1.5)]
  Compressible,  ///< parameters C1, C3                              [LTL87 sec. 8]
  Ogden,         ///< incompressible, terms (mu_p, alpha_p)          [paper_notes/materials.md]
  Gent           ///< incompressible, parameters mu, J_m             [paper_notes/materials.md]
};

/// One term mu_p / alpha_p (sum_i t_i^alpha_p - 3) of an Ogden law: mu_p in Pa, alpha_p
/// dimensionless and non-zero, mu_p alpha_p > 0.
struct OgdenTerm {
  double mu = 0.0;
  double alpha = 0.0;
};

struct Material {
  MaterialModel model = MaterialModel::MooneyRivlin;
  double C1 = 0.0;  ///< Pa, coefficient of |F|^2 (lives in the global Laplacian, (2.5))
  double C2 = 0.0;  ///< Pa, coefficient of |adj F|^2 (Mooney-Rivlin)
  double C3 = 0.0;  ///< Pa, volumetric coefficient (compressible law)
  std::vector<OgdenTerm> ogden;  ///< Ogden terms
  double mu = 0.0;               ///< Pa, Gent: initial shear modulus
  double Jm = 0.0;               ///< 1, Gent: limit of |F|^2 - 3

  /// Incompressible Mooney-Rivlin (1.5) with moduli C1, C2 (Pa).
  static Material mooney_rivlin(double C1, double C2) {
    Material m;
    m.C1 = C1;
    m.C2 = C2;
    return m;
  }
  /// The compressible law of section 8 with moduli C1, C3 (Pa).
  static Material compressible(double C1, double C3) {
    Material m;
    m.model = MaterialModel::Compressible;
    m.C1 = C1;
    m.C3 = C3;
    return m;
  }

  /// Ogden with the given terms; C1 = mu / 2 with mu = (1/2) sum_p mu_p alpha_p, the
  /// neo-Hookean part that the split (2.5) puts in the global Laplacian.
  static Material ogden_law(std::vector<OgdenTerm> terms);
  /// Gent with initial shear modulus mu (Pa) and locking parameter Jm; C1 = mu / 2.
  static Material gent(double mu, double Jm);

  bool incompressible() const { return model != MaterialModel::Compressible; }
  /// Ogden or Gent: laws in the principal stretches, solved by the general local step.
  bool principal() const { return model == MaterialModel::Ogden || model == MaterialModel::Gent; }
  std::string name() const;

  /// Ogden and Gent: W as a function of the principal stretches t (no constraint), with, when
  /// asked, its gradient and Hessian in the log stretches s_i = ln t_i (g_i = t_i dW/dt_i) and
  /// in gmag_i the sum of the magnitudes of the terms of g_i (its round-off scale). +inf outside
  /// the domain (t_i <= 0; Gent: sum t_i^2 >= 3 + J_m).
  double W_principal(const Eigen::Vector3d& t, Eigen::Vector3d* g = nullptr,
                     Eigen::Matrix3d* H = nullptr, Eigen::Vector3d* gmag = nullptr) const;

  /// W(F) for a 3x3 F. For the compressible law and Ogden, +inf when det F <= 0; Gent: +inf
  /// when |F|^2 >= 3 + J_m. The incompressible laws return their expression without checking
  /// det F = 1 (the constraint is the caller's).
  double W(const Eigen::Matrix3d& F) const;
  /// dW/dF (first Piola-Kirchhoff stress without the pressure term).
  Eigen::Matrix3d dW(const Eigen::Matrix3d& F) const;
  /// Plane strain: W(diag(F2, 1)) and the in-plane block of dW.
  double W(const Eigen::Matrix2d& F2) const;
  Eigen::Matrix2d dW(const Eigen::Matrix2d& F2) const;
  /// [LTL87 (1.5), sec. 8] The second derivative in direction H, d/dt dW(F + t H) at t = 0 (the
  /// consistent tangent of the Newton phase, newton.hpp); plane strain: H = diag(H2, 0), the
  /// in-plane block. NaN for the compressible law and Ogden when det F <= 0, Gent outside its
  /// domain.
  Eigen::Matrix3d d2W(const Eigen::Matrix3d& F, const Eigen::Matrix3d& H) const;
  Eigen::Matrix2d d2W(const Eigen::Matrix2d& F2, const Eigen::Matrix2d& H2) const;
  /// [LTL87 (4.6)] On a material as split (Discretization::split, P = 2 C1 E - lambda): the
  /// multiplier lambda = 2 C1 F - dW(F) + p cof F for which the local strain step returns E = F,
  /// p the pressure (0 without the constraint); F is 2 x 2 (plane strain) or 3 x 3. The state
  /// of a displacement (Newton::to_state, the nested start).
  Eigen::MatrixXd multiplier(const Eigen::MatrixXd& F, double p) const;
  /// The pressure of a cell's E and lambda: the least-squares p of lambda = multiplier(E, p)
  /// (Newton::unknowns, the nested start).
  double pressure(const Eigen::MatrixXd& E, const Eigen::MatrixXd& lambda) const;

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
