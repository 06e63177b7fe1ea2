// Several rigid obstacles ([[contact]], paper_notes/obstacles.md):
//   - the exact projection onto two half-spaces (the frictionless step (6.6)-(6.7) of a point
//     held by two planes) against an independent iteration and random sampling, 2-D and 3-D;
//   - two plates squeezing a compressible block (F = diag(a, 1): the plates hold the lateral
//     stretch) and an incompressible block pressed into a corner by two tractions (a node of both
//     obstacles), against the homogeneous closed forms, by ALG2 and by the Newton phase;
//   - a block pressed into a V-groove and a pressurized ring between two plates (the
//     experiments/vgroove and experiments/oring configurations on coarse meshes): admissible
//     (no node behind either plane), the forces of the obstacles balance the load;
//   - one [contact] table and a one-element [[contact]] list give identical results;
//   - configuration errors naming the key and index.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

#include "admissibility.hpp"
#include "alg2.hpp"
#include "config.hpp"
#include "measures.hpp"
#include "obstacles.hpp"
#include "simulation.hpp"
#include "testing.hpp"

using namespace ltl;
using Eigen::Vector3d;
using ltl::testing::source_path;
using ltl::testing::temp_dir;
using ltl::testing::test_path;
using ltl::testing::write_file;

namespace {

// Dykstra's alternating projections onto two half-spaces: converges to the projection onto their
// intersection (an independent computation of project_two_planes).
Vector3d dykstra(const Vector3d& x, const Vector3d& N1, double g1, const Vector3d& N2, double g2) {
  Vector3d y = x, p = Vector3d::Zero(), q = Vector3d::Zero();
  for (int it = 0; it < 200000; ++it) {
    const Vector3d y1 = ContactStep::project(y + p, N1, g1);
    p = y + p - y1;
    const Vector3d y2 = ContactStep::project(y1 + q, N2, g2);
    q = y1 + q - y2;
    const double change = (y2 - y).norm();
    y = y2;
    if (change <= 1e-16 * (1 + x.norm()) && it > 10) break;
  }
  return y;
}

// Random unit normals at least 10 degrees apart (and not opposite), gaps and points.
void two_plane_cases(int dim, unsigned seed, int cases,
                     const std::function<void(const Vector3d&, const Vector3d&, double,
                                              const Vector3d&, double)>& check) {
  std::mt19937 g(seed);
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int k = 0; k < cases; ++k) {
    Vector3d N1 = Vector3d::Zero(), N2 = Vector3d::Zero(), x = Vector3d::Zero();
    for (int i = 0; i < dim; ++i) N1(i) = n01(g), N2(i) = n01(g), x(i) = 2 * U(g);
    N1.normalize(), N2.normalize();
    if (std::abs(N1.dot(N2)) > std::cos(10 * M_PI / 180)) {
      --k;
      continue;
    }
    check(x, N1, 0.5 * U(g), N2, 0.5 * U(g));
  }
}

void expect_two_plane_projection(int dim) {
  int regime[4] = {0, 0, 0, 0};  // inside, on plane 1, on plane 2, on the edge
  double worst = 0, worst_feasible = 0;
  two_plane_cases(
      dim, 11 + dim, 4000,
      [&](const Vector3d& x, const Vector3d& N1, double g1, const Vector3d& N2, double g2) {
        const Vector3d e = project_two_planes(x, N1, g1, N2, g2);
        const double tol = 1e-12 * (1 + x.norm());
        worst_feasible = std::max({worst_feasible, N1.dot(e) - g1, N2.dot(e) - g2});
        const bool on1 = std::abs(N1.dot(e) - g1) <= tol, on2 = std::abs(N2.dot(e) - g2) <= tol;
        ++regime[(e - x).norm() <= tol ? 0 : on1 && on2 ? 3 : on1 ? 1 : 2];
        worst = std::max(worst, (e - dykstra(x, N1, g1, N2, g2)).norm());
        if (dim == 2) {
          EXPECT_EQ(e(2), 0.0);
        }
      });
  std::printf(
      "  %d-D: %d inside, %d on plane 1, %d on plane 2, %d on the edge; max |e - Dykstra| "
      "= %.1e, max violation %.1e\n",
      dim, regime[0], regime[1], regime[2], regime[3], worst, worst_feasible);
  for (int r = 0; r < 4; ++r) EXPECT_GT(regime[r], 100) << "regime " << r;
  EXPECT_LT(worst, 1e-9);
  EXPECT_LE(worst_feasible, 1e-12);
}

}  // namespace

