// Tests of the adhesion kernel [LTL87 (1.3), (1.6), (6.4)-(6.5)] (lib/adhesion_kernel.cpp): the
// integrals of d(y) = d0 exp(-d0 |y|) behind the exact rule against closed forms and independent
// quadratures, the symmetry of |G_s| k_ss', and row sums of k against closed forms for both rules.
// (The kernel as the contact step uses it, on the Fig 3 surface: test_contact_step.cpp.)
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "adhesion_kernel.hpp"
#include "testing.hpp"

namespace {

using Eigen::MatrixXd;
using Eigen::Vector2d;
using Eigen::Vector3d;
namespace kernel = ltl::kernel;

constexpr double kPi = 3.14159265358979323846;

using ltl::testing::quad;

double d(double r, double d0) {
  return d0 * std::exp(-d0 * r);
}

TEST(AdhesionKernel, Eq1_6_CollinearClosedFormAgainstQuadrature) {
  // Brute force: the inner integral split at y = x (the kink of |x - y|), both by Gauss.
  struct Case {
    double p, q, r, s, d0;
  };
  for (const Case& c : {Case{0.0, 1.0, 2.0, 3.5, 1.3}, Case{0.0, 1.0, 0.5, 2.0, 4.0},
                        Case{0.0, 1.0, 0.0, 1.0, 10.0}, Case{0.2, 0.3, 0.0, 1.0, 40.0},
                        Case{1.0, 2.0, -3.0, -1.0, 0.01}, Case{0.0, 0.01, 0.01, 0.02, 1000.0}}) {
    auto inner = [&](double x) {
      auto f = [&](double y) { return d(std::abs(x - y), c.d0); };
      const double m = std::clamp(x, c.r, c.s);
      return quad(f, c.r, m, 40) + quad(f, m, c.s, 40);
    };
    const double ref = quad(inner, c.p, c.q, 40);
    EXPECT_NEAR(kernel::collinear(c.p, c.q, c.r, c.s, c.d0), ref, 1e-12 * ref)
        << c.p << " " << c.q << " " << c.r << " " << c.s << " d0 " << c.d0;
    // symmetric in the two intervals
    EXPECT_NEAR(kernel::collinear(c.r, c.s, c.p, c.q, c.d0), ref, 1e-12 * ref);
  }
  // the self term in closed form: (2 / d0) (x - 1 + e^{-x}), x = d0 h (its Taylor series
  // sum_{k >= 2} (-x)^k / k! for small x, where the closed form cancels)
  for (double x : {1e-6, 0.01, 1.0, 36.0}) {
    const double h = 0.5, d0 = x / h;
    double psi = 0.0, term = x * x / 2.0;
    for (int k = 2; k < 30; ++k) {
      psi += term;
      term *= -x / (k + 1);
    }
    if (x > 0.5) psi = x + std::expm1(-x);
    const double exact = 2.0 / d0 * psi;
    EXPECT_NEAR(kernel::collinear(0.0, h, 0.0, h, d0), exact, 1e-13 * exact) << "d0 h = " << x;
  }
}

TEST(AdhesionKernel, Eq1_6_PointSegmentAgainstBessel) {
  // A segment longer than the cut-off (60/d0 each side) is the whole line:
  // int d0 exp(-d0 sqrt(p^2 + t^2)) dt = 2 d0 p K1(d0 p).
  for (double d0 : {0.5, 3.0, 200.0}) {
    const double L = 100.0 / d0;
    for (double dp : {1e-3, 0.1, 1.0, 5.0, 30.0}) {
      const double p = dp / d0;
      const double exact = 2.0 * dp * std::cyl_bessel_k(1.0, dp);
      const double v =
          kernel::point_segment(Vector2d(0.3 / d0, p), Vector2d(-L, 0.0), Vector2d(L, 0.0), d0);
      EXPECT_NEAR(v, exact, 1e-11 * exact) << "d0 " << d0 << " d0 p " << dp;
    }
    // on the line: 2 (the whole mass of the 1-D kernel)
    EXPECT_NEAR(kernel::point_segment(Vector2d(0.0, 0.0), Vector2d(-L, 0.0), Vector2d(L, 0.0), d0),
                2.0, 1e-13);
  }
}

TEST(AdhesionKernel, Eq1_6_SegmentPairAgainstQuadrature) {
  // Non-collinear segments that do not touch: the integrand is smooth, tensor Gauss converges.
  struct Case {
    Vector2d p0, p1, q0, q1;
    double d0;
  };
  const std::vector<Case> cases = {
      {Vector2d(0, 0), Vector2d(1, 0), Vector2d(0, 0.5), Vector2d(1, 0.8), 2.0},
      {Vector2d(0, 0), Vector2d(1, 0), Vector2d(1.2, 0.1), Vector2d(1.2, 1.0), 5.0},
      {Vector2d(0, 0), Vector2d(0.1, 0.02), Vector2d(0.12, 0.0), Vector2d(0.2, -0.03), 40.0},
      {Vector2d(0, 0), Vector2d(1, 1), Vector2d(2, 0), Vector2d(3, 0.5), 0.7}};
  for (const Case& c : cases) {
    const double hp = (c.p1 - c.p0).norm(), hq = (c.q1 - c.q0).norm();
    auto outer = [&](double s) {
      const Vector2d x = c.p0 + (s / hp) * (c.p1 - c.p0);
      return quad([&](double t) { return d((x - (c.q0 + (t / hq) * (c.q1 - c.q0))).norm(), c.d0); },
                  0.0, hq, 30);
    };
    const double ref = quad(outer, 0.0, hp, 30);
    const double v = kernel::segment_pair(c.p0, c.p1, c.q0, c.q1, c.d0);
    EXPECT_NEAR(v, ref, 1e-10 * ref) << "d0 " << c.d0;
    // symmetric although the outer and inner integrals are done differently
    EXPECT_NEAR(kernel::segment_pair(c.q0, c.q1, c.p0, c.p1, c.d0), v, 1e-10 * v);
  }
}

TEST(AdhesionKernel, Eq1_6_PointPolygonAgainstPlaneClosedForm) {
  // A square much larger than 60/d0 is the whole plane: at height p,
  // int d0 exp(-d0 sqrt(p^2 + rho^2)) 2 pi rho drho = (2 pi / d0) (1 + d0 p) exp(-d0 p).
  for (double d0 : {1.0, 50.0}) {
    const double a = 100.0 / d0;
    const Vector3d sq[4] = {Vector3d(-a, -a, 0), Vector3d(a, -a, 0), Vector3d(a, a, 0),
                            Vector3d(-a, a, 0)};
    for (double dp : {0.0, 1e-3, 0.5, 3.0, 20.0}) {
      const double p = dp / d0;
      const double exact = 2.0 * kPi / d0 * (1.0 + dp) * std::exp(-dp);
      const double v = kernel::point_polygon(Vector3d(0.2 / d0, -0.1 / d0, p), sq, 4, d0);
      // relative to the value, and absolute to 1e-14 of the kernel's mass 2 pi / d0
      EXPECT_NEAR(v, exact, 1e-10 * exact + 1e-14 * 2.0 * kPi / d0)
          << "d0 " << d0 << " d0 p " << dp;
    }
  }
  // additive: a quad is the sum of its two triangles, any point (inside, outside, above)
  const Vector3d q[4] = {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(1.2, 0.9, 0),
                         Vector3d(-0.1, 1, 0)};
  const Vector3d t0[3] = {q[0], q[1], q[2]}, t1[3] = {q[0], q[2], q[3]};
  for (const Vector3d& x : {Vector3d(0.5, 0.5, 0.0), Vector3d(0.5, 0.5, 0.3),
                            Vector3d(2.0, -1.0, 0.1), Vector3d(1.0, 0.0, 0.0)}) {
    const double whole = kernel::point_polygon(x, q, 4, 3.0);
    const double parts =
        kernel::point_polygon(x, t0, 3, 3.0) + kernel::point_polygon(x, t1, 3, 3.0);
    EXPECT_NEAR(whole, parts, 1e-13 * whole) << x.transpose();
  }
}

/// Uniform segments of length h on the x axis, [0, n h].
ltl::ContactPoints line(int n, double h) {
  ltl::ContactPoints S;
  S.dim = 2;
  S.area = Eigen::VectorXd::Constant(n, h);
  S.centre.resize(2, n);
  S.gap = Eigen::VectorXd::Zero(n);
  S.N = Vector2d(0.0, -1.0);
  S.vertices.assign(2, MatrixXd(2, n));
  for (int s = 0; s < n; ++s) {
    S.centre.col(s) << (s + 0.5) * h, 0.0;
    S.vertices[0].col(s) << s * h, 0.0;
    S.vertices[1].col(s) << (s + 1) * h, 0.0;
  }
  return S;
}

TEST(AdhesionKernel, Eq6_4_Eq6_5_RowSumsAgainstClosedForms2D) {
  const int n = 40;
  const double h = 0.025, L = n * h;
  for (double d0 : {2.0, 40.0, 1000.0}) {
    const ltl::ContactPoints S = line(n, h);
    // exact rule: |G_s| sum_s' k_ss' = int_a^b int_0^L d(x - y) dy dx
    //   = 2 (b - a) - (e^{-d0 a} - e^{-d0 b}) / d0 - (e^{-d0 (L - b)} - e^{-d0 (L - a)}) / d0
    const MatrixXd k = ltl::adhesion_kernel(S, d0, true);
    // centre-point rule: sum_s' d0 h q^{|s - s'|}, q = e^{-d0 h}, two geometric series
    const MatrixXd kc = ltl::adhesion_kernel(S, d0, false);
    const double q = std::exp(-d0 * h);
    for (int s = 0; s < n; ++s) {
      const double a = s * h, b = a + h;
      const double exact = 2.0 * h - (std::exp(-d0 * a) - std::exp(-d0 * b)) / d0 -
                           (std::exp(-d0 * (L - b)) - std::exp(-d0 * (L - a))) / d0;
      EXPECT_NEAR(h * k.row(s).sum(), exact, 1e-12 * exact) << "d0 " << d0 << " facet " << s;
      const double geo =
          d0 * h * ((1.0 - std::pow(q, s + 1)) + (q - std::pow(q, n - s))) / (1.0 - q);
      EXPECT_NEAR(kc.row(s).sum(), geo, 1e-13 * geo) << "d0 " << d0 << " facet " << s;
    }
  }
}

TEST(AdhesionKernel, Eq6_4_Eq6_5_AreaWeightedKernelIsSymmetric) {
  // Segments of different lengths on an arc (no two collinear): |G_s| k_ss' = |G_s'| k_s's.
  const int n = 12;
  ltl::ContactPoints S;
  S.dim = 2;
  S.area.resize(n);
  S.centre.resize(2, n);
  S.gap = Eigen::VectorXd::Zero(n);
  S.N = Vector2d(0.0, -1.0);
  S.vertices.assign(2, MatrixXd(2, n));
  double th = 0.0;
  for (int s = 0; s < n; ++s) {
    const double th1 = th + 0.05 * (1.0 + 0.3 * (s % 3));
    S.vertices[0].col(s) << std::sin(th), 1.0 - std::cos(th);
    S.vertices[1].col(s) << std::sin(th1), 1.0 - std::cos(th1);
    S.area(s) = (S.vertices[1].col(s) - S.vertices[0].col(s)).norm();
    S.centre.col(s) = 0.5 * (S.vertices[0].col(s) + S.vertices[1].col(s));
    th = th1;
  }
  for (bool exact : {false, true}) {
    const MatrixXd k = ltl::adhesion_kernel(S, 25.0, exact);
    const MatrixXd Gk = S.area.asDiagonal() * k;
    EXPECT_LE((Gk - Gk.transpose()).cwiseAbs().maxCoeff(), 1e-14 * Gk.cwiseAbs().maxCoeff());
    EXPECT_GT(k.minCoeff(), 0.0);
  }
  // the exact rule against the quadrature of each pair, entry by entry
  const MatrixXd k = ltl::adhesion_kernel(S, 25.0, true);
  for (int i = 0; i < n; i += 5)
    for (int j = 0; j < n; j += 3) {
      const int a = std::min(i, j), b = std::max(i, j);  // the pair the kernel integrates
      const double I = kernel::segment_pair(S.vertices[0].col(a), S.vertices[1].col(a),
                                            S.vertices[0].col(b), S.vertices[1].col(b), 25.0);
      EXPECT_DOUBLE_EQ(k(i, j), I / S.area(i));
    }
}

TEST(AdhesionKernel, Eq6_4_Eq6_5_RowSumOfAPlaneGridIs2PiOverD0In3D) {
  // Unit squares on the plane z = 0, [-m, m+1]^2: for the centre facet, at more than 10 / d0
  // from the border, |G_s| sum_s' k_ss' = int_{G_s} int_plane d = |G_s| 2 pi / d0 up to
  // (1 + d0 R) e^{-d0 R} ~ 3e-12 of the plane's mass (R = 10). Measured: 6.1e-8 relative, the
  // outer adaptive rule of the 441 pairs (its local tolerance kTriTol = 3e-7 is the bound used).
  const double d0 = 3.0;
  const int m = 10;
  const Vector3d P[4] = {Vector3d(0, 0, 0), Vector3d(1, 0, 0), Vector3d(1, 1, 0),
                         Vector3d(0, 1, 0)};
  double sum = 0.0;
  for (int i = -m; i <= m; ++i)
    for (int j = -m; j <= m; ++j) {
      const Vector3d o(i, j, 0.0);
      const Vector3d Q[4] = {P[0] + o, P[1] + o, P[2] + o, P[3] + o};
      sum += kernel::facet_pair(P, 4, Q, 4, d0);
    }
  EXPECT_NEAR(sum, 2.0 * kPi / d0, 3e-7 * 2.0 * kPi / d0);
  // symmetric pair integrals although outer and inner rules differ
  const Vector3d Q[4] = {Vector3d(1.3, 0.2, 0.1), Vector3d(2.1, 0.1, 0.1), Vector3d(2.2, 1.0, 0.1),
                         Vector3d(1.2, 0.9, 0.1)};
  const double pq = kernel::facet_pair(P, 4, Q, 4, d0), qp = kernel::facet_pair(Q, 4, P, 4, d0);
  EXPECT_NEAR(pq, qp, 1e-8 * pq);
}

/// The sparse kernel against the dense reference on S: every pair within the cutoff r_c stored with
/// the dense value (bitwise: the same code per pair), every dropped row mass below rel_tol x the
/// kernel's whole mass (2 on a line, 2 pi / d0 on a plane), and most pairs dropped (the cutoff
/// is exercised).
void expect_sparse_equals_dense(const ltl::ContactPoints& S, double d0, bool exact,
                                double rel_tol) {
  const MatrixXd k = ltl::adhesion_kernel(S, d0, exact);
  const Eigen::SparseMatrix<double> sparse = ltl::adhesion_kernel_sparse(S, d0, exact, rel_tol);
  const MatrixXd ks(sparse);
  const double rc = ltl::kernel_cutoff(S, d0, rel_tol);
  const double mass = S.dim == 2 ? 2.0 : 2.0 * kPi / d0;
  const int n = S.size();
  long dropped = 0;
  double worst = 0.0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      if ((S.centre.col(i) - S.centre.col(j)).norm() <= rc)
        EXPECT_EQ(ks(i, j), k(i, j)) << "pair " << i << ", " << j << " within the cutoff";
      else
        EXPECT_EQ(ks(i, j), 0.0) << "pair " << i << ", " << j << " beyond the cutoff";
      dropped += ks(i, j) == 0.0;
    }
    const double lost = k.row(i).sum() - ks.row(i).sum();
    EXPECT_GE(lost, 0.0) << "row " << i;
    worst = std::max(worst, lost / mass);
  }
  EXPECT_LE(worst, rel_tol) << "dropped mass of the worst row, relative to the kernel's";
  EXPECT_GT(dropped, static_cast<long>(n) * n / 2) << "r_c = " << rc << ": the cutoff drops little";
}

