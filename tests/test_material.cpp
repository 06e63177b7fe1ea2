// Tests of the stored energy functions: [LTL87 (1.5)] Mooney-Rivlin and the compressible law of
// [LTL87 sec. 8, Fig 3]. Invariants first: stress-free reference, derivative = finite
// differences, frame indifference and isotropy, and the small-strain limit quoted in section 8.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "material.hpp"

namespace {

using ltl::Material;
using ltl::MaterialModel;

Material mooney_rivlin(double C1 = 435e3, double C2 = 65e3) {  // Fig 5 of the paper, Pa
  Material m;
  m.model = MaterialModel::MooneyRivlin;
  m.C1 = C1;
  m.C2 = C2;
  return m;
}

Material compressible(double C1 = 187.5e3, double C3 = 187.5e3) {  // Fig 3 of the paper, Pa
  Material m;
  m.model = MaterialModel::Compressible;
  m.C1 = C1;
  m.C3 = C3;
  return m;
}

Eigen::Matrix3d random_rotation(std::mt19937_64& g) {
  std::normal_distribution<double> N(0.0, 1.0);
  Eigen::Quaterniond q(N(g), N(g), N(g), N(g));
  return q.normalized().toRotationMatrix();
}

/// A random F with det F > 0.2 (so that the compressible law is smooth around it).
Eigen::Matrix3d random_F(std::mt19937_64& g, double amp = 0.4) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (;;) {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int i = 0; i < 9; ++i) F(i) += amp * U(g);
    if (F.determinant() > 0.2) return F;
  }
}

template <class Mat>
Mat fd_gradient(const Material& m, const Mat& F, double h) {
  Mat G;
  for (int i = 0; i < F.size(); ++i) {
    Mat Fp = F, Fm = F;
    Fp(i) += h;
    Fm(i) -= h;
    G(i) = (m.W(Fp) - m.W(Fm)) / (2.0 * h);
  }
  return G;
}

// --- values -----------------------------------------------------------------------------

TEST(Material, Eq1_5_MooneyRivlinZeroAtIdentityAndKnownValue) {
  const Material m = mooney_rivlin(2.0, 3.0);
  EXPECT_EQ(m.W(Eigen::Matrix3d::Identity().eval()), 0.0);
  EXPECT_EQ(m.W(Eigen::Matrix2d::Identity().eval()), 0.0);
  // F = diag(2, 1/2, 1): |F|^2 = 5.25, adj F = diag(1/2, 2, 1), |adj F|^2 = 5.25
  const Eigen::Matrix3d F = Eigen::Vector3d(2.0, 0.5, 1.0).asDiagonal();
  EXPECT_NEAR(m.W(F), 2.0 * 2.25 + 3.0 * 2.25, 1e-14);
  // plane strain embeds diag(F2, 1)
  EXPECT_NEAR(m.W(Eigen::Matrix2d(Eigen::Vector2d(2.0, 0.5).asDiagonal())), 11.25, 1e-14);
  // |adj F| uses the cofactor (not the inverse): a shear keeps det = 1, |adj F|^2 = 3 + 0.25
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(0, 1) = 0.5;
  EXPECT_NEAR(m.W(S), 2.0 * 0.25 + 3.0 * 0.25, 1e-14);
}

TEST(Material, Fig3_CompressibleStressFreeReferenceAndKnownValue) {
  const Material m = compressible();
  // W(I) = 0 and dW(I) = 0: the reference configuration is stress free (3-D and plane strain)
  EXPECT_NEAR(m.W(Eigen::Matrix3d::Identity().eval()), 0.0, 1e-9);
  EXPECT_LT(m.dW(Eigen::Matrix3d::Identity().eval()).norm(), 1e-9);
  EXPECT_NEAR(m.W(Eigen::Matrix2d::Identity().eval()), 0.0, 1e-9);
  EXPECT_LT(m.dW(Eigen::Matrix2d::Identity().eval()).norm(), 1e-9);
  // F = diag(2, 1, 1): 3 C1 + 3 C3 - 2 (C1 + C3) ln 2
  const Eigen::Matrix3d F = Eigen::Vector3d(2.0, 1.0, 1.0).asDiagonal();
  EXPECT_NEAR(m.W(F), 3.0 * 375e3 - 2.0 * 375e3 * std::log(2.0), 1e-8);
  // + inf for det F <= 0
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(m.W(Eigen::Matrix3d(Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal())), inf);
  EXPECT_EQ(m.W(Eigen::Matrix3d::Zero().eval()), inf);
  EXPECT_EQ(m.W(Eigen::Matrix2d(Eigen::Vector2d(-1.0, 1.0).asDiagonal())), inf);
}

