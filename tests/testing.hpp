// Helpers shared by the tests: paths, and problems built in code.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "cg_amg.hpp"  // CgAmg::available, for LTL_NEEDS_PETSC
#include "mesh.hpp"
#include "problem.hpp"

#ifndef LTL_TEST_DIR
#define LTL_TEST_DIR "tests"
#endif
#ifndef LTL_BINARY_DIR
#define LTL_BINARY_DIR "build"
#endif

/// In a test that needs PETSc (CG + AMG, Newton's Krylov solves): SKIPPED in a build without it,
/// unless LTL_REQUIRE_PETSC is set (`make test-petsc`, `make test-mpi`), where it fails.
#define LTL_NEEDS_PETSC()                                                        \
  do {                                                                           \
    if (!::ltl::CgAmg::available()) {                                            \
      if (std::getenv("LTL_REQUIRE_PETSC")) FAIL() << "built without PETSc";     \
      GTEST_SKIP() << "built without PETSc (make test-petsc installs and runs)"; \
    }                                                                            \
  } while (0)

namespace ltl::testing {

inline std::string test_path(const std::string& rel) {
  return std::string(LTL_TEST_DIR) + "/" + rel;
}
inline std::string source_path(const std::string& rel) {
  return std::string(LTL_TEST_DIR) + "/../" + rel;
}
inline std::string binary_path(const std::string& rel) {
  return std::string(LTL_BINARY_DIR) + "/" + rel;
}

/// Starts the program `bin` with `args` (no shell) in `dir`, its stderr into the file `err` and
/// its stdout discarded; returns its pid (for waitpid, kill).
inline pid_t spawn(const std::string& bin, const std::vector<std::string>& args,
                   const std::filesystem::path& dir, const std::filesystem::path& err) {
  std::vector<std::string> all{bin};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null = ::open("/dev/null", O_WRONLY);
    if (::chdir(dir.c_str()) != 0 || e < 0 || null < 0) _exit(127);
    ::dup2(e, 2);
    ::dup2(null, 1);
    ::execv(bin.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

/// [LTL87 (1.5)] Incompressible Mooney-Rivlin in uniaxial compression with free lateral faces:
/// F = diag(l^-1/2, l^-1/2, l), P33 = 2 (l - l^-2)(C1 + C2 / l) (P11 = P22 = 0 fix the pressure);
/// with C2 = 0, P33 = 2 C1 (l - l^-2).
inline double uniaxial_pressure(double C1, double C2, double l) {
  return -2 * (l - 1 / (l * l)) * (C1 + C2 / l);
}

/// The 3-D block of tests/geometry/tet_box.geo (a quarter of a 2a x 2a x a block of gmsh's
/// tetrahedra, symmetry planes x = 0 and y = 0) on the plane z = 0 under the dead traction
/// -p e3 on its top: the user cases' block (test_user_cases.cpp) and its run on MPI ranks
/// (mpi_ranks.cpp).
inline std::string block_config(double C1, double C2, double p, double a = 0.05) {
  std::ostringstream s;
  s.precision(17);
  s << "name = \"block3d\"\n[mesh]\ngeometry = \"" << test_path("geometry/tet_box.geo")
    << "\"\nparameters = { a = " << a << ", n = 2 }\n[material]\nmodel = \"mooney-rivlin\"\n"
    << "C1 = " << C1 << "\nC2 = " << C2
    << "\n[[symmetry]]\ngroup = \"x0\"\ncomponent = \"x\"\n[[symmetry]]\ngroup = \"y0\"\n"
       "component = \"y\"\n[[load.traction]]\ngroup = \"z1\"\nvalue = [0, 0, "
    << -p
    << "]\n[contact]\ngroup = \"z0\"\nplane_point = [0, 0, 0]\nplane_normal = [0, 0, -1]\n"
       "beta0 = 0.0\n";
  return s.str();
}

/// A fresh temporary directory for one test.
inline std::filesystem::path temp_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("ltl_" + name + "_" + std::to_string(std::random_device{}()));
  std::filesystem::create_directories(dir);
  return dir;
}

inline void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

/// A valid small problem to break one key at a time: Fig 5's half cylinder on a coarse mesh
/// (n = nd = 4), loose tolerance; `geometry` is the .geo path as the configuration states it.
inline std::string coarse_fig5_config(const std::string& geometry) {
  return "name = \"case\"\n[mesh]\ngeometry = \"" + geometry + "\"\n" +
         R"(parameters = { n = 4, nd = 4 }
[material]
model = "mooney-rivlin"
C1 = "435 kPa"
C2 = "65 kPa"
[[symmetry]]
group = "symmetry_x"
component = "x"
[load]
body_force = [0, "-400 kN/m^3"]
[contact]
group = "contact"
plane_point = [0, -1]
plane_normal = [0, -1]
beta0 = 0.0
[algorithm]
R = 5
q = "1 MPa"
q_c = "1 MPa/m"
tol = 1e-4
[time]
dt = "1 s"
steps = 1
)";
}

/// Default algorithm parameters for verification runs: tight tolerance.
inline AlgorithmParams tight(double Rq, double R = 1.0) {
  AlgorithmParams a;
  a.R = R;
  a.q = Rq / R;
  a.q_c = Rq / R;
  a.tol = 1e-12;
  a.max_iter = 20000;
  return a;
}

// The unit box of n^3 hexahedra (tests/geometry/box.geo) with its interior nodes moved at random
// by up to a quarter of a cell (as in test_operators.cpp): the faces stay planar, the cells are
// general trilinear hexahedra, not parallelepipeds.
inline Mesh distorted_box(int n, unsigned seed = 7) {
  Mesh m = load_mesh(test_path("geometry/box.geo"), {{"n", n}});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-0.25, 0.25);
  const double h = 1.0 / n;
  for (int i = 0; i < m.num_nodes(); ++i) {
    bool interior = true;
    for (int k = 0; k < 3; ++k) interior &= m.X(i, k) > 1e-9 && m.X(i, k) < 1 - 1e-9;
    if (interior) {
      for (int k = 0; k < 3; ++k) m.X(i, k) += U(rng) * h;
    }
  }
  return m;
}

