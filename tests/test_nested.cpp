// The nested start (lib/nested_start.hpp, paper_notes/nested.md): a field of one mesh evaluated
// on another (lib/mesh_transfer.hpp), and a run started from a results file of another mesh.
#include <sys/wait.h>

#include <random>

#include "config.hpp"
#include "error.hpp"
#include "fe.hpp"
#include "mesh_transfer.hpp"
#include "nested_start.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

namespace {

using ltl::testing::source_path;
namespace fs = std::filesystem;

const std::string kFig6 = "experiments/fig6/fig6.toml";

/// The gutter (Fig 6) with (nt, na, nl) hexahedra, solved to a force residual of 1e-6.
ltl::Problem gutter(int nt, int na, int nl, const std::string& solver,
                    std::vector<std::string> more = {}) {
  std::vector<std::string> o = {"mesh.parameters.nt=" + std::to_string(nt),
                                "mesh.parameters.na=" + std::to_string(na),
                                "mesh.parameters.nl=" + std::to_string(nl),
                                "algorithm.solver=\"" + solver + "\"",
                                "algorithm.stopping=\"equilibrium\"",
                                "algorithm.acceleration=\"anderson\"",
                                "algorithm.force_tol=1e-6"};
  o.insert(o.end(), more.begin(), more.end());
  return ltl::load_problem(source_path(kFig6), o);
}

/// A homogeneous deformation u = (F - I) X, exactly representable by every element.
Eigen::MatrixXd homogeneous(const Eigen::MatrixXd& X) {
  Eigen::Matrix3d G;
  G << 0.10, -0.20, 0.05, 0.30, -0.15, 0.02, -0.04, 0.25, 0.12;
  const int d = static_cast<int>(X.cols());
  return X * G.topLeftCorner(d, d).transpose();
}

/// Evaluating u = (F - I) X of `coarse` at the nodes of `fine`: exact (to rounding) at every
/// node inside the coarse mesh; returns the number of nodes that were not inside.
int expect_reproduced(const ltl::Mesh& coarse, const ltl::Mesh& fine) {
  const Eigen::MatrixXd u = homogeneous(coarse.X), exact = homogeneous(fine.X);
  const ltl::PointLocator locate(coarse);
  const double scale = exact.cwiseAbs().maxCoeff();
  int outside = 0;
  double worst = 0;
  for (int a = 0; a < fine.num_nodes(); ++a) {
    const ltl::PointLocator::Hit hit = locate.locate(fine.X.row(a).transpose());
    EXPECT_GE(hit.cell, 0);
    if (!hit.inside()) {
      ++outside;
      continue;
    }
    worst = std::max(worst, (locate.evaluate(u, hit) - exact.row(a)).cwiseAbs().maxCoeff());
  }
  EXPECT_LT(worst, 1e-12 * scale) << fine.source;
  return outside;
}

}  // namespace

TEST(Nested, HomogeneousDeformationIsReproducedOnFinerMeshes) {
  // P2 triangles, P2 tetrahedra and H8 on straight-sided boxes: every node of the finer mesh is
  // inside the coarser one, and the field is reproduced to rounding.
  const std::string sq = source_path("tests/geometry/square.geo");
  EXPECT_EQ(expect_reproduced(ltl::load_mesh(sq, {{"n", 3}}), ltl::load_mesh(sq, {{"n", 7}})), 0);
  const std::string tet = source_path("tests/geometry/tet_box.geo");
  EXPECT_EQ(expect_reproduced(ltl::load_mesh(tet, {{"n", 2}}), ltl::load_mesh(tet, {{"n", 3}})), 0);
  const std::string box = source_path("tests/geometry/box.geo");
  EXPECT_EQ(expect_reproduced(ltl::load_mesh(box, {{"n", 2}}), ltl::load_mesh(box, {{"n", 5}})), 0);
  // The gutter: H8 whose trilinear maps are not affine (the inverse map needs Newton's
  // iterations); the finer mesh's nodes on the curved faces lie outside the coarse chords.
  const ltl::Problem c = gutter(2, 9, 5, "alg2"), f = gutter(4, 18, 10, "alg2");
  const int outside = expect_reproduced(c.mesh, f.mesh);
  EXPECT_GT(outside, 0);
  EXPECT_LT(outside, f.mesh.num_nodes() / 2);
}