// --- derivatives ------------------------------------------------------------------------

TEST(Material, Eq1_5_Fig3_dWMatchesCentralFiniteDifferences3D) {
  std::mt19937_64 g(1);
  for (const Material& m : {mooney_rivlin(), mooney_rivlin(187.5e3, 0.0), compressible()}) {
    for (int k = 0; k < 50; ++k) {
      const Eigen::Matrix3d F = random_F(g);
      const Eigen::Matrix3d G = m.dW(F), Gfd = fd_gradient(m, F, 1e-5);
      EXPECT_LT((G - Gfd).norm(), 1e-6 * G.norm()) << m.name() << "\n" << F;
    }
  }
}

TEST(Material, Eq1_5_Fig3_dWMatchesCentralFiniteDifferencesPlaneStrain) {
  std::mt19937_64 g(2);
  for (const Material& m : {mooney_rivlin(), compressible()}) {
    for (int k = 0; k < 50; ++k) {
      const Eigen::Matrix2d F = random_F(g).topLeftCorner<2, 2>();
      if (F.determinant() < 0.2) continue;
      const Eigen::Matrix2d G = m.dW(F), Gfd = fd_gradient(m, F, 1e-5);
      EXPECT_LT((G - Gfd).norm(), 1e-6 * G.norm()) << m.name() << "\n" << F;
      // plane strain = in-plane block of the 3-D law at diag(F, 1)
      Eigen::Matrix3d F3 = Eigen::Matrix3d::Identity();
      F3.topLeftCorner<2, 2>() = F;
      EXPECT_DOUBLE_EQ(m.W(F), m.W(F3));
    }
  }
}

TEST(Material, Eq1_5_dWAccurateAtLargeStretch) {
  // dI2/dF is evaluated from cofactor columns: at stretch 1e4 the textbook
  // 2 (|F|^2 F - F F^T F) loses eps |F|^2 ~ 1e-8 relative accuracy, ours does not.
  const Material m = mooney_rivlin(0.0, 1.0);
  const double a = 1e4;
  const Eigen::Matrix3d F = Eigen::Vector3d(a, 1.0 / a, 1.0).asDiagonal();
  // |cof F|^2 = a^-2 + a^2 + 1 exactly
  const Eigen::Vector3d c(1.0 / a, a, 1.0);  // cof F diagonal
  EXPECT_NEAR(m.W(F), c.squaredNorm() - 3.0, 1e-16 * c.squaredNorm());
  // dI2/dF_11 = 2 F_11 (F_22^2 + F_33^2), etc. for a diagonal F
  const Eigen::Vector3d f(a, 1.0 / a, 1.0);
  const Eigen::Vector3d expect(2.0 * f[0] * (f[1] * f[1] + f[2] * f[2]),
                               2.0 * f[1] * (f[0] * f[0] + f[2] * f[2]),
                               2.0 * f[2] * (f[0] * f[0] + f[1] * f[1]));
  const Eigen::Matrix3d G = m.dW(F);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(G(i, i), expect[i], 1e-15 * std::abs(expect[i]));
}

// --- invariance ----------------------------------------------------------------------------