TEST(Obstacles, Eq6_7_TwoPlaneProjectionMatchesDykstra2D) {
  expect_two_plane_projection(2);
}

TEST(Obstacles, Eq6_7_TwoPlaneProjectionMatchesDykstra3D) {
  expect_two_plane_projection(3);
}

// No point of the intersection, sampled at random around the answer, is nearer to x.
TEST(Obstacles, Eq6_7_TwoPlaneProjectionIsTheNearestPointBruteForce) {
  for (int dim : {2, 3}) {
    std::mt19937 g(5);
    std::uniform_real_distribution<double> U(-1, 1);
    int beaten = 0, samples = 0;
    two_plane_cases(
        dim, 3, 300,
        [&](const Vector3d& x, const Vector3d& N1, double g1, const Vector3d& N2, double g2) {
          const Vector3d e = project_two_planes(x, N1, g1, N2, g2);
          const double d = (e - x).norm();
          for (int k = 0; k < 2000; ++k) {
            Vector3d y = e;
            for (int i = 0; i < dim; ++i) y(i) += 0.2 * U(g) * (k % 2 ? d : 1e-3);
            if (N1.dot(y) > g1 || N2.dot(y) > g2) continue;
            ++samples;
            if ((y - x).norm() < d - 1e-13) ++beaten;
          }
        });
    EXPECT_EQ(beaten, 0) << dim << "-D";
    EXPECT_GT(samples, 10000);
  }
}

TEST(Obstacles, Eq6_7_TwoPlaneProjectionParallelPlanes) {
  const Vector3d N(0, 1, 0), x(0.3, 2.0, 0);
  // Same direction: the half-space of the smaller gap.
  EXPECT_NEAR(project_two_planes(x, N, 0.5, N, 1.0)(1), 0.5, 1e-15);
  // Opposite: the slab -1 <= x2 <= 0.5.
  EXPECT_NEAR(project_two_planes(x, N, 0.5, -N, 1.0)(1), 0.5, 1e-15);
  EXPECT_NEAR(project_two_planes(Vector3d(0.3, -3, 0), N, 0.5, -N, 1.0)(1), -1.0, 1e-15);
  EXPECT_EQ(project_two_planes(Vector3d(0.3, 0.1, 0), N, 0.5, -N, 1.0), Vector3d(0.3, 0.1, 0));
}

namespace {

ContactCondition plane(const std::string& group, const Vector3d& point, const Vector3d& N) {
  ContactCondition cc;
  cc.group = group;
  cc.plane_point = point;
  cc.plane_normal = N.normalized();
  cc.beta0 = 0.0;
  return cc;
}

// At a converged state, each copy of a node of two obstacles lies in its half-space, and the node
// is the joint projection of itself pushed by the sum of the two forces: the KKT conditions of
// the frictionless step of one point held by both planes (obstacles.hpp).
void expect_shared_points_exact(const Discretization& d, const State& s) {
  const ContactPoints& pts = *d.points();
  const Eigen::MatrixXd ubar = pts.mean * s.u;
  const double scale = std::max(1e-300, s.u.cwiseAbs().maxCoeff());
  int shared = 0;
  for (int a = 0; a < pts.offset[1]; ++a)
    for (int b = pts.offset[1]; b < pts.size(); ++b) {
      if (pts.nodes.empty() || pts.nodes[a] != pts.nodes[b]) continue;
      ++shared;
      Vector3d u = Vector3d::Zero(), N1 = Vector3d::Zero(), N2 = Vector3d::Zero(),
               f = Vector3d::Zero();
      u.head(d.dim()) = ubar.row(a).transpose();
      N1.head(d.dim()) = pts.normals.row(a).transpose();
      N2.head(d.dim()) = pts.normals.row(b).transpose();
      EXPECT_LE(N1.dot(u) - pts.gap(a), 1e-9 * scale);
      EXPECT_LE(N2.dot(u) - pts.gap(b), 1e-9 * scale);
      // -lambda_c of both copies: the obstacles' push (mu_1 N1 + mu_2 N2 per unit weight).
      f.head(d.dim()) = -(s.lambda_c.row(a) + s.lambda_c.row(b)).transpose();
      const double c = scale / std::max(1e-300, f.norm());
      const Vector3d p = project_two_planes(u + c * f, N1, pts.gap(a), N2, pts.gap(b));
      EXPECT_LT((p - u).norm(), 1e-7 * scale) << "node " << pts.nodes[a];
    }
  EXPECT_GT(shared, 0);
}

}  // namespace