TEST(Nested, InverseMapRecoversRandomPointsOfDistortedHexahedra) {
  // A box of 3^3 H8 with its interior nodes moved at random: x(xi) at random xi of random cells
  // is located back in its cell (or a neighbour sharing the point) with the field exact.
  ltl::Mesh m = ltl::load_mesh(source_path("tests/geometry/box.geo"), {{"n", 3}});
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int a = 0; a < m.num_nodes(); ++a) {
    const Eigen::RowVector3d x = m.X.row(a);
    if (x.minCoeff() > 1e-9 && x.maxCoeff() < 1 - 1e-9)
      m.X.row(a) += 0.08 * Eigen::RowVector3d(U(rng), U(rng), U(rng));
  }
  const Eigen::MatrixXd u = homogeneous(m.X);
  const ltl::PointLocator locate(m);
  for (int k = 0; k < 200; ++k) {
    const int c = static_cast<int>(std::uniform_int_distribution<int>(0, m.num_cells() - 1)(rng));
    const Eigen::Vector3d xi(U(rng), U(rng), U(rng));
    Eigen::VectorXd N;
    Eigen::MatrixXd dN;
    ltl::reference_shape(m, xi, N, dN);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(3);
    for (int a = 0; a < 8; ++a) x += N(a) * m.X.row(m.cells(c, a)).transpose();
    const ltl::PointLocator::Hit hit = locate.locate(x);
    ASSERT_TRUE(hit.inside()) << "point " << k << " distance " << hit.distance;
    EXPECT_LT((locate.evaluate(u, hit) - homogeneous(x.transpose())).norm(), 1e-12);
  }
}

TEST(Nested, PointsOutsideTheMeshFindTheClosestCell) {
  // Outside the distorted box (planar faces, interior nodes moved): a point at distance delta
  // beyond a face, or beyond a corner, is located in no cell, at that distance from the closest
  // cell, with the field of the closest boundary point: the locator's pruned search of the
  // closest cell (skipping cells whose box is no nearer than the best so far) finds the nearest.
  const ltl::Mesh m = ltl::testing::distorted_box(4);
  const Eigen::MatrixXd u = homogeneous(m.X);
  const ltl::PointLocator locate(m);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> U(0.1, 0.9), D(1e-4, 0.1);
  for (int k = 0; k < 120; ++k) {
    Eigen::Vector3d on(U(rng), U(rng), U(rng)), x = on;
    double distance = 0;
    if (k % 4 == 3) {  // beyond the corner (1, 1, 1)
      on.setOnes();
      const Eigen::Vector3d off(D(rng), D(rng), D(rng));
      x = on + off;
      distance = off.norm();
    } else {  // beyond face k % 6 / 2 on its low or high side
      const int axis = (k / 4) % 3;
      const bool high = k % 2;
      on(axis) = high ? 1.0 : 0.0;
      distance = D(rng);
      x = on;
      x(axis) += high ? distance : -distance;
    }
    const ltl::PointLocator::Hit hit = locate.locate(x);
    ASSERT_FALSE(hit.inside()) << "point " << k;
    EXPECT_NEAR(hit.distance, distance, 1e-9) << "point " << k;
    EXPECT_LT((locate.evaluate(u, hit) - homogeneous(on.transpose())).norm(), 1e-9) << k;
  }
}

TEST(Nested, Eq4_1to4_3_SameMeshStartFromAConvergedStateStopsInOneOrTwoIterations) {
  // A converged state (Newton, force residual <= 1e-6) transferred to the same mesh is the
  // state itself: ALG2 + Anderson stops at once where it needs hundreds of iterations from rest.
  const fs::path dir = ltl::testing::temp_dir("nested_same");
  const ltl::Problem newton = gutter(2, 9, 5, "newton"), alg2 = gutter(2, 9, 5, "alg2");
  ltl::RunOptions o;
  o.verbosity = 0;
  o.output = (dir / "coarse.h5").string();
  ltl::run(newton, o);
  ltl::RunOptions from_rest;
  from_rest.verbosity = 0;
  const ltl::RunSummary rest = ltl::run(alg2, from_rest);
  ltl::RunOptions nested = from_rest;
  nested.init = o.output;
  nested.output = (dir / "again.h5").string();
  const ltl::RunSummary again = ltl::run(alg2, nested);
  std::printf("  same mesh: ALG2 + Anderson %d iterations from rest, %d from the nested start\n",
              rest.iterations.at(0), again.iterations.at(0));
  EXPECT_LE(again.iterations.at(0), 2);
  EXPECT_GT(rest.iterations.at(0), 50);
  EXPECT_EQ(ltl::ResultsFile::read_attribute(nested.output, "initial_from"), o.output);
  fs::remove_all(dir);
}

