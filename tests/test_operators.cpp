// The discrete operators of the mean-gradient formulation and the global matrix of (4.5).
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <utility>
#include <vector>

#include "error.hpp"
#include "fe.hpp"
#include "global_step.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::distorted_box;
using ltl::testing::source_path;
using ltl::testing::test_path;

namespace {

// Mean gradient of u(x) = A x + c is A in every cell.
void expect_mean_gradient_exact(const Mesh& m, const Eigen::MatrixXd& A) {
  const CellOperators ops = cell_operators(m);
  const Eigen::MatrixXd U =
      m.X * A.transpose() + Eigen::MatrixXd::Constant(m.num_nodes(), m.dim, 0.3);
  const Eigen::MatrixXd GU = ops.Gbar * U;  // transposed blocks
  for (int c = 0; c < m.num_cells(); ++c)
    ASSERT_LT((GU.block(m.dim * c, 0, m.dim, m.dim).transpose() - A).norm(), 1e-12 * A.norm())
        << "cell " << c;
}

}  // namespace

TEST(Operators, MeanGradientOfALinearFieldIsExact_2D_3D) {
  // [LTL87 (2.7)] B_h uses cell means of grad v: exact for linear fields, including on curved
  // (isoparametric) P2 cells and distorted hexahedra.
  Eigen::Matrix2d A2;
  A2 << 0.3, -1.2, 0.7, 2.1;
  expect_mean_gradient_exact(load_mesh(test_path("geometry/square.geo")), A2);
  expect_mean_gradient_exact(load_mesh(source_path("experiments/fig5/half_disc.geo")), A2);
  Eigen::Matrix3d A3;
  A3 << 0.3, -1.2, 0.7, 2.1, 0.1, -0.4, 0.5, 0.9, -1.3;
  expect_mean_gradient_exact(distorted_box(3), A3);
}

TEST(Operators, VolumesAreasAndLoadsAddUp) {
  const Mesh bar = load_mesh(source_path("experiments/fig3/bar.geo"));
  const CellOperators c = cell_operators(bar);
  EXPECT_NEAR(c.vol.sum(), 0.2, 1e-14);
  const ContactPoints f = facet_mean_points(bar, bar.boundary("contact"));
  EXPECT_NEAR(f.area.sum(), 1.0, 1e-14);
  EXPECT_NEAR(f.area(0), 1.0 / 28, 1e-12);
  // The facet mean of a linear field is its value at the facet centre.
  const Eigen::MatrixXd U = bar.X * Eigen::Vector2d(2.0, -1.0).asDiagonal();
  const Eigen::MatrixXd ubar = f.mean * U;
  for (int s = 0; s < f.size(); ++s)
    EXPECT_NEAR(
        (ubar.row(s).transpose() - Eigen::Vector2d(2.0, -1.0).asDiagonal() * f.centre.col(s))
            .norm(),
        0, 1e-14);
  // Consistent loads: body force over the area, the affine Fig 3 traction over the top face
  // (integral of 1e4 (1 - x1) over [0, 1] = 5e3 N/m).
  const Eigen::MatrixXd F = body_load(bar, Eigen::Vector3d(0, -3.0, 0));
  EXPECT_NEAR(F.col(1).sum(), -0.6, 1e-13);
  AffineField g;
  g.value << 0, 1e4, 0;
  g.gradient(1, 0) = -1e4;
  const Eigen::MatrixXd G = surface_load(bar, bar.boundary("top"), g);
  EXPECT_NEAR(G.col(1).sum(), 5e3, 1e-9);
  EXPECT_NEAR(G.col(0).sum(), 0, 1e-12);
  // Curved contact arc of the half disc: length pi/2 up to the P2 geometry error.
  const Mesh disc = load_mesh(source_path("experiments/fig5/half_disc.geo"));
  EXPECT_NEAR(facet_mean_points(disc, disc.boundary("contact")).area.sum(), M_PI / 2, 2e-4);
  EXPECT_NEAR(cell_operators(disc).vol.sum(), M_PI / 2, 2e-4);
}