/// A solver and the state it converged to in one step from the initial state.
struct Solved {
  std::unique_ptr<Solver> solver;
  State s;
  StepReport report;
};

/// One static step (4.1)-(4.4) from the initial state; expects convergence with every local
/// strain problem solved to round-off.
inline Solved solve_one_step(const Problem& p) {
  Solved r;
  r.solver = std::make_unique<Solver>(p);
  r.s = r.solver->initial_state();
  r.report = r.solver->solve_step(r.s, r.s.beta);
  EXPECT_TRUE(r.report.converged) << r.report.status;
  EXPECT_EQ(r.report.strain_failures, 0);
  return r;
}

/// [LTL87 (1.5)] Plane-strain planar tension of the unit square (tests/geometry/square.geo):
/// incompressible Mooney-Rivlin, u1 = 0 on x1 = 0, u2 = 0 on x2 = 0, the dead nominal traction
/// P = 2 (l - l^-3)(C1 + C2) on x1 = 1, x2 = 1 free; closed form F = diag(l, 1/l, 1).
/// R q = 2 (C1 + C2), tol 1e-11.
inline Problem planar_tension(double l, double C1 = 100e3, double C2 = 30e3) {
  Problem p;
  p.name = "planar";
  p.mesh = load_mesh(test_path("geometry/square.geo"));
  p.material = Material::mooney_rivlin(C1, C2);
  p.dirichlet = {{"left", {0}, {}, "test"}, {"bottom", {1}, {}, "test"}};
  Traction t{"right", {}, "test"};
  t.g.value(0) = 2 * (l - std::pow(l, -3)) * (C1 + C2);
  p.tractions = {t};
  p.algorithm = tight(2 * (C1 + C2), 1.0);
  p.algorithm.tol = 1e-11;
  return p;
}

/// Largest nodal error of u against planar tension's F = diag(l, 1/l), relative to l.
inline double planar_tension_error(const Mesh& mesh, const Eigen::MatrixXd& u, double l) {
  double worst = 0;
  for (int i = 0; i < mesh.num_nodes(); ++i) {
    worst = std::max(worst, std::abs(u(i, 0) - (l - 1) * mesh.X(i, 0)) / l);
    worst = std::max(worst, std::abs(u(i, 1) - (1 / l - 1) * mesh.X(i, 1)) / l);
  }
  return worst;
}

