// The local adhesion / contact step [LTL87 (4.7), (6.1)-(6.8)]; see contact_step.hpp and
// paper_notes/section6.md.
#include "contact_step.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

// Eigen's unsupported polynomial solver: keep its warnings out of our -Wall -Wextra build.
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-parameter"
#pragma GCC diagnostic ignored "-Wunused-variable"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wdeprecated-copy"
#endif
#include <unsupported/Eigen/Polynomials>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace ltl {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------
// The scalar problem (6.8)
// ---------------------------------------------------------------------------------------------

/// p[0] + p[1] x + ... + p[deg] x^deg and its derivative (Horner).
inline void poly_eval(const double* p, int deg, double x, double& P, double& dP) {
  P = p[deg];
  dP = 0.0;
  for (int i = deg - 1; i >= 0; --i) {
    dP = dP * x + P;
    P = P * x + p[i];
  }
}

/// Roots of a polynomial of exact degree Deg (p[Deg] != 0), fixed size: no heap allocation.
template <int Deg>
int complex_roots(const double* p, std::complex<double>* out) {
  Eigen::Matrix<double, Deg + 1, 1> c;
  for (int i = 0; i <= Deg; ++i) c(i) = p[i];
  Eigen::PolynomialSolver<double, Deg> solver;
  solver.compute(c);
  for (int i = 0; i < Deg; ++i) out[i] = solver.roots()(i);
  return Deg;
}

/// Candidate roots in [0,1] of p[0] + ... + p[5] x^5: the real parts of the companion-matrix
/// eigenvalues that lie near the real segment [0,1] (|Im| <= 0.1, Re in [-0.1, 1.1]: far wider
/// than the eigenvalue error, even for a double or triple root), each polished by Newton on the
/// full polynomial and clamped to [0,1]. Spurious candidates are harmless: the caller judges
/// every candidate by the true objective. Returns the count (<= 5).
int unit_roots(const double p[6], double* out) {
  double pmax = 0.0;
  for (int i = 0; i < 6; ++i) pmax = std::max(pmax, std::abs(p[i]));
  if (!(pmax > 0.0) || !std::isfinite(pmax)) return 0;  // P == 0: f' == 0 on this regime
  int deg = 5;
  while (deg > 0 && std::abs(p[deg]) <= 1e-14 * pmax) --deg;
  if (deg == 0) return 0;
  std::complex<double> z[5];
  int nz = 0;
  switch (deg) {
    case 1:
      z[0] = -p[0] / p[1];
      nz = 1;
      break;
    case 2:
      nz = complex_roots<2>(p, z);
      break;
    case 3:
      nz = complex_roots<3>(p, z);
      break;
    case 4:
      nz = complex_roots<4>(p, z);
      break;
    default:
      nz = complex_roots<5>(p, z);
      break;
  }
  int n = 0;
  for (int i = 0; i < nz; ++i) {
    double x = z[i].real();
    if (!std::isfinite(x) || std::abs(z[i].imag()) > 0.1 || x < -0.1 || x > 1.1) continue;
    for (int it = 0; it < 30; ++it) {  // Newton polish on the full (untrimmed) polynomial
      double P, dP;
      poly_eval(p, 5, x, P, dP);
      if (dP == 0.0 || !std::isfinite(P / dP)) break;
      const double dx = P / dP;
      x -= dx;
      if (std::abs(dx) <= 1e-15 * std::max(1.0, std::abs(x))) break;
    }
    if (!std::isfinite(x)) continue;
    out[n++] = std::clamp(x, 0.0, 1.0);
  }
  return n;
}

/// Coefficients of c^2 f'(gamma) / Rqc^2 in one regime [LTL87 (6.8)]:
///   (A gamma - b)(1 + r gamma^2)^2 + m gamma,   r = kappa/Rqc,  m = kappa M / Rqc^2,
/// with (inactive) A = aa, M = |a|^2, or (active) A = aa + kappa g^2, M = |a_T|^2.
void regime_poly(double A, double b, double r, double m, double p[6]) {
  p[0] = -b;
  p[1] = A + m;
  p[2] = -2.0 * r * b;
  p[3] = 2.0 * r * A;
  p[4] = -r * r * b;
  p[5] = r * r * A;
}

// ---------------------------------------------------------------------------------------------
// Quadrature for the exact kernel [LTL87 (1.3), (1.6)]
// ---------------------------------------------------------------------------------------------

