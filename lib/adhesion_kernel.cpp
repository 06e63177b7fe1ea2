// The adhesion kernel k_ss' [LTL87 (1.3), (1.6), (6.4)-(6.5)]: the centre-point rule and the
// quadrature of the exact Galerkin integral; see adhesion_kernel.hpp and paper_notes/section6.md.
#include "adhesion_kernel.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace ltl {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kPi = 3.14159265358979323846;

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

Facet3 make_facet3(const Vector3d* v, int nv) {
  Facet3 F;
  const Vector3d t0[3] = {v[0], v[1], v[2]};
  F.tris.push_back(make_face(t0, 3));
  if (nv == 4) {
    const Vector3d t1[3] = {v[0], v[2], v[3]};
    F.tris.push_back(make_face(t1, 3));
  }
  const Face whole = make_face(v, nv);
  if (nv == 4 && is_planar(whole))
    F.inner.push_back(whole);
  else
    F.inner = F.tris;
  for (const Face& t : F.tris) F.area += t.area;
  return F;
}

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

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("adhesion kernel: " + what);
}

}  // namespace

namespace kernel {

double collinear(double p, double q, double r, double s, double d0) {
  return collinear_integral(p, q, r, s, d0);
}

double point_segment(const Vector2d& x, const Vector2d& q0, const Vector2d& q1, double d0) {
  return inner_segment(x, q0, q1, d0);
}

double segment_pair(const Vector2d& p0, const Vector2d& p1, const Vector2d& q0, const Vector2d& q1,
                    double d0) {
  return pair_integral_2d(p0, p1, q0, q1, d0);
}

double point_polygon(const Vector3d& x, const Vector3d* v, int nv, double d0) {
  return inner_face(x, make_face(v, nv), d0);
}

double facet_pair(const Vector3d* P, int np, const Vector3d* Q, int nq, double d0) {
  return pair_integral_3d(make_facet3(P, np), make_facet3(Q, nq), d0);
}

}  // namespace kernel

namespace {

/// The entries of one pair of facets i <= j, (k_ij, k_ji), by the centre-point rule or the exact
/// Galerkin integral; the constructor checks the vertices the exact rule needs.
class PairRule {
 public:
  PairRule(const ContactPoints& surface, double d0, bool exact)
      : S_(surface), d0_(d0), exact_(exact) {
    const int n = S_.size(), dim = S_.dim;
    if (!exact) return;
    const int nv = static_cast<int>(S_.vertices.size());
    if ((dim == 2 && nv != 2) || (dim == 3 && nv != 3 && nv != 4))
      fail(
          "the exact kernel needs surface.vertices: 2 (2-D) or 4 (3-D) matrices of size dim x "
          "#points, got " +
          std::to_string(nv));
    for (int v = 0; v < nv; ++v)
      if (S_.vertices[v].rows() != dim || S_.vertices[v].cols() != n)
        fail("surface.vertices[" + std::to_string(v) + "] must be dim x #points");
    auto check_measure = [&](int s, double measure, double rel, const char* what) {
      if (std::abs(measure - S_.area(s)) > rel * S_.area(s))
        fail("on facet " + std::to_string(s) + " the " + what + " " + std::to_string(measure) +
             " differs from surface.area " + std::to_string(S_.area(s)) +
             ": check surface.vertices");
    };
    if (dim == 2) {
      for (int s = 0; s < n; ++s)
        check_measure(s, (S_.vertices[1].col(s) - S_.vertices[0].col(s)).norm(), 1e-3,
                      "segment length");
      return;
    }
    facets_.resize(n);
    for (int s = 0; s < n; ++s) {
      Vector3d v[4];
      for (int c = 0; c < nv; ++c) v[c] = S_.vertices[c].col(s);
      facets_[s] = make_facet3(v, nv);
      check_measure(s, facets_[s].area, 1e-2, "area of the vertices' triangles (cyclic order?)");
    }
  }

  /// Is a pair expensive (3-D exact quadrature: worth a parallel loop)?
  bool costly() const { return exact_ && S_.dim == 3; }

  std::pair<double, double> operator()(int i, int j) const {
    if (!exact_) {
      // [LTL87 (6.4)-(6.5)] centre-point rule: k_ss' = d(x_s - x_s') |G_s'|.
      const double d = d0_ * std::exp(-d0_ * (S_.centre.col(i) - S_.centre.col(j)).norm());
      return {d * S_.area(j), d * S_.area(i)};
    }
    // Exact Galerkin integral: k_ss' = (1/|G_s|) int_{G_s} int_{G_s'} d(x - y) dy dx.
    const double I = S_.dim == 2
                         ? pair_integral_2d(S_.vertices[0].col(i), S_.vertices[1].col(i),
                                            S_.vertices[0].col(j), S_.vertices[1].col(j), d0_)
                         : pair_integral_3d(facets_[i], facets_[j], d0_);
    return {I / S_.area(i), I / S_.area(j)};
  }