// [LTL87 (1.5), sec. 8] The compressible law between two plates x2 = 0 and x2 = 1 (the unit
// square, u1 = 0 on x1 = 0, dead traction -p1 e1 on x1 = 1): the plates hold the lateral stretch
// at 1, F = diag(a, 1), J = a, and with W = C1 (|F|^2 - 3) + C3 J^2 - C3 - 2 (C1 + C3) ln J,
//   P11 = 2 C1 a + (2 C3 a^2 - 2 (C1 + C3)) / a = -p1,   P22 = 2 C3 (a^2 - 1) = -p_plate:
// each plate presses with p_plate = 2 C3 (1 - a^2) over its unit length.
TEST(Obstacles, Eq1_5_TwoPlatesSqueezeACompressibleBlock) {
  const double C1 = 187.5e3, C3 = 187.5e3, a = 0.85;
  const double p1 = -(2 * C1 * a + (2 * C3 * a * a - 2 * (C1 + C3)) / a);
  const double p_plate = 2 * C3 * (1 - a * a);
  ASSERT_GT(p1, 0);
  for (NonlinearSolver solver : {NonlinearSolver::Alg2, NonlinearSolver::Newton}) {
    Problem p;
    p.mesh = load_mesh(test_path("geometry/square.geo"));
    p.material = Material::compressible(C1, C3);
    p.dirichlet = {{"left", {0}, {}, "test"}};
    Traction right{"right", {}, "test"};
    right.g.value(0) = -p1;
    p.tractions = {right};
    p.contacts = {plane("bottom", Vector3d::Zero(), Vector3d(0, -1, 0)),
                  plane("top", Vector3d(0, 1, 0), Vector3d(0, 1, 0))};
    p.contacts[1].origin = "contact[1]";
    p.algorithm = ltl::testing::tight(4 * C1);
    p.algorithm.tol = 1e-11;
    p.algorithm.solver = solver;
    const ltl::testing::Solved r = ltl::testing::solve_one_step(p);
    const Discretization& d = r.solver->discretization();
    double worst_u = 0;
    for (int i = 0; i < p.mesh.num_nodes(); ++i)
      worst_u = std::max(
          {worst_u, std::abs(r.s.u(i, 0) - (a - 1) * p.mesh.X(i, 0)), std::abs(r.s.u(i, 1))});
    EXPECT_LT(worst_u, 1e-7);
    const StepMeasures m = step_measures(d, r.s);
    ASSERT_TRUE(m.contact);
    ASSERT_EQ(m.obstacles.size(), 1u);
    const double err0 = std::abs(m.contact->force - p_plate) / p_plate,
                 err1 = std::abs(m.obstacles[0].force - p_plate) / p_plate;
    EXPECT_LT(err0, 1e-7);
    EXPECT_LT(err1, 1e-7);
    EXPECT_NEAR(m.contact->resultant(1), p_plate, 1e-7 * p_plate);  // the lower plate pushes up
    EXPECT_NEAR(m.obstacles[0].resultant(1), -p_plate, 1e-7 * p_plate);
    EXPECT_LE(max_penetration(d, r.s), 1e-10);
    EXPECT_TRUE(check_admissibility(d, r.s).admissible());
    std::printf(
        "  %s: %d iterations, max |u - u_exact| = %.1e m, plate forces %.6g, %.6g N/m "
        "(closed form %.6g: errors %.1e, %.1e)\n",
        solver == NonlinearSolver::Newton ? "newton" : "alg2", r.report.iterations, worst_u,
        m.contact->force, m.obstacles[0].force, p_plate, err0, err1);
  }
}