// 8-point Gauss-Legendre on [-1,1].
constexpr double kGL8x[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                             -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                             0.7966664774136267,  0.9602898564975363};
constexpr double kGL8w[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                             0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                             0.2223810344533745, 0.1012285362903763};
// 4-point Gauss-Legendre on [-1,1].
constexpr double kGL4x[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                             0.8611363115940526};
constexpr double kGL4w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                             0.3478548451374538};

/// Beyond d0 r > kCut the kernel is below e^-60 of its peak and is dropped.
constexpr double kCut = 60.0;

/// psi(x) = x - 1 + exp(-x) >= 0, without cancellation for small x.
double psi(double x) {
  if (x < 0.1) {
    double term = x * x / 2.0, sum = 0.0;
    for (int k = 2; k < 16; ++k) {
      sum += term;
      term *= -x / (k + 1);
    }
    return sum;
  }
  return x + std::expm1(-x);
}

/// [LTL87 (1.6)] Exact integral over x in [p,q], y in [r,s] (collinear, p<q, r<s) of
/// d0 exp(-d0 |x - y|). Disjoint intervals use the product form (no cancellation); overlapping
/// ones use the second antiderivative G(t) = psi(d0|t|)/d0 of the kernel:
///   I = G(q-r) - G(p-r) - G(q-s) + G(p-s).
double collinear_integral(double p, double q, double r, double s, double d0) {
  if (r >= q || p >= s) {
    const double gap = (r >= q) ? r - q : p - s;
    return std::exp(-d0 * gap) * (-std::expm1(-d0 * (q - p))) * (-std::expm1(-d0 * (s - r))) / d0;
  }
  auto G = [d0](double t) { return psi(d0 * std::abs(t)) / d0; };
  return G(q - r) - G(p - r) - G(q - s) + G(p - s);
}

/// Integral of F over [t0, t1] by 8-point Gauss-Legendre on n equal pieces.
template <class F>
double gauss_pieces(const F& f, double t0, double t1, int n) {
  if (!(t1 > t0) || n < 1) return 0.0;
  const double L = (t1 - t0) / n;
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const double mid = t0 + (k + 0.5) * L;
    for (int i = 0; i < 8; ++i) sum += kGL8w[i] * f(mid + 0.5 * L * kGL8x[i]);
  }
  return 0.5 * L * sum;
}

/// Integral over tau in [ta, tb] of an even function F(tau) that is smooth on the scale 1 for
/// |tau| < t1, decays fast beyond t1 (on the scale `len`) and is negligible beyond tcut:
/// 8-point Gauss-Legendre on pieces of length <= 2 before t1 and <= len after.
template <class F>
double even_tau_integral(const F& f, double ta, double tb, double t1, double tcut, double len) {
  auto span = [&](double lo, double hi, double L) {
    if (!(hi > lo)) return 0.0;
    return gauss_pieces(f, lo, hi, std::max(1, static_cast<int>(std::ceil((hi - lo) / L))));
  };
  auto half = [&](double lo, double hi) {  // 0 <= lo < hi
    hi = std::min(hi, tcut);
    if (!(hi > lo)) return 0.0;
    const double mid = std::clamp(t1, lo, hi);
    return span(lo, mid, 2.0) + span(mid, hi, len);
  };
  if (ta >= 0.0) return half(ta, tb);
  if (tb <= 0.0) return half(-tb, -ta);
  return half(0.0, -ta) + half(0.0, tb);
}

/// [LTL87 (1.6)] 2-D: integral over the segment [q0,q1] of d0 exp(-d0 |x - y|) dy.
/// With p the distance from x to the segment's line and t the abscissa along it,
/// t = p sinh(tau) turns the integrand into X exp(-X), X = d0 p cosh(tau): smooth, done by
/// Gauss-Legendre on pieces of tau; p = 0 is done in closed form.
double inner_segment(const Vector2d& x, const Vector2d& q0, const Vector2d& q1, double d0) {
  const Vector2d d = q1 - q0;
  const double L = d.norm();
  const Vector2d u = d / L;
  const Vector2d r0 = q0 - x;
  const double ta = r0.dot(u), tb = ta + L;
  const double p = std::abs(r0.x() * u.y() - r0.y() * u.x());
  const double dp = d0 * p;
  if (dp > kCut) return 0.0;
  if (dp < 1e-12) {  // x on the line: int d0 exp(-d0|t|) dt, error O((d0 p)^2 log)
    auto F = [d0](double t) { return std::copysign(-std::expm1(-d0 * std::abs(t)), t); };
    return F(tb) - F(ta);
  }
  auto f = [dp](double tau) {
    const double X = dp * std::cosh(tau);
    return X * std::exp(-X);
  };
  const double t1 = std::acosh(std::max(1.0, 1.0 / dp)), tcut = std::acosh(kCut / dp);
  const double len = std::min(0.5, 1.5 / std::sqrt(dp));
  return even_tau_integral(f, std::asinh(ta / p), std::asinh(tb / p), t1, tcut, len);
}

