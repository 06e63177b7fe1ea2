// Tests of the local adhesion / contact step [LTL87 (4.7), (4.10)-(4.11), (6.1)-(6.8)] and of the
// dissipation kernel [LTL87 (1.3), (1.6)]. See paper_notes/section6.md.
//
// Every reference below is computed independently of lib/contact_step.cpp: brute-force grids for
// the facet problem, closed forms and independent quadratures for the kernel.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "contact_step.hpp"
#include "testing.hpp"

using Eigen::MatrixXd;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::VectorXd;
using ltl::Adhesion;
using ltl::ContactPoints;
using ltl::ContactStep;
using ltl::PointSolution;

// ---------------------------------------------------------------------------------------------
// Heap allocation counter (glibc): malloc is interposed so that solve() can be checked to be
// allocation-free. Only counts while g_count_mallocs is set.
// ---------------------------------------------------------------------------------------------
#if defined(__GLIBC__) && !defined(__SANITIZE_ADDRESS__) && !defined(__SANITIZE_THREAD__)
#define LTL_COUNT_MALLOC 1
extern "C" void* __libc_malloc(size_t size);
extern "C" void* __libc_realloc(void* ptr, size_t size);
extern "C" void* __libc_calloc(size_t n, size_t size);
static std::atomic<bool> g_count_mallocs{false};
static std::atomic<long> g_mallocs{0};
extern "C" void* malloc(size_t size) noexcept {
  if (g_count_mallocs.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_malloc(size);
}
extern "C" void* realloc(void* ptr, size_t size) noexcept {
  if (g_count_mallocs.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_realloc(ptr, size);
}
extern "C" void* calloc(size_t n, size_t size) noexcept {
  if (g_count_mallocs.load(std::memory_order_relaxed)) ++g_mallocs;
  return __libc_calloc(n, size);
}
#endif

namespace {

constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------
// Independent reference implementation of the facet problem (6.2), (6.6)-(6.7)
// ---------------------------------------------------------------------------------------------

struct PointProblem {
  Vector3d a = Vector3d::Zero();
  double aa = 0, b = 0, Rqc = 1, kappa = 0;
  Vector3d N = Vector3d::Zero();
  double gap = 0;
  int dim = 2;
};

// (6.2)
double Jc(const PointProblem& F, const Vector3d& e, double g) {
  return 0.5 * F.Rqc * e.squaredNorm() - F.a.dot(e) + 0.5 * F.kappa * g * g * e.squaredNorm() +
         0.5 * F.aa * g * g - F.b * g;
}

// (6.6)-(6.7), written out: e = a/c, moved back to the plane e.N = g when it crosses it.
Vector3d e_of_gamma(const PointProblem& F, double g) {
  const double c = F.Rqc + F.kappa * g * g;
  Vector3d e = F.a / c;
  const double en = e.dot(F.N);
  if (en > F.gap) e -= (en - F.gap) * F.N;
  return e;
}

double reduced(const PointProblem& F, double g) {
  return Jc(F, e_of_gamma(F, g), g);
}

struct Brute {
  double gamma, f;
  int local_minima;  // interior local minima + end-point minima seen on the grid
};

// Grid in gamma (n intervals), then golden-section refinement around the best grid point.
Brute brute_gamma(const PointProblem& F, int n = 20000) {
  std::vector<double> f(n + 1);
  for (int i = 0; i <= n; ++i) f[i] = reduced(F, double(i) / n);
  int best = 0, minima = 0;
  for (int i = 0; i <= n; ++i) {
    if (f[i] < f[best]) best = i;
    const bool left_ok = (i == 0) || f[i] < f[i - 1];
    const bool right_ok = (i == n) || f[i] < f[i + 1];
    if (left_ok && right_ok) ++minima;
  }
  double lo = std::max(0.0, double(best - 1) / n), hi = std::min(1.0, double(best + 1) / n);
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - r * (hi - lo), x2 = lo + r * (hi - lo);
  double f1 = reduced(F, x1), f2 = reduced(F, x2);
  for (int it = 0; it < 80; ++it) {
    if (f1 < f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - r * (hi - lo);
      f1 = reduced(F, x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + r * (hi - lo);
      f2 = reduced(F, x2);
    }
  }
  Brute B{0.5 * (lo + hi), reduced(F, 0.5 * (lo + hi)), minima};
  if (f[best] < B.f) B = Brute{double(best) / n, f[best], minima};
  return B;
}

// A size for absolute tolerances on values of (6.2).
double fscale(const PointProblem& F) {
  return F.a.squaredNorm() / F.Rqc + (F.Rqc + F.kappa) * F.gap * F.gap +
         std::abs(F.a.dot(F.N) * F.gap) + F.aa + std::abs(F.b);
}

PointSolution solve(const PointProblem& F, double beta_current = 1.0) {
  return ContactStep::solve_point(F.a, F.aa, F.b, F.Rqc, F.kappa, F.N, F.gap, F.dim, beta_current);
}

// Brute-force check of the elimination (6.6)-(6.7): at fixed gamma, a grid over the feasible e
// finds nothing better than e(gamma), and its best point is within grid resolution of
// J(e(gamma)). The grid lives in the frame (T1, T2, N): tangentially centred on the tangential
// part of a/c, normally from the plane e.N = g downwards past (a/c).N; it does not use e(gamma).
void check_elimination(const PointProblem& F, double g) {
  const double c = F.Rqc + F.kappa * g * g;
  const Vector3d ustar = F.a / c, estar = e_of_gamma(F, g);
  const double Jstar = Jc(F, estar, g);
  Vector3d T1, T2;
  if (F.dim == 2) {
    T1 = Vector3d(-F.N(1), F.N(0), 0.0);
    T2.setZero();
  } else {
    T1 = F.N.unitOrthogonal();
    T2 = F.N.cross(T1);
  }
  const double half = 0.3 * ustar.norm() + 1e-3 * F.gap + 1e-300;
  const int n = (F.dim == 2) ? 400 : 60;
  const double hstep = 2.0 * half / n;
  const double un = ustar.dot(F.N);
  const int nn = static_cast<int>(std::ceil((std::max(F.gap - un, 0.0) + half) / hstep));
  const int nz = (F.dim == 2) ? 0 : n;
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i)
    for (int k = 0; k <= nz; ++k)
      for (int j = 0; j <= nn; ++j) {
        const double t2 = (F.dim == 2) ? 0.0 : ustar.dot(T2) - half + k * hstep;
        const Vector3d e =
            (ustar.dot(T1) - half + i * hstep) * T1 + t2 * T2 + (F.gap - j * hstep) * F.N;
        best = std::min(best, Jc(F, e, g));
      }
  const double tol = 1e-12 * fscale(F);
  EXPECT_GE(best, Jstar - tol) << "a grid point beats e(gamma) at gamma = " << g;
  EXPECT_LE(best, Jstar + c * hstep * hstep + tol) << "grid min far from J(e(gamma))";
}

// The solution of solve_point against the brute force; returns it.
PointSolution check_point(const PointProblem& F, const char* name) {
  SCOPED_TRACE(name);
  const PointSolution S = solve(F);
  const Brute B = brute_gamma(F);
  const double tol = 1e-10 * fscale(F);
  // beta in [0,1] and e from (6.6)-(6.7) at that beta, feasible.
  EXPECT_GE(S.beta, 0.0);
  EXPECT_LE(S.beta, 1.0);
  const Vector3d e_ref = e_of_gamma(F, S.beta);
  EXPECT_LE((S.e - e_ref).norm(), 1e-13 * (e_ref.norm() + F.gap + 1e-300));
  EXPECT_LE(S.e.dot(F.N), F.gap + 1e-14 * (S.e.norm() + F.gap));
  // Global optimality in gamma: no better value on the fine grid, and the same minimizer.
  const double fS = Jc(F, S.e, S.beta);
  EXPECT_LE(fS, B.f + tol);
  EXPECT_GE(fS, B.f - tol);
  EXPECT_NEAR(S.beta, B.gamma, 1e-6);
  // The elimination of e at a few gammas, including the solution.
  for (double g : {0.0, 0.5, 1.0, S.beta}) check_elimination(F, g);
  return S;
}

// Regime helpers.
bool active(const PointProblem& F, double g) {  // the unconstrained e = a/c violates e.N <= g
  return (F.a / (F.Rqc + F.kappa * g * g)).dot(F.N) > F.gap;
}

PointProblem fig3_point(double beta_prev, Vector3d a, Vector3d N, double gap, int dim) {
  // Fig 3 data: Rqc = 8e9 (R = 8, q_c = 1/eps), kappa = 1e9, w = 0.01, d0 = 1000, |G_s| = 1/28,
  // dt = 5: aa = d0 |G_s| / dt (6.4), b = w + aa beta_prev (6.5) with the centre-point rule,
  // whose neighbour terms are ~1e-14 here.
  PointProblem F;
  F.Rqc = 8e9;
  F.kappa = 1e9;
  F.aa = 1000.0 / 28.0 / 5.0;
  F.b = 0.01 + F.aa * beta_prev;
  F.a = a;
  F.N = N;
  F.gap = gap;
  F.dim = dim;
  return F;
}

const Vector3d kN2(0.0, -1.0, 0.0);                   // 2-D: plane x2 = 0, body above
const Vector3d kN3 = Vector3d(1.0, 2.0, -2.0) / 3.0;  // 3-D: a tilted plane

// ---------------------------------------------------------------------------------------------
// Projection (6.7)
// ---------------------------------------------------------------------------------------------

TEST(ContactProjection, Eq6_7_LandsOnHalfSpaceIsIdempotentAndNearest) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int trial = 0; trial < 2000; ++trial) {
    Vector3d N(U(rng), U(rng), U(rng));
    if (trial % 2 == 0) N(2) = 0.0;  // 2-D normals
    N.normalize();
    const double scale = std::pow(10.0, 6.0 * U(rng));
    const Vector3d x = scale * Vector3d(U(rng), U(rng), U(rng));
    const double gap = (trial % 3 == 0) ? 0.0 : scale * 0.5 * (1.0 + U(rng));
    const Vector3d e = ContactStep::project(x, N, gap);
    const double tol = 1e-15 * 8 * (x.norm() + gap);
    EXPECT_LE(e.dot(N), gap + tol);  // lands on the constraint set
    if (x.dot(N) <= gap) {
      EXPECT_EQ(e, x);  // feasible points are left alone, bit for bit
    } else {
      EXPECT_NEAR(e.dot(N), gap, tol);                      // on the plane
      EXPECT_LE((x - e - (x - e).dot(N) * N).norm(), tol);  // moved along N only
    }
    EXPECT_LE((ContactStep::project(e, N, gap) - e).norm(), tol);  // idempotent
    // Nearest feasible point: random feasible y are never closer.
    for (int k = 0; k < 5; ++k) {
      Vector3d y = x + scale * Vector3d(U(rng), U(rng), U(rng));
      if (y.dot(N) > gap) y -= (y.dot(N) - gap + scale * 1e-3) * N;
      EXPECT_LE((x - e).norm(), (x - y).norm() + tol);
    }
  }
}

TEST(ContactProjection, Eq6_7_PaperFormWithoutGap) {
  // (6.7) with g = 0: a- = a if a.n <= 0, a - (a.n) n otherwise.
  const Vector3d n(0.0, -1.0, 0.0);
  EXPECT_EQ(ContactStep::project(Vector3d(3, 2, 0), n, 0.0), Vector3d(3, 2, 0));
  EXPECT_EQ(ContactStep::project(Vector3d(3, -2, 0), n, 0.0), Vector3d(3, 0, 0));
  // With a gap g: the plane e.N = g.
  EXPECT_TRUE(ContactStep::project(Vector3d(3, -2, 0), n, 0.5).isApprox(Vector3d(3, -0.5, 0)));
  EXPECT_EQ(ContactStep::project(Vector3d(3, -0.25, 0), n, 0.5), Vector3d(3, -0.25, 0));
}

TEST(ContactProjection, Eq6_7_DeepPenetrationStaysFeasibleRelativeToTheResult) {
  // |x| >> |e|: the round-off O(eps |x|) of a one-pass projection would exceed the tolerance of
  // energy() (relative to |e|); the result must be feasible relative to its own size.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int trial = 0; trial < 500; ++trial) {
    Vector3d N(U(rng), U(rng), (trial % 2) ? U(rng) : 0.0);
    N.normalize();
    Vector3d T = N.unitOrthogonal();
    if (trial % 2 == 0) T = Vector3d(-N(1), N(0), 0.0);
    const double gap = (trial % 3 == 0) ? 0.0 : 1e-4;
    const Vector3d x = 1e8 * N + 1e-3 * T;
    const Vector3d e = ContactStep::project(x, N, gap);
    EXPECT_LE(e.dot(N), gap + 1e-14 * (e.norm() + gap));
    const Vector3d d = x - e;  // along N, up to the round-off of x itself
    EXPECT_LE((d - d.dot(N) * N).norm(), 8e-16 * x.norm());
  }
}