 private:
  const ContactPoints& S_;
  double d0_;
  bool exact_;
  std::vector<Facet3> facets_;
};

/// The largest facet diameter D of kernel_cutoff().
double largest_diameter(const ContactPoints& S) {
  double D = 0.0;
  for (int s = 0; s < S.size(); ++s) {
    double d = S.dim == 2 ? S.area(s) : 2.0 * std::sqrt(S.area(s));
    if (S.dim == 3 && !S.vertices.empty()) {
      d = 0.0;
      for (const Eigen::MatrixXd& v : S.vertices)
        d = std::max(d, 2.0 * (v.col(s) - S.centre.col(s)).norm());
    }
    D = std::max(D, d);
  }
  return D;
}

}  // namespace

Eigen::MatrixXd adhesion_kernel(const ContactPoints& surface, double d0, bool exact) {
  const int n = surface.size();
  const PairRule rule(surface, d0, exact);
  Eigen::MatrixXd k(n, n);
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic) if (rule.costly())
#endif
  for (int j = 0; j < n; ++j)
    for (int i = 0; i <= j; ++i)  // iteration j writes k(i,j), k(j,i), i <= j: no race
      std::tie(k(i, j), k(j, i)) = rule(i, j);
  return k;
}

double kernel_cutoff(const ContactPoints& surface, double d0, double rel_tol) {
  if (!(d0 > 0.0) || !std::isfinite(d0)) fail("d0 must be > 0 for a kernel cutoff");
  if (!(rel_tol > 0.0 && rel_tol < 1.0)) fail("the cutoff tolerance must be in (0, 1)");
  const double D = largest_diameter(surface), delta = d0 * D;
  // Newton on f(x) = delta - x + log(1 + x) - log(rel_tol) = 0 from the right of the root (f is
  // concave and decreasing there): monotone convergence.
  double x = delta - std::log(rel_tol) + std::log1p(delta - std::log(rel_tol));
  for (int it = 0; it < 50; ++it) {
    const double f = delta - x + std::log1p(x) - std::log(rel_tol);
    const double dx = f / (1.0 - 1.0 / (1.0 + x));
    x += dx;
    if (std::abs(dx) <= 1e-12 * x) break;
  }
  return D + x / d0;
}

Eigen::SparseMatrix<double> adhesion_kernel_sparse(const ContactPoints& surface, double d0,
                                                   bool exact, double rel_tol) {
  const int n = surface.size(), dim = surface.dim;
  const PairRule rule(surface, d0, exact);
  const double rc = kernel_cutoff(surface, d0, rel_tol);
  // The centres on a grid of cell size rc: the pairs within rc are in neighbouring cells.
  using Cell = std::array<long long, 3>;
  std::vector<std::pair<Cell, int>> binned(n);
  Eigen::Vector3d lo = Eigen::Vector3d::Zero();
  if (n > 0) lo.head(dim) = surface.centre.rowwise().minCoeff();
  for (int s = 0; s < n; ++s) {
    Cell c{0, 0, 0};
    for (int a = 0; a < dim; ++a)
      c[a] = static_cast<long long>(std::floor((surface.centre(a, s) - lo(a)) / rc));
    binned[s] = {c, s};
  }
  std::sort(binned.begin(), binned.end());
  std::vector<std::pair<int, int>> pairs;  // i <= j within rc
  for (int s = 0; s < n; ++s) {
    const Cell& c = binned[s].first;
    const int i = binned[s].second;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = (dim == 3 ? -1 : 0); dz <= (dim == 3 ? 1 : 0); ++dz) {
          const Cell nb{c[0] + dx, c[1] + dy, c[2] + dz};
          auto first = std::lower_bound(binned.begin(), binned.end(), std::make_pair(nb, 0));
          for (auto it = first; it != binned.end() && it->first == nb; ++it) {
            const int j = it->second;
            if (i <= j && (surface.centre.col(i) - surface.centre.col(j)).norm() <= rc)
              pairs.emplace_back(i, j);
          }
        }
  }
  std::vector<std::pair<double, double>> value(pairs.size());
  const long np = static_cast<long>(pairs.size());
#if defined(_OPENMP)
#pragma omp parallel for schedule(dynamic) if (rule.costly())
#endif
  for (long p = 0; p < np; ++p) value[p] = rule(pairs[p].first, pairs[p].second);
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(2 * pairs.size());
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    const auto [i, j] = pairs[p];
    t.emplace_back(i, j, value[p].first);
    if (i != j) t.emplace_back(j, i, value[p].second);
  }
  Eigen::SparseMatrix<double> k(n, n);
  k.setFromTriplets(t.begin(), t.end());
  return k;
}

}  // namespace ltl