// [LTL87 (1.5), sec. 8] The same in 3-D on distorted hexahedra: the unit box between the plates
// x3 = 0 and x3 = 1, u1 = 0 on x1 = 0, u2 = 0 on x2 = 0, dead traction -p1 e1 on x1 = 1, x2 free:
// F = diag(a, b, 1), J = a b, P22 = 0 gives b^2 = (C1 + C3) / (C1 + C3 a^2), and each plate
// presses with -P33 = 2 C3 (1 - a^2 b^2) over its unit area.
TEST(Obstacles, Eq1_5_TwoPlatesSqueezeACompressibleBlock3D) {
  const double C1 = 187.5e3, C3 = 187.5e3, a = 0.9;
  const double b = std::sqrt((C1 + C3) / (C1 + C3 * a * a)), J = a * b;
  const double p1 = -(2 * C1 * a + (2 * C3 * J * J - 2 * (C1 + C3)) / a);
  const double p_plate = 2 * C3 * (1 - J * J);
  ASSERT_GT(p1, 0);
  ASSERT_GT(p_plate, 0);
  for (NonlinearSolver solver : {NonlinearSolver::Alg2, NonlinearSolver::Newton}) {
    Problem p;
    p.mesh = ltl::testing::distorted_box(2);
    p.material = Material::compressible(C1, C3);
    p.dirichlet = {{"x0", {0}, {}, "test"}, {"y0", {1}, {}, "test"}};
    Traction right{"x1", {}, "test"};
    right.g.value(0) = -p1;
    p.tractions = {right};
    p.contacts = {plane("z0", Vector3d::Zero(), Vector3d(0, 0, -1)),
                  plane("z1", Vector3d(0, 0, 1), Vector3d(0, 0, 1))};
    p.algorithm = ltl::testing::tight(8 * C1);
    p.algorithm.tol = 1e-11;
    p.algorithm.solver = solver;
    const ltl::testing::Solved r = ltl::testing::solve_one_step(p);
    const Discretization& d = r.solver->discretization();
    double worst_u = 0;
    for (int i = 0; i < p.mesh.num_nodes(); ++i)
      worst_u = std::max({worst_u, std::abs(r.s.u(i, 0) - (a - 1) * p.mesh.X(i, 0)),
                          std::abs(r.s.u(i, 1) - (b - 1) * p.mesh.X(i, 1)), std::abs(r.s.u(i, 2))});
    EXPECT_LT(worst_u, 1e-7);
    const StepMeasures m = step_measures(d, r.s);
    ASSERT_TRUE(m.contact);
    ASSERT_EQ(m.obstacles.size(), 1u);
    EXPECT_NEAR(m.contact->force, p_plate, 1e-7 * p_plate);
    EXPECT_NEAR(m.obstacles[0].force, p_plate, 1e-7 * p_plate);
    EXPECT_TRUE(check_admissibility(d, r.s).admissible());
    std::printf(
        "  3-D %s: %d iterations, max |u - u_exact| = %.1e m, plate forces %.8g, %.8g N "
        "(closed form %.8g)\n",
        solver == NonlinearSolver::Newton ? "newton" : "alg2", r.report.iterations, worst_u,
        m.contact->force, m.obstacles[0].force, p_plate);
  }
}

