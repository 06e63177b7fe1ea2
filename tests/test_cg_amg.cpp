// The iterative global step [LTL87 (4.1), (4.5)]: CG preconditioned by PETSc's GAMG
// (lib/cg_amg.hpp) against the Cholesky factor (lib/global_step.hpp). The CgAmg tests need PETSc:
// in a build without it they report themselves SKIPPED (by name, in ctest's summary), unless
// LTL_REQUIRE_PETSC is set (`make test-petsc`), where a missing PETSc fails them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <string>

#include "cg_amg.hpp"
#include "config.hpp"
#include "error.hpp"
#include "global_step.hpp"
#include "simulation.hpp"
#include "testing.hpp"

namespace {

using namespace ltl;

/// The global matrix of the unit box (n^3 distorted H8) with z0 clamped, and the box's nodes.
struct BoxSystem {
  Mesh mesh;
  SpMat K;
  DirichletData bc;
};

BoxSystem box_system(int n) {
  BoxSystem s{ltl::testing::distorted_box(n), {}, {}};
  const CellOperators cells = cell_operators(s.mesh);
  s.K = global_matrix(cells, nullptr, 1.0, 3.0, 0.0);
  const std::vector<int> z0 = s.mesh.boundary_nodes("z0");
  s.bc.fixed.assign(3, z0);
  s.bc.fixed[0] = s.mesh.boundary_nodes("x0");  // a second Dirichlet set: two groups
  s.bc.value.assign(3, {});
  for (int c = 0; c < 3; ++c) s.bc.value[c].assign(s.bc.fixed[c].size(), 0.0);
  for (std::size_t k = 0; k < z0.size(); ++k) s.bc.value[2][k] = 0.01 * s.mesh.X(z0[k], 0);
  return s;
}

TEST(CgAmg, Eq4_5_SolvesTheGlobalMatrixLikeTheFactor) {
  LTL_NEEDS_PETSC();
  BoxSystem s = box_system(8);
  GlobalStep chol(s.K, s.bc, GlobalSolver::Cholesky);
  GlobalStep cg(s.K, s.bc, GlobalSolver::CgAmg, &s.mesh.X);
  EXPECT_EQ(cg.solver(), GlobalSolver::CgAmg);
  EXPECT_EQ(cg.num_factors(), 2);
  EXPECT_GT(cg.amg_nonzeros(), s.K.nonZeros());  // the finest operator and the coarser ones
  const Eigen::MatrixXd b = Eigen::MatrixXd::Random(s.mesh.num_nodes(), 3);
  Eigen::MatrixXd u_chol, u_cg = Eigen::MatrixXd::Zero(s.mesh.num_nodes(), 3);
  chol.solve(b, u_chol);
  // From zero, repeated solves reach the floor: each reduces the warm start's residual 1000x.
  for (int k = 0; k < 6; ++k) cg.solve(b, u_cg);
  EXPECT_LE((u_cg - u_chol).norm(), 1e-9 * u_chol.norm());
  const double per_solve = static_cast<double>(cg.cg_iterations()) / cg.cg_solves();
  EXPECT_LT(per_solve, 30) << "CG iterations per solve: the AMG preconditions poorly";
  // Warm-started at the solution: no iteration.
  const long before = cg.cg_iterations();
  cg.solve(b, u_cg);
  EXPECT_EQ(cg.cg_iterations(), before);
}

TEST(CgAmg, AutoKeepsCholeskyBelowItsThresholds) {
  BoxSystem s = box_system(3);
  EXPECT_EQ(GlobalStep(s.K, s.bc, GlobalSolver::Auto, &s.mesh.X).solver(), GlobalSolver::Cholesky);
  // The prediction (2 Dirichlet sets x CHOLMOD's AMD count on the larger) against the factors
  // the constructor computes (best of AMD, METIS and nested dissection per set).
  const double lnz = GlobalStep::predicted_factor_nonzeros(s.K, s.bc);
  const GlobalStep chol(s.K, s.bc, GlobalSolver::Cholesky);
  EXPECT_GE(lnz, 0.9 * chol.factor_nonzeros());
  EXPECT_LE(lnz, 1.5 * chol.factor_nonzeros());
  const double n = s.K.rows();
  EXPECT_LE(lnz, n * (n + 1.0));
}

/// [(4.5), (2.2)] The serial automatic choice with its thresholds lowered (GlobalStep::AutoLimits):
/// the box's two Dirichlet sets, and with a Newton phase (newton_dim = 3) the tangent's factor
/// counted as 9 more sets' (predicted_factor_nonzeros). A byte limit between the two predictions
/// keeps the factors for plain ALG2 and takes CG + AMG with the Newton phase; a rows' limit at
/// the matrix's size keeps the factors whatever the bytes. Without PETSc (`make test`) Auto
/// always factorizes. Fails if the rule leaves the Newton phase's factor out, or compares either
/// limit the wrong way.
TEST(CgAmg, Eq4_5_AutoCountsTheNewtonPhasesFactor) {
  BoxSystem s = box_system(3);
  const int n = static_cast<int>(s.K.rows());
  const double alone = GlobalStep::predicted_factor_nonzeros(s.K, s.bc);
  const double with = GlobalStep::predicted_factor_nonzeros(s.K, s.bc, 3);
  ASSERT_GT(alone, 0);
  EXPECT_DOUBLE_EQ(with, alone * (2 + 9) / 2);  // 2 sets, plus 3^2 sets' worth
  const GlobalSolver cg = CgAmg::available() ? GlobalSolver::CgAmg : GlobalSolver::Cholesky;
  auto choice = [&](int newton_dim, int min_rows, double bytes) {
    GlobalStep::AutoLimits limits;
    limits.min_rows = min_rows;
    limits.factor_bytes = bytes;
    return GlobalStep(s.K, s.bc, GlobalSolver::Auto, &s.mesh.X, newton_dim, &limits).solver();
  };
  const double between = 8.0 * 0.5 * (alone + with);
  EXPECT_EQ(choice(0, n - 1, between), GlobalSolver::Cholesky) << "ALG2 alone: its factors fit";
  EXPECT_EQ(choice(3, n - 1, between), cg) << "with the Newton phase's factor they do not";
  EXPECT_EQ(choice(0, n - 1, 0.5 * 8.0 * alone), cg);
  EXPECT_EQ(choice(3, n, 0.0), GlobalSolver::Cholesky) << "not above the rows' limit";
}

TEST(CgAmg, WithoutPetscTheKeyIsAClearError) {
  if (CgAmg::available()) GTEST_SKIP() << "built with PETSc";
  BoxSystem s = box_system(2);
  try {
    GlobalStep step(s.K, s.bc, GlobalSolver::CgAmg, &s.mesh.X);
    FAIL() << "no error";
  } catch (const ltl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("needs PETSc"), std::string::npos) << e.what();
  }
}