TEST(Operators, LaplacianAnnihilatesConstantsAndIsSymmetric) {
  for (const Mesh& m : {load_mesh(test_path("geometry/square.geo")), distorted_box(2)}) {
    const CellOperators c = cell_operators(m);
    EXPECT_LT((c.laplacian * Eigen::VectorXd::Ones(m.num_nodes())).norm(), 1e-12);
    EXPECT_LT((SpMat(c.laplacian.transpose()) - c.laplacian).norm(), 1e-14);
  }
}

TEST(GlobalMatrix, Eq4_5_IsSymmetricPositiveDefinite) {
  // [LTL87 (4.5)] K = 2 C1 L + R q Gbar^T |O| Gbar + R q_c M^T |G| M is SPD on the free nodes,
  // and definite with NO fixed node when a contact surface has q_c > 0.
  const Mesh bar = load_mesh(source_path("experiments/fig3/bar.geo"), {{"nx", 6}, {"ny", 2}});
  const CellOperators c = cell_operators(bar);
  const ContactPoints f = facet_mean_points(bar, bar.boundary("contact"));
  const SpMat K = global_matrix(c, &f, 187.5e3, 3e6, 8e9);
  EXPECT_LT((SpMat(K.transpose()) - K).norm(), 1e-9 * K.norm());
  const Eigen::MatrixXd Kd(K);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(Kd);
  EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
  // Without the contact term and without Dirichlet nodes, constants are in the kernel.
  const SpMat K0 = global_matrix(c, nullptr, 187.5e3, 3e6, 0);
  EXPECT_LT((K0 * Eigen::VectorXd::Ones(bar.num_nodes())).norm(), 1e-6);
}

TEST(GlobalMatrix, Eq4_5_PartsOfSomeCellsOnTheirNodesAddUp) {
  // [LTL87 (2.7), (3.3), (4.5)] The operators of some cells (a rank's, paper_notes/mpi.md) are on
  // the columns of those cells' nodes, numbered in increasing order: Gbar's block of each cell is
  // the whole Gbar's on those columns, L is that part's Laplacian there, and the parts of K of
  // complementary sets of cells, back in the mesh's numbering, add up to K. On a distorted box:
  // every third cell, and the others.
  const Mesh m = distorted_box(3);
  const CellOperators whole = cell_operators(m);
  std::vector<int> a, b;
  for (int c = 0; c < m.num_cells(); ++c) (c % 3 == 0 ? a : b).push_back(c);
  const CellOperators oa = cell_operators(m, &a), ob = cell_operators(m, &b);
  EXPECT_TRUE(whole.node.empty());
  EXPECT_EQ(whole.columns(), m.num_nodes());
  const Eigen::MatrixXd U = Eigen::MatrixXd::Random(m.num_nodes(), 3);
  {
    Eigen::MatrixXd T(3 * m.num_cells(), 3);
    mean_gradients(whole, 0, m.num_cells(), U, T);
    EXPECT_LT((T - whole.Gbar * U).norm(), 1e-14 * T.norm());
  }
  for (const auto& [set, ops] : {std::pair{&a, &oa}, std::pair{&b, &ob}}) {
    std::vector<int> nodes;
    for (int c : *set)
      for (int k = 0; k < m.nodes_per_cell(); ++k) nodes.push_back(m.cells(c, k));
    std::sort(nodes.begin(), nodes.end());
    nodes.erase(std::unique(nodes.begin(), nodes.end()), nodes.end());
    ASSERT_EQ(ops->node, nodes);
    ASSERT_LT(ops->columns(), m.num_nodes());
    ASSERT_EQ(ops->Gbar.cols(), ops->columns());
    ASSERT_EQ(ops->laplacian.rows(), ops->columns());
    const Eigen::MatrixXd GU = ops->Gbar * U(nodes, Eigen::all), GU_whole = whole.Gbar * U;
    // ... and so is mean_gradients' from u whole (no copy on the columns), from the second cell.
    const int n = static_cast<int>(set->size()) - 1;
    Eigen::MatrixXd T(3 * n, 3);
    mean_gradients(*ops, 1, n, U, T);
    for (std::size_t k = 0; k < set->size(); ++k) {
      EXPECT_EQ((GU.middleRows(3 * k, 3) - GU_whole.middleRows(3 * (*set)[k], 3)).norm(), 0.0);
      if (k > 0) {
        EXPECT_LT((T.middleRows(3 * (k - 1), 3) - GU_whole.middleRows(3 * (*set)[k], 3)).norm(),
                  1e-14 * GU_whole.norm());
      }
    }
    EXPECT_LT((ops->laplacian * Eigen::VectorXd::Ones(ops->columns())).norm(), 1e-12);
  }
  const SpMat K = global_matrix(whole, nullptr, 1.7, 3.1, 0);
  const SpMat Ka = global_matrix(oa, nullptr, 1.7, 3.1, 0),
              Kb = global_matrix(ob, nullptr, 1.7, 3.1, 0);
  ASSERT_EQ(Ka.rows(), m.num_nodes());
  ASSERT_EQ(Kb.cols(), m.num_nodes());
  EXPECT_LT((SpMat(Ka + Kb) - K).norm(), 1e-12 * K.norm());
}