// [LTL87 (1.1)] A node behind ANY obstacle is inadmissible: the block between the plates x2 = 0
// and x2 = 1 lifted by 1 cm is 1 cm behind the upper plate (obstacle 1) and 1 cm clear of the
// lower one.
TEST(Obstacles, Eq1_1_ANodeBehindTheSecondObstacleIsInadmissible) {
  Problem p;
  p.mesh = load_mesh(test_path("geometry/square.geo"));
  p.material = Material::compressible(187.5e3, 187.5e3);
  p.dirichlet = {{"left", {0}, {}, "test"}};
  Traction right{"right", {}, "test"};
  right.g.value(0) = -1e4;
  p.tractions = {right};
  p.contacts = {plane("bottom", Vector3d::Zero(), Vector3d(0, -1, 0)),
                plane("top", Vector3d(0, 1, 0), Vector3d(0, 1, 0))};
  const Solver solver(p);
  const Discretization& d = solver.discretization();
  State s = solver.initial_state();
  s.u.col(1).setConstant(0.01);
  s.e = d.points()->mean * s.u;
  EXPECT_NEAR(penetration_of(d, s, 0), -0.01, 1e-15);
  EXPECT_NEAR(penetration_of(d, s, 1), 0.01, 1e-15);
  EXPECT_NEAR(max_penetration(d, s), 0.01, 1e-15);
  const AdmissibilityReport adm = check_admissibility(d, s);
  EXPECT_FALSE(adm.admissible());
  EXPECT_NE(adm.message().find("inside the obstacles"), std::string::npos) << adm.message();
  EXPECT_NEAR(adm.max_inside, 0.01, 1e-15);
  // The gaps of the points, each to its own plane: -1 cm at the top, +1 cm at the bottom.
  const Eigen::VectorXd gap = d.contact_gap(s);
  const ContactPoints& pts = *d.points();
  EXPECT_NEAR(gap.head(pts.offset[1]).maxCoeff(), 0.01, 1e-15);
  EXPECT_NEAR(gap.tail(pts.size() - pts.offset[1]).maxCoeff(), -0.01, 1e-15);
}

// [LTL87 (1.5)] Incompressible Mooney-Rivlin in the corner of two planes x1 = 0 and x2 = 0, pressed
// by dead tractions -p1 e1 on x1 = 1 and -p2 e2 on x2 = 1: F = diag(a, 1/a), P = 2 (C1 + C2) F -
// pi F^-T, so p1 = pi / a - 2 (C1 + C2) a and p2 = pi a - 2 (C1 + C2) / a for a chosen pressure
// pi; each plane carries its traction over the unit side. The corner node is a contact point of
// both obstacles. (With a = 0.9, pi = 3 (C1 + C2), both solvers reach from rest another
// equilibrium of the dead loads, the block turned through the corner into both obstacles with
// its contact faces still on the planes (the corner (1, 1) at (-1.19, -0.84)): the loads here
// keep the physical branch, as in test_contact_problems.cpp.)
TEST(Obstacles, Eq1_5_BlockPressedIntoACornerSharedNode) {
  const double C1 = 100e3, C2 = 30e3, C = C1 + C2, a = 0.95, pi = 2.5 * C;
  const double p1 = pi / a - 2 * C * a, p2 = pi * a - 2 * C / a;
  ASSERT_GT(p2, 0);
  for (NonlinearSolver solver : {NonlinearSolver::Alg2, NonlinearSolver::Newton}) {
    Problem p;
    p.mesh = load_mesh(test_path("geometry/square.geo"));
    p.material = Material::mooney_rivlin(C1, C2);
    Traction right{"right", {}, "test"}, top{"top", {}, "test"};
    right.g.value(0) = -p1;
    top.g.value(1) = -p2;
    p.tractions = {right, top};
    p.contacts = {plane("left", Vector3d::Zero(), Vector3d(-1, 0, 0)),
                  plane("bottom", Vector3d::Zero(), Vector3d(0, -1, 0))};
    p.algorithm = ltl::testing::tight(4 * C);
    p.algorithm.tol = 1e-11;
    p.algorithm.solver = solver;
    const ltl::testing::Solved r = ltl::testing::solve_one_step(p);
    const Discretization& d = r.solver->discretization();
    double worst_u = 0;
    for (int i = 0; i < p.mesh.num_nodes(); ++i)
      worst_u = std::max({worst_u, std::abs(r.s.u(i, 0) - (a - 1) * p.mesh.X(i, 0)),
                          std::abs(r.s.u(i, 1) - (1 / a - 1) * p.mesh.X(i, 1))});
    EXPECT_LT(worst_u, 1e-7);
    const StepMeasures m = step_measures(d, r.s);
    ASSERT_TRUE(m.contact);
    ASSERT_EQ(m.obstacles.size(), 1u);
    EXPECT_NEAR(m.contact->force, p1, 1e-7 * p1);
    EXPECT_NEAR(m.obstacles[0].force, p2, 1e-7 * p2);
    EXPECT_LE(max_penetration(d, r.s), 1e-10);
    const AdmissibilityReport adm = check_admissibility(d, r.s);
    EXPECT_TRUE(adm.admissible()) << adm.message();
    expect_shared_points_exact(d, r.s);
    std::printf(
        "  %s: %d iterations, max |u - u_exact| = %.1e m, forces %.6g, %.6g N/m (closed "
        "form %.6g, %.6g)\n",
        solver == NonlinearSolver::Newton ? "newton" : "alg2", r.report.iterations, worst_u,
        m.contact->force, m.obstacles[0].force, p1, p2);
  }
}

