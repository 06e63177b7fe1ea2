// Memory that scales with the mesh: the contact step stores no #points^2 buffer, with or without
// glue [LTL87 (4.7), (6.4)-(6.5)] (lib/contact_step.hpp, the sparse kernel of
// lib/adhesion_kernel.hpp).
//
// This executable replaces malloc, calloc, realloc and the aligned allocators (glibc's own
// __libc_* do the work) to record the largest single request: Eigen, std::vector and CHOLMOD all
// allocate through them. The tests fail if a buffer of #points^2 / 4 doubles or more is requested
// while a problem is set up and iterated, and check that the recorder sees such a buffer.
#include <gtest/gtest.h>

#include <atomic>
#include <cerrno>
#include <cstddef>
#include <vector>

#include "contact_step.hpp"
#include "testing.hpp"

extern "C" {
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
void* __libc_memalign(std::size_t, std::size_t);
}

namespace {
std::atomic<std::size_t> g_largest{0};
void note(std::size_t n) {
  std::size_t cur = g_largest.load(std::memory_order_relaxed);
  while (n > cur && !g_largest.compare_exchange_weak(cur, n, std::memory_order_relaxed)) {
  }
}
}  // namespace

extern "C" {
void* malloc(std::size_t n) {
  note(n);
  return __libc_malloc(n);
}
void* calloc(std::size_t a, std::size_t b) {
  note(a * b);
  return __libc_calloc(a, b);
}
void* realloc(void* p, std::size_t n) {
  note(n);
  return __libc_realloc(p, n);
}
void* memalign(std::size_t align, std::size_t n) {
  note(n);
  return __libc_memalign(align, n);
}
void* aligned_alloc(std::size_t align, std::size_t n) {
  note(n);
  return __libc_memalign(align, n);
}
int posix_memalign(void** p, std::size_t align, std::size_t n) {
  note(n);
  *p = __libc_memalign(align, n);
  return *p ? 0 : ENOMEM;
}
}