// ---------------------------------------------------------------------------------------------
// The facet problem (6.1)-(6.8) against brute force
// ---------------------------------------------------------------------------------------------

TEST(ContactPoint, Eq6_8_ObjectiveMatchesPaperForm) {
  // (6.8) of the paper: aa g^2 - 2 b g - eps |a-|^2 / (g^2 + Rqc eps) = 2 x our reduced objective.
  PointProblem F;
  F.a = Vector3d(0.7, -0.4, 0.0);
  F.aa = 0.3;
  F.b = 0.2;
  F.Rqc = 2.0;
  F.kappa = 5.0;
  F.N = kN2;
  const double eps = 1.0 / F.kappa;
  for (double g : {0.0, 0.3, 1.0}) {
    Vector3d am = F.a;
    if (am.dot(F.N) > 0) am -= am.dot(F.N) * F.N;
    const double paper =
        F.aa * g * g - 2 * F.b * g - eps * am.squaredNorm() / (g * g + F.Rqc * eps);
    EXPECT_NEAR(
        2.0 * ContactStep::reduced_objective(F.a, F.aa, F.b, F.Rqc, F.kappa, F.N, 0.0, 2, g), paper,
        1e-14);
    EXPECT_NEAR(ContactStep::point_objective(F.a, F.aa, F.b, F.Rqc, F.kappa, e_of_gamma(F, g), g),
                reduced(F, g), 1e-14);
  }
}