/// One run of `config` with the given global solver; the final displacement.
Eigen::MatrixXd converged_u(const std::string& config, std::vector<std::string> overrides,
                            const std::string& solver, int* cg_iterations = nullptr) {
  overrides.push_back("algorithm.global_solver=\"" + solver + "\"");
  const Problem p = load_problem(ltl::testing::source_path(config), overrides);
  Solver solver_(p);
  RunOptions options;
  options.verbosity = 0;
  const RunSummary summary = run(solver_, options);
  EXPECT_EQ(summary.last_step, p.time.steps) << config << " with " << solver;
  EXPECT_EQ(solver_.global_step().solver(),
            solver == "cg-amg" ? GlobalSolver::CgAmg : GlobalSolver::Cholesky);
  if (cg_iterations) *cg_iterations = static_cast<int>(solver_.global_step().cg_iterations());
  return summary.state.u;
}

void expect_same_converged_state(const std::string& config,
                                 const std::vector<std::string>& overrides) {
  const Eigen::MatrixXd u_chol = converged_u(config, overrides, "cholesky");
  int its = 0;
  const Eigen::MatrixXd u_cg = converged_u(config, overrides, "cg-amg", &its);
  EXPECT_GT(its, 0);
  const double rel = (u_cg - u_chol).norm() / u_chol.norm();
  std::cout << config << ": |u_cg - u_chol| / |u_chol| = " << rel << ", " << its
            << " CG iterations in all\n";
  EXPECT_LE(rel, 1e-8) << config << ": CG + AMG against Cholesky, relative difference in u";
}

TEST(CgAmg, Eq4_5_SameConvergedStateAsCholeskyFig5) {
  LTL_NEEDS_PETSC();
  expect_same_converged_state("experiments/fig5/fig5.toml", {"algorithm.tol=1e-12"});
}

TEST(CgAmg, Eq4_5_SameConvergedStateAsCholeskyCoarseGutter) {
  LTL_NEEDS_PETSC();
  expect_same_converged_state("experiments/fig6/fig6.toml",
                              {"mesh.parameters.nl=5", "mesh.parameters.na=5",
                               "algorithm.acceleration=anderson", "algorithm.tol=1e-12"});
}

TEST(CgAmg, Eq4_5_SameConvergedStateAsCholeskyGluedFig3Step) {
  LTL_NEEDS_PETSC();
  expect_same_converged_state("experiments/fig3/fig3.toml",
                              {"time.steps=1", "algorithm.tol=1e-12"});
}

}  // namespace