namespace {

using namespace ltl;

/// The largest single allocation while f runs.
template <class F>
std::size_t largest_allocation(const F& f) {
  g_largest = 0;
  f();
  return g_largest.load();
}

/// A surface of n collinear segments of length h on the plane x2 = 0.
ContactPoints line(int n, double h) {
  ContactPoints S;
  S.dim = 2;
  S.area = Eigen::VectorXd::Constant(n, h);
  S.centre = Eigen::MatrixXd::Zero(2, n);
  for (int s = 0; s < n; ++s) S.centre(0, s) = (s + 0.5) * h;
  S.gap = Eigen::VectorXd::Zero(n);
  S.N = Eigen::Vector2d(0.0, -1.0);
  return S;
}

/// The bound the tests assert: a quarter of a dense #points^2 matrix of doubles.
std::size_t quarter_dense(int n) {
  return static_cast<std::size_t>(n) * n * sizeof(double) / 4;
}

TEST(Memory, TheRecorderSeesADensePointsSquaredBuffer) {
  const int n = 3000;
  const std::size_t big = largest_allocation([&] {
    Eigen::MatrixXd k = Eigen::MatrixXd::Zero(n, n);
    EXPECT_EQ(k(n - 1, n - 1), 0.0);
  });
  EXPECT_GE(big, quarter_dense(n));
  const std::size_t vec = largest_allocation([&] {
    std::vector<double> k(static_cast<std::size_t>(n) * n);
    EXPECT_EQ(k.back(), 0.0);
  });
  EXPECT_GE(vec, quarter_dense(n));
}

TEST(Memory, Eq4_7_ContactStepWithoutGlueAllocatesNoPointsSquaredBuffer) {
  const int n = 3000;
  const ContactPoints S = line(n, 1e-3);
  Adhesion A;  // no glue, no dissipation: d0 = 0
  A.dt = 1.0;
  Eigen::MatrixXd ubar = Eigen::MatrixXd::Constant(n, 2, 1e-4), lambda_c = ubar, e = ubar;
  Eigen::VectorXd beta_prev = Eigen::VectorXd::Zero(n), beta = beta_prev;
  const std::size_t big = largest_allocation([&] {
    const ContactStep cs(S, A, 1e6);
    cs.solve(ubar, lambda_c, beta_prev, e, beta);
    EXPECT_EQ(cs.kernel().nonZeros(), 0);
  });
  EXPECT_LT(big, 64u * n) << "a buffer of " << big << " bytes for " << n << " contact points";
}

TEST(Memory, Eq6_4_Eq6_5_ContactStepWithGlueStoresASparseKernel) {
  // d0 h = 36 as Fig 3: a few neighbours per point within the cutoff.
  const int n = 3000;
  const ContactPoints S = line(n, 1.0 / 28);
  Adhesion A;
  A.w = 0.01;
  A.kappa = 1e9;
  A.d0 = 1000.0;
  A.dt = 5.0;
  Eigen::MatrixXd ubar = Eigen::MatrixXd::Constant(n, 2, 1e-4), lambda_c = ubar, e = ubar;
  Eigen::VectorXd beta_prev = Eigen::VectorXd::Zero(n), beta = Eigen::VectorXd::Ones(n);
  double bytes = 0;
  const std::size_t big = largest_allocation([&] {
    const ContactStep cs(S, A, 8e9);
    cs.solve(ubar, lambda_c, beta_prev, e, beta);
    EXPECT_LE(cs.kernel().nonZeros(), 7L * n);  // the point and a few neighbours on each side
    EXPECT_GE(cs.kernel().nonZeros(), 3L * n - 2);
    bytes = cs.kernel_bytes();
  });
  EXPECT_LT(big, 1024u * n) << "a buffer of " << big << " bytes for " << n << " contact points";
  EXPECT_LT(bytes, 200.0 * n);
}

/// The strip of tests/geometry/strip.geo, 3 m x 1 mm, nx x 1 cells, resting on the plane x2 = 0
/// (nodal contact: 2 nx + 1 contact points), its left end clamped; glued or not.
Problem long_strip(int nx, bool glue) {
  Problem p;
  p.name = "strip";
  p.mesh = load_mesh(ltl::testing::test_path("geometry/strip.geo"),
                     {{"L", 3.0}, {"H", 1e-3}, {"nx", nx}, {"ny", 1}});
  p.material = Material::mooney_rivlin(100e3, 30e3);
  p.dirichlet = {{"left", {0, 1}, {}, "test"}};
  Traction t{"top", {}, "test"};
  t.g.value(1) = -1e3;
  p.tractions = {t};
  ContactCondition cc;
  cc.group = "bottom";
  cc.plane_point.setZero();
  cc.plane_normal = Eigen::Vector3d(0, -1, 0);
  cc.beta0 = glue ? 1.0 : 0.0;
  if (glue) {
    cc.adhesion.w = 0.01;
    cc.adhesion.kappa = 1e9;
    cc.adhesion.d0 = 1000.0;
  }
  cc.origin = "test";
  p.contacts = {cc};
  p.time.dt = 1.0;
  p.algorithm = ltl::testing::tight(2 * 130e3);
  p.algorithm.max_iter = 3;
  return p;
}

TEST(Memory, Eq4_7_SolverSetupAndIterationsAllocateNoPointsSquaredBuffer) {
  for (bool glue : {false, true}) {
    const Problem p = long_strip(1500, glue);
    int points = 0;
    const std::size_t big = largest_allocation([&] {
      Solver solver(p);
      points = solver.discretization().points()->size();
      State s = solver.initial_state();
      solver.solve_step(s, s.beta);  // 3 iterations: not converged, not the point here
    });
    EXPECT_EQ(points, 3001);
    EXPECT_LT(big, quarter_dense(points))
        << (glue ? "glued" : "not glued") << ": a buffer of " << big << " bytes";
  }
}

}  // namespace