TEST(ContactPoint, Eq6_1_Order1RegimesIn2D) {
  PointProblem F;
  F.Rqc = 1.0;
  F.kappa = 4.0;
  F.N = kN2;
  F.dim = 2;
  {  // glued: strong Dupre energy, body pulled off the support (constraint inactive)
    F.a = Vector3d(0.3, 0.2, 0.0);
    F.aa = 0.5;
    F.b = 1.0;
    const auto S = check_point(F, "glued, inactive");
    EXPECT_EQ(S.beta, 1.0);
    EXPECT_FALSE(active(F, S.beta));
  }
  {  // partly debonded, pressed onto the support (active, gap 0)
    F.a = Vector3d(1.0, -0.5, 0.0);
    F.aa = 1.0;
    F.b = 0.5;
    const auto S = check_point(F, "partial, active");
    EXPECT_GT(S.beta, 0.05);
    EXPECT_LT(S.beta, 0.95);
    EXPECT_TRUE(active(F, S.beta));
    EXPECT_NEAR(S.e(1), 0.0, 1e-15);
  }
  {  // partly debonded, pulled off (inactive)
    F.a = Vector3d(0.6, 1.2, 0.0);
    F.aa = 0.8;
    F.b = 1.0;
    const auto S = check_point(F, "partial, inactive");
    EXPECT_GT(S.beta, 0.05);
    EXPECT_LT(S.beta, 0.95);
    EXPECT_FALSE(active(F, S.beta));
  }
  {  // fully debonded: b < 0 (neighbours healing in (6.5)) pushes beta to 0
    F.a = Vector3d(0.5, 0.5, 0.0);
    F.aa = 1.0;
    F.b = -0.2;
    const auto S = check_point(F, "debonded");
    EXPECT_EQ(S.beta, 0.0);
    EXPECT_TRUE(S.e.isApprox(F.a / F.Rqc));
  }
  {  // gap g = 0.3: active for small gamma, inactive for large gamma; solution active
    F.gap = 0.3;
    F.a = Vector3d(0.2, -0.8, 0.0);
    F.aa = 0.6;
    F.b = 0.4;
    EXPECT_TRUE(active(F, 0.0));
    EXPECT_FALSE(active(F, 1.0));
    const auto S = check_point(F, "gap, switch inside (0,1)");
    EXPECT_GT(S.beta, 0.0);
    EXPECT_LT(S.beta, 1.0);
  }
  {  // gap, solution glued and the constraint active: e.N = g
    F.gap = 0.1;
    F.a = Vector3d(0.2, -3.0, 0.0);
    F.aa = 0.5;
    F.b = 3.0;
    const auto S = check_point(F, "gap, glued, active");
    EXPECT_EQ(S.beta, 1.0);
    EXPECT_TRUE(active(F, 1.0));
    EXPECT_NEAR(S.e.dot(F.N), F.gap, 1e-15);
  }
}

TEST(ContactPoint, Eq6_1_Order1RegimesIn3D) {
  PointProblem F;
  F.Rqc = 2.0;
  F.kappa = 6.0;
  F.N = kN3;
  F.dim = 3;
  F.a = Vector3d(0.4, -0.3, 0.9);  // a.N < 0: inactive
  F.aa = 0.3;
  F.b = 0.6;
  EXPECT_EQ(check_point(F, "3-D glued").beta, 1.0);
  F.a = Vector3d(1.5, 2.0, -1.0);  // a.N > 0: active at gap 0
  F.aa = 1.0;
  F.b = 0.4;
  {
    const auto S = check_point(F, "3-D partial active");
    EXPECT_TRUE(active(F, S.beta));
    EXPECT_GT(S.beta, 0.0);
    EXPECT_LT(S.beta, 1.0);
  }
  F.b = -0.1;
  EXPECT_EQ(check_point(F, "3-D debonded active").beta, 0.0);
  F.gap = 0.3;  // switch inside (0,1): a.N / c crosses g
  F.a = Vector3d(1.0, 2.0, -2.0) * 0.5 + Vector3d(0.4, -0.2, 0.0);
  F.b = 0.3;
  F.aa = 0.2;
  EXPECT_TRUE(active(F, 0.0));
  EXPECT_FALSE(active(F, 1.0));
  check_point(F, "3-D gap switch");
}

TEST(ContactPoint, Eq6_1_Fig3Magnitudes2D) {
  {  // glued: small pull, beta_prev = 1
    PointProblem F = fig3_point(1.0, Vector3d(2e4, 1e4, 0), kN2, 0.0, 2);
    const auto S = check_point(F, "Fig3 glued");
    EXPECT_EQ(S.beta, 1.0);
    EXPECT_FALSE(active(F, 1.0));
  }
  {  // peeling: partly debonded, inactive
    PointProblem F = fig3_point(1.0, Vector3d(3e5, 1e6, 0), kN2, 0.0, 2);
    const auto S = check_point(F, "Fig3 peeling");
    EXPECT_GT(S.beta, 0.1);
    EXPECT_LT(S.beta, 0.9);
    EXPECT_FALSE(active(F, S.beta));
  }
  {  // pressed onto the support: active, tangential sliding only
    PointProblem F = fig3_point(1.0, Vector3d(5e5, -2e6, 0), kN2, 0.0, 2);
    const auto S = check_point(F, "Fig3 pressed");
    EXPECT_GT(S.beta, 0.1);
    EXPECT_LT(S.beta, 0.9);
    EXPECT_TRUE(active(F, S.beta));
    EXPECT_EQ(S.e(1), 0.0);
  }
  {  // debonded: beta_prev = 0 and b < 0
    PointProblem F = fig3_point(0.0, Vector3d(3e5, 1e6, 0), kN2, 0.0, 2);
    F.b = -0.5;
    EXPECT_EQ(check_point(F, "Fig3 debonded").beta, 0.0);
    // beta_prev = 0, b = w > 0: beta stays small but positive, ~ w / (aa + kappa |e|^2)
    F.b = 0.01;
    const auto S = check_point(F, "Fig3 almost debonded");
    EXPECT_GT(S.beta, 0.0);
    EXPECT_LT(S.beta, 1e-3);
  }
  {  // gap 1e-4 m: active for gamma < 1/sqrt(2), solution active
    PointProblem F = fig3_point(1.0, Vector3d(1e5, -8.5e5, 0), kN2, 1e-4, 2);
    EXPECT_TRUE(active(F, 0.0));
    EXPECT_FALSE(active(F, 1.0));
    const auto S = check_point(F, "Fig3 gap active");
    EXPECT_LT(S.beta, std::sqrt(0.5));
    EXPECT_TRUE(active(F, S.beta));
    EXPECT_NEAR(S.e.dot(F.N), 1e-4, 1e-18);
  }
  {  // gap 1e-4 m, never active
    PointProblem F = fig3_point(1.0, Vector3d(1e5, -5e5, 0), kN2, 1e-4, 2);
    const auto S = check_point(F, "Fig3 gap inactive");
    EXPECT_FALSE(active(F, 0.0));
    EXPECT_TRUE(S.e.isApprox(F.a / (F.Rqc + F.kappa * S.beta * S.beta), 1e-15));
  }
}

TEST(ContactPoint, Eq6_1_Fig3Magnitudes3D) {
  PointProblem F = fig3_point(1.0, Vector3d(3e5, -4e5, 9e5), kN3, 0.0, 3);
  check_point(F, "3-D Fig3 inactive");
  F.a = Vector3d(1e6, 2e6, -1e6);  // a.N > 0
  EXPECT_TRUE(active(F, check_point(F, "3-D Fig3 active").beta));
  F.gap = 2e-4;
  F.a = 1e6 * kN3 * 1.7 + Vector3d(2e5, 0, 2e5);
  check_point(F, "3-D Fig3 gap");
}

TEST(ContactPoint, Eq6_8_NonConvexTwoMinimaTakesTheBest) {
  // f(gamma) = -|a|^2 / (2 (Rqc + kappa gamma^2)) + aa gamma^2 / 2 - b gamma, kappa = 100:
  // the glue term makes a bump in f' near gamma = 1/sqrt(3 kappa), hence two local minima.
  PointProblem F;
  F.Rqc = 1.0;
  F.kappa = 100.0;
  F.N = kN2;
  F.a = Vector3d(0.0, 1.0, 0.0);  // |a| = 1, pulled off: inactive
  {                               // local minimum near 0.0106, global minimum at the end point 1
    F.aa = 0.0;
    F.b = 1.0;
    const Brute B = brute_gamma(F);
    EXPECT_EQ(B.local_minima, 2);
    const auto S = check_point(F, "two minima: interior (local) and 1 (global)");
    EXPECT_EQ(S.beta, 1.0);
    EXPECT_LT(reduced(F, 1.0), reduced(F, 0.0106) - 0.4);  // the first local minimum is wrong
  }
  {  // two interior minima, near 0.015 (local) and 0.75 (global)
    F.aa = 2.0;
    F.b = 1.5;
    EXPECT_EQ(brute_gamma(F).local_minima, 2);
    const auto S = check_point(F, "two interior minima, the second is global");
    EXPECT_GT(S.beta, 0.5);
    EXPECT_LT(S.beta, 0.9);
  }
  {  // two interior minima, the first is global (a "last minimum" rule would be wrong)
    F.a = Vector3d(0.0, 2.0, 0.0);
    F.aa = 2.0;
    F.b = 1.5;
    EXPECT_EQ(brute_gamma(F).local_minima, 2);
    const auto S = check_point(F, "two interior minima, the first is global");
    EXPECT_GT(S.beta, 0.0);
    EXPECT_LT(S.beta, 0.1);
  }
  {  // the same in 3-D with the constraint active and a gap
    PointProblem G = F;
    G.dim = 3;
    G.N = kN3;
    G.gap = 0.05;
    G.a = 3.0 * kN3 + Vector3d(0.6, 0.0, 0.3);
    G.aa = 0.0;
    G.b = 0.8;
    EXPECT_EQ(brute_gamma(G).local_minima, 2);
    check_point(G, "3-D two minima, active");
  }
}