TEST(Material, FrameIndifferenceAndIsotropy) {
  std::mt19937_64 g(3);
  for (const Material& m : {mooney_rivlin(), compressible()}) {
    for (int k = 0; k < 30; ++k) {
      const Eigen::Matrix3d F = random_F(g), Q = random_rotation(g);
      const double w = m.W(F);
      EXPECT_NEAR(m.W((Q * F).eval()), w, 1e-12 * std::abs(w) + 1e-9) << m.name();  // frame
      EXPECT_NEAR(m.W((F * Q).eval()), w, 1e-12 * std::abs(w) + 1e-9) << m.name();  // isotropy
      // the stress transforms accordingly: dW(Q F) = Q dW(F)
      EXPECT_LT((m.dW((Q * F).eval()) - Q * m.dW(F)).norm(), 1e-12 * m.dW(F).norm() + 1e-9);
    }
  }
}

// --- small strains ------------------------------------------------------------------------

/// Linearization of dW at I in the direction H, by central differences.
template <class Mat>
Mat linearized_stress(const Material& m, const Mat& H) {
  const double h = 1e-6;
  const Mat I = Mat::Identity();
  return (m.dW((I + h * H).eval()) - m.dW((I - h * H).eval())) / (2.0 * h);
}

TEST(Material, Sec8_CompressibleLawIsLinearElasticE1000kPaNuOneThird) {
  // [LTL87 sec. 8]: C1 = C3 = 187.5 kPa "corresponds to a Young modulus of 1000 kpa and a
  // Poisson coefficient of 0.33". From W: linearized dW(I)[H] = 2 C1 (H + H^T) + 4 C3 tr(H) I,
  // i.e. Lame mu = 2 C1 = 375 kPa, lambda = 4 C3 = 750 kPa, hence E = mu (3 lambda + 2 mu) /
  // (lambda + mu) = 1000 kPa, nu = lambda / (2 (lambda + mu)) = 1/3.
  const Material m = compressible();
  const double E = 1000e3, nu = 1.0 / 3.0;
  const double mu = E / (2.0 * (1.0 + nu)), lambda = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
  EXPECT_NEAR(mu, 2.0 * m.C1, 1e-9);
  EXPECT_NEAR(lambda, 4.0 * m.C3, 1e-9);
  std::mt19937_64 g(4);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int k = 0; k < 10; ++k) {
    Eigen::Matrix3d H;
    for (int i = 0; i < 9; ++i) H(i) = U(g);
    // H may be unsymmetric: the rotation part costs nothing
    const Eigen::Matrix3d eps = 0.5 * (H + H.transpose());
    const Eigen::Matrix3d sigma =
        2.0 * mu * eps + lambda * eps.trace() * Eigen::Matrix3d::Identity();
    EXPECT_LT((linearized_stress(m, H) - sigma).norm(), 1e-6 * sigma.norm());
    // plane strain: the same tensor restricted to the plane
    const Eigen::Matrix2d H2 = H.topLeftCorner<2, 2>(), e2 = eps.topLeftCorner<2, 2>();
    const Eigen::Matrix2d s2 = 2.0 * mu * e2 + lambda * e2.trace() * Eigen::Matrix2d::Identity();
    EXPECT_LT((linearized_stress(m, H2) - s2).norm(), 1e-6 * s2.norm());
  }
}

TEST(Material, Eq1_5_MooneyRivlinShearModulus) {
  // Incompressible: P = dW - p cof F with p = p0 = 2 C1 + 4 C2 at F = I (dW(I) = p0 I).
  // For symmetric traceless H the linearized stress is 2 mu H with mu = 2 (C1 + C2).
  const Material m = mooney_rivlin();
  const double p0 = 2.0 * m.C1 + 4.0 * m.C2;
  EXPECT_LT((m.dW(Eigen::Matrix3d::Identity().eval()) - p0 * Eigen::Matrix3d::Identity()).norm(),
            1e-9);
  Eigen::Matrix3d H;
  H << 0.3, 0.2, -0.1, 0.2, -0.5, 0.4, -0.1, 0.4, 0.2;
  // d cof(I + hH)/dh = tr(H) I - H^T
  const Eigen::Matrix3d dcof = H.trace() * Eigen::Matrix3d::Identity() - H.transpose();
  const Eigen::Matrix3d lin = linearized_stress(m, H) - p0 * dcof;
  EXPECT_LT((lin - 4.0 * (m.C1 + m.C2) * H).norm(), 1e-6 * lin.norm());
}

}  // namespace
