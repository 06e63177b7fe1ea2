// The incompressible laws in principal stretches, Ogden with N terms and Gent (material.hpp,
// paper_notes/materials.md), in the local strain step (4.6) beside (1.5): derivatives against
// central differences (dW, and d2W the Newton phase uses), the reductions to Mooney-Rivlin (1.5)
// and neo-Hookean, the local step's minimizer on det E = 1 against a search over the constraint
// set, and incompressible uniaxial tension of a bar through the whole solver (ALG2 and the Newton
// phase) against the closed-form nominal stress.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "cofactor.hpp"
#include "material.hpp"
#include "strain_step.hpp"
#include "testing.hpp"

namespace {

using ltl::Material;
using ltl::OgdenTerm;
using ltl::StrainStep;

/// Ogden's three-term fit of Treloar's rubber data (Ogden 1972), Pa.
Material treloar_ogden() {
  return Material::ogden_law({{630e3, 1.3}, {1.2e3, 5.0}, {-10e3, -2.0}});
}
Material gent() {
  return Material::gent(300e3, 10.0);
}

Eigen::Matrix3d random_F(std::mt19937_64& g, double amp) {
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (;;) {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int i = 0; i < 9; ++i) F(i) += amp * U(g);
    if (F.determinant() > 0.3) return F;
  }
}

/// Largest relative error of dW against central differences of W, and of d2W(F, H) against
/// central differences of dW in a random direction H, over random F (3-D and plane strain).
void expect_derivatives(const Material& m, unsigned seed) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  double worst_dW = 0, worst_d2W = 0;
  const double h = 1e-6;
  for (int k = 0; k < 40; ++k) {
    Eigen::Matrix3d F = random_F(g, 0.4);
    if (k % 4 == 0) F = Eigen::Matrix3d::Identity() + 1e-9 * F;  // repeated stretches
    if (k % 4 == 1) F.row(2) = Eigen::RowVector3d(0, 0, 1), F.col(2) = Eigen::Vector3d(0, 0, 1);
    Eigen::Matrix3d H, G;
    for (int i = 0; i < 9; ++i) H(i) = U(g);
    for (int i = 0; i < 9; ++i) {
      Eigen::Matrix3d Fp = F, Fm = F;
      Fp(i) += h;
      Fm(i) -= h;
      G(i) = (m.W(Fp) - m.W(Fm)) / (2 * h);
    }
    const Eigen::Matrix3d P = m.dW(F);
    const double scale = P.norm() + m.C1;
    worst_dW = std::max(worst_dW, (P - G).norm() / scale);
    const Eigen::Matrix3d dP = (m.dW((F + h * H).eval()) - m.dW((F - h * H).eval())) / (2 * h);
    worst_d2W = std::max(worst_d2W, (m.d2W(F, H) - dP).norm() / (dP.norm() + m.C1));
    // plane strain: the in-plane blocks of the embedded F = diag(F2, 1)
    const Eigen::Matrix2d F2 = F.topLeftCorner<2, 2>(), H2 = H.topLeftCorner<2, 2>();
    Eigen::Matrix3d F3 = Eigen::Matrix3d::Identity(), H3 = Eigen::Matrix3d::Zero();
    F3.topLeftCorner<2, 2>() = F2;
    H3.topLeftCorner<2, 2>() = H2;
    EXPECT_LT((m.dW(F2) - m.dW(F3).topLeftCorner<2, 2>()).norm(), 1e-12 * scale);
    EXPECT_LT((m.d2W(F2, H2) - m.d2W(F3, H3).topLeftCorner<2, 2>()).norm(), 1e-12 * scale);
  }
  EXPECT_LT(worst_dW, 1e-7) << m.name();
  EXPECT_LT(worst_d2W, 1e-6) << m.name();
  std::printf("  %s: max |dW - FD| / |dW| = %.1e, max |d2W - FD| / |d2W| = %.1e\n",
              m.name().c_str(), worst_dW, worst_d2W);
}

TEST(PrincipalLaws, Eq1_5_OgdenDerivativesMatchFiniteDifferences) {
  expect_derivatives(treloar_ogden(), 1);
}

TEST(PrincipalLaws, Eq1_5_GentDerivativesMatchFiniteDifferences) {
  expect_derivatives(gent(), 2);
}