/// A planar polygon (3 or 4 vertices, in cyclic order) of a 3-D facet.
struct Face {
  int nv = 0;
  Vector3d V[4], n, centroid;
  double area = 0.0, radius = 0.0;
};

Face make_face(const Vector3d* v, int nv) {
  Face f;
  f.nv = nv;
  Vector3d newell = Vector3d::Zero(), c = Vector3d::Zero();
  for (int k = 0; k < nv; ++k) {
    f.V[k] = v[k];
    newell += 0.5 * v[k].cross(v[(k + 1) % nv]);
    c += v[k] / nv;
  }
  f.area = newell.norm();
  f.n = (f.area > 0.0) ? Vector3d(newell / f.area) : Vector3d::Zero();
  f.centroid = c;
  for (int k = 0; k < nv; ++k) f.radius = std::max(f.radius, (v[k] - c).norm());
  return f;
}

bool is_planar(const Face& f) {
  for (int k = 0; k < f.nv; ++k)
    if (std::abs((f.V[k] - f.centroid).dot(f.n)) > 1e-12 * f.radius) return false;
  return true;
}

/// phi2(x) = 1 - (1 + x) exp(-x) = int_0^x t e^-t dt, without cancellation for small x.
double phi2(double x) {
  if (x < 0.5) {
    double term = x * x / 2.0, sum = 0.0;  // sum_{k>=2} (-1)^k (k-1) x^k / k!
    for (int k = 2; k < 18; ++k) {
      sum += (k - 1) * term;
      term *= -x / (k + 1);
    }
    return sum;
  }
  return -std::expm1(-x) - x * std::exp(-x);
}

/// [LTL87 (1.6)] 3-D: integral over the planar polygon T of d0 exp(-d0 |x - y|) dy, any x.
/// Polar coordinates around the projection x' of x on T's plane (p = distance to the plane):
/// the radial integral is exact, int_0^rho d0 e^(-d0 r) rho' drho' = (phi2(d0 R) - phi2(d0 p))
/// / d0 with R = sqrt(p^2 + rho^2). Summing over the signed triangles (x', P0, P1) of the edges,
/// with h the distance from x' to the edge line, t = h sinh(tau) along it (so dphi = dtau /
/// cosh(tau) and rho = h cosh(tau)):
///   sum sigma int (phi2(d0 R(tau)) - phi2(d0 p)) / (d0 cosh(tau)) dtau.
/// The integrand is entire in tau (no cancellation for small d0); where d0 R > 60 it equals
/// H(p) / cosh(tau), H(p) = (1 - phi2(d0 p)) / d0, up to e^-60, integrated in closed form.
double inner_face(const Vector3d& x, const Face& T, double d0) {
  if (T.area <= 0.0) return 0.0;
  if (d0 * ((x - T.centroid).norm() - T.radius) > kCut) return 0.0;
  const double z = (x - T.V[0]).dot(T.n);
  const double p = std::abs(z), dp = d0 * p;
  if (dp >= kCut) return 0.0;
  const Vector3d xp = x - z * T.n;
  const double phi2p = phi2(dp), Hp = (1.0 - phi2p) / d0;
  const double Rcut2 = (kCut / d0) * (kCut / d0) - p * p;  // d0 R = kCut
  const double R1sq = 1.0 / (d0 * d0) - p * p;             // d0 R = 1
  double sum = 0.0;
  for (int k = 0; k < T.nv; ++k) {
    const Vector3d& P0 = T.V[k];
    const Vector3d& P1 = T.V[(k + 1) % T.nv];
    const Vector3d r0 = P0 - xp, r1 = P1 - xp;
    const Vector3d edge = P1 - P0;
    const double L = edge.norm();
    if (!(L > 0.0)) continue;
    const Vector3d u = edge / L;
    const double ta = r0.dot(u), tb = ta + L;
    const double h = (r0 - ta * u).norm();
    if (d0 * h < 1e-12) continue;  // degenerate triangle (x' on the edge line): no contribution
    const double sigma = (r0.cross(r1).dot(T.n) >= 0.0) ? 1.0 : -1.0;
    const double taua = std::asinh(ta / h), taub = std::asinh(tb / h);
    const double tauc = (Rcut2 > h * h) ? std::acosh(std::sqrt(Rcut2) / h) : 0.0;
    const double tau1 = (R1sq > h * h) ? std::acosh(std::sqrt(R1sq) / h) : 0.0;
    auto f = [&](double tau) {
      const double c = std::cosh(tau);
      return (phi2(d0 * std::sqrt(p * p + h * h * c * c)) - phi2p) / (d0 * c);
    };
    const double len = std::min(0.5, 1.5 / std::sqrt(d0 * h));
    double val = even_tau_integral(f, taua, taub, tau1, tauc, len);
    // Tail |tau| > tauc: int dtau / cosh(tau) = [atan(sinh(tau))].
    auto gd = [](double tau) { return std::atan(std::sinh(tau)); };
    const double gda = std::atan(ta / h), gdb = std::atan(tb / h);
    if (taub > tauc) val += Hp * (gdb - ((taua > tauc) ? gda : gd(tauc)));
    if (taua < -tauc) val += Hp * (((taub < -tauc) ? gdb : gd(-tauc)) - gda);
    sum += sigma * val;
  }
  return sum;
}

