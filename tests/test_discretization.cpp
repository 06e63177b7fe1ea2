// The discretization of incompressibility (paper_notes/discretization.md): the default
// "mean-det" constraint, (1/|O_e|) integral det F = 1 per cell, against the paper's "det-mean",
// det(Gbar_e u + I) = 1, on Fig 5's problem. Invariants first (a finite-difference derivative,
// the deformed area), then the behaviour that made us change: det-mean loses area on every mesh.
#include <gtest/gtest.h>

#include <random>

#include "alg2.hpp"
#include "config.hpp"
#include "fe.hpp"
#include "measures.hpp"
#include "testing.hpp"

namespace {

using ltl::testing::source_path;

ltl::Problem fig5(int K, std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {"mesh.parameters.n=" + std::to_string(K),
                                "mesh.parameters.nd=" + std::to_string(K), "algorithm.R=20"};
  o.insert(o.end(), extra.begin(), extra.end());
  return ltl::load_problem(source_path("experiments/fig5/fig5.toml"), o);
}

// Deformed area sum_e integral_e det(I + grad u), by the quadrature visitor of fe.hpp (not by the
// solver's own point-gradient operator).
double deformed_area(const ltl::Mesh& mesh, const Eigen::MatrixXd& u) {
  double area = 0;
  for (int c = 0; c < mesh.num_cells(); ++c)
    ltl::for_each_quadrature_point(mesh, c, [&](const Eigen::MatrixXd& grad, double w) {
      Eigen::Matrix2d F = Eigen::Matrix2d::Identity();
      for (int a = 0; a < grad.rows(); ++a)
        F += u.row(mesh.cells(c, a)).transpose() * grad.row(a);  // F_ij += u_i dphi/dx_j
      area += w * F.determinant();
    });
  return area;
}

// (2.7) mean-det: the force of the constraint's pressure on the intra-cell fluctuations is the
// derivative of sum_e p_e |O_e| c_e(u), checked by central differences at a random u, with
// E = I and lambda = p I per cell (so that p_e = lambda : E / (2 det E) = p).
TEST(MeanDet, FluctuationForceIsTheDerivativeOfTheFluctuationDeterminant_2_7) {
  const ltl::Problem problem = fig5(7);
  const ltl::Solver solver(problem);
  ASSERT_TRUE(solver.mean_det());
  ltl::State s = solver.initial_state();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-0.05, 0.05);
  const int nn = problem.mesh.num_nodes();
  Eigen::MatrixXd u(nn, 2), v(nn, 2);
  for (int i = 0; i < nn; ++i)
    for (int k = 0; k < 2; ++k) u(i, k) = U(rng), v(i, k) = U(rng);
  const double p = 1.3e6;
  s.u = u;
  s.lambda = p * s.E;  // E = I blocks
  const Eigen::MatrixXd force = solver.fluctuation_force(s);
  const double h = 1e-6;
  const Eigen::VectorXd& vol = solver.cells().vol;
  const double fd =
      p *
      (vol.dot(solver.fluctuation_det(u + h * v)) - vol.dot(solver.fluctuation_det(u - h * v))) /
      (2 * h);
  const double exact = (force.array() * v.array()).sum();
  EXPECT_NEAR(fd, exact, 1e-6 * std::abs(exact));
  EXPECT_GT(std::abs(exact), 1.0);  // not a vacuous 0 = 0
}

// An affine displacement has no fluctuation: c_e = 0 and no force (the patch test of mean-det).
TEST(MeanDet, AffineDisplacementHasNoFluctuation_2_7) {
  const ltl::Problem problem = fig5(7);
  const ltl::Solver solver(problem);
  ltl::State s = solver.initial_state();
  Eigen::Matrix2d A;
  A << 0.1, -0.3, 0.2, 0.05;
  s.u = problem.mesh.X * A.transpose();
  s.lambda *= 7.0;
  EXPECT_LT(solver.fluctuation_det(s.u).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(solver.fluctuation_force(s).cwiseAbs().maxCoeff(), 1e-6);
}

// (2.7), (4.1)-(4.4): at the converged Fig 5 state the deformed area equals the reference area
// (the body is incompressible) with mean-det, to the stopping tolerance; with det-mean it is
// short by more than 3e-4 m^2 on the same mesh (the defect that does not vanish under
// refinement: 7e-4, 4.4e-4, 1.2e-3 m^2 at K = 7, 14, 28).
TEST(MeanDet, ConvergedFig5KeepsItsAreaWhereDetMeanLosesIt_2_7) {
  for (const bool mean_det : {true, false}) {
    const ltl::Problem problem = fig5(7, {std::string("discretization.incompressibility=") +
                                          (mean_det ? "mean-det" : "det-mean")});
    ltl::Solver solver(problem);
    ltl::State s = solver.initial_state();
    const ltl::StepReport report = solver.solve_step(s, s.beta);
    ASSERT_TRUE(report.converged) << report.status;
    const double change = deformed_area(problem.mesh, s.u) - solver.cells().vol.sum();
    if (mean_det) {
      EXPECT_LT(std::abs(change), 1e-8);
      EXPECT_LT(report.det_error, 1e-8);  // det E_e + c_e = 1 per cell
      EXPECT_LT(report.force_residual, 1e-4);
    } else {
      EXPECT_LT(change, -3e-4);
    }
  }
}

}  // namespace
