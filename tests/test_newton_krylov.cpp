// Newton's linear systems by GMRES with the augmented-Lagrangian block preconditioner and an AMG
// V-cycle (lib/newton_krylov.hpp), the path of a run whose global step is CG + AMG, against the
// factorizations of the Newton phase [LTL87 (2.2), (2.7), (1.1)]. They need PETSc: in a build
// without it they report themselves SKIPPED, unless LTL_REQUIRE_PETSC is set (`make test-petsc`,
// `make test-mpi`), where a missing PETSc fails them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <random>
#include <string>

#include "config.hpp"
#include "error.hpp"
#include "mpi_newton.hpp"  // NewtonSolveStats
#include "newton_krylov.hpp"
#include "simulation.hpp"
#include "testing.hpp"

namespace {

using namespace ltl;

// [(2.7)] The KKT system [A, G^T; G, 0] (du, dq) = (f, g) of a distorted box (2 x 2 x 2 H8, the
// face z0 prescribed) with a random SPD cell matrix per cell, a random fluctuation row and three
// random constraint rows: GMRES to 1e-12 equals the dense solution of the same system, assembled
// here independently, to 1e-8.
TEST(NewtonKrylov, Eq2_7_KktSolveEqualsTheDenseSolution) {
  LTL_NEEDS_PETSC();
  const Mesh mesh = ltl::testing::distorted_box(2);
  const int nn = mesh.num_nodes(), nc = mesh.num_cells(), npc = 8, n = 3 * nn, dn = 3 * npc;
  std::vector<char> fixed(n, 0);
  for (int a : mesh.boundary_nodes("z0"))
    for (int i = 0; i < 3; ++i) fixed[3 * a + i] = 1;
  NewtonKrylov kr(3, mesh.X, mesh.cells, fixed);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  kr.zero();
  for (int e = 0; e < nc; ++e) {
    Eigen::MatrixXd R(dn, dn);
    for (int i = 0; i < R.size(); ++i) R.data()[i] = U(rng);
    const Eigen::MatrixXd Ke = R * R.transpose() / dn + Eigen::MatrixXd::Identity(dn, dn);
    std::vector<int> dofs(dn);
    for (int r = 0; r < dn; ++r) {
      const int k = 3 * mesh.cells(e, r / 3) + r % 3;
      dofs[r] = fixed[k] ? -1 : k;
    }
    kr.add(dn, dofs.data(), Ke.data());
    for (int r = 0; r < dn; ++r)
      for (int c = 0; c < dn; ++c)
        if (dofs[r] >= 0 && dofs[c] >= 0) dense(dofs[r], dofs[c]) += Ke(r, c);
  }
  int row = 0;  // a free dof, and a symmetric pair of entries in its row and column
  while (fixed[row]) ++row;
  const int col = 3 * mesh.cells(0, 7) + 1;
  ASSERT_FALSE(fixed[col]);
  const double v = 0.3;
  kr.add_row(row, 1, &col, &v);
  kr.add_row(col, 1, &row, &v);
  dense(row, col) += v, dense(col, row) += v;
  kr.finish(2.0);
  for (int k = 0; k < n; ++k)
    if (fixed[k]) dense(k, k) = 2.0;
  const int m = 3;
  std::vector<Eigen::Triplet<double>> tg;
  Eigen::MatrixXd Gd = Eigen::MatrixXd::Zero(m, n);
  for (int r = 0; r < m; ++r)
    for (int k = 0; k < n; ++k)
      if (!fixed[k] && (k + r) % 5 == 0) {
        const double g = U(rng);
        tg.emplace_back(r, k, g);
        Gd(r, k) = g;
      }
  SpMatR G(m, n);
  G.setFromTriplets(tg.begin(), tg.end());
  Eigen::VectorXd f(n), g(m), sinv = Eigen::VectorXd::Constant(m, -1.0);
  for (int k = 0; k < n; ++k) f(k) = fixed[k] ? 0.0 : U(rng);
  for (int r = 0; r < m; ++r) g(r) = U(rng);
  Eigen::VectorXd du, dq;
  const NewtonKrylov::Result res = kr.solve(G, sinv, f, g, 1e-12, du, dq);
  EXPECT_TRUE(res.converged) << res.reason;
  EXPECT_LE(res.residual, 1e-12);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(n + m, n + m);
  M.topLeftCorner(n, n) = dense;
  M.topRightCorner(n, m) = Gd.transpose();
  M.bottomLeftCorner(m, n) = Gd;
  Eigen::VectorXd rhs(n + m), x(n + m);
  rhs << f, g;
  x << du, dq;
  const Eigen::VectorXd exact = M.fullPivLu().solve(rhs);
  EXPECT_LE((x - exact).norm() / exact.norm(), 1e-8);
  EXPECT_GT(kr.matrix_nonzeros(), 0);
}

/// One Newton run of `config` with the given global solver; the final displacement, and the
/// Newton phase's linear solves during it.
Eigen::MatrixXd newton_u(const std::string& config, std::vector<std::string> overrides,
                         const std::string& solver, NewtonSolveStats* used) {
  overrides.push_back("algorithm.global_solver=\"" + solver + "\"");
  overrides.push_back("algorithm.solver=\"newton\"");
  const Problem p = load_problem(ltl::testing::source_path(config), overrides);
  const NewtonSolveStats before = newton_solve_stats();
  Solver solver_(p);
  RunOptions options;
  options.verbosity = 0;
  const RunSummary summary = run(solver_, options);
  EXPECT_EQ(summary.last_step, p.time.steps) << config << " with " << solver;
  const NewtonSolveStats& after = newton_solve_stats();
  used->krylov_solves = after.krylov_solves - before.krylov_solves;
  used->krylov_iterations = after.krylov_iterations - before.krylov_iterations;
  used->krylov_failures = after.krylov_failures - before.krylov_failures;
  used->cholmod_factorizations = after.cholmod_factorizations - before.cholmod_factorizations;
  used->umfpack_factorizations = after.umfpack_factorizations - before.umfpack_factorizations;
  return summary.state.u;
}

/// [(2.2), (2.7), (1.1)] The Newton phase with Krylov solves converges to the state of the
/// factorized solves, and the tangent was not factorized.
void expect_same_newton_state(const std::string& config, const std::vector<std::string>& overrides,
                              bool glued = false) {
  NewtonSolveStats direct, krylov;
  const Eigen::MatrixXd u_direct = newton_u(config, overrides, "cholesky", &direct);
  const Eigen::MatrixXd u_krylov = newton_u(config, overrides, "cg-amg", &krylov);
  const double rel = (u_krylov - u_direct).norm() / u_direct.norm();
  std::cout << config << ": |u_krylov - u_direct| / |u_direct| = " << rel << ", "
            << krylov.krylov_solves << " Krylov solves, " << krylov.krylov_iterations
            << " GMRES iterations; " << direct.cholmod_factorizations << " factorizations\n";
  EXPECT_LE(rel, 1e-8) << config << ": Newton with Krylov solves against the factorizations";
  EXPECT_EQ(direct.krylov_solves, 0);
  if (glued) {  // the glued system is solved by LU on either path (newton.hpp)
    EXPECT_EQ(krylov.krylov_solves, 0);
    EXPECT_GT(krylov.umfpack_factorizations, 0);
  } else {
    // Every Krylov solve converged and gave a step as good as the factor's: one solve per
    // factorization of the direct run (a step rejected or damped would add one).
    EXPECT_GT(krylov.krylov_solves, 0);
    EXPECT_EQ(krylov.krylov_failures, 0);
    EXPECT_EQ(krylov.krylov_solves, direct.cholmod_factorizations);
    EXPECT_EQ(krylov.cholmod_factorizations, 0) << "the tangent was factorized";
    EXPECT_EQ(krylov.umfpack_factorizations, 0) << "the KKT system was factorized";
  }
}

TEST(NewtonKrylov, Eq2_2_SameConvergedStateAsTheFactorFig5) {
  LTL_NEEDS_PETSC();
  expect_same_newton_state("experiments/fig5/fig5.toml", {"algorithm.force_tol=1e-10"});
}

TEST(NewtonKrylov, Eq2_2_SameConvergedStateAsTheFactorCoarseGutter) {
  LTL_NEEDS_PETSC();
  expect_same_newton_state("experiments/fig6/fig6.toml",
                           {"mesh.parameters.nl=5", "mesh.parameters.na=5",
                            "algorithm.stopping=\"equilibrium\"", "algorithm.force_tol=1e-10"});
}

TEST(NewtonKrylov, Eq2_2_GluedFig3StepKeepsTheLU) {
  LTL_NEEDS_PETSC();
  expect_same_newton_state("experiments/fig3/fig3.toml",
                           {"time.steps=1", "algorithm.force_tol=1e-10"}, true);
}

}  // namespace