/// Adaptive 8-point Gauss-Legendre on [a,b]: bisect until the parent and the two halves agree
/// within tol (absolute, shared in proportion to length).
template <class F>
double adapt_1d(const F& f, double a, double b, double whole, double tol, int depth) {
  const double m = 0.5 * (a + b);
  const double left = gauss_pieces(f, a, m, 1), right = gauss_pieces(f, m, b, 1);
  if (std::abs(left + right - whole) <= tol || depth >= 30) return left + right;
  return adapt_1d(f, a, m, left, 0.5 * tol, depth + 1) +
         adapt_1d(f, m, b, right, 0.5 * tol, depth + 1);
}

template <class F>
double integrate_1d(const F& f, double a, double b, double max_piece, double tol) {
  if (!(b > a)) return 0.0;
  const int n = std::clamp(static_cast<int>(std::ceil((b - a) / max_piece)), 1, 4000);
  const double L = (b - a) / n;
  double sum = 0.0;
  for (int k = 0; k < n; ++k) {
    const double lo = a + k * L, hi = lo + L;
    sum += adapt_1d(f, lo, hi, gauss_pieces(f, lo, hi, 1), tol / n, 0);
  }
  return sum;
}

/// Collapsed 4x4 Gauss rule on a triangle: x = A + xi (B - A) + xi eta (C - B).
template <class F>
double tri_rule(const F& f, const Vector3d& A, const Vector3d& B, const Vector3d& C) {
  const double area2 = (B - A).cross(C - A).norm();
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    const double xi = 0.5 * (1.0 + kGL4x[i]);
    for (int j = 0; j < 4; ++j) {
      const double eta = 0.5 * (1.0 + kGL4x[j]);
      sum += kGL4w[i] * kGL4w[j] * xi * f(Vector3d(A + xi * (B - A) + xi * eta * (C - B)));
    }
  }
  return 0.25 * area2 * sum;
}

/// Outer adaptive quadrature on triangles: local tolerance kTriTol x (area share) x (largest
/// possible inner value), at most kExtraDepth adaptive levels after the uniform ones. The
/// parent/children difference overestimates the error of the returned children sum by orders of
/// magnitude: the measured relative errors of k are below 1e-8 (tests/test_contact_step.cpp,
/// Eq1_6_Exact3DQuadrilaterals, against independent covariogram quadratures).
constexpr double kTriTol = 3e-7;
constexpr int kExtraDepth = 4;

/// Adaptive quadrature on a triangle: split into 4 (mid-edge points) until the parent rule and
/// the sum of its children agree within tol. `level0` uniform refinements are done first.
template <class F>
double adapt_tri(const F& f, const Vector3d& A, const Vector3d& B, const Vector3d& C, double whole,
                 double tol, int depth, int level0) {
  const Vector3d ab = 0.5 * (A + B), bc = 0.5 * (B + C), ca = 0.5 * (C + A);
  const Vector3d K[4][3] = {{A, ab, ca}, {ab, B, bc}, {ca, bc, C}, {bc, ca, ab}};
  double I[4], total = 0.0;
  for (int c = 0; c < 4; ++c) total += (I[c] = tri_rule(f, K[c][0], K[c][1], K[c][2]));
  if (depth >= level0 && (std::abs(total - whole) <= tol || depth >= level0 + kExtraDepth))
    return total;
  double sum = 0.0;
  for (int c = 0; c < 4; ++c)
    sum += adapt_tri(f, K[c][0], K[c][1], K[c][2], I[c], 0.25 * tol, depth + 1, level0);
  return sum;
}

