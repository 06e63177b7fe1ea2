// Helpers shared by the tests: paths, and problems built in code.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>

#include "alg2.hpp"
#include "mesh.hpp"
#include "problem.hpp"

#ifndef LTL_TEST_DIR
#define LTL_TEST_DIR "tests"
#endif
#ifndef LTL_BINARY_DIR
#define LTL_BINARY_DIR "build"
#endif

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

}  // namespace ltl::testing