/// A random rotation (2x2 or 3x3) drawn from g.
template <int n>
Eigen::Matrix<double, n, n> random_rotation(std::mt19937_64& g) {
  std::normal_distribution<double> N(0.0, 1.0);
  if constexpr (n == 2) {
    const double a = 3.14159 * N(g);
    Eigen::Matrix2d Q;
    Q << std::cos(a), -std::sin(a), std::sin(a), std::cos(a);
    return Q;
  } else {
    return Eigen::Quaterniond(N(g), N(g), N(g), N(g)).normalized().toRotationMatrix();
  }
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n), for reference quadratures.
inline void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.resize(n);
  w.resize(n);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5)), dp = 0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2 * k - 1) * z * p1 - (k - 1) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      dp = n * (z * p1 - p0) / (z * z - 1);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-16) break;
    }
    x[i] = z;
    w[i] = 2.0 / ((1 - z * z) * dp * dp);
  }
}

/// Composite 20-point Gauss of f on [a, b] with m pieces.
inline double quad(const std::function<double(double)>& f, double a, double b, int m) {
  static std::vector<double> X, W;
  if (X.empty()) gauss_legendre(20, X, W);
  double sum = 0.0;
  const double L = (b - a) / m;
  for (int k = 0; k < m; ++k)
    for (size_t i = 0; i < X.size(); ++i)
      sum += 0.5 * L * W[i] * f(a + (k + 0.5) * L + 0.5 * L * X[i]);
  return sum;
}

/// u = (F - I) x imposed on the whole boundary (group "boundary") of a 3-D mesh, one step.
inline Solved homogeneous_3d(const Mesh& mesh, const Material& material, const Eigen::Matrix3d& F) {
  Problem p;
  p.mesh = mesh;
  p.material = material;
  DirichletCondition bc{"boundary", {0, 1, 2}, {}, "test"};
  bc.field.gradient = F - Eigen::Matrix3d::Identity();
  p.dirichlet = {bc};
  p.algorithm = tight(2 * material.C1 * 4);
  return solve_one_step(p);
}

/// [LTL87 (2.7), (5.1)] 3-D patch test: every cell has E = F (to 1e-9; det E = det F to 1e-12
/// for the incompressible law, where it holds by construction of (5.4), (5.7)) and every node
/// u = (F - I) x (to 1e-10 m), the interior nodes carrying a displacement of at least 0.1 m.
inline void expect_patch_3d(const Mesh& mesh, const Material& material, const Eigen::Matrix3d& F) {
  const Solved r = homogeneous_3d(mesh, material, F);
  double worst_E = 0, worst_det = 0;
  for (int c = 0; c < mesh.num_cells(); ++c) {
    const Eigen::Matrix3d Ec = cell_tensor(r.s.E, c);
    worst_E = std::max(worst_E, (Ec - F).norm());
    worst_det = std::max(worst_det, std::abs(Ec.determinant() - F.determinant()));
  }
  EXPECT_LT(worst_E, 1e-9) << material.name();
  EXPECT_LT(worst_det, material.incompressible() ? 1e-12 : 1e-9) << material.name();
  const Eigen::MatrixXd u_exact = mesh.X * (F - Eigen::Matrix3d::Identity()).transpose();
  const double worst_u = (r.s.u - u_exact).cwiseAbs().maxCoeff();
  EXPECT_LT(worst_u, 1e-10) << material.name();
  EXPECT_GT(u_exact.cwiseAbs().maxCoeff(), 0.1);  // not trivially
  std::printf(
      "  %d cells, %s, det F = %.4f: %d iterations, max |E - F| = %.1e, max |det E - det F| = "
      "%.1e, max |u - (F - I) x| = %.1e m\n",
      mesh.num_cells(), material.name().c_str(), F.determinant(), r.report.iterations, worst_E,
      worst_det, worst_u);
}