/// [LTL87 (1.3), (1.6)] 2-D: int over [p0,p1] int over [q0,q1] of d0 exp(-d0 |x - y|) dy dx.
double pair_integral_2d(const Vector2d& p0, const Vector2d& p1, const Vector2d& q0,
                        const Vector2d& q1, double d0) {
  const double hp = (p1 - p0).norm(), hq = (q1 - q0).norm();
  const Vector2d up = (p1 - p0) / hp;
  const Vector2d np(-up.y(), up.x());
  // Lower bound of the distance between the segments (bounding circles).
  const double sep = (0.5 * (p0 + p1) - 0.5 * (q0 + q1)).norm() - 0.5 * (hp + hq);
  if (d0 * sep > kCut) return 0.0;
  const double tol_line = 1e-10 * (hp + hq);
  if (std::abs((q0 - p0).dot(np)) <= tol_line && std::abs((q1 - p0).dot(np)) <= tol_line) {
    const double t0 = (q0 - p0).dot(up), t1 = (q1 - p0).dot(up);
    return collinear_integral(0.0, hp, std::min(t0, t1), std::max(t0, t1), d0);
  }
  auto f = [&](double s) { return inner_segment(Vector2d(p0 + s * up), q0, q1, d0); };
  // The inner integral is least smooth where x crosses the line of Q: split there.
  const Vector2d uq = (q1 - q0) / hq;
  const Vector2d nq(-uq.y(), uq.x());
  const double den = up.dot(nq);
  double sc = -1.0;
  if (den != 0.0) sc = (q0 - p0).dot(nq) / den;
  const double tol = 1e-12 * hp * std::min(2.0, d0 * hq);
  const double piece = 4.0 / d0;
  if (sc > 0.0 && sc < hp)
    return integrate_1d(f, 0.0, sc, piece, tol * sc / hp) +
           integrate_1d(f, sc, hp, piece, tol * (hp - sc) / hp);
  return integrate_1d(f, 0.0, hp, piece, tol);
}

/// A 3-D facet: its triangles (v0,v1,v2), (v0,v2,v3) for the outer integral, and for the inner
/// one the facet itself when planar, else the same two triangles.
struct Facet3 {
  std::vector<Face> tris, inner;
  double area = 0.0;
};

/// [LTL87 (1.3), (1.6)] 3-D: int over facet P int over facet Q of d0 exp(-d0 |x - y|).
/// Outer integral: adaptive collapsed Gauss on each triangle of P; inner: inner_face.
double pair_integral_3d(const Facet3& P, const Facet3& Q, double d0) {
  auto f = [&](const Vector3d& x) {
    double v = 0.0;
    for (const Face& q : Q.inner) v += inner_face(x, q, d0);
    return v;
  };
  double sum = 0.0;
  for (const Face& t : P.tris) {
    if (t.area <= 0.0) continue;
    const double diam = 2.0 * t.radius;
    int level0 = 0;
    while (level0 < 5 && diam / (1 << level0) > 8.0 / d0) ++level0;
    const double tol = kTriTol * t.area * std::min(2.0 * kPi / d0, d0 * Q.area);
    sum +=
        adapt_tri(f, t.V[0], t.V[1], t.V[2], tri_rule(f, t.V[0], t.V[1], t.V[2]), tol, 0, level0);
  }
  return sum;
}

std::string facet_str(int s) {
  return "facet " + std::to_string(s);
}

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("ContactStep: " + what);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The facet problem
// ---------------------------------------------------------------------------------------------

Vector3d ContactStep::project(const Vector3d& x, const Vector3d& N, double gap) {
  const double xn = x.dot(N);
  if (xn <= gap) return x;
  Vector3d e = x - (xn - gap) * N;
  // A second pass removes the round-off O(eps |x|) left in e.N when |x| >> |e|.
  const double en = e.dot(N);
  if (en > gap) e -= (en - gap) * N;
  return e;
}

double ContactStep::facet_objective(const Vector3d& a, double aa, double b, double Rqc,
                                    double kappa, const Vector3d& e, double gamma) {
  const double c = Rqc + kappa * gamma * gamma;
  return 0.5 * c * e.squaredNorm() - a.dot(e) + 0.5 * aa * gamma * gamma - b * gamma;
}