// Golden-section minimum of (6.8) on [lo, hi] (unimodal there).
double min_on(const PointProblem& F, double lo, double hi) {
  const double r = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - r * (hi - lo), x2 = lo + r * (hi - lo), f1 = reduced(F, x1), f2 = reduced(F, x2);
  for (int it = 0; it < 200; ++it) {
    if (f1 < f2) {
      hi = x2, x2 = x1, f2 = f1, x1 = hi - r * (hi - lo), f1 = reduced(F, x1);
    } else {
      lo = x1, x1 = x2, f1 = f2, x2 = lo + r * (hi - lo), f2 = reduced(F, x2);
    }
  }
  return std::min(f1, f2);
}

TEST(ContactPoint, Eq6_8_EqualMinimaGoToTheLargerGamma) {
  // Two interior minima (near 0.015 and 0.69) made equal by bisection on b: the tie goes to the
  // larger gamma (the glue stays); a difference of 1e-9 in b (1e-9 in f) is not a tie.
  PointProblem F;
  F.Rqc = 1.0;
  F.kappa = 100.0;
  F.N = kN2;
  F.a = Vector3d(0.0, 1.0, 0.0);
  F.aa = 2.0;
  double lo = 1.3, hi = 1.5;  // diff(b) = min on [0.3,1] - min on [0,0.1], decreasing in b
  for (int it = 0; it < 200; ++it) {
    F.b = 0.5 * (lo + hi);
    (min_on(F, 0.3, 1.0) - min_on(F, 0.0, 0.1) > 0.0 ? lo : hi) = F.b;
  }
  F.b = 0.5 * (lo + hi);
  EXPECT_NEAR(min_on(F, 0.3, 1.0), min_on(F, 0.0, 0.1), 1e-15);
  const double b_tie = F.b;
  EXPECT_GT(solve(F).beta, 0.6);
  F.b = b_tie + 1e-9;
  EXPECT_GT(solve(F).beta, 0.6);
  F.b = b_tie - 1e-9;
  EXPECT_LT(solve(F).beta, 0.05);
  EXPECT_GT(solve(F).beta, 0.0);
}

TEST(ContactPoint, Eq6_8_RandomFacetsAcrossMagnitudesMatchBruteForce) {
  // Rqc from 1e-6 to 1e6, kappa / Rqc from 1e-6 to 1e6, gaps, both dimensions, aa = 0 or not,
  // b of both signs: the solution is never worse than a grid + golden-section search.
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  for (int t = 0; t < 400; ++t) {
    PointProblem F;
    F.dim = 2 + t % 2;
    F.N = Vector3d(U(rng), U(rng), F.dim == 3 ? U(rng) : 0.0).normalized();
    F.Rqc = std::pow(10.0, 6.0 * U(rng));
    F.kappa = F.Rqc * std::pow(10.0, 6.0 * U(rng));
    F.a =
        F.Rqc * std::pow(10.0, 3.0 * U(rng)) * Vector3d(U(rng), U(rng), F.dim == 3 ? U(rng) : 0.0);
    F.gap = (t % 3 == 0) ? 0.0 : std::abs(U(rng)) * F.a.norm() / F.Rqc;
    const double fs = F.a.squaredNorm() / F.Rqc * (F.kappa / (F.Rqc + F.kappa));
    F.aa = (t % 5 == 0) ? 0.0 : std::abs(U(rng)) * fs * std::pow(10.0, 2.0 * U(rng));
    F.b = U(rng) * fs * std::pow(10.0, 2.0 * U(rng));
    const PointSolution S = solve(F);
    const Brute B = brute_gamma(F, 2000);
    EXPECT_LE(Jc(F, S.e, S.beta), B.f + 1e-12 * fscale(F)) << "case " << t;
    EXPECT_LE((S.e - e_of_gamma(F, S.beta)).norm(), 1e-13 * (S.e.norm() + F.gap + 1e-300));
  }
}

TEST(ContactPoint, Eq6_8_NoGlueKappaZero) {
  // kappa = 0: e = projection of a / Rqc; beta minimizes (aa/2) g^2 - b g on [0,1].
  PointProblem F;
  F.Rqc = 3.0;
  F.N = kN2;
  F.a = Vector3d(0.3, -0.9, 0.0);
  F.aa = 2.0;
  F.b = 0.5;
  auto S = solve(F);
  EXPECT_EQ(S.beta, 0.25);
  EXPECT_EQ(S.e, ContactStep::project(F.a / 3.0, F.N, 0.0));
  F.b = 5.0;
  EXPECT_EQ(solve(F).beta, 1.0);
  F.b = -1.0;
  EXPECT_EQ(solve(F).beta, 0.0);
  F.aa = 0.0;
  F.b = 1e-3;
  EXPECT_EQ(solve(F).beta, 1.0);
  F.b = -1e-3;
  EXPECT_EQ(solve(F).beta, 0.0);
  // aa = b = 0: beta is arbitrary and is kept.
  F.b = 0.0;
  EXPECT_EQ(solve(F, 0.37).beta, 0.37);
  EXPECT_EQ(solve(F, 0.0).beta, 0.0);
  EXPECT_EQ(solve(F, 1.0).beta, 1.0);
}

TEST(ContactPoint, Eq6_8_ConstantObjectiveKeepsBetaAndTiesGoUp) {
  // kappa > 0 but (6.8) constant in gamma: a pressed straight into the support (a_T = 0, g = 0,
  // so e = 0 for every gamma) and aa = b = 0. beta is kept.
  PointProblem F;
  F.Rqc = 1.0;
  F.kappa = 10.0;
  F.N = kN2;
  F.a = Vector3d(0.0, -2.0, 0.0);
  EXPECT_EQ(solve(F, 0.42).beta, 0.42);
  F.a.setZero();  // no load at all
  EXPECT_EQ(solve(F, 0.8).beta, 0.8);
  // Exactly flat in the active regime but a constant pull b > 0: beta = 1.
  F.a = Vector3d(0.0, -2.0, 0.0);
  F.b = 0.1;
  EXPECT_EQ(solve(F, 0.2).beta, 1.0);
  // Same, with aa = 2 b: f = b g (g - 1) + const, equal at both ends; the minimum is 1/2.
  F.aa = 0.2;
  EXPECT_DOUBLE_EQ(solve(F, 0.2).beta, 0.5);
}

// ---------------------------------------------------------------------------------------------
// The kernel (1.6), (6.4)-(6.5)
// ---------------------------------------------------------------------------------------------