/// [LTL87 (1.5)] Uniaxial tension of the unit block (groups x0, y0, z0 with symmetry, x1
/// loaded): dead nominal traction P e1 with the closed form F = diag(l, l^-1/2, l^-1/2),
/// P = 2 (l - l^-2)(C1 + C2 / l), for l = 1.5 and 2, from a perturbed non-homogeneous start
/// (E_e = (I + A_e) / det^(1/3), |A_e| ~ 0.05). Nodal u to 1e-6 l, P_e = diag(P, 0, 0) and the
/// true stress sigma11 = l P to 1e-5 relative, det E = 1 to 1e-12. Another incompressible law:
/// `material` with its closed form P(l) = dW/dl along F = diag(l, l^-1/2, l^-1/2), and the solver.
inline void expect_uniaxial_tension_3d(const Mesh& mesh,
                                       const Material& material = Material::mooney_rivlin(100e3,
                                                                                          30e3),
                                       const std::function<double(double)>& nominal_stress = {},
                                       NonlinearSolver nonlinear = NonlinearSolver::Alg2) {
  const double C1 = material.C1, C2 = material.C2;
  for (const double l : {1.5, 2.0}) {
    const double P = nominal_stress ? nominal_stress(l) : 2 * (l - 1 / (l * l)) * (C1 + C2 / l);
    const double lt = 1 / std::sqrt(l);  // lateral stretch
    Problem p;
    p.mesh = mesh;
    p.material = material;
    p.dirichlet = {{"x0", {0}, {}, "test"}, {"y0", {1}, {}, "test"}, {"z0", {2}, {}, "test"}};
    Traction t{"x1", {}, "test"};
    t.g.value(0) = P;
    p.tractions = {t};
    // R q = 8 (C1 + C2): with R q = 2 (C1 + C2), enough in plane strain (test_verification), the
    // 3-D iteration is unstable (a skew, i.e. rotational, mode of the local step (5.4) grows
    // from round-off once R q is below about 4 C1; measured threshold between 2.6 C1 and 4 C1).
    p.algorithm = tight(8 * (C1 + C2), 1.0);
    p.algorithm.tol = 1e-11;
    p.algorithm.solver = nonlinear;
    Solver solver(p);
    State s = solver.initial_state();
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> U(-0.05, 0.05);
    for (int c = 0; c < mesh.num_cells(); ++c) {
      Eigen::Matrix3d A;
      for (int i = 0; i < 9; ++i) A(i) = U(rng);
      A += Eigen::Matrix3d::Identity();
      s.E.block<3, 3>(3 * c, 0) = (A / std::cbrt(A.determinant())).transpose();
    }
    const StepReport report = solver.solve_step(s, s.beta);
    EXPECT_TRUE(report.converged) << report.status;
    EXPECT_EQ(report.strain_failures, 0);
    double worst = 0;
    for (int i = 0; i < mesh.num_nodes(); ++i) {
      worst = std::max(worst, std::abs(s.u(i, 0) - (l - 1) * mesh.X(i, 0)) / l);
      worst = std::max(worst, std::abs(s.u(i, 1) - (lt - 1) * mesh.X(i, 1)) / l);
      worst = std::max(worst, std::abs(s.u(i, 2) - (lt - 1) * mesh.X(i, 2)) / l);
    }
    EXPECT_LT(worst, 1e-6) << "stretch " << l << " after " << report.iterations << " iterations";
    const Eigen::MatrixXd Pc = solver.discretization().piola(s),
                          sigma = solver.discretization().cauchy(s);
    double worst_P = 0, worst_sigma = 0, worst_det = 0;
    for (int c = 0; c < mesh.num_cells(); ++c) {
      Eigen::Matrix3d expected = Eigen::Matrix3d::Zero();
      expected(0, 0) = P;
      worst_P = std::max(worst_P, (cell_tensor(Pc, c) - expected).norm() / P);
      worst_sigma = std::max(worst_sigma, std::abs(cell_tensor(sigma, c)(0, 0) - l * P) / (l * P));
      worst_det = std::max(worst_det, std::abs(cell_tensor(s.E, c).determinant() - 1));
    }
    EXPECT_LT(worst_P, 1e-5) << "stretch " << l;
    EXPECT_LT(worst_sigma, 1e-5) << "stretch " << l;
    EXPECT_LT(worst_det, 1e-12) << "stretch " << l;
    std::printf(
        "  l = %.1f: P = %.6g Pa, %d iterations, max |u - u_exact| / l = %.2e, max |P_e - P| / P "
        "= %.2e, max |det E - 1| = %.1e (%s)\n",
        l, P, report.iterations, worst, worst_P, worst_det, material.name().c_str());
  }
}

}  // namespace ltl::testing