double ContactStep::reduced_objective(const Vector3d& a_in, double aa, double b, double Rqc,
                                      double kappa, const Vector3d& N_in, double gap, int dim,
                                      double gamma) {
  Vector3d a = a_in, N = N_in;
  if (dim == 2) a(2) = N(2) = 0.0;
  const double c = Rqc + kappa * gamma * gamma;
  return facet_objective(a, aa, b, Rqc, kappa, project(a / c, N, gap), gamma);
}

FacetSolution ContactStep::solve_facet(const Vector3d& a_in, double aa, double b, double Rqc,
                                       double kappa, const Vector3d& N_in, double gap, int dim,
                                       double beta_current) {
  Vector3d a = a_in, N = N_in;
  if (dim == 2) a(2) = N(2) = 0.0;
  const double beta_keep = std::clamp(beta_current, 0.0, 1.0);
  FacetSolution sol;

  // No glue: e does not depend on gamma, and (6.8) is the quadratic (aa/2) g^2 - b g.
  if (kappa == 0.0) {
    sol.e = project(a / Rqc, N, gap);
    if (aa > 0.0)
      sol.beta = std::clamp(b / aa, 0.0, 1.0);
    else
      sol.beta = (b > 0.0) ? 1.0 : (b < 0.0) ? 0.0 : beta_keep;
    return sol;
  }

  // Candidates: the end points and every stationary point of (6.8) in each regime present on
  // [0,1], i.e. every root in [0,1] of c^2 f'(gamma) = 0 (degree 5). f is C^1 across the regime
  // switch (the projection is continuous), so no other point can be a minimizer. Roots of a
  // regime's polynomial that fall in the other regime are harmless extra candidates: each
  // candidate is judged by the true objective.
  double cand[12];
  int nc = 0;
  cand[nc++] = 0.0;
  cand[nc++] = 1.0;
  const double an = a.dot(N);
  const Vector3d aT = a - an * N;
  const double r = kappa / Rqc;
  const bool active0 = an > gap * Rqc, active1 = an > gap * (Rqc + kappa);
  double p[6];
  if (!active0 || !active1) {  // constraint inactive somewhere on [0,1]: e = a/c
    regime_poly(aa, b, r, kappa * a.squaredNorm() / (Rqc * Rqc), p);
    nc += unit_roots(p, cand + nc);
  }
  if (active0 || active1) {  // constraint active somewhere: e = a_T/c + g N
    regime_poly(aa + kappa * gap * gap, b, r, kappa * aT.squaredNorm() / (Rqc * Rqc), p);
    nc += unit_roots(p, cand + nc);
  }

  // Best candidate; equal values (up to round-off) go to the larger gamma.
  const double scale =
      a.squaredNorm() / Rqc + (Rqc + kappa) * gap * gap + std::abs(an * gap) + aa + std::abs(b);
  const double tol = 1e-13 * scale;
  double fval[12];
  double fmin = kInf, fmax = -kInf;
  for (int i = 0; i < nc; ++i) {
    fval[i] = reduced_objective(a, aa, b, Rqc, kappa, N, gap, 3, cand[i]);
    fmin = std::min(fmin, fval[i]);
    fmax = std::max(fmax, fval[i]);
  }
  double best = -1.0;
  if (fmax - fmin <= tol) {
    best = beta_keep;  // (6.8) constant on [0,1]: beta is arbitrary, leave it unchanged
  } else {
    for (int i = 0; i < nc; ++i)
      if (fval[i] <= fmin + tol) best = std::max(best, cand[i]);
  }
  sol.beta = best;
  sol.e = project(a / (Rqc + kappa * best * best), N, gap);
  return sol;
}

// ---------------------------------------------------------------------------------------------
// The surface
// ---------------------------------------------------------------------------------------------

