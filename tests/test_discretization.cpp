// The discretization of incompressibility (paper_notes/discretization.md): the default
// "mean-det" constraint, (1/|O_e|) integral det F = 1 per cell, against the paper's "det-mean",
// det(Gbar_e u + I) = 1, on Fig 5's problem. Invariants first (a finite-difference derivative,
// the deformed area), then the behaviour that made us change: det-mean loses area on every mesh.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"
#include "fe.hpp"
#include "global_step.hpp"
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

// The coarse Fig 6 gutter (C2 = 0, H8): 3 cells around the arc, 4 along the half length.
ltl::Problem gutter(std::vector<std::string> extra = {}) {
  std::vector<std::string> o = {"mesh.parameters.na=3", "mesh.parameters.nl=4"};
  o.insert(o.end(), extra.begin(), extra.end());
  return ltl::load_problem(source_path("experiments/fig6/fig6.toml"), o);
}

// Deformed area (2-D) or volume (3-D) sum_e integral_e det(I + grad u), by the quadrature visitor
// of fe.hpp (not by the solver's own point-gradient operator).
double deformed_area(const ltl::Mesh& mesh, const Eigen::MatrixXd& u) {
  double area = 0;
  const int d = mesh.dim;
  for (int c = 0; c < mesh.num_cells(); ++c)
    ltl::for_each_quadrature_point(mesh, c, [&](const Eigen::MatrixXd& grad, double w) {
      Eigen::MatrixXd F = Eigen::MatrixXd::Identity(d, d);
      for (int a = 0; a < grad.rows(); ++a)
        F += u.row(mesh.cells(c, a)).transpose() * grad.row(a);  // F_ij += u_i dphi/dx_j
      area += w * F.determinant();
    });
  return area;
}

// sum_k force . v against the central difference of p sum_e |O_e| c_e(u) along v, at a random u
// with E = I and lambda = p I per cell (so that p_e = lambda : E / (d det E) = p).
void expect_force_is_derivative(const ltl::Problem& problem, double amplitude) {
  const ltl::Solver solver(problem);
  ASSERT_TRUE(solver.discretization().mean_det());
  ltl::State s = solver.initial_state();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-amplitude, amplitude);
  const int nn = problem.mesh.num_nodes(), d = problem.mesh.dim;
  Eigen::MatrixXd u(nn, d), v(nn, d);
  for (int i = 0; i < nn; ++i)
    for (int k = 0; k < d; ++k) u(i, k) = U(rng), v(i, k) = U(rng);
  const double p = 1.3e6;
  s.u = u;
  s.lambda = p * s.E;  // E = I blocks
  const Eigen::MatrixXd force = solver.discretization().fluctuation_force(s);
  const double h = 1e-6;
  const Eigen::VectorXd& vol = solver.discretization().cells().vol;
  const double fd = p *
                    (vol.dot(solver.discretization().fluctuation_det(u + h * v)) -
                     vol.dot(solver.discretization().fluctuation_det(u - h * v))) /
                    (2 * h);
  const double exact = (force.array() * v.array()).sum();
  EXPECT_NEAR(fd, exact, 1e-6 * std::abs(exact));
  EXPECT_GT(std::abs(exact), 1.0);  // not a vacuous 0 = 0
}