TEST(PrincipalLaws, StressFreeReferenceAndShearModulus) {
  // W(I) = 0, dW(I) = c I (a pressure: stress free under det F = 1; c = sum mu_p for Ogden,
  // mu for Gent); simple shear of amount g: W = mu g^2 / 2 + O(g^4), mu the initial
  // shear modulus (1/2) sum mu_p alpha_p (Ogden), mu (Gent); C1 = mu / 2.
  for (const Material& m : {treloar_ogden(), gent()}) {
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    EXPECT_NEAR(m.W(I), 0.0, 1e-9) << m.name();
    const Eigen::Matrix3d P0 = m.dW(I);
    EXPECT_LT((P0 - (P0.trace() / 3) * I).norm(), 1e-9 * m.C1) << m.name();
    EXPECT_GT(P0.trace(), 0.0) << m.name();
    Eigen::Matrix3d S = I;
    const double gam = 1e-3;
    S(0, 1) = gam;
    const double mu = 2 * m.C1;
    EXPECT_NEAR(m.W(S) / (0.5 * mu * gam * gam), 1.0, 1e-5) << m.name();
  }
  EXPECT_NEAR(treloar_ogden().C1, 0.25 * (630e3 * 1.3 + 1.2e3 * 5 + 10e3 * 2), 1e-6);
}

TEST(PrincipalLaws, Eq1_5_OgdenWithTwoTermsIsMooneyRivlin) {
  // Ogden (2, 2 C1), (-2, -2 C2) is (1.5) on det F = 1: the same W, a stress that differs by a
  // pressure only (dW - dW_MR parallel to cof F), and the same local step (4.6).
  const double C1 = 435e3, C2 = 65e3;
  const Material mr = Material::mooney_rivlin(C1, C2);
  const Material og = Material::ogden_law({{2 * C1, 2.0}, {-2 * C2, -2.0}});
  EXPECT_EQ(og.C1, C1 + C2);  // the split keeps the initial shear modulus 2 (C1 + C2)
  std::mt19937_64 g(5);
  for (int k = 0; k < 20; ++k) {
    Eigen::Matrix3d F = random_F(g, 0.5);
    F /= std::cbrt(F.determinant());
    EXPECT_NEAR(og.W(F), mr.W(F), 1e-9 * mr.W(F)) << F;
    const Eigen::Matrix3d c = ltl::cofactor<3>(F), d = og.dW(F) - mr.dW(F);
    const Eigen::Matrix3d off = d - (d.cwiseProduct(c).sum() / c.squaredNorm()) * c;
    EXPECT_LT(off.norm(), 1e-9 * mr.dW(F).norm()) << F;
  }
  // the local step, with the same split (C1 in the Laplacian; the Ogden default is C1 + C2):
  // the objectives agree on det E = 1, so do the minimizers
  Material og_split = og;
  og_split.C1 = C1;
  for (const double Rq : {8 * (C1 + C2), 1e8}) {
    const StrainStep s_og(og_split, Rq), s_mr(mr, Rq);
    double worst = 0;
    for (int k = 0; k < 30; ++k) {
      const Eigen::Matrix3d D = Rq * random_F(g, 0.4);
      Eigen::Matrix3d Eo, Em;
      ASSERT_TRUE(s_og.solve(D, Eo)) << D;
      ASSERT_TRUE(s_mr.solve(D, Em)) << D;
      worst = std::max(worst, (Eo - Em).norm() / Em.norm());
    }
    EXPECT_LT(worst, 1e-10) << "Rq " << Rq;
  }
}

TEST(PrincipalLaws, GentTendsToNeoHookean) {
  // W_Gent = -(mu Jm / 2) ln(1 - x), x = (|F|^2 - 3) / Jm, = mu/2 (|F|^2 - 3)(1 + x/2 + ...)
  std::mt19937_64 g(9);
  const Material nh = Material::mooney_rivlin(150e3, 0.0);
  for (const double Jm : {1e2, 1e4, 1e6}) {
    const Material ge = Material::gent(300e3, Jm);
    const Eigen::Matrix3d F = random_F(g, 0.4);
    const double x = (F.squaredNorm() - 3) / Jm;
    EXPECT_NEAR(ge.W(F) / nh.W(F), 1 + x / 2, x * x) << Jm;
  }
  // outside the locking surface: no energy, no stress
  const Material ge = Material::gent(300e3, 1.0);
  const Eigen::Matrix3d F = Eigen::Vector3d(2.0, 0.5, 1.0).asDiagonal();  // |F|^2 - 3 = 2.25
  EXPECT_TRUE(std::isinf(ge.W(F)));
  EXPECT_TRUE(std::isnan(ge.dW(F)(0, 0)));
}