ContactStep::ContactStep(const ContactSurface& surface, const Adhesion& adhesion, double Rqc)
    : surface_(surface), adhesion_(adhesion), Rqc_(Rqc) {
  const int dim = surface_.dim;
  if (dim != 2 && dim != 3) fail("surface.dim = " + std::to_string(dim) + ", expected 2 or 3");
  const int n = surface_.size();
  if (surface_.centre.rows() != dim || surface_.centre.cols() != n)
    fail("surface.centre is " + std::to_string(surface_.centre.rows()) + " x " +
         std::to_string(surface_.centre.cols()) + ", expected dim x #facets = " +
         std::to_string(dim) + " x " + std::to_string(n) + " (#facets = surface.area.size())");
  if (surface_.gap.size() != n)
    fail("surface.gap has " + std::to_string(surface_.gap.size()) +
         " entries, expected #facets = " + std::to_string(n));
  if (surface_.N.size() != dim)
    fail("surface.N has " + std::to_string(surface_.N.size()) +
         " entries, expected dim = " + std::to_string(dim));
  const double Nn = surface_.N.norm();
  if (!(Nn > 0.0) || !std::isfinite(Nn)) fail("surface.N must be a nonzero finite vector");
  surface_.N /= Nn;
  for (int s = 0; s < n; ++s) {
    if (!(surface_.area(s) > 0.0) || !std::isfinite(surface_.area(s)))
      fail("surface.area(" + std::to_string(s) + ") = " + std::to_string(surface_.area(s)) +
           " on " + facet_str(s) + ", must be > 0");
    if (!std::isfinite(surface_.gap(s))) fail("surface.gap is not finite on " + facet_str(s));
  }
  if (!(Rqc > 0.0) || !std::isfinite(Rqc)) fail("Rqc = R q_c must be > 0");
  if (!(adhesion_.kappa >= 0.0) || !std::isfinite(adhesion_.kappa))
    fail("adhesion.kappa = 1/eps must be >= 0 (0: no glue)");
  if (!(adhesion_.d0 >= 0.0) || !std::isfinite(adhesion_.d0))
    fail("adhesion.d0 must be >= 0 (0: no dissipation)");
  if (!(adhesion_.dt > 0.0) || !std::isfinite(adhesion_.dt)) fail("adhesion.dt must be > 0");
  if (!std::isfinite(adhesion_.w)) fail("adhesion.w must be finite");

  N3_.setZero();
  N3_.head(dim) = surface_.N;

  k_ = Eigen::MatrixXd::Zero(n, n);
  const double d0 = adhesion_.d0;
  if (d0 == 0.0) return;  // no dissipation: k = 0, solve() never reads it

  if (!adhesion_.exact_kernel) {
    // [LTL87 (6.4)-(6.5)] centre-point rule: k_ss' = d(x_s - x_s') |G_s'|.
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        k_(i, j) = d0 * std::exp(-d0 * (surface_.centre.col(i) - surface_.centre.col(j)).norm()) *
                   surface_.area(j);
  } else {
    // Exact Galerkin integral: k_ss' = (1/|G_s|) int_{G_s} int_{G_s'} d(x - y) dy dx.
    const int nv = static_cast<int>(surface_.vertices.size());
    if ((dim == 2 && nv != 2) || (dim == 3 && nv != 3 && nv != 4))
      fail(
          "the exact kernel needs surface.vertices: 2 (2-D) or 4 (3-D) matrices of size dim x "
          "#facets, got " +
          std::to_string(nv));
    for (int k = 0; k < nv; ++k)
      if (surface_.vertices[k].rows() != dim || surface_.vertices[k].cols() != n)
        fail("surface.vertices[" + std::to_string(k) + "] must be dim x #facets");
    if (dim == 2) {
      for (int s = 0; s < n; ++s) {
        const double len = (surface_.vertices[1].col(s) - surface_.vertices[0].col(s)).norm();
        if (std::abs(len - surface_.area(s)) > 1e-3 * surface_.area(s))
          fail("on " + facet_str(s) + " the segment length " + std::to_string(len) +
               " differs from surface.area " + std::to_string(surface_.area(s)) +
               ": check surface.vertices");
      }
      for (int j = 0; j < n; ++j)
        for (int i = 0; i <= j; ++i) {
          const double I =
              pair_integral_2d(surface_.vertices[0].col(i), surface_.vertices[1].col(i),
                               surface_.vertices[0].col(j), surface_.vertices[1].col(j), d0);
          k_(i, j) = I / surface_.area(i);
          k_(j, i) = I / surface_.area(j);
        }
    } else {
      std::vector<Facet3> facets(n);
      for (int s = 0; s < n; ++s) {
        Vector3d v[4];
        for (int k = 0; k < nv; ++k) v[k] = surface_.vertices[k].col(s);
        Facet3& F = facets[s];
        const Vector3d t0[3] = {v[0], v[1], v[2]}, t1[3] = {v[0], v[2], v[3]};
        F.tris.push_back(make_face(t0, 3));
        if (nv == 4) F.tris.push_back(make_face(t1, 3));
        const Face whole = make_face(v, nv);
        if (nv == 4 && is_planar(whole))
          F.inner.push_back(whole);
        else
          F.inner = F.tris;
        double A = 0.0;
        for (const Face& t : F.tris) A += t.area;
        F.area = A;
        if (std::abs(A - surface_.area(s)) > 1e-2 * surface_.area(s))
          fail("on " + facet_str(s) + " the area of the vertices' triangles " + std::to_string(A) +
               " differs from surface.area " + std::to_string(surface_.area(s)) +
               ": check surface.vertices (cyclic order)");
      }
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic)
#endif
      for (int j = 0; j < n; ++j)
        for (int i = 0; i <= j; ++i) {  // iteration j writes k(i,j), k(j,i), i <= j: no race
          const double I = pair_integral_3d(facets[i], facets[j], d0);
          k_(i, j) = I / surface_.area(i);
          k_(j, i) = I / surface_.area(j);
        }
    }
  }
  kt_ = k_.transpose();
}

