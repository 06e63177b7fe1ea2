// Three-dimensional verification of ALG2 (4.1)-(4.4) on H8 hexahedra (the element of the paper's
// Fig 6): patch tests on distorted cells for both laws of the paper, uniaxial tension of an
// incompressible Mooney-Rivlin block under a dead load against its closed form, and frame
// indifference (rigid rotations are stress-free; sigma(Q F) = Q sigma(F) Q^T).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <random>

#include "alg2.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::distorted_box;
using ltl::testing::expect_patch_3d;
using ltl::testing::homogeneous_3d;
using ltl::testing::solve_one_step;
using ltl::testing::Solved;
using ltl::testing::test_path;

namespace {

Eigen::Matrix3d rotation(double angle, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

}  // namespace

TEST(PatchTest3D, Eq1_5_Eq5_7_DistortedHexahedraIncompressibleMooneyRivlinDetEIs1) {
  const Mesh mesh = distorted_box(3);
  // An isochoric F: a rotation times a symmetric stretch scaled to det = 1.
  Eigen::Matrix3d U;
  U << 1.3, 0.2, 0.0, 0.2, 0.9, 0.1, 0.0, 0.1, 1.0;
  U /= std::cbrt(U.determinant());
  const Eigen::Matrix3d F = rotation(0.4, {1, 2, 3}) * U;
  ASSERT_NEAR(F.determinant(), 1.0, 1e-14);
  expect_patch_3d(mesh, Material::mooney_rivlin(100e3, 30e3), F);
}

TEST(PatchTest3D, Sec8_DistortedHexahedraCompressibleLaw) {
  const Mesh mesh = distorted_box(3);
  Eigen::Matrix3d F;
  F << 1.2, 0.3, -0.1, 0.0, 0.9, 0.2, 0.1, -0.2, 1.1;
  ASSERT_GT(std::abs(F.determinant() - 1), 0.1);  // a genuine volume change
  expect_patch_3d(mesh, Material::compressible(187.5e3, 187.5e3), F);
}

TEST(UniaxialTension3D, Eq1_5_IncompressibleMooneyRivlinDeadLoad) {
  // [LTL87 (1.5)] Block [0,1]^3 (distorted interior), symmetry u1 = 0 on x0, u2 = 0 on y0,
  // u3 = 0 on z0, dead nominal traction P e1 on x1, the other faces free. Closed form:
  //   F = diag(l, l^-1/2, l^-1/2),  W = C1 (l^2 + 2/l - 3) + C2 (l^-2 + 2 l - 3),
  //   P = dW/dl = 2 (l - l^-2)(C1 + C2 / l)   (testing.hpp: expect_uniaxial_tension_3d).
  ltl::testing::expect_uniaxial_tension_3d(distorted_box(3, 11));
}

TEST(FrameIndifference3D, RigidRotationIsStressFreeForBothLaws) {
  // W(Q) = 0 and dW(Q) = 0 for a rotation Q [LTL87 (1.5), sec. 8]: imposing u = (Q - I) x gives
  // E = Q in every cell (a finite, 60 degree rotation, far from linearized kinematics) and, for
  // the compressible law whose stress is fully determined, P = 2 C1 E - lambda = 0 and J_p = 0.
  const Mesh mesh = distorted_box(2, 3);
  const Eigen::Matrix3d Q = rotation(M_PI / 3, {1, -1, 2});
  expect_patch_3d(mesh, Material::mooney_rivlin(100e3, 30e3), Q);
  const Material m = Material::compressible(187.5e3, 187.5e3);
  const Solved r = homogeneous_3d(mesh, m, Q);
  const Eigen::MatrixXd P = r.solver->discretization().piola(r.s);
  EXPECT_LT(P.cwiseAbs().maxCoeff(), 1e-6 * m.C1);
  EXPECT_LT(std::abs(r.solver->energy(r.s, r.s.beta)), 1e-9 * m.C1);
  std::printf("  compressible, rigid rotation: max |P| = %.1e Pa, J_p = %.1e J/m\n",
              P.cwiseAbs().maxCoeff(), r.solver->energy(r.s, r.s.beta));
}

TEST(FrameIndifference3D, CauchyStressOfQFIsQSigmaQt_CompressibleLaw) {
  // sigma(Q F) = Q sigma(F) Q^T, and both equal the closed form dW(F) F^T / det F cell by cell.
  const Mesh mesh = distorted_box(2, 5);
  const Material m = Material::compressible(187.5e3, 187.5e3);
  Eigen::Matrix3d F;
  F << 1.1, 0.2, 0.0, -0.1, 0.95, 0.15, 0.05, 0.0, 1.2;
  const Eigen::Matrix3d Q = rotation(1.0, {0.3, 1, -0.5});
  const Solved a = homogeneous_3d(mesh, m, F), b = homogeneous_3d(mesh, m, Q * F);
  const Eigen::MatrixXd sa = a.solver->discretization().cauchy(a.s),
                        sb = b.solver->discretization().cauchy(b.s);
  const Eigen::Matrix3d exact = m.dW(F) * F.transpose() / F.determinant();
  ASSERT_GT(exact.norm(), 0.1 * m.C1);  // a genuinely stressed state
  double worst_exact = 0, worst_frame = 0;
  for (int c = 0; c < mesh.num_cells(); ++c) {
    const Eigen::Matrix3d sigma_a = cell_tensor(sa, c), sigma_b = cell_tensor(sb, c);
    worst_exact = std::max(worst_exact, (sigma_a - exact).norm() / exact.norm());
    worst_frame =
        std::max(worst_frame, (sigma_b - Q * sigma_a * Q.transpose()).norm() / exact.norm());
  }
  EXPECT_LT(worst_exact, 1e-7);
  EXPECT_LT(worst_frame, 1e-7);
  std::printf(
      "  |sigma| = %.4g Pa; max |sigma - closed form| / |sigma| = %.1e, "
      "max |sigma(QF) - Q sigma(F) Q^T| / |sigma| = %.1e\n",
      exact.norm(), worst_exact, worst_frame);
}