// Segments [x_k, x_{k+1}] on the line x2 = 0, the body above (N = (0,-1)).
ContactPoints line_surface(const std::vector<double>& x) {
  const int n = static_cast<int>(x.size()) - 1;
  ContactPoints S;
  S.dim = 2;
  S.area.resize(n);
  S.centre.resize(2, n);
  S.gap = VectorXd::Zero(n);
  S.N = Vector2d(0.0, -1.0);
  S.vertices.assign(2, MatrixXd(2, n));
  for (int s = 0; s < n; ++s) {
    S.area(s) = x[s + 1] - x[s];
    S.centre.col(s) << 0.5 * (x[s] + x[s + 1]), 0.0;
    S.vertices[0].col(s) << x[s], 0.0;
    S.vertices[1].col(s) << x[s + 1], 0.0;
  }
  return S;
}

ContactPoints fig3_surface() {
  std::vector<double> x(29);
  for (int k = 0; k <= 28; ++k) x[k] = k / 28.0;
  return line_surface(x);
}

Adhesion fig3_adhesion(bool exact) {
  Adhesion A;
  A.w = 0.01;
  A.kappa = 1e9;
  A.d0 = 1000.0;
  A.dt = 5.0;
  A.exact_kernel = exact;
  return A;
}

using ltl::testing::quad;

TEST(ContactKernel, Eq6_4_Eq6_5_CentrePointRule) {
  const ContactPoints S = line_surface({0.0, 0.01, 0.03, 0.035, 0.06});
  Adhesion A = fig3_adhesion(false);
  A.d0 = 50.0;
  const ContactStep cs(S, A, 8e9);
  const MatrixXd k(cs.kernel());
  for (int s = 0; s < 4; ++s)
    for (int t = 0; t < 4; ++t) {
      const double d = std::abs(S.centre(0, s) - S.centre(0, t));
      EXPECT_DOUBLE_EQ(k(s, t), 50.0 * std::exp(-50.0 * d) * S.area(t));  // d(x_s - x_t) |G_t|
      EXPECT_NEAR(S.area(s) * k(s, t), S.area(t) * k(t, s), 1e-15);       // |G_s| k symmetric
    }
  EXPECT_DOUBLE_EQ(k(1, 1), 50.0 * 0.02);  // (6.4): aa dt = d(0) |G_s|
}

TEST(ContactKernel, Eq1_6_ExactSelfTermClosedFormAndQuadrature) {
  // (1/h) int_0^h int_0^h d0 e^{-d0|x-y|} dy dx = 2 (1 - (1 - e^{-d0 h}) / (d0 h)).
  for (double d0h : {1e-4, 0.01, 0.5, 1.0, 5.0, 1000.0 / 28.0, 300.0}) {
    const double h = 0.1, d0 = d0h / h;
    const ContactPoints S = line_surface({0.0, h});
    Adhesion A;
    A.d0 = d0;
    A.exact_kernel = true;
    const double k = ContactStep(S, A, 1.0).kernel().coeff(0, 0);
    const long double x = d0h;  // long double: the closed form cancels for small d0 h
    const double closed = static_cast<double>(2.0L * (1.0L - (-std::expm1(-x)) / x));
    EXPECT_NEAR(k, closed, 1e-12 * closed) << "d0 h = " << d0h;
    // Independent quadrature: int_{-h}^{h} d0 e^{-d0|t|} (h - |t|) dt / h.
    const double q =
        2.0 * quad([&](double t) { return d0 * std::exp(-d0 * t) * (h - t); }, 0.0, h, 400) / h;
    EXPECT_NEAR(k, q, 1e-12 * q) << "d0 h = " << d0h;
    // And a crude 2-D midpoint rule (n x n), which does not know about the kink at x = y.
    if (d0h < 10) {
      const int n = 600;
      double mid = 0.0;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) mid += d0 * std::exp(-d0 * std::abs(i - j) * h / n);
      mid *= (h / n) * (h / n) / h;
      EXPECT_NEAR(k, mid, 2e-3 * k) << "d0 h = " << d0h;
    }
  }
}

TEST(ContactKernel, Eq1_6_ExactCollinearPairs) {
  // Unequal, disjoint and touching collinear segments: the closed form
  //   int_P int_Q = e^{-d0 delta} (1 - e^{-d0 hp}) (1 - e^{-d0 hq}) / d0,  delta = gap between,
  // against an independent quadrature of the double integral.
  const std::vector<double> x = {0.0, 0.02, 0.05, 0.051, 0.09};
  const ContactPoints S = line_surface(x);
  Adhesion A;
  A.d0 = 60.0;
  A.exact_kernel = true;
  const ContactStep cs(S, A, 1.0);
  const MatrixXd k(cs.kernel());
  const double d0 = A.d0;
  for (int s = 0; s < 4; ++s)
    for (int t = 0; t < 4; ++t) {
      EXPECT_NEAR(S.area(s) * k(s, t), S.area(t) * k(t, s), 1e-16);
      if (s == t) continue;
      const double hp = S.area(s), hq = S.area(t);
      const double delta = std::max(x[s], x[t]) - std::min(x[s + 1], x[t + 1]);
      const double I =
          std::exp(-d0 * delta) * (-std::expm1(-d0 * hp)) * (-std::expm1(-d0 * hq)) / d0;
      EXPECT_NEAR(k(s, t), I / hp, 1e-13 * I / hp);
      const double Iq = quad(
          [&](double xx) {
            return quad([&](double yy) { return d0 * std::exp(-d0 * std::abs(xx - yy)); }, x[t],
                        x[t + 1], 20);
          },
          x[s], x[s + 1], 20);
      EXPECT_NEAR(k(s, t), Iq / hp, 1e-10 * Iq / hp);
    }
}

TEST(ContactKernel, Eq1_6_Fig3SurfaceNumbers) {
  // The numbers quoted in paper_notes/section6.md: 28 segments of 1/28 m, d0 = 1000 /m.
  const ContactPoints S = fig3_surface();
  const ContactStep cp(S, fig3_adhesion(false), 8e9), ex(S, fig3_adhesion(true), 8e9);
  const MatrixXd kc(cp.kernel()), ke(ex.kernel());
  const double x = 1000.0 / 28.0;  // d0 h
  EXPECT_NEAR(kc(0, 0), 35.714285714285715, 1e-12);
  EXPECT_NEAR(ke(0, 0), 2.0 * (1.0 - (1.0 - std::exp(-x)) / x), 1e-13);
  EXPECT_NEAR(ke(0, 0), 1.944, 1e-12);
  EXPECT_NEAR(kc(0, 1), x * std::exp(-x), 1e-25);  // 1.10e-14
  EXPECT_NEAR(ke(0, 1), 0.028, 1e-12);             // (1 - e^{-x})^2 / x
  EXPECT_NEAR(ke(0, 2), std::exp(-x) / x * std::pow(-std::expm1(-x), 2), 1e-28);
  EXPECT_NEAR(kc.row(14).sum(), 35.714285714285715, 1e-12);  // d0 h, no coupling
  EXPECT_NEAR(ke.row(14).sum(), 2.0, 1e-12);                 // int_R d = 2
  EXPECT_NEAR(ke.row(0).sum(), 1.972, 1e-12);                // 2 - 1/(d0 h): the free end
  EXPECT_NEAR(kc(0, 0) / ke(0, 0), 18.37, 0.01);
}

// Independent references for 2-D non-collinear pairs.
double L_shape_reference(double h, double d0) {
  // P = [(0,0),(h,0)], Q = [(0,0),(0,h)]: int_0^h int_0^h d0 e^{-d0 sqrt(s^2+t^2)} ds dt in polar
  // coordinates: 2 int_0^{pi/4} phi2(d0 h / cos th) / d0 dth, phi2(x) = 1 - (1+x) e^{-x}.
  auto phi2 = [](double x) { return -std::expm1(-x) - x * std::exp(-x); };
  return 2.0 * quad([&](double th) { return phi2(d0 * h / std::cos(th)) / d0; }, 0.0, kPi / 4, 40);
}