namespace {

// Runs a configuration; checks every step admissible and the obstacles' forces in balance with
// the loads along the directions no support holds (`free`: the components to check). Returns the
// last step's measures.
StepMeasures run_and_balance(const std::string& config, const std::vector<std::string>& overrides,
                             const std::vector<int>& free, bool shared, double* seconds) {
  const Problem p = load_problem(config, overrides);
  RunOptions o;
  o.verbosity = 0;
  StepMeasures last;
  int steps = 0;
  const auto t0 = std::chrono::steady_clock::now();
  run(p, o, [&](const Solver& solver, int, const State& s) {
    ++steps;
    const Discretization& d = solver.discretization();
    const AdmissibilityReport adm = check_admissibility(d, s);
    EXPECT_TRUE(adm.admissible()) << adm.message();
    for (int k = 0; k < d.num_obstacles(); ++k) EXPECT_LE(penetration_of(d, s, k), 1e-9);
    last = step_measures(d, s);
    if (shared) expect_shared_points_exact(d, s);
    Eigen::Vector3d sum = last.contact->resultant;
    for (const ContactMeasures& c : last.obstacles) sum += c.resultant;
    const Eigen::VectorXd load = solver.external_load().colwise().sum().transpose();
    for (int i : free)
      EXPECT_NEAR(sum(i) + load(i), 0.0, 1e-8 * std::max(1.0, load.norm() + sum.norm()))
          << "component " << i;
  });
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(steps, p.time.steps);
  return last;
}

}  // namespace

// [LTL87 (4.5), (1.1)] A square block pressed into a right-angled V-groove
// (experiments/vgroove/vgroove.toml, coarse): no node behind either face of the groove, the two
// faces' forces balance the load in both directions, symmetric, and the corner node (a contact
// point of both faces) exact.
TEST(Obstacles, Eq1_1_BlockPressedIntoAVGroove) {
  double seconds = 0;
  const StepMeasures m = run_and_balance(source_path("experiments/vgroove/vgroove.toml"),
                                         {"mesh.parameters.n=4"}, {0, 1}, true, &seconds);
  ASSERT_TRUE(m.contact);
  ASSERT_EQ(m.obstacles.size(), 1u);
  // Symmetric: the two faces carry the same normal force, 6000 N/m / sqrt(2) each.
  const double load = 2 * 150e3 * 0.02;
  EXPECT_NEAR(m.contact->force, load / std::sqrt(2.0), 1e-8 * load);
  EXPECT_NEAR(m.obstacles[0].force, load / std::sqrt(2.0), 1e-8 * load);
  std::printf("  V-groove: face forces %.10g, %.10g N/m (load / sqrt 2 = %.10g), %.2f s\n",
              m.contact->force, m.obstacles[0].force, load / std::sqrt(2.0), seconds);
  EXPECT_LT(seconds, 20);
}

