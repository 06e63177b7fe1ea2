// Stored energy functions of the paper and their first derivatives (see material.hpp).
#include "material.hpp"

#include <cmath>
#include <limits>

#include "cofactor.hpp"
#include "signed_svd.hpp"

namespace ltl {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Matrix3d embed(const Eigen::Matrix2d& F2) {
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F.topLeftCorner<2, 2>() = F2;
  return F;
}

/// (x^a - y^a) / (x - y) for x, y > 0, without cancellation: y^(a-1) expm1(a r) / expm1(r),
/// r = ln(x / y); a y^(a-1) when x = y.
double pow_divided_difference(double x, double y, double a) {
  const double r = std::log(x / y);
  if (r == 0.0) return a * std::pow(y, a - 1.0);
  return std::pow(y, a - 1.0) * std::expm1(a * r) / std::expm1(r);
}

/// Gent: x = (|F|^2 - 3) / J_m and the derivatives G'(I1), G''(I1) of
/// G(I1) = -(mu J_m / 2) ln(1 - x); false outside the domain x < 1.
bool gent_derivatives(double mu, double Jm, double I1, double& x, double& G1, double& G2) {
  x = (I1 - 3.0) / Jm;
  if (!(x < 1.0)) return false;
  G1 = 0.5 * mu / (1.0 - x);
  G2 = G1 / (Jm * (1.0 - x));
  return true;
}

}  // namespace

Material Material::ogden_law(std::vector<OgdenTerm> terms) {
  Material m;
  m.model = MaterialModel::Ogden;
  double mu = 0.0;
  for (const OgdenTerm& t : terms) mu += 0.5 * t.mu * t.alpha;
  m.C1 = 0.5 * mu;
  m.ogden = std::move(terms);
  return m;
}

Material Material::gent(double mu, double Jm) {
  Material m;
  m.model = MaterialModel::Gent;
  m.mu = mu;
  m.Jm = Jm;
  m.C1 = 0.5 * mu;
  return m;
}

std::string Material::name() const {
  switch (model) {
    case MaterialModel::MooneyRivlin:
      return "MooneyRivlin";
    case MaterialModel::Compressible:
      return "Compressible";
    case MaterialModel::Ogden:
      return "Ogden";
    case MaterialModel::Gent:
      return "Gent";
  }
  return "";
}

/// Ogden: W = sum_p mu_p / alpha_p sum_i expm1(alpha_p ln t_i) (no cancellation near t = 1),
/// g_i = sum_p mu_p t_i^alpha_p, H_ii = sum_p mu_p alpha_p t_i^alpha_p (H diagonal).
/// Gent: W = G(I1), I1 = sum t_i^2, g_i = 2 G' t_i^2, H_ij = 4 G'' t_i^2 t_j^2 + 4 G' t_i^2 d_ij.
double Material::W_principal(const Eigen::Vector3d& t, Eigen::Vector3d* g, Eigen::Matrix3d* H,
                             Eigen::Vector3d* gmag) const {
  if (g) g->setZero();
  if (H) H->setZero();
  if (gmag) gmag->setZero();
  if (!(t.minCoeff() > 0.0)) return kInf;
  if (model == MaterialModel::Ogden) {
    double w = 0.0;
    for (const OgdenTerm& p : ogden)
      for (int i = 0; i < 3; ++i) {
        const double l = std::log(t[i]);
        w += p.mu / p.alpha * std::expm1(p.alpha * l);
        const double ta = std::exp(p.alpha * l);
        if (g) (*g)[i] += p.mu * ta;
        if (H) (*H)(i, i) += p.mu * p.alpha * ta;
        if (gmag) (*gmag)[i] += std::abs(p.mu) * ta;
      }
    return w;
  }
  if (model == MaterialModel::Gent) {
    double x, G1, G2;
    if (!gent_derivatives(mu, Jm, t.squaredNorm(), x, G1, G2)) return kInf;
    const Eigen::Vector3d t2 = t.cwiseAbs2();
    if (g) *g = 2.0 * G1 * t2;
    if (gmag) *gmag = 2.0 * G1 * t2;
    if (H) *H = 4.0 * G2 * t2 * t2.transpose() + Eigen::Matrix3d(4.0 * G1 * t2.asDiagonal());
    return -0.5 * mu * Jm * std::log1p(-x);
  }
  return kNaN;  // the other laws are not written in principal stretches
}

