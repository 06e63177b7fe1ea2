// A converged state is a result only if it is a physical one (lib/admissibility.hpp,
// paper_notes/admissibility.md): no node of the body inside the obstacle, det F > 0 at every
// quadrature point and det E > 0, no cell on the rotated branch of the local strain step, no
// contact tension without glue, 0 <= beta <= 1. Constructed states that break one condition
// each are refused, naming the node, cell or contact point; converged states of the repository's
// problems pass; a reversed obstacle normal is refused before any iteration; a run that converges
// to an inadmissible state ends with an error and keeps it apart in /unconverged.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>

#include "admissibility.hpp"
#include "config.hpp"
#include "error.hpp"
#include "measures.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::source_path;
using ltl::testing::test_path;
namespace fs = std::filesystem;

namespace {

const std::string kBlock = source_path("experiments/first_problem/block.toml");

bool contains(const std::string& text, const std::string& word) {
  return text.find(word) != std::string::npos;
}

/// The block of experiments/first_problem (100 kPa on a 10 x 5 cm rubber block) converged with
/// the derived parameters: the reference admissible state the constructed ones start from.
const ltl::testing::Solved& converged_block() {
  static const ltl::testing::Solved solved = ltl::testing::solve_one_step(load_problem(kBlock));
  return solved;
}

/// The cells sharing node n.
std::vector<int> cells_of_node(const Mesh& mesh, int n) {
  std::vector<int> out;
  for (int c = 0; c < mesh.num_cells(); ++c)
    for (int a = 0; a < mesh.nodes_per_cell(); ++a)
      if (mesh.cells(c, a) == n) out.push_back(c);
  return out;
}

bool has_object(const std::string& file, const std::string& path) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return false;
  bool ok = true;
  for (std::size_t at = 1; ok && at <= path.size(); ++at)
    if (at == path.size() || path[at] == '/') ok = H5Lexists(f, path.substr(0, at).c_str(), 0) > 0;
  H5Fclose(f);
  return ok;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Converged states of the repository's problems are admissible (no false positive).
// ---------------------------------------------------------------------------------------------

TEST(Admissibility, Eq1_1_FirstProblemConvergedStatePasses) {
  const auto& r = converged_block();
  const AdmissibilityReport a = check_admissibility(r.solver->discretization(), r.s);
  EXPECT_TRUE(a.admissible()) << a.message();
  EXPECT_EQ(a.message(), "");
  // The exact state is homogeneous: F = diag(1/l, l), l = 0.868 under 100 kPa, no rotation;
  // det F = 1 at every quadrature point up to the mean-det fluctuation.
  EXPECT_NEAR(a.det_F_min, 1.0, 1e-5);
  EXPECT_NEAR(a.det_E_min, 1.0, 1e-5);
  EXPECT_LT(a.rotation_jump, 1e-3);
  EXPECT_EQ(a.cells_rotated, 0);
  EXPECT_EQ(a.nodes_inside, 0);
  EXPECT_LE(a.max_inside, a.inside_tol);
  EXPECT_NEAR(a.pressure_min, 100e3, 1.0);  // the applied pressure at every contact node
  EXPECT_NEAR(a.h, std::sqrt(0.1 * 0.05 / r.solver->problem().mesh.num_cells()), 1e-12);
  EXPECT_DOUBLE_EQ(a.inside_tol, kInsideTolerance * a.h);
}

TEST(Admissibility, Eq1_1_Fig5CoarseConvergedStatePasses) {
  const fs::path dir = ltl::testing::temp_dir("admissibility_fig5");
  ltl::testing::write_file(dir / "fig5.toml", ltl::testing::coarse_fig5_config(
                                                  source_path("experiments/fig5/half_disc.geo")));
  const Problem p = load_problem((dir / "fig5.toml").string());
  fs::remove_all(dir);
  const auto r = ltl::testing::solve_one_step(p);
  const AdmissibilityReport a = check_admissibility(r.solver->discretization(), r.s);
  EXPECT_TRUE(a.admissible()) << a.message();
  // A cylinder flattened on the plane: det F stays near 1, rotations vary smoothly.
  EXPECT_GT(a.det_F_min, 0.5);
  EXPECT_LT(a.rotation_jump, 30);
  EXPECT_GE(a.pressure_min, -a.pressure_tol);
  std::printf(
      "  coarse Fig 5: det F min %.4f, det E min %.4f, rotation jump %.3g deg, max "
      "(x - p0).N = %.3g m (tol %.3g m), min pressure %.4g Pa (tol %.3g Pa)\n",
      a.det_F_min, a.det_E_min, a.rotation_jump, a.max_inside, a.inside_tol, a.pressure_min,
      a.pressure_tol);
}

// ---------------------------------------------------------------------------------------------
// Constructed inadmissible states are refused, naming where.
// ---------------------------------------------------------------------------------------------

TEST(Admissibility, Eq1_1_TurnedOverBlockIsRefusedNamingTheNode) {
  // The block turned by pi about the origin (x = -X): det F = 1, E = -I in every cell (no cell
  // against its neighbours), but every node off the contact face lies behind the plane x2 = 0.
  const auto& r = converged_block();
  const Mesh& mesh = r.solver->problem().mesh;
  State s = r.s;
  s.u = -2 * mesh.X;
  s.E = -r.solver->discretization().identity();
  const AdmissibilityReport a = check_admissibility(r.solver->discretization(), s);
  ASSERT_FALSE(a.admissible());
  ASSERT_EQ(a.failures.size(), 1u) << a.message();
  int off_plane = 0;
  for (int n = 0; n < mesh.num_nodes(); ++n) off_plane += mesh.X(n, 1) > 1e-9;
  EXPECT_EQ(a.nodes_inside, off_plane);
  EXPECT_NEAR(a.max_inside, 0.05, 1e-12);  // the top face, 5 cm behind the plane
  ASSERT_GE(a.inside_node, 0);
  EXPECT_NEAR(mesh.X(a.inside_node, 1), 0.05, 1e-12);
  const std::string m = a.message();
  EXPECT_TRUE(contains(m, cat("node ", a.inside_node, " at reference"))) << m;
  EXPECT_TRUE(contains(m, "inside the obstacle")) << m;
  EXPECT_TRUE(contains(m, "ramp")) << m;  // what to try
  EXPECT_NEAR(a.det_F_min, 1.0, 1e-12);
  EXPECT_EQ(a.cells_rotated, 0);
}

TEST(Admissibility, Eq4_6_RotatedBranchCellIsRefusedNamingTheCell) {
  // One cell's E turned by pi (plane strain: E -> -E, det unchanged), its neighbours untouched.
  const auto& r = converged_block();
  const int nc = r.solver->problem().mesh.num_cells(), c = nc / 2;
  State s = r.s;
  s.E.block<2, 2>(2 * c, 0) *= -1;
  const AdmissibilityReport a = check_admissibility(r.solver->discretization(), s);
  ASSERT_FALSE(a.admissible());
  ASSERT_EQ(a.failures.size(), 1u) << a.message();
  EXPECT_EQ(a.cells_rotated, 1);
  EXPECT_EQ(a.rotation_cell, c);
  EXPECT_NEAR(a.rotation_jump, 180, 1e-3);
  EXPECT_TRUE(contains(a.message(), cat("cell ", c, " (centre"))) << a.message();
  EXPECT_TRUE(contains(a.message(), "raise algorithm.R")) << a.message();
  // A rotation by 60 degrees of the same cell is a large but not a flipped one: accepted.
  State t = r.s;
  const Eigen::Matrix2d Q = Eigen::Rotation2Dd(M_PI / 3).toRotationMatrix();
  t.E.block<2, 2>(2 * c, 0) = (Q * cell_tensor(r.s.E, c)).transpose();
  const AdmissibilityReport b = check_admissibility(r.solver->discretization(), t);
  EXPECT_TRUE(b.admissible()) << b.message();
  EXPECT_NEAR(b.rotation_jump, 60, 1e-3);
}

TEST(Admissibility, Eq4_6_RotatedBranchCellIsRefusedIn3D) {
  // 3-D: the paper's rotated branch E ~ diag(0.97, -1.01, -1.01) (section3-4.md), a rotation by
  // pi about x1, in one hexahedron of a 3 x 3 x 3 box at rest.
  Problem p;
  p.name = "box";
  p.mesh = load_mesh(test_path("geometry/box.geo"), {{"n", 3}});
  p.material = Material::mooney_rivlin(100e3, 0);
  p.dirichlet = {{"x0", {0, 1, 2}, {}, "test"}};
  const Discretization d(p);
  State s;
  s.u = Eigen::MatrixXd::Zero(p.mesh.num_nodes(), 3);
  s.E = d.identity();
  EXPECT_TRUE(check_admissibility(d, s).admissible());
  int c = 0;  // the centre cell
  for (int k = 0; k < p.mesh.num_cells(); ++k) {
    Eigen::RowVector3d x = Eigen::RowVector3d::Zero();
    for (int a = 0; a < p.mesh.nodes_per_cell(); ++a) x += p.mesh.X.row(p.mesh.cells(k, a));
    if ((x / p.mesh.nodes_per_cell() - Eigen::RowVector3d(0.5, 0.5, 0.5)).norm() < 1e-9) c = k;
  }
  s.E.block<3, 3>(3 * c, 0) = Eigen::Vector3d(0.97, -1.01, -1.01).asDiagonal();
  const AdmissibilityReport a = check_admissibility(d, s);
  ASSERT_FALSE(a.admissible());
  EXPECT_EQ(a.cells_rotated, 1);
  EXPECT_EQ(a.rotation_cell, c);
  EXPECT_NEAR(a.rotation_jump, 180, 1e-6);
  EXPECT_TRUE(contains(a.message(), cat("cell ", c, " (centre (0.5, 0.5, 0.5))"))) << a.message();
}

TEST(Admissibility, InvertedQuadraturePointIsRefusedNamingTheCell) {
  // An interior node moved by 2 h across its neighbours: the cells around it turn inside out
  // near it (det F < 0 at a quadrature point), E untouched.
  const auto& r = converged_block();
  const Mesh& mesh = r.solver->problem().mesh;
  const Eigen::RowVector2d target(0.05, 0.03);
  int n = 0;
  (mesh.X.rowwise() - target).rowwise().squaredNorm().minCoeff(&n);
  State s = r.s;
  const double h = check_admissibility(r.solver->discretization(), s).h;
  s.u(n, 0) += 2 * h;
  const AdmissibilityReport a = check_admissibility(r.solver->discretization(), s);
  ASSERT_FALSE(a.admissible());
  ASSERT_EQ(a.failures.size(), 1u) << a.message();
  EXPECT_LT(a.det_F_min, 0);
  EXPECT_GE(a.cells_inverted, 1);
  const std::vector<int> around = cells_of_node(mesh, n);
  EXPECT_NE(std::find(around.begin(), around.end(), a.det_F_cell), around.end()) << a.det_F_cell;
  EXPECT_LE(a.cells_inverted, static_cast<int>(around.size()));
  EXPECT_TRUE(contains(a.message(), cat("det F = ", a.det_F_min, ", is in cell ", a.det_F_cell)))
      << a.message();
  // The stored strain inverted in one cell: det E < 0, named.
  State t = r.s;
  const int c = 7;
  t.E.block<2, 2>(2 * c, 0) = Eigen::Vector2d(1.0, -0.5).asDiagonal();
  const AdmissibilityReport b = check_admissibility(r.solver->discretization(), t);
  ASSERT_FALSE(b.admissible());
  EXPECT_DOUBLE_EQ(b.det_E_min, -0.5);
  EXPECT_EQ(b.det_E_cell, c);
  EXPECT_TRUE(contains(b.message(), cat("det E = -0.5 <= 0 in cell ", c))) << b.message();
}

TEST(Admissibility, Eq1_1_TensionWithoutGlueIsRefusedAndAcceptedWithGlue) {
  // A tension of 50 kPa at one contact node of the block (p = -lambda_c . N = -50 kPa).
  const auto& r = converged_block();
  const Discretization& d = r.solver->discretization();
  const Eigen::VectorXd N = d.problem().contacts[0].plane_normal.head(2);
  State s = r.s;
  const int i = 3;
  s.lambda_c.row(i) = 50e3 * N.transpose();
  const AdmissibilityReport a = check_admissibility(d, s);
  ASSERT_FALSE(a.admissible());
  ASSERT_EQ(a.failures.size(), 1u) << a.message();
  EXPECT_DOUBLE_EQ(a.pressure_min, -50e3);
  EXPECT_EQ(a.pressure_point, i);
  EXPECT_GT(a.pressure_tol, 0);
  EXPECT_LT(a.pressure_tol, 1e3);
  EXPECT_TRUE(contains(a.message(), cat("at contact point ", i, " (reference"))) << a.message();
  // With glue holding that point (kappa > 0, beta = 1) the same tension is the glue's.
  Problem glued = d.problem();
  glued.contacts[0].adhesion.kappa = 1e9;
  glued.contacts[0].beta0 = 1;
  const Discretization dg(glued);
  s.beta.setOnes();
  EXPECT_TRUE(check_admissibility(dg, s).admissible()) << check_admissibility(dg, s).message();
  // ... but not where the glue is broken (beta = 0).
  s.beta(i) = 0;
  const AdmissibilityReport b = check_admissibility(dg, s);
  EXPECT_FALSE(b.admissible());
  EXPECT_EQ(b.pressure_point, i);
}

TEST(Admissibility, Eq1_2_BetaOutsideZeroOneIsRefused) {
  const auto& r = converged_block();
  State s = r.s;
  s.beta(5) = 1.25;
  const AdmissibilityReport a = check_admissibility(r.solver->discretization(), s);
  ASSERT_FALSE(a.admissible());
  EXPECT_EQ(a.beta_point, 5);
  EXPECT_DOUBLE_EQ(a.beta_max, 1.25);
  EXPECT_TRUE(contains(a.message(), "beta = 1.25 is outside [0, 1] at contact point 5"))
      << a.message();
  s.beta(5) = 1 + 0.5 * kBetaTolerance;  // round-off of the projection: accepted
  EXPECT_TRUE(check_admissibility(r.solver->discretization(), s).admissible());
}

// ---------------------------------------------------------------------------------------------
// An obstacle whose normal points into the body is refused before any iteration.
// ---------------------------------------------------------------------------------------------

TEST(Admissibility, Eq1_1_ReversedNormalIsRefusedNamingPlaneNormal) {
  EXPECT_NO_THROW({ const Discretization d(load_problem(kBlock)); });
  const Problem p = load_problem(kBlock, {"contact.plane_normal=[0, 1]"});
  std::string msg;
  try {
    Discretization d(p);
  } catch (const Error& e) {
    msg = e.what();
  }
  EXPECT_TRUE(contains(msg, "contact.plane_normal must point into the obstacle")) << msg;
  EXPECT_TRUE(contains(msg, "its centroid is 0.025 m from the plane")) << msg;
  EXPECT_TRUE(contains(msg, "plane_normal = [0, -1]")) << msg;
  // A plane that cuts the body away from the contact surface: the node is named.
  const Problem q = load_problem(
      kBlock, {"contact.plane_normal=[0, 1]", "contact.plane_point=[\"0 m\", \"4 cm\"]"});
  msg.clear();
  try {
    Discretization d(q);
  } catch (const Error& e) {
    msg = e.what();
  }
  EXPECT_TRUE(contains(msg, "of the body (at ")) << msg;
  EXPECT_TRUE(contains(msg, "starts inside the obstacle")) << msg;
}

// ---------------------------------------------------------------------------------------------
// The time loop: a converged but inadmissible step is not a result.
// ---------------------------------------------------------------------------------------------

TEST(Admissibility, Eq1_1_InadmissibleConvergedStepEndsTheRunAndIsSavedApart) {
  // The block of test_contact_problems.cpp at l = 0.8 (dead pressure 299.8 kPa): ALG2 converges
  // to the block turned by pi, hanging from its contact face through the obstacle.
  const double C1 = 100e3, C2 = 30e3, l = 0.8;
  Problem p;
  p.name = "turned";
  p.mesh = load_mesh(test_path("geometry/square.geo"));
  p.material = Material::mooney_rivlin(C1, C2);
  p.dirichlet = {{"left", {0}, {}, "test"}};
  Traction top{"top", {}, "test"};
  top.g.value(1) = 2 * (l - std::pow(l, -3)) * (C1 + C2);
  p.tractions = {top};
  ContactCondition cc;
  cc.group = "bottom";
  cc.plane_normal = Eigen::Vector3d(0, -1, 0);
  cc.beta0 = 0;
  cc.origin = "test";
  p.contacts = {cc};
  p.algorithm = ltl::testing::tight(4 * (C1 + C2));
  p.algorithm.tol = 1e-10;
  const fs::path dir = ltl::testing::temp_dir("admissibility_run");
  RunOptions o;
  o.output = (dir / "turned.h5").string();
  o.verbosity = 0;
  std::string msg;
  try {
    run(p, o);
  } catch (const Error& e) {
    msg = e.what();
  }
  EXPECT_TRUE(contains(msg, "inadmissible state at step 1")) << msg;
  EXPECT_TRUE(contains(msg, "inside the obstacle")) << msg;
  EXPECT_TRUE(contains(msg, "the deepest is node ")) << msg;
  EXPECT_TRUE(contains(msg, "group /unconverged/000001 (not a result)")) << msg;
  ASSERT_TRUE(fs::exists(o.output));
  EXPECT_FALSE(ResultsFile::read_last_step(o.output));  // nothing written as a result
  EXPECT_TRUE(has_object(o.output, "/unconverged/000001/u"));
  EXPECT_TRUE(
      contains(ResultsFile::read_attribute(o.output, "status"), "inadmissible state at step 1"));
  fs::remove_all(dir);
}