/// [LTL87 (4.6), (5.4)-(5.5)] The local step's minimizer for Ogden and Gent: det E = 1, and no
/// point of the constraint set found by a random search around it (E (I + A) / det^(1/n), small
/// and large A) has a lower objective.
template <int n>
void expect_local_minimizer(const Material& m, double Rq, unsigned seed) {
  using Mat = Eigen::Matrix<double, n, n>;
  const StrainStep st(m, Rq);
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  int solved = 0;
  for (int k = 0; k < 60; ++k) {
    Mat D = Mat::Identity();
    for (int i = 0; i < n * n; ++i) D(i) += (k < 30 ? 0.4 : 1.5) * U(g);
    D *= Rq;
    Mat E;
    ASSERT_TRUE(st.solve(D, E)) << m.name() << "\n" << D;
    ++solved;
    EXPECT_NEAR(E.determinant(), 1.0, 1e-12) << D;
    const double J = st.objective(D, E);
    ASSERT_TRUE(std::isfinite(J));
    for (int trial = 0; trial < 300; ++trial) {
      Mat A;
      for (int i = 0; i < n * n; ++i) A(i) = U(g) * (trial < 150 ? 1e-3 : 0.5);
      Mat Et = E * (Mat::Identity() + A);
      if (!(Et.determinant() > 0)) continue;
      Et /= std::pow(Et.determinant(), 1.0 / n);
      EXPECT_GE(st.objective(D, Et), J - 1e-12 * (std::abs(J) + Rq)) << m.name() << "\n" << D;
    }
  }
  EXPECT_EQ(solved, 60);
}

TEST(PrincipalLaws, Eq4_6_LocalStepMinimizesOnTheConstraintSet) {
  for (const Material& m : {treloar_ogden(), gent(), Material::gent(300e3, 0.5)}) {
    for (const double Rq : {8 * m.C1, 50 * m.C1}) {
      expect_local_minimizer<2>(m, Rq, 11);
      expect_local_minimizer<3>(m, Rq, 12);
    }
  }
}

// [LTL87 (1.5), (4.1)-(4.4)] Incompressible uniaxial tension of the unit block (symmetry on
// x0, y0, z0, dead nominal traction P e1 on x1) through the whole solver: F = diag(l, l^-1/2,
// l^-1/2) and the nominal stress P = dW/dl along that path,
//   Ogden: P = sum_p mu_p (l^(alpha_p - 1) - l^(-alpha_p/2 - 1)),
//   Gent:  P = mu (l - l^-2) / (1 - (l^2 + 2/l - 3) / Jm),
// for l = 1.5, 2 (testing.hpp: expect_uniaxial_tension_3d, nodal u to 1e-6 l, P_e to 1e-5).
double ogden_uniaxial(const Material& m, double l) {
  double P = 0;
  for (const OgdenTerm& t : m.ogden)
    P += t.mu * (std::pow(l, t.alpha - 1) - std::pow(l, -t.alpha / 2 - 1));
  return P;
}
double gent_uniaxial(const Material& m, double l) {
  return m.mu * (l - 1 / (l * l)) / (1 - (l * l + 2 / l - 3) / m.Jm);
}

/// Both solvers on the same bar: ALG2 alone, and ALG2 then the Newton phase (d2W).
void expect_uniaxial(const Material& m, double (*nominal)(const Material&, double)) {
  const auto P = [&](double l) { return nominal(m, l); };
  const ltl::Mesh mesh = ltl::testing::distorted_box(2, 11);
  for (const auto solver : {ltl::NonlinearSolver::Alg2, ltl::NonlinearSolver::Newton})
    ltl::testing::expect_uniaxial_tension_3d(mesh, m, P, solver);
}

TEST(PrincipalLaws, Eq1_5_OgdenUniaxialTensionClosedForm) {
  expect_uniaxial(treloar_ogden(), ogden_uniaxial);
}

TEST(PrincipalLaws, Eq1_5_GentUniaxialTensionClosedForm) {
  expect_uniaxial(gent(), gent_uniaxial);
}

}  // namespace