void ContactStep::solve(const Eigen::MatrixXd& ubar, const Eigen::MatrixXd& lambda_c,
                        const Eigen::VectorXd& beta_prev, Eigen::MatrixXd& e, Eigen::VectorXd& beta,
                        int sweeps) const {
  const int n = surface_.size(), dim = surface_.dim;
  if (ubar.rows() != dim || ubar.cols() != n || lambda_c.rows() != dim || lambda_c.cols() != n ||
      e.rows() != dim || e.cols() != n || beta_prev.size() != n || beta.size() != n)
    fail("solve(): ubar, lambda_c, e must be dim x #facets and beta_prev, beta #facets (dim = " +
         std::to_string(dim) + ", #facets = " + std::to_string(n) + ")");
  const double dt = adhesion_.dt, w = adhesion_.w, kappa = adhesion_.kappa;
  const bool dissipation = adhesion_.d0 > 0.0;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (int s = 0; s < n; ++s) {
      Vector3d a = Vector3d::Zero();
      a.head(dim) = Rqc_ * ubar.col(s) - lambda_c.col(s);  // (6.3)
      double aa = 0.0, b = w;
      if (dissipation) {
        const double kss = k_(s, s);
        aa = kss / dt;  // (6.4)
        // (6.5), with the newest beta of the other facets (Gauss-Seidel).
        const double others = kt_.col(s).dot(beta - beta_prev) - kss * (beta(s) - beta_prev(s));
        b = w - others / dt + kss * beta_prev(s) / dt;
      }
      const FacetSolution sol =
          solve_facet(a, aa, b, Rqc_, kappa, N3_, surface_.gap(s), dim, beta(s));
      e.col(s) = sol.e.head(dim);
      beta(s) = sol.beta;
    }
  }
}

double ContactStep::energy(const Eigen::MatrixXd& e, const Eigen::VectorXd& beta,
                           const Eigen::VectorXd& beta_prev) const {
  const int n = surface_.size(), dim = surface_.dim;
  if (e.rows() != dim || e.cols() != n || beta.size() != n || beta_prev.size() != n)
    fail("energy(): e must be dim x #facets and beta, beta_prev #facets");
  double E = 0.0;
  for (int s = 0; s < n; ++s) {
    if (!(beta(s) >= 0.0 && beta(s) <= 1.0)) return kInf;
    const double en = e.col(s).dot(surface_.N), g = surface_.gap(s);
    if (en > g + 1e-10 * (e.col(s).norm() + std::abs(g))) return kInf;
    E += surface_.area(s) * (0.5 * adhesion_.kappa * beta(s) * beta(s) * e.col(s).squaredNorm() -
                             adhesion_.w * beta(s));
  }
  if (adhesion_.d0 > 0.0) {
    double D = 0.0;
    for (int s = 0; s < n; ++s)
      D += surface_.area(s) * (beta(s) - beta_prev(s)) * kt_.col(s).dot(beta - beta_prev);
    E += D / (2.0 * adhesion_.dt);
  }
  return E;
}

double ContactStep::local_objective(const Eigen::MatrixXd& ubar, const Eigen::MatrixXd& lambda_c,
                                    const Eigen::VectorXd& beta_prev, const Eigen::MatrixXd& e,
                                    const Eigen::VectorXd& beta) const {
  const int n = surface_.size(), dim = surface_.dim;
  if (ubar.rows() != dim || ubar.cols() != n || lambda_c.rows() != dim || lambda_c.cols() != n)
    fail("local_objective(): ubar and lambda_c must be dim x #facets");
  double J = energy(e, beta, beta_prev);
  for (int s = 0; s < n; ++s)
    J += surface_.area(s) * (0.5 * Rqc_ * e.col(s).squaredNorm() -
                             (Rqc_ * ubar.col(s) - lambda_c.col(s)).dot(e.col(s)));
  return J;
}

}  // namespace ltl