// An affine u has no fluctuation: c_e = 0 and no force (the patch test of mean-det).
void expect_affine_has_no_fluctuation(const ltl::Problem& problem, const Eigen::MatrixXd& A) {
  const ltl::Solver solver(problem);
  ASSERT_TRUE(solver.discretization().mean_det());
  ltl::State s = solver.initial_state();
  s.u = problem.mesh.X * A.transpose();
  s.lambda *= 7.0;
  EXPECT_LT(solver.discretization().fluctuation_det(s.u).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(solver.discretization().fluctuation_force(s).cwiseAbs().maxCoeff(), 1e-6);
}

// (2.7) mean-det: the force of the constraint's pressure on the intra-cell fluctuations is the
// derivative of sum_e p_e |O_e| c_e(u), checked by central differences; in 2-D (P2 triangles,
// c_e the mean of det(delta)) and in 3-D (H8, c_e = mean det F - det Fbar, cubic in delta).
TEST(MeanDet, Eq2_7_FluctuationForceIsTheDerivativeOfTheFluctuationDeterminant) {
  expect_force_is_derivative(fig5(7), 0.05);
}
TEST(MeanDet, Eq2_7_FluctuationForceIsTheDerivativeOfTheFluctuationDeterminant3D) {
  expect_force_is_derivative(gutter(), 0.05);
}

TEST(MeanDet, Eq2_7_AffineDisplacementHasNoFluctuation) {
  Eigen::Matrix2d A;
  A << 0.1, -0.3, 0.2, 0.05;
  expect_affine_has_no_fluctuation(fig5(7), A);
}
TEST(MeanDet, Eq2_7_AffineDisplacementHasNoFluctuation3D) {
  Eigen::Matrix3d A;
  A << 0.1, -0.3, 0.2, 0.05, 0.02, -0.1, 0.3, 0.15, -0.2;
  expect_affine_has_no_fluctuation(gutter(), A);
}

// (2.7), (3.3) The operators of some cells (a rank's, paper_notes/mpi.md) read u, and put the
// mean-det force, on the rows of their columns (row_of: a rank's iterate and right-hand side on
// its ghost layer's rows): mean_gradients' Gbar u, the fluctuation c_e and the force with its
// gamma term equal those of the whole discretization reading u by node, on every other cell.
// The rows are spread (column j at row 2 j + 1) and the rows between hold NaN, so that a
// reader taking a node or a column for its row fails.
void expect_rows_of_columns_read_like_nodes(const ltl::Problem& problem) {
  const int nn = problem.mesh.num_nodes(), d = problem.mesh.dim;
  std::vector<int> held;
  for (int c = 0; c < problem.mesh.num_cells(); c += 2) held.push_back(c);
  const ltl::Discretization whole(problem), part(problem, &held);
  ASSERT_TRUE(part.mean_det());
  const std::vector<int>& node = part.cells().node;
  ASSERT_FALSE(node.empty());
  const int nh = static_cast<int>(held.size()), ncol = static_cast<int>(node.size());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-0.05, 0.05);
  Eigen::MatrixXd u(nn, d), E(d * nh, d), lambda(d * nh, d);
  for (int i = 0; i < nn; ++i)
    for (int k = 0; k < d; ++k) u(i, k) = U(rng);
  for (int r = 0; r < d * nh; ++r)
    for (int k = 0; k < d; ++k)
      E(r, k) = (r % d == k ? 1.0 : 0.0) + U(rng), lambda(r, k) = 1e6 * U(rng);
  std::vector<int> row_of(ncol);
  Eigen::MatrixXd u_rows = Eigen::MatrixXd::Constant(2 * ncol + 1, d, std::nan(""));
  for (int j = 0; j < ncol; ++j) {
    row_of[j] = 2 * j + 1;
    u_rows.row(row_of[j]) = u.row(node[j]);
  }
  Eigen::VectorXd c_whole(nh), c_rows(nh);
  Eigen::MatrixXd f_whole = Eigen::MatrixXd::Zero(nn, d),
                  f_rows = Eigen::MatrixXd::Zero(2 * ncol + 1, d);
  whole.fluctuation(u, &lambda, &E, &c_whole, &f_whole, 0.7, &held);
  part.fluctuation(u_rows, &lambda, &E, &c_rows, &f_rows, 0.7, &held, row_of.data());
  EXPECT_EQ((c_rows - c_whole).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT(c_whole.cwiseAbs().maxCoeff(), 1e-6);  // not 0 = 0
  for (int j = 0; j < ncol; ++j) {
    EXPECT_EQ((f_rows.row(row_of[j]) - f_whole.row(node[j])).cwiseAbs().maxCoeff(), 0.0) << j;
    EXPECT_EQ(f_rows.row(row_of[j] - 1).cwiseAbs().maxCoeff(), 0.0) << j;
  }
  EXPECT_GT(f_whole.cwiseAbs().maxCoeff(), 1.0);
  // The c of one call without the force reads the same rows.
  Eigen::VectorXd c_alone(nh);
  part.fluctuation(u_rows, nullptr, nullptr, &c_alone, nullptr, 0.0, &held, row_of.data());
  EXPECT_EQ((c_alone - c_whole).cwiseAbs().maxCoeff(), 0.0);
  // [(3.3)] Gbar u on the held cells from u on the columns' rows.
  Eigen::MatrixXd T(d * nh, d);
  ltl::mean_gradients(part.cells(), 0, nh, u_rows, T, row_of.data());
  const Eigen::MatrixXd GU = whole.cells().Gbar * u;
  for (int k = 0; k < nh; ++k)
    EXPECT_LT((T.middleRows(d * k, d) - GU.middleRows(d * held[k], d)).norm(), 1e-14 * GU.norm());
}
TEST(MeanDet, Eq2_7_SomeCellsReadUOnTheRowsOfTheirColumns) {
  expect_rows_of_columns_read_like_nodes(fig5(7));
}
TEST(MeanDet, Eq2_7_SomeCellsReadUOnTheRowsOfTheirColumns3D) {
  // 4 480 H8 cells, 2 240 held: more than one block of the kernel (2 048 cells), so that the
  // rows kept for the scatter are found again in the second block.
  expect_rows_of_columns_read_like_nodes(
      gutter({"mesh.parameters.na=32", "mesh.parameters.nl=70"}));
}

// (2.7) The volumes |O_e| of some cells (a rank's, paper_notes/mpi.md) are held alone, in the
// order of the held cells: the same numbers as the whole discretization's (and cell_volumes'),
// |Omega| still the whole body's, and every reader of them by position: c_e of mean-det per held
// cell, the fluctuation force from E and lambda whole or on the held cells' rows; a list of other
// cells than the held ones is an Error (their volumes are not here).
void expect_some_cells_hold_their_volumes(const ltl::Problem& problem) {
  const int nn = problem.mesh.num_nodes(), d = problem.mesh.dim, nc = problem.mesh.num_cells();
  std::vector<int> held;
  for (int c = 1; c < nc; c += 2) held.push_back(c);
  const ltl::Discretization whole(problem), part(problem, &held);
  ASSERT_TRUE(part.partial() && part.mean_det());
  const int nh = static_cast<int>(held.size());
  const Eigen::VectorXd all = ltl::cell_volumes(problem.mesh);
  ASSERT_EQ(all.size(), nc);
  EXPECT_EQ((all - whole.cells().vol).cwiseAbs().maxCoeff(), 0.0);
  ASSERT_EQ(part.cells().vol.size(), nh);
  for (int at = 0; at < nh; ++at) {
    EXPECT_EQ(part.cells().vol(at), all(held[at])) << at;
    EXPECT_EQ(part.cell_volume(held[at], at), all(held[at])) << at;
    EXPECT_EQ(whole.cell_volume(held[at], at), all(held[at])) << at;
  }
  EXPECT_EQ(part.volume(), whole.volume());
  EXPECT_GT(whole.volume(), 2 * part.cells().vol.sum() * 0.9);  // the whole body, not the part's
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(-0.05, 0.05);
  ltl::State s;
  s.u.resize(nn, d);
  s.E.resize(d * nc, d);
  s.lambda.resize(d * nc, d);
  for (int i = 0; i < nn; ++i)
    for (int k = 0; k < d; ++k) s.u(i, k) = U(rng);
  for (int r = 0; r < d * nc; ++r)
    for (int k = 0; k < d; ++k)
      s.E(r, k) = (r % d == k ? 1.0 : 0.0) + U(rng), s.lambda(r, k) = 1e6 * U(rng);
  // [(2.7)] c_e per held cell, in their order.
  const Eigen::VectorXd c_whole = whole.fluctuation_det(s.u), c_part = part.fluctuation_det(s.u);
  ASSERT_EQ(c_part.size(), nh);
  for (int at = 0; at < nh; ++at) EXPECT_EQ(c_part(at), c_whole(held[at])) << at;
  EXPECT_GT(c_whole.cwiseAbs().maxCoeff(), 1e-6);
  // The held cells' part of the force, from E and lambda whole (read at the held cells' rows) and
  // on those rows: the whole discretization's on the same cells, exactly.
  ltl::State rows = s;
  rows.E.resize(d * nh, d);
  rows.lambda.resize(d * nh, d);
  for (int at = 0; at < nh; ++at) {
    rows.E.middleRows(d * at, d) = s.E.middleRows(d * held[at], d);
    rows.lambda.middleRows(d * at, d) = s.lambda.middleRows(d * held[at], d);
  }
  Eigen::MatrixXd f_held = Eigen::MatrixXd::Zero(nn, d);
  whole.fluctuation(s.u, &rows.lambda, &rows.E, nullptr, &f_held, 0.0, &held);
  ASSERT_GT(f_held.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_EQ((part.fluctuation_force(s) - f_held).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((part.fluctuation_force(rows) - f_held).cwiseAbs().maxCoeff(), 0.0);
  // Other cells than the held ones: their volumes are not held.
  std::vector<int> fewer(held.begin(), held.end() - 1);
  Eigen::VectorXd c_fewer(nh - 1);
  EXPECT_THROW(part.fluctuation(s.u, nullptr, nullptr, &c_fewer, nullptr, 0.0, &fewer), ltl::Error);
}
TEST(Discretization, Eq2_7_SomeCellsHoldTheirVolumesAlone) {
  expect_some_cells_hold_their_volumes(fig5(7));
}
TEST(Discretization, Eq2_7_SomeCellsHoldTheirVolumesAlone3D) {
  expect_some_cells_hold_their_volumes(gutter());
}

// (4.5), (4.1) On some cells (a rank's) the contact points keep the entries of M^T |G| by point
// (an index of #points + 1, not of every node), and meanT_area_of makes the same matrix again,
// its entries in the same order, so that the global step's contact term R q_c M^T |G| M, the
// right-hand side's M^T |G| (R q_c e + lambda_c) and the reactions are the whole
// discretization's to the bit.
void expect_contact_transpose_by_point(const ltl::Problem& problem) {
  const int d = problem.mesh.dim;
  std::vector<int> held;
  for (int c = 0; c < problem.mesh.num_cells(); c += 2) held.push_back(c);
  const ltl::Discretization whole(problem), part(problem, &held);
  ASSERT_TRUE(whole.points() && part.points());
  const ltl::ContactPoints &w = *whole.points(), &p = *part.points();
  const int np = p.size();
  ASSERT_GT(np, 0);
  EXPECT_EQ(p.meanT_area.outerSize(), 0);  // no index of every node
  EXPECT_EQ(p.meanT_area_by_point.outerSize(), np);
  EXPECT_EQ(w.meanT_area_by_point.nonZeros(), 0);
  ltl::SpMatR work;
  EXPECT_EQ(&w.meanT_area_of(work), &w.meanT_area);
  const ltl::SpMatR& made = p.meanT_area_of(work);
  ASSERT_EQ(&made, &work);
  ASSERT_EQ(made.rows(), w.meanT_area.rows());
  ASSERT_EQ(made.cols(), w.meanT_area.cols());
  ASSERT_EQ(made.nonZeros(), w.meanT_area.nonZeros());
  EXPECT_TRUE(std::equal(made.outerIndexPtr(), made.outerIndexPtr() + made.rows() + 1,
                         w.meanT_area.outerIndexPtr()));
  EXPECT_TRUE(std::equal(made.innerIndexPtr(), made.innerIndexPtr() + made.nonZeros(),
                         w.meanT_area.innerIndexPtr()));
  EXPECT_TRUE(
      std::equal(made.valuePtr(), made.valuePtr() + made.nonZeros(), w.meanT_area.valuePtr()));
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1, 1);
  Eigen::MatrixXd lambda_c(np, d);
  for (int i = 0; i < np; ++i)
    for (int k = 0; k < d; ++k) lambda_c(i, k) = U(rng);
  EXPECT_EQ((made * lambda_c - w.meanT_area * lambda_c).cwiseAbs().maxCoeff(), 0.0);
  // [(4.5)] K's contact term alone (C1 = R q = 0) on the part's operators, from the part's points
  // and from the whole's: the same matrix.
  const ltl::SpMat Kp = ltl::global_matrix(part.cells(), &p, 0.0, 0.0, 2.0);
  const ltl::SpMat Kw = ltl::global_matrix(part.cells(), &w, 0.0, 0.0, 2.0);
  EXPECT_GT(Kw.norm(), 0.0);
  EXPECT_EQ(ltl::SpMat(Kp - Kw).norm(), 0.0);
}
TEST(Discretization, Eq4_5_SomeCellsKeepTheContactTransposeByPoint) {
  expect_contact_transpose_by_point(fig5(7));
}
TEST(Discretization, Eq4_5_SomeCellsKeepTheContactTransposeByPoint3D) {
  expect_contact_transpose_by_point(gutter());
}

// (4.5) On some cells (a rank's) the equilibrium residual's rows are made on the cells' nodes
// (held_cell_forces_on_columns) and summed on the blocks of the nodes (one block, every node, on
// one process): to the bit the rows of equilibrium_residual on those cells, with mean-det's
// fluctuation force, the dead loads read on the loaded nodes (or given whole) and the contact
// term point by point; with the other cells' rows, the whole discretization's residual.
void expect_residual_rows_of_some_cells(const ltl::Problem& problem) {
  const int d = problem.mesh.dim, nn = problem.mesh.num_nodes();
  std::vector<int> held;
  for (int c = 0; c < problem.mesh.num_cells(); c += 2) held.push_back(c);
  const ltl::Discretization whole(problem), part(problem, &held);
  ASSERT_TRUE(part.partial() && part.mean_det() && part.points());
  ASSERT_FALSE(part.loaded_nodes().empty());
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> U(-1, 1);
  const auto random = [&](Eigen::Index rows, int cols, double size) {
    Eigen::MatrixXd A(rows, cols);
    for (Eigen::Index i = 0; i < A.size(); ++i) A.data()[i] = size * U(rng);
    return A;
  };
  ltl::State s;
  s.u = random(nn, d, 1e-3);
  s.E = random(static_cast<Eigen::Index>(d) * problem.mesh.num_cells(), d, 1e-2);
  for (int c = 0; c < problem.mesh.num_cells(); ++c)
    s.E.middleRows(d * c, d) += Eigen::MatrixXd::Identity(d, d);
  s.lambda = random(s.E.rows(), d, 1e3);
  s.lambda_c = random(part.points()->size(), d, 1e3);
  const double scale = 0.7;
  const Eigen::MatrixXd f = part.dead_load();
  const Eigen::MatrixXd r = ltl::equilibrium_residual(part, f, s, scale);
  ASSERT_GT(r.cwiseAbs().maxCoeff(), 0.0);
  for (const Eigen::MatrixXd* loads : {static_cast<const Eigen::MatrixXd*>(nullptr), &f}) {
    const ltl::ResidualRows rows = ltl::equilibrium_residual_rows(part, loads, s, scale);
    EXPECT_EQ(rows.first, 0);
    ASSERT_EQ(rows.r.rows(), nn);
    EXPECT_EQ((rows.r - r).cwiseAbs().maxCoeff(), 0.0);
  }
  // The other cells' rows added: the whole discretization's residual (its cells' sum through
  // GbarT_vol and fluctuation_force, not run by run), once the loads and the contact term,
  // which each part subtracts, are added back once (to rounding).
  std::vector<int> rest;
  for (int c = 1; c < problem.mesh.num_cells(); c += 2) rest.push_back(c);
  const ltl::Discretization other(problem, &rest);
  const Eigen::MatrixXd r_whole = ltl::equilibrium_residual(whole, f, s, scale);
  const Eigen::MatrixXd sum = ltl::equilibrium_residual_rows(part, nullptr, s, scale).r +
                              ltl::equilibrium_residual_rows(other, nullptr, s, scale).r +
                              scale * f + whole.points()->meanT_area * s.lambda_c;
  EXPECT_LE((sum - r_whole).cwiseAbs().maxCoeff(), 1e-12 * r_whole.cwiseAbs().maxCoeff());
}
TEST(Discretization, Eq4_5_SomeCellsMakeTheResidualOnTheirNodes) {
  expect_residual_rows_of_some_cells(fig5(7, {"discretization.incompressibility=mean-det"}));
}
TEST(Discretization, Eq4_5_SomeCellsMakeTheResidualOnTheirNodes3D) {
  expect_residual_rows_of_some_cells(gutter({"discretization.incompressibility=mean-det"}));
}

// (2.7), (4.1)-(4.4): at the converged Fig 5 state the deformed area equals the reference area
// (the body is incompressible) with mean-det, to the stopping tolerance; with det-mean it is
// short by more than 3e-4 m^2 on the same mesh (the defect that does not vanish under
// refinement: 7e-4, 4.4e-4, 1.2e-3 m^2 at K = 7, 14, 28).
TEST(MeanDet, Eq2_7_ConvergedFig5KeepsItsAreaWhereDetMeanLosesIt) {
  for (const bool mean_det : {true, false}) {
    const ltl::Problem problem = fig5(7, {std::string("discretization.incompressibility=") +
                                          (mean_det ? "mean-det" : "det-mean")});
    ltl::Solver solver(problem);
    ltl::State s = solver.initial_state();
    const ltl::StepReport report = solver.solve_step(s, s.beta);
    ASSERT_TRUE(report.converged) << report.status;
    const double change =
        deformed_area(problem.mesh, s.u) - solver.discretization().cells().vol.sum();
    if (mean_det) {
      EXPECT_LT(std::abs(change), 1e-8);
      EXPECT_LT(report.det_error, 1e-8);  // det E_e + c_e = 1 per cell
      EXPECT_LT(report.force_residual, 1e-4);
    } else {
      EXPECT_LT(change, -3e-4);
    }
  }
}

// (2.7) in 3-D: the converged coarse gutter keeps its volume with mean-det (H8, 2x2x2 Gauss), to
// the stopping tolerance; det-mean, the paper's choice, changes it by far more.
TEST(MeanDet, Eq2_7_ConvergedGutterKeepsItsVolumeWhereDetMeanDoesNot) {
  double change_det_mean = 0;
  for (const bool mean_det : {true, false}) {
    const ltl::Problem problem = gutter(
        {std::string("discretization.incompressibility=") + (mean_det ? "mean-det" : "det-mean")});
    ltl::Solver solver(problem);
    ltl::State s = solver.initial_state();
    const ltl::StepReport report = solver.solve_step(s, s.beta);
    ASSERT_TRUE(report.converged) << report.status;
    const double change =
        deformed_area(problem.mesh, s.u) - solver.discretization().cells().vol.sum();
    std::printf("  %s: %d iterations, volume change %.3e m^3, det error %.1e\n",
                mean_det ? "mean-det" : "det-mean", report.iterations, change, report.det_error);
    if (mean_det) {
      EXPECT_TRUE(solver.discretization().mean_det());
      EXPECT_LT(std::abs(change), 1e-6);
      EXPECT_LT(report.det_error, 1e-7);  // det E_e + c_e = 1 per cell
      EXPECT_LT(report.force_residual, 1e-3);
    } else {
      change_det_mean = change;
    }
  }
  EXPECT_GT(std::abs(change_det_mean), 1e-4);
}

}  // namespace

// The discrete problem does not depend on how it is solved: R, q, q_c meet the operators only in
// the solver's precompute (4.5). A solver built from a discretization made beforehand iterates
// exactly as one built from the problem.
TEST(Discretization, Eq4_5_IsIndependentOfTheAugmentationAndFeedsTheSolverUnchanged) {
  const ltl::Problem a = fig5(7, {"algorithm.R=5", "algorithm.max_iter=30"});
  const ltl::Problem b = fig5(7, {"algorithm.q=\"3 MPa\"", "algorithm.q_c=\"7 MPa/m\""});
  const ltl::Discretization da(a), db(b);
  EXPECT_EQ((da.cells().vol - db.cells().vol).norm(), 0.0);
  EXPECT_EQ(ltl::SpMat(da.cells().Gbar - db.cells().Gbar).norm(), 0.0);
  EXPECT_EQ((da.dead_load() - db.dead_load()).norm(), 0.0);
  EXPECT_EQ((da.points()->gap - db.points()->gap).norm(), 0.0);
  EXPECT_EQ(da.dirichlet().fixed, db.dirichlet().fixed);
  EXPECT_EQ(da.split().C1, 435e3 + 65e3);  // plane strain, pointwise C2 split (2.5)-(2.6)
  EXPECT_TRUE(da.mean_det());

  // 30 iterations (not converged): the two iterates agree to the last bit.
  ltl::Solver from_problem(a), from_discretization{ltl::Discretization(a)};
  ltl::State s1 = from_problem.initial_state(), s2 = from_discretization.initial_state();
  EXPECT_FALSE(from_problem.solve_step(s1, s1.beta).converged);
  EXPECT_FALSE(from_discretization.solve_step(s2, s2.beta).converged);
  EXPECT_EQ((s1.u - s2.u).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((s1.lambda - s2.lambda).cwiseAbs().maxCoeff(), 0.0);
}

// [LTL87 (1.1)] u = value on Gamma_1, held per fixed node (value[i][k] at fixed[i][k], not a
// dense #nodes x dim array). Two conditions on one part fix the same component with the same
// affine value (different values are refused when the problem is validated): the node is listed
// once, with that value; the initial state and value_at give it, and 0 on the free nodes.
TEST(Discretization, Eq1_1_DirichletValuesHeldPerFixedNodeEachOnce) {
  ltl::Problem p = fig5(7);
  const ltl::DirichletCondition sym = p.dirichlet.at(0);  // a copy: the list grows below
  ltl::DirichletCondition first{sym.group, {1}, {}, "test.first"};
  first.field.value(1) = -0.2;
  first.field.gradient(1, 1) = 0.5;  // affine: -0.2 + 0.5 y (the part is the plane x = 0)
  ltl::DirichletCondition later = first;
  later.origin = "test.later";
  p.dirichlet.push_back(first);
  p.dirichlet.push_back(later);
  const ltl::Discretization d(p);
  const ltl::DirichletData& bc = d.dirichlet();
  const std::vector<int> part = p.mesh.boundary_nodes(sym.group);
  ASSERT_EQ(bc.fixed.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(bc.value[i].size(), bc.fixed[i].size());
    EXPECT_TRUE(std::is_sorted(bc.fixed[i].begin(), bc.fixed[i].end()));
    EXPECT_EQ(std::adjacent_find(bc.fixed[i].begin(), bc.fixed[i].end()), bc.fixed[i].end());
  }
  EXPECT_EQ(bc.fixed[1], part);
  const ltl::State s = ltl::Solver(p).initial_state();
  std::vector<char> on_part(p.mesh.num_nodes(), 0);
  for (int a : part) on_part[a] = 1;
  for (int a = 0; a < p.mesh.num_nodes(); ++a) {
    const double expected = on_part[a] ? -0.2 + 0.5 * p.mesh.X(a, 1) : 0.0;
    EXPECT_EQ(bc.value_at(a, 1), expected) << "node " << a;
    EXPECT_EQ(s.u(a, 1), expected) << "node " << a;
  }
  double largest = 0;
  for (int a : part) largest = std::max(largest, std::abs(-0.2 + 0.5 * p.mesh.X(a, 1)));
  EXPECT_EQ(bc.max_abs_value(), largest);
}

// [LTL87 (1.2)] The dead loads are held on the loaded nodes' rows: on the gutter, whose load is a
// traction on its inner face, those of that face alone; on Fig 5, whose load is a body force,
// every node. dead_load() makes the whole array from them, equal to the consistent loads
// assembled afresh (body_load + surface_load), and add_dead_load adds a multiple in place.
TEST(Discretization, Eq1_2_DeadLoadsAreHeldOnTheLoadedNodes) {
  const ltl::Problem g = gutter();
  const ltl::Discretization dg(g);
  const ltl::Traction& t = g.tractions.at(0);
  const ltl::Mesh::Boundary& inner = g.mesh.boundary(t.group, t.origin);
  std::vector<int> face;
  for (int f = 0; f < static_cast<int>(inner.facets.rows()); ++f)
    for (int a = 0; a < static_cast<int>(inner.facets.cols()); ++a)
      face.push_back(inner.facets(f, a));
  std::sort(face.begin(), face.end());
  face.erase(std::unique(face.begin(), face.end()), face.end());
  EXPECT_EQ(dg.loaded_nodes(), face);
  EXPECT_LT(static_cast<int>(face.size()), g.mesh.num_nodes() / 2);
  EXPECT_EQ(dg.loaded_rows().rows(), static_cast<Eigen::Index>(face.size()));
  const Eigen::MatrixXd Fg =
      ltl::surface_load(g.mesh, inner, t.g) + ltl::body_load(g.mesh, g.body_force);
  EXPECT_LE((dg.dead_load() - Fg).cwiseAbs().maxCoeff(), 1e-15 * Fg.cwiseAbs().maxCoeff());
  EXPECT_GT(Fg.cwiseAbs().maxCoeff(), 0.0);

  const ltl::Problem p = fig5(5);
  const ltl::Discretization d(p);
  EXPECT_EQ(static_cast<int>(d.loaded_nodes().size()), p.mesh.num_nodes());
  const Eigen::MatrixXd F = ltl::body_load(p.mesh, p.body_force);
  EXPECT_LE((d.dead_load() - F).cwiseAbs().maxCoeff(), 1e-15 * F.cwiseAbs().maxCoeff());
  Eigen::MatrixXd f = Eigen::MatrixXd::Random(p.mesh.num_nodes(), p.mesh.dim), sum = f + 2.5 * F;
  d.add_dead_load(f, 2.5);
  EXPECT_LE((f - sum).cwiseAbs().maxCoeff(), 1e-15 * sum.cwiseAbs().maxCoeff());
}