/// [LTL87 (1.5)] W = C1 (|F|^2 - 3) + C2 (|adj F|^2 - 3);
/// [LTL87 sec. 8, Fig 3] W = C1 (|F|^2 - 3) + C3 J^2 - C3 - 2 (C1 + C3) ln J, J = det F.
double Material::W(const Eigen::Matrix3d& F) const {
  const double I1 = F.squaredNorm();
  if (model == MaterialModel::Ogden) {  // the principal stretches t_i: the singular values of F
    Eigen::Matrix3d Q, R;
    Eigen::Vector3d t;
    signed_svd(F, Q, t, R);
    return W_principal(t);
  }
  if (model == MaterialModel::Gent) {
    double x, G1, G2;
    return gent_derivatives(mu, Jm, I1, x, G1, G2) ? -0.5 * mu * Jm * std::log1p(-x) : kInf;
  }
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
/// Ogden: F = Q diag(t) R^T (signed SVD), dW/dF = Q diag(sum_p mu_p t_i^(alpha_p - 1)) R^T;
/// Gent: dW/dF = 2 G'(|F|^2) F.
Eigen::Matrix3d Material::dW(const Eigen::Matrix3d& F) const {
  if (model == MaterialModel::Ogden) {
    Eigen::Matrix3d Q, R;
    Eigen::Vector3d t, g;
    signed_svd(F, Q, t, R);
    if (!(W_principal(t, &g) < kInf)) return Eigen::Matrix3d::Constant(kNaN);
    return Q * g.cwiseQuotient(t).asDiagonal() * R.transpose();
  }
  if (model == MaterialModel::Gent) {
    double x, G1, G2;
    if (!gent_derivatives(mu, Jm, F.squaredNorm(), x, G1, G2))
      return Eigen::Matrix3d::Constant(kNaN);
    return 2.0 * G1 * F;
  }
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

// [LTL87 (4.6)] lambda = 2 C1 F - dW(F) + p cof F, the stationarity of the strain step at F.
Eigen::MatrixXd Material::multiplier(const Eigen::MatrixXd& F, double p) const {
  if (F.rows() == 2) {
    const Eigen::Matrix2d F2 = F;
    return 2 * C1 * F2 - dW(F2) + p * cofactor<2>(F2);
  }
  const Eigen::Matrix3d F3 = F;
  return 2 * C1 * F3 - dW(F3) + p * cofactor<3>(F3);
}

double Material::pressure(const Eigen::MatrixXd& E, const Eigen::MatrixXd& lambda) const {
  Eigen::MatrixXd dWE(E.rows(), E.cols()), C(E.rows(), E.cols());
  if (E.rows() == 2) {
    dWE = dW(Eigen::Matrix2d(E));
    C = cofactor<2>(Eigen::Matrix2d(E));
  } else {
    dWE = dW(Eigen::Matrix3d(E));
    C = cofactor<3>(Eigen::Matrix3d(E));
  }
  return (lambda - 2 * C1 * E + dWE).cwiseProduct(C).sum() / C.squaredNorm();
}

Eigen::Matrix2d Material::dW(const Eigen::Matrix2d& F2) const {
  return dW(embed(F2)).topLeftCorner<2, 2>();
}

/// d/dt dW(F + t H): Mooney-Rivlin 2 C1 H + 2 C2 (2 (F : H) F + |F|^2 H - H F^T F - F H^T F
/// - F F^T H), the derivative of dI2/dF = 2 (|F|^2 F - F F^T F); compressible
/// 2 C1 H + phi'(J) (cof F : H) cof F + phi(J) dcof F[H], phi(J) = 2 C3 J - 2 (C1 + C3) / J, with
/// dcof F[H] column k = h_{k+1} x f_{k+2} + f_{k+1} x h_{k+2}.
/// Ogden, in the frame of F = Q diag(t) R^T with Ht = Q^T H R and p_i = dW/dt_i: dPt_ii =
/// (d p_i / dt_i) Ht_ii; for i != j, dPt_ij = a Ht_ij + b Ht_ji, dPt_ji = b Ht_ij + a Ht_ji with
/// a + b = (p_i - p_j) / (t_i - t_j) (a divided difference, exact at t_i = t_j) and
/// a - b = (p_i + p_j) / (t_i + t_j); dP = Q dPt R^T. Gent: 2 G' H + 4 G'' (F : H) F.
Eigen::Matrix3d Material::d2W(const Eigen::Matrix3d& F, const Eigen::Matrix3d& H) const {
  if (model == MaterialModel::Ogden) {
    Eigen::Matrix3d Q, R;
    Eigen::Vector3d t;
    signed_svd(F, Q, t, R);
    if (!(t.minCoeff() > 0.0)) return Eigen::Matrix3d::Constant(kNaN);
    const Eigen::Matrix3d Ht = Q.transpose() * H * R;
    Eigen::Matrix3d dP = Eigen::Matrix3d::Zero();
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (const OgdenTerm& o : ogden)
      for (int i = 0; i < 3; ++i) {
        p[i] += o.mu * std::pow(t[i], o.alpha - 1.0);
        dP(i, i) += o.mu * (o.alpha - 1.0) * std::pow(t[i], o.alpha - 2.0) * Ht(i, i);
      }
    for (int i = 0; i < 3; ++i)
      for (int j = i + 1; j < 3; ++j) {
        double sum = 0.0;  // a + b
        for (const OgdenTerm& o : ogden)
          sum += o.mu * pow_divided_difference(t[i], t[j], o.alpha - 1.0);
        const double diff = (p[i] + p[j]) / (t[i] + t[j]);  // a - b
        const double a = 0.5 * (sum + diff), b = 0.5 * (sum - diff);
        dP(i, j) = a * Ht(i, j) + b * Ht(j, i);
        dP(j, i) = b * Ht(i, j) + a * Ht(j, i);
      }
    return Q * dP * R.transpose();
  }
  if (model == MaterialModel::Gent) {
    double x, G1, G2;
    if (!gent_derivatives(mu, Jm, F.squaredNorm(), x, G1, G2))
      return Eigen::Matrix3d::Constant(kNaN);
    return 2.0 * G1 * H + 4.0 * G2 * F.cwiseProduct(H).sum() * F;
  }
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