TEST(ContactKernel, Eq1_6_ExactNonCollinear2D) {
  const double h = 0.05;
  for (double d0 : {2.0, 40.0, 700.0}) {
    ContactPoints S = line_surface({0.0, h});  // two facets, edited below
    S.area = VectorXd::Constant(2, h);
    S.centre = MatrixXd::Zero(2, 2);
    S.gap = VectorXd::Zero(2);
    S.vertices.assign(2, MatrixXd(2, 2));
    S.vertices[0].col(0) << h, 0.0;  // P from (h,0) to (0,0)
    S.vertices[1].col(0) << 0.0, 0.0;
    S.vertices[0].col(1) << 0.0, 0.0;  // Q from (0,0) to (0,h)
    S.vertices[1].col(1) << 0.0, h;
    Adhesion A;
    A.d0 = d0;
    A.exact_kernel = true;
    const ContactStep cs(S, A, 1.0);
    const double ref = L_shape_reference(h, d0);
    EXPECT_NEAR(cs.kernel().coeff(0, 1) * h, ref, 1e-9 * ref) << "d0 = " << d0;
    EXPECT_EQ(cs.kernel().coeff(0, 1), cs.kernel().coeff(1, 0));
  }
  {  // separated, tilted segments: smooth integrand, tensor Gauss reference
    ContactPoints S = line_surface({0.0, 0.1});
    S.area = VectorXd::Constant(2, 0.1);
    S.centre = MatrixXd::Zero(2, 2);
    S.gap = VectorXd::Zero(2);
    S.vertices.assign(2, MatrixXd(2, 2));
    const Vector2d p0(0, 0), p1(0.1, 0), q0(0.13, 0.01), q1(0.13 + 0.06, 0.01 + 0.08);
    S.vertices[0].col(0) = p0;
    S.vertices[1].col(0) = p1;
    S.vertices[0].col(1) = q0;
    S.vertices[1].col(1) = q1;
    Adhesion A;
    A.d0 = 30.0;
    A.exact_kernel = true;
    const ContactStep cs(S, A, 1.0);
    const double ref =
        quad(
            [&](double s) {
              return quad(
                  [&](double t) {
                    return A.d0 *
                           std::exp(-A.d0 * ((p0 + s * (p1 - p0)) - (q0 + t * (q1 - q0))).norm());
                  },
                  0, 1, 8);
            },
            0, 1, 8) *
        0.1 * 0.1;
    EXPECT_NEAR(cs.kernel().coeff(0, 1) * 0.1, ref, 1e-11 * ref);
  }
  {  // nearly collinear (tilt 1e-6): the quadrature path agrees with the collinear closed form
    ContactPoints S = line_surface({0.0, 0.05, 0.1});
    const double tilt = 1e-6;
    S.vertices[1].col(1) << 0.05 + 0.05 * std::cos(tilt), 0.05 * std::sin(tilt);
    Adhesion A;
    A.d0 = 100.0;
    A.exact_kernel = true;
    const double k01 = ContactStep(S, A, 1.0).kernel().coeff(0, 1);
    const double closed = std::pow(-std::expm1(-5.0), 2) / 100.0 / 0.05;
    EXPECT_NEAR(k01, closed, 1e-9 * closed);
  }
}

// 3-D: unit squares scaled by h. References from the covariogram of squares:
//   int_P int_Q f(|x-y|) dy dx = int f(|v|) |P cap (Q - v)| dv.
double square_self_reference(double h, double d0) {
  // 8 int_0^{pi/4} int_0^{h/cos th} f(r) (h - r cos th)(h - r sin th) r dr dth.
  return 8.0 *
         quad(
             [&](double th) {
               const double c = std::cos(th), s = std::sin(th);
               return quad(
                   [&](double r) { return d0 * std::exp(-d0 * r) * (h - r * c) * (h - r * s) * r; },
                   0.0, h / c, 16);
             },
             0.0, kPi / 4, 4);
}

double square_neighbour_reference(double h, double d0) {
  // P = [0,h]^2, Q = [h,2h] x [0,h]: 2 int_0^h int_0^{2h} f(|v|) tent(v1 - h) (h - v2) dv1 dv2.
  auto f = [&](double r) { return d0 * std::exp(-d0 * r); };
  // v1 in [0,h] (tent = v1): polar around the origin over [0,h]^2, weight v1 (h - v2).
  const double near = 2.0 * quad(
                                [&](double th) {
                                  return quad(
                                      [&](double r) {
                                        const double a = r * std::cos(th), b = r * std::sin(th);
                                        // both orientations of the triangle split
                                        return f(r) * r * (a * (h - b) + b * (h - a));
                                      },
                                      0.0, h / std::cos(th), 16);
                                },
                                0.0, kPi / 4, 4);
  // v1 in [h,2h] (tent = 2h - v1): smooth.
  const double far =
      2.0 *
      quad(
          [&](double v2) {
            return quad([&](double v1) { return f(std::hypot(v1, v2)) * (2 * h - v1) * (h - v2); },
                        h, 2 * h, 8);
          },
          0.0, h, 8);
  return near + far;
}

double square_folded_reference(double h, double d0) {
  // P = [0,h]^2 in z = 0, Q = {x = 0, y in [0,h], z in [0,h]} (a right-angle fold along y):
  // 4 int_0^h (h - t) int_0^{pi/4} [H(t) - H(sqrt(t^2 + h^2/cos^2 th))] dth dt,
  // H(r) = (r + 1/d0) e^{-d0 r}.
  auto H = [&](double r) { return (r + 1.0 / d0) * std::exp(-d0 * r); };
  return 4.0 * quad(
                   [&](double t) {
                     return (h - t) *
                            quad(
                                [&](double th) {
                                  return H(t) -
                                         H(std::sqrt(t * t + h * h / std::pow(std::cos(th), 2)));
                                },
                                0.0, kPi / 4, 4);
                   },
                   0.0, h, 16);
}

TEST(ContactKernel, Eq1_6_Exact3DQuadrilaterals) {
  const double h = 0.5;
  for (double d0 : {0.2, 4.0, 20.0}) {
    SCOPED_TRACE(d0);
    ContactPoints S;
    S.dim = 3;
    const int n = 3;
    S.area = VectorXd::Constant(n, h * h);
    S.centre = MatrixXd::Zero(3, n);
    S.gap = VectorXd::Zero(n);
    S.N = Vector3d(0, 0, -1);
    S.vertices.assign(4, MatrixXd(3, n));
    for (int s = 0; s < 2; ++s) {  // [0,h]^2 and [h,2h] x [0,h] in z = 0
      const double x0 = s * h;
      S.vertices[0].col(s) << x0, 0, 0;
      S.vertices[1].col(s) << x0 + h, 0, 0;
      S.vertices[2].col(s) << x0 + h, h, 0;
      S.vertices[3].col(s) << x0, h, 0;
    }
    S.vertices[0].col(2) << 0, 0, 0;  // folded up along the edge x = 0
    S.vertices[1].col(2) << 0, h, 0;
    S.vertices[2].col(2) << 0, h, h;
    S.vertices[3].col(2) << 0, 0, h;
    Adhesion A;
    A.d0 = d0;
    A.exact_kernel = true;
    const ContactStep cs(S, A, 1.0);
    const MatrixXd k(cs.kernel());
    const double A2 = h * h;
    const double self = square_self_reference(h, d0) / A2;
    const double nb = square_neighbour_reference(h, d0) / A2;
    const double fold = square_folded_reference(h, d0) / A2;
    EXPECT_NEAR(k(0, 0), self, 5e-8 * self);
    EXPECT_NEAR(k(1, 1), self, 5e-8 * self);
    EXPECT_NEAR(k(2, 2), self, 5e-8 * self);
    EXPECT_NEAR(k(0, 1), nb, 5e-8 * nb);
    EXPECT_NEAR(k(0, 2), fold, 5e-8 * fold);
    for (int s = 0; s < n; ++s)
      for (int t = 0; t < n; ++t) EXPECT_EQ(k(s, t), k(t, s));  // equal areas: symmetric
  }
}

