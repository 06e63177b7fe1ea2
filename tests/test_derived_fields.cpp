// The derived fields of the results files (lib/derived_fields.hpp): det F and the principal
// stretches of the deformation gradient F (the paper's strain unknown F of (2.7), E in the
// code), the von Mises stress, and the nodal stresses recovered by volume-weighted averaging.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "derived_fields.hpp"
#include "error.hpp"
#include "fe.hpp"
#include "testing.hpp"

namespace {

using ltl::DerivedFields;

TEST(DerivedFields, Eq2_7_DetFStretchesAndVonMisesPerCell) {
  const ltl::Mesh mesh = ltl::load_mesh(ltl::testing::test_path("geometry/square.geo"));
  const int nc = mesh.num_cells();
  const Eigen::VectorXd vol = ltl::cell_operators(mesh).vol;
  std::mt19937_64 g(4);
  std::uniform_real_distribution<double> U(0.5, 2.0);
  Eigen::MatrixXd F(2 * nc, 2), sigma(2 * nc, 2);
  Eigen::VectorXd s33(nc);
  std::vector<Eigen::Matrix2d> R(nc);
  for (int c = 0; c < nc; ++c) {
    // F = rotation diag(a, b): stretches a, b and 1; sigma = diag(s, 0), sigma33 = s / 2
    const double a = U(g), b = U(g), th = U(g), s = 1e5 * U(g);
    Eigen::Matrix2d Q;
    Q << std::cos(th), -std::sin(th), std::sin(th), std::cos(th);
    F.block<2, 2>(2 * c, 0) = (Q * Eigen::Vector2d(a, b).asDiagonal()).transpose();
    sigma.block<2, 2>(2 * c, 0) = Eigen::Vector2d(s, 0).asDiagonal();
    s33(c) = s / 2;
  }
  const DerivedFields d = ltl::derived_fields(mesh, vol, F, sigma, s33);
  for (int c = 0; c < nc; ++c) {
    const Eigen::Matrix2d Fc = F.block<2, 2>(2 * c, 0).transpose();
    Eigen::Vector3d t(Fc.col(0).norm(), Fc.col(1).norm(), 1.0);
    std::sort(t.data(), t.data() + 3, std::greater<double>());
    EXPECT_NEAR(d.detF(c), Fc.determinant(), 1e-14);
    EXPECT_LT((d.stretches.row(c).transpose() - t).norm(), 1e-13);
    // deviator of diag(s, 0, s/2): (s/2, -s/2, 0), von Mises sqrt(3/2 * s^2/2) = s sqrt(3)/2
    const double s = sigma(2 * c, 0);
    EXPECT_NEAR(d.von_mises(c), s * std::sqrt(3.0) / 2, 1e-9 * s);
  }
}

TEST(DerivedFields, UniformStressRecoveredExactlyAtTheNodes) {
  for (const char* geo : {"geometry/square.geo", "geometry/box.geo"}) {
    const ltl::Mesh mesh = ltl::load_mesh(ltl::testing::test_path(geo));
    const int d = mesh.dim, nc = mesh.num_cells();
    const Eigen::VectorXd vol = ltl::cell_operators(mesh).vol;
    Eigen::Matrix3d S;
    S << 1, 2, 3, 2, -4, 5, 3, 5, 6;
    S *= 1e4;
    Eigen::MatrixXd F(d * nc, d), sigma(d * nc, d);
    Eigen::VectorXd s33 = Eigen::VectorXd::Constant(d == 2 ? nc : 0, S(2, 2));
    for (int c = 0; c < nc; ++c) {
      F.block(d * c, 0, d, d).setIdentity();
      sigma.block(d * c, 0, d, d) = S.topLeftCorner(d, d).transpose();
    }
    if (d == 2) S(0, 2) = S(2, 0) = S(1, 2) = S(2, 1) = 0;  // plane strain: sigma13 = sigma23 = 0
    const DerivedFields df = ltl::derived_fields(mesh, vol, F, sigma, s33);
    double worst = 0;
    for (int n = 0; n < mesh.num_nodes(); ++n) {
      const Eigen::Matrix<double, 1, 9> row = df.sigma_node.row(n);
      const Eigen::Matrix3d Sn = Eigen::Map<const Eigen::Matrix3d>(row.data()).transpose();
      worst = std::max(worst, (Sn - S).norm() / S.norm());
      EXPECT_NEAR(df.von_mises_node(n), ltl::von_mises(S), 1e-12 * S.norm());
    }
    EXPECT_LT(worst, 1e-14) << geo;
  }
}

/// The fields of some cells, as a rank makes them under mpirun (lib/step_fields.hpp): cell_fields
/// of the cells' blocks are those cells' rows of the whole mesh's, and the nodal sums of two
/// complementary sets of cells add up to the whole mesh's, from which nodal_stress gives
/// derived_fields' nodal stress. Fails when a cell set's sums miss its cells or count another's.
TEST(DerivedFields, Eq2_7_FieldsOfSomeCellsAddUpToTheWholeMeshs) {
  for (const char* geo : {"geometry/square.geo", "geometry/box.geo"}) {
    const ltl::Mesh mesh = ltl::load_mesh(ltl::testing::test_path(geo));
    const int d = mesh.dim, nc = mesh.num_cells();
    const Eigen::VectorXd vol = ltl::cell_operators(mesh).vol;
    std::mt19937_64 g(7);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    Eigen::MatrixXd F(d * nc, d), sigma(d * nc, d);
    Eigen::VectorXd s33(d == 2 ? nc : 0);
    for (int c = 0; c < nc; ++c) {
      Eigen::MatrixXd A = Eigen::MatrixXd::Identity(d, d), S(d, d);
      for (int i = 0; i < d; ++i)
        for (int j = 0; j < d; ++j) A(i, j) += 0.2 * U(g), S(i, j) = 1e5 * U(g);
      F.block(d * c, 0, d, d) = A;
      sigma.block(d * c, 0, d, d) = S + S.transpose();
      if (d == 2) s33(c) = 1e5 * U(g);
    }
    const DerivedFields whole = ltl::derived_fields(mesh, vol, F, sigma, s33);
    // Two sets of cells: the even and the odd ones, each sorted, with their blocks.
    Eigen::MatrixXd sums = Eigen::MatrixXd::Zero(mesh.num_nodes(), 10);
    for (int parity = 0; parity < 2; ++parity) {
      std::vector<int> cells;
      for (int c = parity; c < nc; c += 2) cells.push_back(c);
      const int n = static_cast<int>(cells.size());
      Eigen::MatrixXd Fk(d * n, d), Sk(d * n, d);
      Eigen::VectorXd s33k(d == 2 ? n : 0);
      for (int k = 0; k < n; ++k) {
        Fk.block(d * k, 0, d, d) = F.block(d * cells[k], 0, d, d);
        Sk.block(d * k, 0, d, d) = sigma.block(d * cells[k], 0, d, d);
        if (d == 2) s33k(k) = s33(cells[k]);
      }
      const DerivedFields part = ltl::cell_fields(Fk, Sk, s33k);
      for (int k = 0; k < n; ++k) {
        EXPECT_EQ(part.detF(k), whole.detF(cells[k])) << geo;
        EXPECT_EQ(part.von_mises(k), whole.von_mises(cells[k])) << geo;
        EXPECT_EQ(part.stretches.row(k), whole.stretches.row(cells[k])) << geo;
      }
      // Their volumes alone, in their order (a rank's CellOperators::vol).
      sums += ltl::nodal_stress_sums(mesh, vol(cells), Sk, s33k, &cells);
    }
    DerivedFields nodal;
    ltl::nodal_stress(std::move(sums), nodal);
    ASSERT_EQ(nodal.sigma_node.rows(), mesh.num_nodes());
    ASSERT_EQ(nodal.sigma_node.cols(), 9);
    const double scale = whole.sigma_node.cwiseAbs().maxCoeff();
    EXPECT_LT((nodal.sigma_node - whole.sigma_node).cwiseAbs().maxCoeff(), 1e-12 * scale) << geo;
    EXPECT_LT((nodal.von_mises_node - whole.von_mises_node).cwiseAbs().maxCoeff(), 1e-12 * scale)
        << geo;
    // One set alone is not the whole: its sums miss the other set's cells.
    std::vector<int> even;
    for (int c = 0; c < nc; c += 2) even.push_back(c);
    Eigen::MatrixXd Se(d * static_cast<int>(even.size()), d);
    Eigen::VectorXd s33e(d == 2 ? even.size() : 0);
    for (std::size_t k = 0; k < even.size(); ++k) {
      Se.block(d * k, 0, d, d) = sigma.block(d * even[k], 0, d, d);
      if (d == 2) s33e(k) = s33(even[k]);
    }
    DerivedFields half;
    ltl::nodal_stress(ltl::nodal_stress_sums(mesh, vol(even), Se, s33e, &even), half);
    // Every cell's volumes for one set's cells: an Error, not sums weighted by other cells'.
    EXPECT_THROW(ltl::nodal_stress_sums(mesh, vol, Se, s33e, &even), ltl::Error) << geo;
    EXPECT_GT((half.sigma_node - whole.sigma_node).cwiseAbs().maxCoeff(), 1e-3 * scale) << geo;
  }
}

/// The nodal stress a block of nodes at a time, as the results writer reads it
/// (lib/step_fields.hpp): the sums of the nodes first .. first + count - 1 over some cells
/// (nodal_stress_sums' node range) are those nodes' rows of the sums of every node, and
/// nodal_stress of a block gives those rows of derived_fields' nodal stress, over blocks of 7
/// nodes that cut through cells. A range outside the nodes is an error. Fails when a block's sums
/// are put at the whole array's rows or count the nodes of another block.
TEST(DerivedFields, Eq2_7_NodalStressOfABlockOfNodesIsThoseNodesRows) {
  for (const char* geo : {"geometry/square.geo", "geometry/box.geo"}) {
    const ltl::Mesh mesh = ltl::load_mesh(ltl::testing::test_path(geo));
    const int d = mesh.dim, nc = mesh.num_cells(), nn = mesh.num_nodes();
    const Eigen::VectorXd vol = ltl::cell_operators(mesh).vol;
    std::mt19937_64 g(11);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    Eigen::MatrixXd F = Eigen::MatrixXd::Zero(d * nc, d), sigma(d * nc, d);
    Eigen::VectorXd s33(d == 2 ? nc : 0);
    for (int c = 0; c < nc; ++c) {
      Eigen::MatrixXd S(d, d);
      for (int i = 0; i < d; ++i)
        for (int j = 0; j < d; ++j) S(i, j) = 1e5 * U(g);
      F.block(d * c, 0, d, d).setIdentity();
      sigma.block(d * c, 0, d, d) = S + S.transpose();
      if (d == 2) s33(c) = 1e5 * U(g);
    }
    const DerivedFields whole = ltl::derived_fields(mesh, vol, F, sigma, s33);
    const Eigen::MatrixXd all = ltl::nodal_stress_sums(mesh, vol, sigma, s33);
    const double scale = whole.sigma_node.cwiseAbs().maxCoeff();
    ASSERT_GT(nn, 3 * 7) << geo;
    int blocks = 0;
    for (int first = 0; first < nn; first += 7, ++blocks) {
      const int count = std::min(7, nn - first);
      const Eigen::MatrixXd sums =
          ltl::nodal_stress_sums(mesh, vol, sigma, s33, nullptr, first, count);
      ASSERT_EQ(sums.rows(), count) << geo;
      EXPECT_LT((sums - all.middleRows(first, count)).cwiseAbs().maxCoeff(),
                1e-12 * all.cwiseAbs().maxCoeff())
          << geo << ", nodes " << first << " + " << count;
      DerivedFields block;
      ltl::nodal_stress(Eigen::MatrixXd(sums), block);
      EXPECT_LT(
          (block.sigma_node - whole.sigma_node.middleRows(first, count)).cwiseAbs().maxCoeff(),
          1e-12 * scale)
          << geo << ", nodes " << first << " + " << count;
      EXPECT_LT(
          (block.von_mises_node - whole.von_mises_node.segment(first, count)).cwiseAbs().maxCoeff(),
          1e-12 * scale)
          << geo << ", nodes " << first << " + " << count;
    }
    EXPECT_EQ(blocks, (nn + 6) / 7);
    EXPECT_THROW(ltl::nodal_stress_sums(mesh, vol, sigma, s33, nullptr, nn - 3, 7), ltl::Error)
        << geo;
    EXPECT_THROW(ltl::nodal_stress_sums(mesh, vol, sigma, s33, nullptr, -1, 2), ltl::Error) << geo;
  }
}

}  // namespace