TEST(Nested, CoarseToFineGutterStartsNewtonNextToTheSolution) {
  // A coarse gutter (nl = 5) -> a mesh twice as fine in every direction: the nested start's u
  // is within 15 % of the sag of the fine solution everywhere (measured: 11 %, where the contact
  // zone moves), and Newton needs fewer outer iterations than from rest (measured: 11 and 35).
  const fs::path dir = ltl::testing::temp_dir("nested_fine");
  ltl::RunOptions o;
  o.verbosity = 0;
  o.output = (dir / "coarse.h5").string();
  ltl::run(gutter(2, 9, 5, "newton"), o);
  const ltl::Problem fine = gutter(4, 18, 10, "newton");
  ltl::Solver solver(fine);
  const ltl::NestedStart start = ltl::nested_start(solver, o.output);
  EXPECT_GT(start.clamped_nodes, 0);  // the nodes of the curved faces, outside the chords
  EXPECT_LT(start.max_outside_relative, ltl::kMaxOutside);
  EXPECT_EQ(start.source_step, 1);
  ltl::RunOptions quiet;
  quiet.verbosity = 0;
  const ltl::RunSummary rest = ltl::run(solver, quiet);
  ltl::Solver solver2(fine);
  quiet.init = o.output;
  const ltl::RunSummary nested = ltl::run(solver2, quiet);
  const double sag = rest.state.u.col(1).cwiseAbs().maxCoeff();
  const double gap = (start.state.u - rest.state.u).cwiseAbs().maxCoeff();
  std::printf(
      "  level 1 -> 2x finer: Newton %d outer iterations from rest, %d nested; start %.3g "
      "of the sag away\n",
      rest.iterations.at(0), nested.iterations.at(0), gap / sag);
  EXPECT_LT(gap, 0.15 * sag);
  // Measured 11 against 35: at most half (a start that only helped a little would fail).
  EXPECT_LE(2 * nested.iterations.at(0), rest.iterations.at(0));
  EXPECT_LT((nested.state.u - rest.state.u).cwiseAbs().maxCoeff(), 1e-4 * sag);
  fs::remove_all(dir);
}

TEST(Nested, RefusesAnotherBodyAnotherDimensionAndResumeTogether) {
  const fs::path dir = ltl::testing::temp_dir("nested_bad");
  ltl::RunOptions o;
  o.verbosity = 0;
  o.output = (dir / "short.h5").string();
  // A gutter half as long: the target's nodes beyond x1 = 5 m are far outside it.
  ltl::run(gutter(2, 9, 3, "newton", {"mesh.parameters.L=10"}), o);
  ltl::Solver solver(gutter(2, 9, 5, "newton"));
  try {
    ltl::nested_start(solver, o.output);
    ADD_FAILURE() << "a node far outside the source mesh was accepted";
  } catch (const ltl::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("--init " + o.output), std::string::npos) << what;
    EXPECT_NE(what.find("outside the file's mesh"), std::string::npos) << what;
  }
  // A 2-D file for a 3-D problem.
  ltl::RunOptions o2 = o;
  o2.output = (dir / "fig5.h5").string();
  ltl::run(ltl::load_problem(source_path("experiments/fig5/fig5.toml"),
                             {"mesh.parameters.n=4", "mesh.parameters.nd=4",
                              "algorithm.solver=\"newton\"", "algorithm.stopping=\"equilibrium\""}),
           o2);
  try {
    ltl::nested_start(solver, o2.output);
    ADD_FAILURE() << "a 2-D source was accepted for a 3-D problem";
  } catch (const ltl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("2-D"), std::string::npos) << e.what();
  }
  // A file that does not exist names itself and the option.
  try {
    ltl::nested_start(solver, (dir / "missing.h5").string());
    ADD_FAILURE() << "a missing file was accepted";
  } catch (const ltl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.h5"), std::string::npos) << e.what();
  }
  // --resume and --init together: a usage error (exit status 2).
  const std::string cmd = ltl::testing::binary_path("experiments/ltl_run") + " " +
                          source_path(kFig6) + " -q --resume --init " + o.output + " -o " +
                          (dir / "x.h5").string() + " 2> /dev/null";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, 2);
  fs::remove_all(dir);
}