TEST(ContactKernel, Eq1_6_ZeroWhenNoDissipation) {
  Adhesion A = fig3_adhesion(true);
  A.d0 = 0.0;
  const ContactPoints S = fig3_surface();  // the step keeps a reference: S outlives it
  const ContactStep cs(S, A, 8e9);
  EXPECT_EQ(cs.kernel().rows(), 28);
  EXPECT_EQ(cs.kernel().norm(), 0.0);
  EXPECT_EQ(cs.kernel().nonZeros(), 0);  // nothing stored (the memory test: test_memory.cpp)
}

// ---------------------------------------------------------------------------------------------
// The sweep (4.7), sec. 6, and the discrete functional (2.2), (4.10)
// ---------------------------------------------------------------------------------------------

struct SweepData {
  MatrixXd ubar, lambda_c, e;
  VectorXd beta_prev, beta;
};

SweepData random_data(const ContactPoints& S, double u_scale, double lambda_scale, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> U(-1.0, 1.0), P(0.0, 1.0);
  const int n = S.size(), dim = S.dim;
  SweepData D;
  // Drawn dim x #points (the draws of the earlier layout), stored #points x dim like u.
  D.ubar = u_scale * MatrixXd::NullaryExpr(dim, n, [&]() { return U(rng); }).transpose();
  D.lambda_c = lambda_scale * MatrixXd::NullaryExpr(dim, n, [&]() { return U(rng); }).transpose();
  D.beta_prev = VectorXd::NullaryExpr(n, [&]() { return P(rng); });
  D.beta = VectorXd::NullaryExpr(n, [&]() { return P(rng); });
  D.e = MatrixXd::Zero(n, dim);  // feasible when gap >= 0
  return D;
}

// The local functional written out independently: sum_s |G_s| [(Rqc/2)|e|^2 - a.e
// + (kappa/2) beta^2 |e|^2 - w beta] + (1/(2 dt)) sum sum |G_s| k_ss' db_s db_s'.
double local_J(const ContactStep& cs, double Rqc, const SweepData& D) {
  const ContactPoints& S = cs.points();
  const Adhesion& A = cs.adhesion();
  const MatrixXd k(cs.kernel());
  double J = 0.0;
  for (int s = 0; s < S.size(); ++s) {
    const VectorXd a = (Rqc * D.ubar.row(s) - D.lambda_c.row(s)).transpose();
    const double e2 = D.e.row(s).squaredNorm(), b = D.beta(s);
    J += S.area(s) *
         (0.5 * Rqc * e2 - a.dot(D.e.row(s).transpose()) + 0.5 * A.kappa * b * b * e2 - A.w * b);
    for (int t = 0; t < S.size(); ++t)
      J += S.area(s) * k(s, t) * (D.beta(s) - D.beta_prev(s)) * (D.beta(t) - D.beta_prev(t)) /
           (2.0 * A.dt);
  }
  return J;
}

// Per-facet data (6.3)-(6.5) computed in the test from the kernel.
PointProblem facet_data(const ContactStep& cs, double Rqc, const SweepData& D, int s) {
  const ContactPoints& S = cs.points();
  const Adhesion& A = cs.adhesion();
  const MatrixXd k(cs.kernel());
  PointProblem F;
  F.dim = S.dim;
  F.a.setZero();
  F.a.head(S.dim) = (Rqc * D.ubar.row(s) - D.lambda_c.row(s)).transpose();
  F.N.setZero();
  F.N.head(S.dim) = S.N.normalized();
  F.gap = S.gap(s);
  F.Rqc = Rqc;
  F.kappa = A.kappa;
  F.aa = k(s, s) / A.dt;
  F.b = A.w + k(s, s) * D.beta_prev(s) / A.dt;
  for (int t = 0; t < S.size(); ++t)
    if (t != s) F.b -= k(s, t) * (D.beta(t) - D.beta_prev(t)) / A.dt;
  return F;
}

ContactPoints grid3d(int nx, int ny, double h, double gap) {
  ContactPoints S;
  S.dim = 3;
  const int n = nx * ny;
  S.area = VectorXd::Constant(n, h * h);
  S.centre.resize(3, n);
  S.gap = VectorXd::Constant(n, gap);
  S.N = Vector3d(0, 0, -1);
  S.vertices.assign(4, MatrixXd(3, n));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const int s = i + nx * j;
      S.centre.col(s) << (i + 0.5) * h, (j + 0.5) * h, 0;
      S.vertices[0].col(s) << i * h, j * h, 0;
      S.vertices[1].col(s) << (i + 1) * h, j * h, 0;
      S.vertices[2].col(s) << (i + 1) * h, (j + 1) * h, 0;
      S.vertices[3].col(s) << i * h, (j + 1) * h, 0;
    }
  return S;
}

struct SweepCase {
  const char* name;
  ContactPoints S;
  Adhesion A;
  double Rqc, u_scale, lambda_scale;
};

std::vector<SweepCase> sweep_cases() {
  std::vector<SweepCase> C;
  C.push_back({"Fig3 centre-point", fig3_surface(), fig3_adhesion(false), 8e9, 3e-4, 1e5});
  C.push_back({"Fig3 exact kernel", fig3_surface(), fig3_adhesion(true), 8e9, 3e-4, 1e5});
  {  // O(1), strongly non-convex facets, coupled kernel, gaps
    std::vector<double> x(13);
    for (int k = 0; k <= 12; ++k) x[k] = 0.1 * k;
    ContactPoints S = line_surface(x);
    for (int s = 0; s < 12; ++s) S.gap(s) = 0.05 * (s % 3);
    Adhesion A;
    A.w = 0.3;
    A.kappa = 100.0;
    A.d0 = 5.0;
    A.dt = 0.7;
    C.push_back({"O(1) non-convex", S, A, 1.0, 1.0, 0.5});
  }
  {  // 3-D, 4 x 3 quads, centre-point rule, gap
    Adhesion A;
    A.w = 0.2;
    A.kappa = 20.0;
    A.d0 = 3.0;
    A.dt = 1.0;
    C.push_back({"3-D quads", grid3d(4, 3, 0.25, 0.02), A, 2.0, 0.5, 0.3});
  }
  return C;
}

TEST(ContactSweep, Sec6_GaussSeidelInFacetOrderWithNewestBeta) {
  // One sweep of solve() is exactly the sequence of solve_point calls with (6.3)-(6.5) rebuilt
  // from the newest beta of the other facets.
  for (auto& C : sweep_cases()) {
    SCOPED_TRACE(C.name);
    const ContactStep cs(C.S, C.A, C.Rqc);
    SweepData D = random_data(C.S, C.u_scale, C.lambda_scale, 11);
    SweepData R = D;
    cs.solve(D.ubar, D.lambda_c, D.beta_prev, D.e, D.beta, 1);
    for (int s = 0; s < C.S.size(); ++s) {
      const PointProblem F = facet_data(cs, C.Rqc, R, s);
      const PointSolution sol = solve(F, R.beta(s));
      R.beta(s) = sol.beta;
      R.e.row(s) = sol.e.head(C.S.dim).transpose();
    }
    EXPECT_LE((D.beta - R.beta).lpNorm<Eigen::Infinity>(), 1e-12);
    EXPECT_LE((D.e - R.e).norm(), 1e-12 * (R.e.norm() + 1e-300));
    // And differs from a Jacobi sweep (every facet seeing the old beta) when d0 > 0.
    SweepData Jd = random_data(C.S, C.u_scale, C.lambda_scale, 11);
    const SweepData J0 = Jd;
    for (int s = 0; s < C.S.size(); ++s)
      Jd.beta(s) = solve(facet_data(cs, C.Rqc, J0, s), J0.beta(s)).beta;
    if (std::string(C.name) != "Fig3 centre-point") {
      EXPECT_GT((Jd.beta - D.beta).norm(), 1e-9);
    }
  }
}

