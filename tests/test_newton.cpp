// The Newton phase (lib/newton.hpp): its tangent against central differences of its residual,
// the material's second derivative against central differences of dW, and Newton against ALG2
// on the same discrete problem.
#include <gtest/gtest.h>

#include <random>

#include "config.hpp"
#include "newton.hpp"
#include "simulation.hpp"
#include "testing.hpp"

namespace ltl {
namespace {

Problem figure(const std::string& fig, const std::vector<std::string>& sets = {}) {
  return load_problem(testing::source_path("experiments/" + fig + "/" + fig + ".toml"), sets);
}

// A state away from rest: u random of relative size amp, p random around 2 C1, mu random >= 0.
Newton::Unknowns perturbed(const Discretization& disc, const Newton& newton, double amp,
                           unsigned seed) {
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> U(-1, 1);
  State s;
  const int d = disc.dim(), nc = disc.num_cells(), nn = disc.num_nodes();
  s.u = Eigen::MatrixXd::Zero(nn, d);
  s.E = disc.identity();
  s.lambda = 2 * disc.split().C1 * disc.identity();
  const int np = disc.facets() ? disc.facets()->size() : 0;
  s.e = Eigen::MatrixXd::Zero(d, np);
  s.lambda_c = Eigen::MatrixXd::Zero(d, np);
  Newton::Unknowns x = newton.unknowns(s);
  const double L = disc.problem().mesh.X.cwiseAbs().maxCoeff();
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < d; ++i) x.u(a, i) = amp * L * U(g);
  for (int e = 0; e < x.p.size(); ++e) x.p(e) = disc.split().C1 * (2 + U(g));
  for (int k = 0; k < x.mu.size(); ++k) x.mu(k) = 1e3 * (1 + U(g));
  (void)nc;
  return x;
}

// The tangent is the derivative of the residual: K v = (R(u + h v) - R(u - h v)) / 2h for random v.
double tangent_error(const std::string& fig, const std::vector<std::string>& sets, double amp) {
  const Discretization disc(figure(fig, sets));
  const Newton newton(disc);
  const Newton::Unknowns x = perturbed(disc, newton, amp, 3);
  const int d = disc.dim(), nn = disc.num_nodes();
  const Eigen::MatrixXd F = Eigen::MatrixXd::Zero(nn, d);
  const Eigen::SparseMatrix<double> K = newton.tangent(x);
  const Eigen::SparseMatrix<double> B = newton.constraint_gradient(x.u);
  std::mt19937 g(5);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::MatrixXd v(nn, d);
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < d; ++i) v(a, i) = U(g);
  Eigen::VectorXd vflat(d * nn);
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < d; ++i) vflat(d * a + i) = v(a, i);
  const double h = 1e-6 * disc.problem().mesh.X.cwiseAbs().maxCoeff();
  Newton::Unknowns xp = x, xm = x;
  xp.u += h * v;
  xm.u -= h * v;
  Eigen::VectorXd Rp, Gp, Rm, Gm;
  newton.residual(xp, F, Rp, Gp);
  newton.residual(xm, F, Rm, Gm);
  const Eigen::VectorXd fd = (Rp - Rm) / (2 * h), Kv = K * vflat;
  double err = (fd - Kv).norm() / Kv.norm();
  if (Gp.size()) {
    const Eigen::VectorXd gfd = (Gp - Gm) / (2 * h), Bv = B * vflat;
    err = std::max(err, (gfd - Bv).norm() / Bv.norm());
  }
  return err;
}

TEST(Newton, Eq1_5_MaterialSecondDerivativeIsTheDerivativeOfdW) {
  std::mt19937 g(11);
  std::uniform_real_distribution<double> U(-0.3, 0.3);
  for (const Material& m :
       {Material::mooney_rivlin(435e3, 65e3), Material::compressible(1e5, 2e5)}) {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity(), H;
    for (int i = 0; i < 9; ++i) F(i) += U(g), H(i) = U(g);
    const double h = 1e-6;
    const Eigen::Matrix3d fd =
        (m.dW(Eigen::Matrix3d(F + h * H)) - m.dW(Eigen::Matrix3d(F - h * H))) / (2 * h);
    EXPECT_LT((fd - m.d2W(F, H)).norm() / fd.norm(), 1e-8) << m.name();
    const Eigen::Matrix2d F2 = F.topLeftCorner<2, 2>(), H2 = H.topLeftCorner<2, 2>();
    const Eigen::Matrix2d fd2 =
        (m.dW(Eigen::Matrix2d(F2 + h * H2)) - m.dW(Eigen::Matrix2d(F2 - h * H2))) / (2 * h);
    EXPECT_LT((fd2 - m.d2W(F2, H2)).norm() / fd2.norm(), 1e-8) << m.name();
  }
}

TEST(Newton, Eq2_2_Eq2_7_TangentIsTheDerivativeOfTheResidual) {
  // Plane strain mean-det (Fig 5), 3-D H8 mean-det (Fig 6), det-mean with C2 in the local step,
  // the compressible law (Fig 3's material without its glue).
  EXPECT_LT(tangent_error("fig5", {}, 0.02), 1e-6);
  EXPECT_LT(tangent_error("fig6", {}, 0.01), 1e-6);
  EXPECT_LT(tangent_error("fig5",
                          {"discretization.incompressibility=\"det-mean\"",
                           "discretization.c2=\"cell-mean\""},
                          0.02),
            1e-6);
}

}  // namespace
}  // namespace ltl