// A pressurized ring between two plates (experiments/oring/oring.toml, coarse): admissible at
// every step, both plates pressed, their forces opposite (the pressure has no vertical
// resultant on the half ring; the symmetry plane holds it horizontally).
TEST(Obstacles, Eq1_1_PressurizedRingBetweenTwoPlates) {
  double seconds = 0;
  const StepMeasures m = run_and_balance(source_path("experiments/oring/oring.toml"),
                                         {"mesh.parameters.n=2"}, {1}, false, &seconds);
  ASSERT_TRUE(m.contact);
  ASSERT_EQ(m.obstacles.size(), 1u);
  EXPECT_GT(m.contact->force, 0);
  EXPECT_GT(m.contact->in_contact, 1);
  EXPECT_NEAR(m.contact->force, m.obstacles[0].force, 1e-6 * m.contact->force);
  std::printf("  ring: plate forces %.8g, %.8g N/m, %d and %d points in contact, %.2f s\n",
              m.contact->force, m.obstacles[0].force, m.contact->in_contact,
              m.obstacles[0].in_contact, seconds);
  EXPECT_LT(seconds, 20);
}

namespace {

std::string block_config(const std::string& contact_header) {
  return "name = \"block\"\n[mesh]\ngeometry = \"" +
         source_path("experiments/first_problem/block.geo") +
         "\"\nparameters = { W = 0.1, H = 0.05, n = 4 }\n"
         "[material]\nmodel = \"mooney-rivlin\"\nC1 = \"200 kPa\"\nC2 = \"50 kPa\"\n"
         "[[symmetry]]\ngroup = \"left\"\ncomponent = \"x\"\n"
         "[[load.traction]]\ngroup = \"top\"\nvalue = [\"0 Pa\", \"-100 kPa\"]\n" +
         contact_header +
         "\ngroup = \"bottom\"\nplane_point = [\"0 m\", \"0 m\"]\nplane_normal = [0, -1]\n"
         "beta0 = 0.0\n";
}

}  // namespace