TEST(ContactSweep, Eq4_7_SweepsDecreaseTheLocalFunctionalAndReachAFixedPoint) {
  for (auto& C : sweep_cases()) {
    SCOPED_TRACE(C.name);
    const ContactStep cs(C.S, C.A, C.Rqc);
    for (unsigned seed = 1; seed <= 6; ++seed) {
      SweepData D = random_data(C.S, C.u_scale, C.lambda_scale, seed);
      double J = local_J(cs, C.Rqc, D);
      EXPECT_NEAR(cs.local_objective(D.ubar, D.lambda_c, D.beta_prev, D.e, D.beta), J,
                  1e-12 * std::abs(J) + 1e-300);
      const double Jscale = std::abs(J) + 1.0;
      for (int sweep = 0; sweep < 30; ++sweep) {
        cs.solve(D.ubar, D.lambda_c, D.beta_prev, D.e, D.beta, 1);
        const double Jn = local_J(cs, C.Rqc, D);
        EXPECT_LE(Jn, J + 1e-13 * Jscale) << "sweep " << sweep;  // monotone
        J = Jn;
        // Always admissible.
        EXPECT_GE(D.beta.minCoeff(), 0.0);
        EXPECT_LE(D.beta.maxCoeff(), 1.0);
        EXPECT_TRUE(std::isfinite(cs.energy(D.e, D.beta, D.beta_prev)));
      }
      // Fixed point: sweep until nothing changes, then each facet is optimal for its (6.1)
      // against the brute-force minimization of (6.8).
      double change = 1.0;
      for (int sweep = 0; sweep < 5000 && change > 1e-14; ++sweep) {
        const VectorXd beta = D.beta;
        cs.solve(D.ubar, D.lambda_c, D.beta_prev, D.e, D.beta, 1);
        change = (D.beta - beta).lpNorm<Eigen::Infinity>();
      }
      EXPECT_LE(change, 1e-14);
      for (int s = 0; s < C.S.size(); ++s) {
        const PointProblem F = facet_data(cs, C.Rqc, D, s);
        const Brute B = brute_gamma(F, 2000);
        EXPECT_LE(reduced(F, D.beta(s)), B.f + 1e-10 * fscale(F)) << "facet " << s;
        Vector3d es = Vector3d::Zero();
        es.head(C.S.dim) = D.e.row(s).transpose();
        EXPECT_LE((es - e_of_gamma(F, D.beta(s))).norm(), 1e-13 * (es.norm() + F.gap + 1e-300));
      }
    }
  }
}

TEST(ContactSweep, PureContactKappaZeroD0Zero) {
  // Figs 5-6: w = 1/eps = d = 0. e is the projection of a / Rqc, beta untouched.
  ContactPoints S = fig3_surface();
  for (int s = 0; s < S.size(); ++s) S.gap(s) = 1e-3 * (s % 4);
  Adhesion A;
  A.dt = 1.0;
  const double Rqc = 5e6;
  const ContactStep cs(S, A, Rqc);
  SweepData D = random_data(S, 1e-2, 3e4, 5);
  const VectorXd beta0 = D.beta;
  cs.solve(D.ubar, D.lambda_c, D.beta_prev, D.e, D.beta, 2);
  EXPECT_EQ(D.beta, beta0);
  int active_count = 0;
  for (int s = 0; s < S.size(); ++s) {
    const Vector2d x = (Rqc * D.ubar.row(s) - D.lambda_c.row(s)).transpose() / Rqc;
    const Vector2d N(0, -1);
    const Vector2d e = (x.dot(N) <= S.gap(s)) ? x : Vector2d(x - (x.dot(N) - S.gap(s)) * N);
    EXPECT_LE((D.e.row(s).transpose() - e).norm(), 1e-15 * (x.norm() + S.gap(s)));
    active_count += (x.dot(N) > S.gap(s));
  }
  EXPECT_GT(active_count, 3);  // both regimes visited
  EXPECT_LT(active_count, 25);
  EXPECT_EQ(cs.energy(D.e, D.beta, D.beta_prev), 0.0);
}

#if defined(LTL_COUNT_MALLOC)
TEST(ContactSweep, SolveIsAllocationFree) {
  for (auto& C : sweep_cases()) {
    SCOPED_TRACE(C.name);
    const ContactStep cs(C.S, C.A, C.Rqc);
    SweepData D = random_data(C.S, C.u_scale, C.lambda_scale, 3);
    g_mallocs = 0;
    g_count_mallocs = true;
    cs.solve(D.ubar, D.lambda_c, D.beta_prev, D.e, D.beta, 3);
    g_count_mallocs = false;
    EXPECT_EQ(g_mallocs.load(), 0);
    // Sanity check of the counter itself.
    g_count_mallocs = true;
    volatile void* p = std::malloc(64);
    g_count_mallocs = false;
    std::free(const_cast<void*>(p));
    EXPECT_EQ(g_mallocs.load(), 1);
  }
}
#endif

TEST(ContactEnergy, Eq2_2_DiscreteAdhesionEnergy) {
  const ContactPoints S = line_surface({0.0, 0.1, 0.3});
  Adhesion A;
  A.w = 0.5;
  A.kappa = 10.0;
  A.d0 = 2.0;
  A.dt = 0.5;
  const ContactStep cs(S, A, 1.0);
  MatrixXd e(2, 2);
  e << 0.1, 0.3, -0.2, 0.0;  // one point per row; e.N = -e_y <= 0
  VectorXd beta(2), beta_prev(2);
  beta << 0.4, 0.9;
  beta_prev << 1.0, 0.7;
  const double k00 = 2.0 * 0.1, k11 = 2.0 * 0.2;
  const double k01 = 2.0 * std::exp(-2.0 * 0.15) * 0.2, k10 = 2.0 * std::exp(-2.0 * 0.15) * 0.1;
  const double db0 = -0.6, db1 = 0.2;
  const double expected =
      0.1 * (5.0 * 0.16 * 0.1 - 0.5 * 0.4) + 0.2 * (5.0 * 0.81 * 0.04 - 0.5 * 0.9) +
      (0.1 * (k00 * db0 * db0 + k01 * db0 * db1) + 0.2 * (k10 * db1 * db0 + k11 * db1 * db1)) /
          (2 * 0.5);
  EXPECT_NEAR(cs.energy(e, beta, beta_prev), expected, 1e-15);
  // Outside the admissible set (4.11): +inf.
  VectorXd bad = beta;
  bad(1) = 1.0 + 1e-12;
  EXPECT_EQ(cs.energy(e, bad, beta_prev), std::numeric_limits<double>::infinity());
  MatrixXd pen = e;
  pen(0, 1) = -1e-6;  // e.N = 1e-6 > 0 = g
  EXPECT_EQ(cs.energy(pen, beta, beta_prev), std::numeric_limits<double>::infinity());
}

TEST(ContactStepSetup, RejectsInconsistentData) {
  ContactPoints S = fig3_surface();
  EXPECT_THROW(ContactStep(S, fig3_adhesion(false), 0.0), std::invalid_argument);
  S.gap.resize(27);
  EXPECT_THROW(ContactStep(S, fig3_adhesion(false), 8e9), std::invalid_argument);
  S = fig3_surface();
  S.vertices.clear();
  EXPECT_NO_THROW(ContactStep(S, fig3_adhesion(false), 8e9));  // centre-point: no vertices
  EXPECT_THROW(ContactStep(S, fig3_adhesion(true), 8e9), std::invalid_argument);
  S = fig3_surface();
  S.N = Vector2d(0, -2);  // read normalized by the constructor
  const ContactStep cs(S, fig3_adhesion(false), 8e9);
  EXPECT_DOUBLE_EQ(cs.normal().norm(), 1.0);
}

}  // namespace