TEST(GlobalStep, SolvesWithDirichletValuesAndOneFactorPerDistinctSet) {
  const Mesh m = load_mesh(test_path("geometry/square.geo"));
  const CellOperators c = cell_operators(m);
  const SpMat K = global_matrix(c, nullptr, 1.0, 2.0, 0);
  DirichletData bc;
  // Component x fixed on left and bottom, y only on the left (two distinct sets); the values
  // are held per fixed node (value[i][k] at fixed[i][k]), u = value there (1.1).
  bc.fixed = {m.boundary_nodes("boundary"), m.boundary_nodes("left")};
  bc.value.assign(2, {});
  for (int i : bc.fixed[0]) bc.value[0].push_back(0.1 * m.X(i, 1));
  bc.value[1].assign(bc.fixed[1].size(), -0.2);
  EXPECT_EQ(bc.max_abs_value(), 0.2);
  GlobalStep step(K, bc);
  EXPECT_EQ(step.num_factors(), 2);
  EXPECT_GT(step.min_rcond(), 1e-6);
  Eigen::MatrixXd b = Eigen::MatrixXd::Random(m.num_nodes(), 2), u;
  step.solve(b, u);
  const Eigen::MatrixXd r = K * u - b;
  for (int comp = 0; comp < 2; ++comp) {
    std::vector<char> fixed(m.num_nodes(), 0);
    for (int i : bc.fixed[comp]) fixed[i] = 1;
    for (int i = 0; i < m.num_nodes(); ++i) {
      if (fixed[i]) {
        EXPECT_EQ(u(i, comp), comp == 0 ? 0.1 * m.X(i, 1) : -0.2) << "node " << i;
        EXPECT_EQ(bc.value_at(i, comp), u(i, comp)) << "node " << i;
      } else {
        EXPECT_LT(std::abs(r(i, comp)), 1e-10) << "node " << i;
        EXPECT_EQ(bc.value_at(i, comp), 0.0) << "node " << i;
      }
    }
  }
  // Same set for both components: one factor, solved as one two-column right-hand side.
  bc.fixed = {m.boundary_nodes("left"), m.boundary_nodes("left")};
  bc.value.assign(2, std::vector<double>(bc.fixed[0].size(), 0.0));
  EXPECT_EQ(GlobalStep(K, bc).num_factors(), 1);
  // value_at's binary search needs sorted lists with one value each: anything else is an Error.
  std::swap(bc.fixed[1][0], bc.fixed[1][1]);
  EXPECT_THROW(GlobalStep(K, bc), Error);
  std::swap(bc.fixed[1][0], bc.fixed[1][1]);
  bc.value[1].pop_back();
  EXPECT_THROW(GlobalStep(K, bc), Error);
}

TEST(GlobalStep, SingularMatrixIsAClearError) {
  const Mesh m = load_mesh(test_path("geometry/square.geo"));
  const SpMat K = global_matrix(cell_operators(m), nullptr, 1.0, 2.0, 0);
  DirichletData bc{{{}, {}}, {{}, {}}};  // nothing fixed
  try {
    GlobalStep step(K, bc);
    FAIL() << "no error; condition estimate " << step.min_rcond();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rigid motion"), std::string::npos) << e.what();
  }
}