// One [contact] table is the list of one obstacle: the same problem, resolved configuration and
// converged state, bit for bit.
TEST(Obstacles, OneContactTableEqualsAOneElementList) {
  const auto dir = temp_dir("obstacles_one");
  write_file(dir / "table.toml", block_config("[contact]"));
  write_file(dir / "list.toml", block_config("[[contact]]"));
  const Problem a = load_problem((dir / "table.toml").string());
  const Problem b = load_problem((dir / "list.toml").string());
  ASSERT_EQ(a.contacts.size(), 1u);
  ASSERT_EQ(b.contacts.size(), 1u);
  EXPECT_EQ(a.contacts[0].origin, "contact");
  EXPECT_EQ(b.contacts[0].origin, "contact[0]");
  EXPECT_EQ(resolved_configuration(a), resolved_configuration(b));
  EXPECT_NE(resolved_configuration(a).find("\n[contact]\n"), std::string::npos);
  Solver sa(a), sb(b);
  State s = sa.initial_state(), t = sb.initial_state();
  const StepReport ra = sa.solve_step(s, s.beta), rb = sb.solve_step(t, t.beta);
  ASSERT_TRUE(ra.converged && rb.converged);
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ((s.u - t.u).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ((s.lambda_c - t.lambda_c).cwiseAbs().maxCoeff(), 0.0);
}

// [LTL87 (4.7), (6.1)-(6.8)] Glue on one of several obstacles (ALG2): the block of the first
// problem glued to its plane and pressed by 100 kPa, with a second, frictionless obstacle 15 cm
// above its top that it never reaches, converges to the state of the glued block alone (the
// second obstacle's points add R q_c M^T M to (4.5), another iteration with the same fixed
// point).
TEST(Obstacles, Eq4_7_GlueOnOneOfTwoObstaclesAsAlone) {
  const auto dir = temp_dir("obstacles_glue");
  std::string one = block_config("[[contact]]");
  one.replace(one.find("beta0 = 0.0"), 11, "beta0 = 1.0\nkappa = \"1e9 Pa/m\"\nw = \"1 J/m^2\"");
  one += "[algorithm]\nsolver = \"alg2\"\nforce_tol = 1e-7\nmax_iter = 40000\n";
  const std::string two = one +
                          "[[contact]]\ngroup = \"top\"\nplane_point = [\"0 m\", \"20 cm\"]\n"
                          "plane_normal = [0, 1]\n";
  write_file(dir / "one.toml", one);
  write_file(dir / "two.toml", two);
  const Problem a = load_problem((dir / "one.toml").string());
  const Problem b = load_problem((dir / "two.toml").string());
  ASSERT_EQ(b.contacts.size(), 2u);
  Solver sa(a), sb(b);
  State s = sa.initial_state(), t = sb.initial_state();
  const StepReport ra = sa.solve_step(s, s.beta), rb = sb.solve_step(t, t.beta);
  ASSERT_TRUE(ra.converged) << ra.status;
  ASSERT_TRUE(rb.converged) << rb.status;
  const int n0 = sb.discretization().points()->offset[1];
  ASSERT_EQ(n0, s.beta.size());
  const double du = (s.u - t.u).cwiseAbs().maxCoeff() / s.u.cwiseAbs().maxCoeff();
  const double dbeta = (s.beta - t.beta.head(n0)).cwiseAbs().maxCoeff();
  EXPECT_LT(du, 1e-6);
  EXPECT_LT(dbeta, 1e-6);
  // The far obstacle carries nothing; the glued one the load, 100 kPa x 0.1 m = 10 kN/m.
  const StepMeasures m = step_measures(sb.discretization(), t);
  ASSERT_EQ(m.obstacles.size(), 1u);
  EXPECT_NEAR(m.obstacles[0].force, 0.0, 1e-8 * 1e4);
  EXPECT_NEAR(m.contact->resultant(1), 1e4, 1e-4 * 1e4);
  std::printf(
      "  glued alone: %d iterations; with a second obstacle: %d; max |du| / max |u| = "
      "%.1e, max |dbeta| = %.1e; glue force %.6g N/m\n",
      ra.iterations, rb.iterations, du, dbeta, m.contact->resultant(1));
}

namespace {

std::string load_error(const std::string& text) {
  const auto dir = temp_dir("obstacles_errors");
  write_file(dir / "bad.toml", text);
  try {
    load_problem((dir / "bad.toml").string());
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

std::string second_obstacle(const std::string& extra) {
  return "\n[[contact]]\n" + extra + "plane_point = [\"0 m\", \"5 cm\"]\nplane_normal = [0, 1]\n";
}

}  // namespace

TEST(Obstacles, ConfigTableAndListBothGivenIsRefused) {
  const std::string e =
      load_error(block_config("[contact]") + second_obstacle("group = \"top\"\n"));
  EXPECT_NE(e.find("key 'contact'"), std::string::npos) << e;
  EXPECT_NE(e.find("[[contact]]"), std::string::npos) << e;
  EXPECT_NE(e.find("both given"), std::string::npos) << e;
}

TEST(Obstacles, ConfigObstacleWithoutGroupNamesItsIndex) {
  const std::string e = load_error(block_config("[[contact]]") + second_obstacle(""));
  EXPECT_NE(e.find("contact[1].group"), std::string::npos) << e;
}

TEST(Obstacles, ConfigSharedGlueIsRefusedNamingBothObstacles) {
  const std::string e =
      load_error(block_config("[[contact]]") + "kappa = \"1e9 Pa/m\"\n" +
                 "[algorithm]\nsolver = \"alg2\"\n" + second_obstacle("group = \"bottom\"\n"));
  EXPECT_NE(e.find("contact[0].kappa"), std::string::npos) << e;
  EXPECT_NE(e.find("contact[0] (group 'bottom') and contact[1] (group 'bottom')"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("share the contact node"), std::string::npos) << e;
}

TEST(Obstacles, ConfigNewtonWithGlueOnSeveralObstaclesIsRefused) {
  const std::string e = load_error(block_config("[[contact]]") + "kappa = \"1e9 Pa/m\"\n" +
                                   second_obstacle("group = \"top\"\n"));
  EXPECT_NE(e.find("algorithm.solver"), std::string::npos) << e;
  EXPECT_NE(e.find("contact[0] glued"), std::string::npos) << e;
}
