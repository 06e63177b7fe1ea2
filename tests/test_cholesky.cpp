// Tests of the sparse Cholesky wrapper (lib/cholesky.cpp) behind the global steps (4.5) and (7.7):
// the supernodal sweeps solve A x = b to round-off for 1 to 3 columns, with CHOLMOD's ordering or
// a given one; a singular or indefinite matrix is a clear error naming the matrix and the hint.
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "cholesky.hpp"
#include "error.hpp"

namespace {

/// The 5-point Laplacian on an m x m grid plus shift I (SPD for shift > 0, singular for 0 with
/// pure Neumann rows), with the full symmetric pattern stored.
ltl::SpMat grid_laplacian(int m, double shift) {
  std::vector<Eigen::Triplet<double>> t;
  auto id = [m](int i, int j) { return i * m + j; };
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      double diag = shift;
      for (auto [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int a = i + di, b = j + dj;
        if (a < 0 || a >= m || b < 0 || b >= m) continue;
        t.emplace_back(id(i, j), id(a, b), -1.0);
        diag += 1.0;
      }
      t.emplace_back(id(i, j), id(i, j), diag);
    }
  ltl::SpMat A(m * m, m * m);
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

/// Solves A X = B through the block (gather in the factor's order, sweep, scatter).
Eigen::MatrixXd solve(ltl::Cholesky& c, const Eigen::MatrixXd& B) {
  const int n = c.rows(), nc = c.columns();
  double* y = c.block();
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < nc; ++j) y[nc * k + j] = B(c.perm()[k], j);
  c.solve_in_place();
  Eigen::MatrixXd X(n, nc);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < nc; ++j) X(c.perm()[k], j) = y[nc * k + j];
  return X;
}

TEST(Cholesky, Eq4_5_SolvesToRoundOffForOneToThreeColumns) {
  const ltl::SpMat A = grid_laplacian(40, 1e-2);
  std::mt19937_64 g(3);
  std::normal_distribution<double> N;
  for (int nc = 1; nc <= 3; ++nc) {
    ltl::Cholesky c(A, nc, "test matrix", "no hint");
    EXPECT_EQ(c.rows(), 1600);
    EXPECT_GT(c.nonzeros(), A.nonZeros() / 2);  // nnz(L) >= nnz(lower triangle of A)
    EXPECT_GT(c.rcond(), ltl::Cholesky::kMinRcond);
    Eigen::MatrixXd B(1600, nc);
    for (int k = 0; k < B.size(); ++k) B(k) = N(g);
    for (int rep = 0; rep < 2; ++rep) {  // the workspaces are reused
      const Eigen::MatrixXd X = solve(c, B);
      EXPECT_LT((A * X - B).norm(), 1e-12 * B.norm()) << nc << " columns";
    }
  }
}

TEST(Cholesky, Eq4_5_GivenOrderIsUsedAndGivesTheSameSolution) {
  const ltl::SpMat A = grid_laplacian(20, 0.5);
  std::vector<int> order(400);
  for (int k = 0; k < 400; ++k) order[k] = 399 - k;  // reversed natural order
  ltl::Cholesky given(A, 2, "test matrix", "no hint", order);
  EXPECT_EQ(given.perm(), order);
  ltl::Cholesky best(A, 2, "test matrix", "no hint");
  EXPECT_LE(best.nonzeros(), given.nonzeros());  // the best of AMD, METIS, ND fills no more
  const Eigen::MatrixXd B = Eigen::MatrixXd::Random(400, 2);
  EXPECT_LT((solve(given, B) - solve(best, B)).norm(), 1e-12 * solve(best, B).norm());
}

TEST(Cholesky, SingularOrIndefiniteIsAClearError) {
  for (double shift : {0.0, -0.5}) {  // singular (constants in the kernel), indefinite
    try {
      ltl::Cholesky c(grid_laplacian(10, shift), 1, "the test matrix (100 rows)",
                      "Check the test.");
      FAIL() << "no error for shift " << shift;
    } catch (const ltl::Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("the test matrix (100 rows)"), std::string::npos) << what;
      EXPECT_NE(what.find("singular or not positive definite"), std::string::npos) << what;
      EXPECT_NE(what.find("Check the test."), std::string::npos) << what;
    }
  }
  EXPECT_THROW(ltl::Cholesky(grid_laplacian(4, 1.0), 4, "m", "h"), ltl::Error);  // 4 columns
}

}  // namespace