TEST(AdhesionKernel, Eq1_6_SparseKernelEqualsDenseWithinItsCutoff) {
  // 2-D: 200 segments of 1 cm, d0 h = 10 (Fig 3 has d0 h = 36), both rules.
  for (bool exact : {false, true})
    expect_sparse_equals_dense(line(200, 0.01), 1000.0, exact, 1e-12);
  // 3-D: a 30 x 30 grid of 5 cm squares on a tilted plane (the grid search in 3-D), d0 h = 5,
  // centre-point rule (the exact rule evaluates the same PairRule per pair: only the neighbour
  // search differs from the dense kernel, and it does not depend on the rule).
  const int m = 30;
  const double h = 0.05;
  const Eigen::Matrix3d Q =
      Eigen::AngleAxisd(0.4, Vector3d(1.0, 2.0, 0.5).normalized()).toRotationMatrix();
  ltl::ContactPoints S;
  S.dim = 3;
  S.area = Eigen::VectorXd::Constant(m * m, h * h);
  S.centre.resize(3, m * m);
  S.gap = Eigen::VectorXd::Zero(m * m);
  S.N = Q * Vector3d(0.0, 0.0, -1.0);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      S.centre.col(m * i + j) = Q * Vector3d((i + 0.5) * h, (j + 0.5) * h, 0);
  for (double tol : {1e-12, 1e-6}) expect_sparse_equals_dense(S, 100.0, false, tol);
}

TEST(AdhesionKernel, RejectsVerticesThatDoNotMatchTheFacets) {
  ltl::ContactPoints S = line(5, 0.1);
  S.vertices[1](0, 3) += 0.05;  // facet 3 now 0.15 long, area says 0.1
  try {
    ltl::adhesion_kernel(S, 10.0, true);
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("facet 3"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(ltl::adhesion_kernel(S, 10.0, false));  // centre-point: vertices not read
  S.vertices.clear();
  EXPECT_THROW(ltl::adhesion_kernel(S, 10.0, true), std::invalid_argument);
}

}  // namespace
