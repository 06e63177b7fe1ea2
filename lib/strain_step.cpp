// The local strain step (4.6) by the reduction of section 5 (see strain_step.hpp and
// paper_notes/section5.md for the mathematics and the choices made where the paper is silent).
//
// Everything in this file works on fixed-size Eigen types and scalars: no allocation, no shared
// mutable state, so StrainStep::solve can be called concurrently from OpenMP threads.
//
// Performance (paper_notes/performance.md): one cell costs ~120 ns in plane strain and ~280 ns
// in 3-D (Mooney-Rivlin, C2 = 0, Fig 6 loadings) on one core. The 3-D cost is the signed SVD
// (signed_svd.cpp, ~150 ns) and the reduced problem (solve_mr3_dual, a scalar Newton iteration
// on the multiplier, ~100 ns); the general path (Newton in log variables with certificates)
// remains as the fallback.
#include "strain_step.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "log_newton.hpp"
#include "strain_principal.hpp"

namespace ltl {

namespace {

using namespace log_newton;

// ------------------------------------------------------------------------------------------
// Reduced problems in log variables s_i = ln t_i, with d sorted d_1 >= d_2 (>= d_3), the sign
// on the last one. Each provides value(s), eval(s, g, H) returning the value, the gradient, the
// Hessian and the relative gradient max_i |g_i| / scale_i, and canonical(s), which sorts the
// t_i decreasingly: for d sorted, this never increases the objective (rearrangement), and the
// global minimizer is sorted (section5.md, "ordering").

/// [LTL87 (5.5)-(5.8)] Mooney-Rivlin 3-D: sum_i (Rq/2 t_i^2 + C2 t_i^-2 - d_i t_i) with
/// t_1 t_2 t_3 = 1 (then t_i^-2 = t_j^2 t_k^2); free variables s_1, s_2, s_3 = -s_1 - s_2.
struct ReducedMR3 {
  double Rq, C2;
  Eigen::Vector3d d;

  void t_of(const Vec<2>& s, double x[3]) const {
    x[0] = std::exp(s[0]);
    x[1] = std::exp(s[1]);
    x[2] = 1.0 / (x[0] * x[1]);
  }
  double u(int i, double x) const { return (0.5 * Rq * x - d[i]) * x + C2 / (x * x); }
  /// Value, and in mag the sum of the magnitudes of its terms (its round-off scale).
  double value(const Vec<2>& s, double& mag) const {
    double x[3], f = 0.0;
    t_of(s, x);
    mag = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double q = 0.5 * Rq * x[i] * x[i], c = C2 / (x[i] * x[i]), l = d[i] * x[i];
      f += q + c - l;
      mag += q + c + std::abs(l);
    }
    return f;
  }
  double eval(const Vec<2>& s, Vec<2>& g, Mat<2>& H, double& rel, double& mag) const {
    double x[3], w[3], h[3], sc[3], f = 0.0;
    t_of(s, x);
    mag = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double q = Rq * x[i] * x[i], c = 2.0 * C2 / (x[i] * x[i]), l = d[i] * x[i];
      f += 0.5 * q + 0.5 * c - l;
      w[i] = q - c - l;              // du_i/ds_i
      h[i] = 2.0 * q + 2.0 * c - l;  // d2u_i/ds_i^2
      sc[i] = q + c + std::abs(l);
      mag += 0.5 * (q + c) + std::abs(l);
    }
    g << w[0] - w[2], w[1] - w[2];
    H << h[0] + h[2], h[2], h[2], h[1] + h[2];
    rel = std::max(std::abs(g[0]) / (sc[0] + sc[2]), std::abs(g[1]) / (sc[1] + sc[2]));
    return f;
  }
  void canonical(Vec<2>& s) const {
    double a = s[0], b = s[1], c = -s[0] - s[1];
    if (a < b) std::swap(a, b);
    if (b < c) std::swap(b, c);
    if (a < b) std::swap(a, b);
    s << a, b;
  }
  /// Lagrange multiplier of sum s_i = 0 at a stationary point: du_i/ds_i = mu for all i.
  double multiplier(const double x[3]) const {
    double m = 0.0;
    for (int i = 0; i < 3; ++i) {
      m += Rq * x[i] * x[i] - d[i] * x[i];
      if (C2 != 0.0) m -= 2.0 * C2 / (x[i] * x[i]);
    }
    return m / 3.0;
  }
};

/// [LTL87 sec. 8] compressible law, N = 2 (plane strain, t_3 = 1) or 3:
/// sum_i (Rq/2 t_i^2 - d_i t_i) + C3 J^2 - 2 (C1 + C3) ln J, J = prod t_i; free s_1..s_N.
template <int N>
struct ReducedComp {
  double Rq, C3, K;  // K = 2 (C1 + C3)
  Vec<N> d;

  double value(const Vec<N>& s, double& mag) const {
    double f = 0.0, J = 1.0, sig = 0.0;
    mag = 0.0;
    for (int i = 0; i < N; ++i) {
      const double x = std::exp(s[i]);
      const double q = 0.5 * Rq * x * x, l = d[i] * x;
      f += q - l;
      mag += q + std::abs(l);
      J *= x;
      sig += s[i];
    }
    mag += C3 * J * J + K * std::abs(sig);
    return f + C3 * J * J - K * sig;
  }
  double eval(const Vec<N>& s, Vec<N>& g, Mat<N>& H, double& rel, double& mag) const {
    double x[N], J = 1.0, sig = 0.0, f = 0.0;
    for (int i = 0; i < N; ++i) {
      x[i] = std::exp(s[i]);
      J *= x[i];
      sig += s[i];
    }
    const double cj = 2.0 * C3 * J * J;  // dPsi/dsigma = cj - K, d2Psi/dsigma2 = 2 cj
    f = 0.5 * cj - K * sig;
    mag = 0.5 * cj + K * std::abs(sig);
    H.setConstant(2.0 * cj);
    rel = 0.0;
    for (int i = 0; i < N; ++i) {
      const double q = Rq * x[i] * x[i], l = d[i] * x[i];
      f += 0.5 * q - l;
      mag += 0.5 * q + std::abs(l);
      g[i] = q - l + cj - K;
      H(i, i) += 2.0 * q - l;
      rel = std::max(rel, std::abs(g[i]) / (q + std::abs(l) + cj + K));
    }
    return f;
  }
  void canonical(Vec<N>& s) const {
    // insertion sort, decreasing
    for (int i = 1; i < N; ++i)
      for (int j = i; j > 0 && s[j - 1] < s[j]; --j) std::swap(s[j - 1], s[j]);
  }
};

/// [LTL87 (5.8)] in plane strain: min over s >= 0 of
/// f(s) = A (e^{2s} + e^{-2s}) - d1 e^s - d2 e^{-s},  A = Rq/2 + C2, d1 >= |d2|.
/// For d1 > d2, f'(0) = d2 - d1 < 0 and f' has exactly one zero on (0, inf) (section5.md), so a
/// bracketed Newton iteration converges to the global minimizer. Returns t1 = e^s >= 1.
bool solve_mr2(double A, double d1, double d2, double& t1) {
  if (!(d1 > d2)) {  // d1 == d2: D is a multiple of a rotation
    if (d1 <= 4.0 * A) {
      t1 = 1.0;
    } else {  // e^s solves (x^2 - 1)(2A x^2 - d x + 2A) = 0, largest root
      t1 = (d1 + std::sqrt((d1 - 4.0 * A) * (d1 + 4.0 * A))) / (4.0 * A);
    }
    return true;
  }
  auto fp = [&](double s, double& fpp, double& scale) {
    const double x = std::exp(s), y = 1.0 / x;
    const double a2 = 2.0 * A * x * x, b2 = 2.0 * A * y * y, l1 = d1 * x, l2 = d2 * y;
    fpp = 2.0 * (a2 + b2) - l1 - l2;
    scale = a2 + b2 + std::abs(l1) + std::abs(l2);
    return a2 - b2 - l1 + l2;
  };
  double lo = 0.0;
  double hi = std::log(std::max(1.0, (d1 + std::abs(d2)) / (2.0 * A) + 1.0));
  double fpp, scale;
  double g = fp(0.0, fpp, scale);
  // first guess: the Newton step from 0 when f is convex there, else the large-|D| asymptote
  double s = fpp > 0.0 ? -g / fpp : std::log(std::max(1.0, d1 / (2.0 * A)));
  if (!(s > lo && s < hi)) s = 0.5 * (lo + hi);
  for (int it = 0; it < kMaxIter; ++it) {
    g = fp(s, fpp, scale);
    if (std::abs(g) <= kGradTol * scale) {
      t1 = std::exp(s);
      return true;
    }
    if (g < 0.0) {
      lo = s;
    } else {
      hi = s;
    }
    double sn = s - g / fpp;
    if (!(fpp > 0.0) || !(sn > lo && sn < hi)) sn = 0.5 * (lo + hi);
    if (sn == s || hi - lo <= 4.0 * kEps * (1.0 + hi)) {
      t1 = std::exp(s);
      return std::abs(g) <= kGradFloor * scale;
    }
    s = sn;
  }
  t1 = std::exp(s);
  g = fp(s, fpp, scale);
  return std::abs(g) <= kGradFloor * scale;
}

/// Lower bound of k(t) = Rq/2 t^2 + C2 t^-2 - d t + m ln t (d > 0, m >= 0) over [lo, hi],
/// term by term.
inline double k_lower(double Rq, double C2, double d, double m, double lo, double hi) {
  return 0.5 * Rq * lo * lo + C2 / (hi * hi) - d * hi + m * std::log(lo);
}

/// One component of the certificates (section5.md, "certificates"): is x_star the minimizer of
/// k(t) = Rq/2 t^2 + C2 t^-2 - d t + m ln t over [Y, inf)? Here m >= 0, x_star is a
/// stationary point: q(x_star) = 0 with q(x) = t dk/dt t^2 = phi(x) - 2 C2,
/// phi(x) = Rq x^4 - d x^3 + m x^2, phi' = x (4 Rq x^2 - 3 d x + 2 m).
bool component_global(double Rq, double C2, double d, double m, double x_star, double Y) {
  auto k = [&](double t) { return (0.5 * Rq * t - d) * t + C2 / (t * t) + m * std::log(t); };
  const double D9 = 9.0 * d * d - 32.0 * Rq * m;
  if (d <= 0.0 || D9 <= 0.0) {
    // phi increasing: one stationary point. With C2 > 0, k -> +inf at both ends: global.
    // With C2 = 0 (k -> -inf as t -> 0), compare with the left end of the range.
    return C2 > 0.0 || !(Y < x_star) || k(Y) >= k(x_star);
  }
  const double sq = std::sqrt(D9);
  const double xb = (3.0 * d + sq) / (8.0 * Rq), xa = 4.0 * m / (3.0 * d + sq);
  auto phi = [&](double x) { return ((Rq * x - d) * x + m) * x * x; };
  if (C2 > 0.0 && (phi(xa) <= 2.0 * C2 || phi(xb) >= 2.0 * C2)) return true;  // one root
  // three roots r1 < xa < r2 < xb < r3 (r1 = 0 when C2 = 0); x_star must be r3, and k is
  // decreasing on [xb, r3]: only [Y, xb] remains, bounded below term by term (C2 > 0) or by
  // k(Y) (C2 = 0: k increases up to r2 and decreases after).
  if (!(x_star > xb)) return false;
  if (Y >= xb) return true;
  const double ks = k(x_star);
  const double lower = C2 == 0.0 ? k(Y) : k_lower(Rq, C2, d, m, Y, xb);
  return lower >= ks + 1e-12 * (std::abs(ks) + std::abs(lower));
}

/// Sufficient condition for a stationary point x of ReducedMR3 to be the global minimizer
/// (section5.md, "certificates"): with mu the multiplier of sum s = 0, each
/// k_i(s) = u_i(s) - mu s must be minimal at s_i over the range that s_i can take on the
/// sublevel set {f <= f(x)} (for feasible s, f(s) = sum_i k_i(s_i)).
bool certify_mr3(const ReducedMR3& p, const double x[3], double f) {
  const double mu = p.multiplier(x);
  // mu >= 0: each k_i has one stationary point and -> +inf at both ends (C2 > 0); for C2 = 0,
  // k_i' = Rq t^2 - d t + mu has one positive root and k_i -> +inf at both ends when mu > 0
  // (mu = 0: k_i = u_i, bounded below)
  if (mu >= 0.0) return true;
  const double Rq = p.Rq, C2 = p.C2;
  // bounds X_j >= t_j on the sublevel set, from u_j >= Rq/2 t^2 - d_j t >= -d_j+^2 / (2 Rq)
  double low[3], sum_low = 0.0, mag = std::abs(f);
  for (int j = 0; j < 3; ++j) {
    const double dp = std::max(p.d[j], 0.0);
    low[j] = -dp * dp / (2.0 * Rq);
    sum_low += low[j];
    mag += std::abs(low[j]);
  }
  double X[3];
  for (int j = 0; j < 3; ++j) {
    const double B = f - (sum_low - low[j]) + 1e-10 * mag;
    X[j] = (p.d[j] + std::sqrt(std::max(0.0, p.d[j] * p.d[j] + 2.0 * Rq * B))) / Rq;
  }
  for (int i = 0; i < 3; ++i) {
    const double Y = 1.0 / (X[(i + 1) % 3] * X[(i + 2) % 3]);
    if (!component_global(Rq, C2, p.d[i], -mu, x[i], Y)) return false;
  }
  return true;
}

/// Same for ReducedComp<N> (section5.md): kappa = dPsi/dsigma at the stationary point. For
/// kappa < 0 every k_i = u_i + kappa s has one stationary point and tends to +inf at both ends;
/// Psi lies above its tangent: Lagrangian sufficiency. For kappa >= 0, the range of s_i on the
/// sublevel set is bounded below and each k_i is checked on it.
template <int N>
bool certify_comp(const ReducedComp<N>& p, const Vec<N>& x, double f) {
  double J = 1.0;
  for (int i = 0; i < N; ++i) J *= x[i];
  const double kappa = 2.0 * p.C3 * J * J - p.K;
  if (kappa < 0.0) return true;
  const double Rq = p.Rq;
  // Psi(sigma) = C3 e^{2 sigma} - K sigma >= Psi_min; u_j >= -d_j+^2 / (2 Rq)
  const double psi_min = p.C3 > 0.0 ? 0.5 * p.K * (1.0 - std::log(p.K / (2.0 * p.C3))) : -kInf;
  if (!(psi_min > -kInf)) return false;
  double low[N], sum_low = 0.0, mag = std::abs(f) + std::abs(psi_min);
  for (int j = 0; j < N; ++j) {
    const double dp = std::max(p.d[j], 0.0);
    low[j] = -dp * dp / (2.0 * Rq);
    sum_low += low[j];
    mag += std::abs(low[j]);
  }
  const double margin = 1e-10 * mag;
  double lX[N], lXsum = 0.0;
  for (int j = 0; j < N; ++j) {
    const double B = f - (sum_low - low[j]) - psi_min + margin;
    lX[j] = std::log((p.d[j] + std::sqrt(std::max(0.0, p.d[j] * p.d[j] + 2.0 * Rq * B))) / Rq);
    lXsum += lX[j];
  }
  // C3 e^{2 sigma} - K sigma <= f - sum low  =>  sigma >= -(f - sum low) / K
  const double sigma_lo = -(f - sum_low + margin) / p.K;
  for (int i = 0; i < N; ++i) {
    const double Y = std::exp(sigma_lo - (lXsum - lX[i]));
    if (!component_global(Rq, 0.0, p.d[i], kappa, x[i], Y)) return false;
  }
  return true;
}

/// Mooney-Rivlin with C2 = 0, fast path (performance.md): at a stationary point of (5.8)
/// with multiplier mu, Rq t_i^2 - d_i t_i = mu for every i. On the branch where every t_i is the
/// larger root, t_i(mu) = (d_i + S_i) / (2 Rq), S_i = sqrt(d_i^2 + 4 Rq mu), increasing in mu,
/// and mu solves h(mu) = t_1 t_2 t_3 - 1 = 0: safeguarded Newton on a bracket, started from the
/// linearization of ln h at mu = 0; once |h| <= kLinear the last Newton step moves t by its
/// second-order Taylor expansion, dt_i/dmu = 1/S_i, d2t_i/dmu2 = -2 Rq/S_i^3 (the error of
/// that step and of the Newton step itself are then at round-off). The result is
/// accepted only if certify_mr3 proves it global (always when mu >= 0); otherwise (or when the
/// branch has no root) the caller runs minimize_mr3. Three evaluations of t(mu) (3 square roots
/// each) on the Fig 6 loadings, instead of a 2-D Newton iteration in log variables with its line
/// search, the starts and their comparison.
bool solve_mr3_dual(const ReducedMR3& p, double t[3]) {
  if (p.C2 != 0.0) return false;
  const double Rq = p.Rq;
  constexpr double kLinear = 1e-7;  // Newton's next h is ~0.06 h^2 here: at round-off
  const double inv2Rq = 0.5 / Rq;
  double tp[3];                             // dt_i / dmu = 1 / S_i
  auto eval = [&](double mu, double& hp) {  // h = t1 t2 t3 - 1 (no log), hp = dh/dmu
    double P = 1.0, sum = 0.0;
    for (int i = 0; i < 3; ++i) {
      const double d = p.d[i], S = std::sqrt(std::max(d * d + 4.0 * Rq * mu, 0.0));
      t[i] = d >= 0.0 ? (d + S) * inv2Rq : 2.0 * mu / (S - d);  // no cancellation
      tp[i] = 1.0 / S;
      P *= t[i];
      sum += 1.0 / (S * t[i]);  // d ln t_i / d mu
    }
    hp = P * sum;
    return P - 1.0;
  };
  // Bracket [lo, hi] (hi = inf until a point with h > 0 is seen):
  // the branch needs d_i^2 + 4 Rq mu >= 0 (all d_i > 0: mu >= -d_3^2 / (4 Rq)) and t_i > 0
  // (some d_i <= 0: mu > 0; d is sorted, only d_3 can be negative).
  double lo = 0.0, hi = kInf, mu = 0.0, h, hp;
  if (p.d[2] > 0.0) {
    // t_i(0) = d_i / Rq, so the sign of h(0) is known without evaluating; the first iterate is
    // the Newton step of ln(t1 t2 t3) from 0 (t_i ~ d_i / Rq + mu / d_i)
    const double P0 = (p.d[0] / Rq) * (p.d[1] / Rq) * (p.d[2] / Rq);
    if (P0 > 1.0) {
      lo = -p.d[2] * p.d[2] / (4.0 * Rq);
      double hplo;
      if (!(eval(lo, hplo) < 0.0)) return false;  // no stationary point on this branch
      hi = 0.0;
    }
    const double slope =
        Rq * (1.0 / (p.d[0] * p.d[0]) + 1.0 / (p.d[1] * p.d[1]) + 1.0 / (p.d[2] * p.d[2]));
    mu = -std::log(P0) / slope;
    if (!(mu > lo && mu < hi)) mu = hi < kInf ? 0.5 * (lo + hi) : 0.0;
    h = eval(mu, hp);
  } else {
    mu = 1e-2 * Rq;  // h(0) = -inf: start inside
    h = eval(mu, hp);
  }
  bool converged = false;
  for (int it = 0; it < kMaxIter; ++it) {
    if (std::abs(h) <= 8.0 * kEps) {
      converged = true;
      break;
    }
    if (h < 0.0) {
      lo = mu;
    } else {
      hi = mu;
    }
    double mn = mu - h / hp;
    if (std::abs(h) <= kLinear && mn > lo && mn < hi) {  // last step: Taylor, 2nd order
      const double dm = mn - mu;
      for (int i = 0; i < 3; ++i) t[i] += dm * tp[i] * (1.0 - dm * Rq * tp[i] * tp[i]);
      converged = true;
      break;
    }
    if (!(mn > lo && mn < hi)) mn = hi < kInf ? 0.5 * (lo + hi) : 2.0 * mu + Rq;
    if (mn == mu || (hi < kInf && hi - lo <= 4.0 * kEps * std::max(std::abs(lo), std::abs(hi)))) {
      converged = std::abs(h) <= 1e-12;
      break;
    }
    mu = mn;
    h = eval(mu, hp);
  }
  if (!converged || !(t[2] > 0.0)) return false;
  t[2] = 1.0 / (t[0] * t[1]);  // det E = 1 exactly (t_3 the smallest, relative change ~eps)
  double f = 0.0;
  for (int i = 0; i < 3; ++i) f += (0.5 * Rq * t[i] - p.d[i]) * t[i];
  return certify_mr3(p, t, f);
}

/// Global minimizer of ReducedMR3 (returns converged flag); t sorted decreasingly.
bool minimize_mr3(const ReducedMR3& p, double t[3]) {
  const double c1 = p.d[0] / p.Rq, c2 = p.d[1] / p.Rq, c3 = p.d[2] / p.Rq;
  const double floor = 1e-2 * std::max(1.0, c1);
  // primary start: the unconstrained C2 = 0 minimizer d / Rq, floored and put on det = 1
  const double l1 = std::log(std::max(c1, floor)), l2 = std::log(std::max(c2, floor)),
               l3 = std::log(std::max(c3, floor)), lm = (l1 + l2 + l3) / 3.0;
  // other starts: "two large, one small" (the pattern of the minimizer at large |D|) and the
  // identity. Newton starts from the lowest of the first two, the others are tried only
  // when the result is not certified global.
  Vec<2> starts[3] = {Vec<2>(l1 - lm, l2 - lm),
                      Vec<2>(std::log(std::max(c1, 1.0)), std::log(std::max(c2, 1.0))),
                      Vec<2>(0.0, 0.0)};
  double m0, m1;
  if (c3 > 0.0 && c1 * c2 * c3 > 1.0 && p.value(starts[1], m1) < p.value(starts[0], m0)) {
    std::swap(starts[0], starts[1]);
  }
  Vec<2> s = starts[0];
  NewtonResult r = newton<2>(p, s);
  p.t_of(s, t);
  if (r.converged && certify_mr3(p, t, r.f)) return true;
  // not certified: try the other starts and keep the best
  for (int k = 1; k < 3; ++k) {
    Vec<2>& s2 = starts[k];
    NewtonResult r2 = newton<2>(p, s2);
    if (r2.converged && (!r.converged || r2.f < r.f)) {
      r = r2;
      s = s2;
    }
  }
  p.t_of(s, t);
  return r.converged;
}

/// Compressible law, certified regime [section5.md]: stationary points with
/// kappa = dPsi/dsigma < 0 are global minima, and there t_i is the positive root of
/// Rq x^2 - d_i x + kappa = 0, t_i = x_i(kappa), decreasing in kappa. kappa solves
/// h(kappa) = 2 C3 P(kappa)^2 - K - kappa = 0, P = prod x_i, h strictly decreasing on (-K, 0),
/// h(-K) > 0: a root in (-K, 0) exists iff h(0-) < 0. Safeguarded Newton on h. Returns false
/// when there is no such root (then kappa* >= 0) or no convergence; t then is unspecified.
template <int N>
bool solve_comp_dual(const ReducedComp<N>& p, Vec<N>& t) {
  const double Rq = p.Rq, K = p.K, C3 = p.C3;
  double P0 = 1.0;  // P(0-) = prod max(d_i, 0) / Rq
  for (int i = 0; i < N; ++i) P0 *= std::max(p.d[i], 0.0) / Rq;
  if (!(2.0 * C3 * P0 * P0 < K)) return false;
  auto eval = [&](double kappa, double& hp, double& scale) {
    double P = 1.0, sum = 0.0;
    for (int i = 0; i < N; ++i) {
      const double d = p.d[i], S = std::sqrt(d * d - 4.0 * Rq * kappa);
      t[i] = d >= 0.0 ? (d + S) / (2.0 * Rq) : -2.0 * kappa / (S - d);  // no cancellation
      P *= t[i];
      sum += 1.0 / (S * t[i]);  // -d ln x_i / d kappa
    }
    const double c = 2.0 * C3 * P * P;
    hp = -2.0 * c * sum - 1.0;
    scale = c + K + std::abs(kappa);
    return c - K - kappa;
  };
  double lo = -K, hi = 0.0;
  // start: kappa from the volume of t = d / Rq (floored), clamped into the bracket
  double J = 1.0;
  for (int i = 0; i < N; ++i) J *= std::max(p.d[i] / Rq, 1e-3);
  double kappa = std::min(std::max(2.0 * C3 * J * J - K, -0.999 * K), -1e-3 * K);
  for (int it = 0; it < kMaxIter; ++it) {
    double hp, scale;
    const double h = eval(kappa, hp, scale);
    if (std::abs(h) <= kGradTol * scale) return true;
    if (h > 0.0) {
      lo = kappa;
    } else {
      hi = kappa;
    }
    double kn = kappa - h / hp;
    if (!(kn > lo && kn < hi)) kn = 0.5 * (lo + hi);
    if (kn == kappa || hi - lo <= 4.0 * kEps * K) return std::abs(h) <= kGradFloor * scale;
    kappa = kn;
  }
  return false;
}

/// Global minimizer of ReducedComp<N>; t sorted decreasingly.
template <int N>
bool minimize_comp(const ReducedComp<N>& p, Vec<N>& t) {
  if (solve_comp_dual<N>(p, t)) {
    // t_i from the decoupled conditions are sorted like d; keep them so
    return true;
  }
  const double c1 = p.d[0] / p.Rq;
  const double floor = 1e-2 * std::max(1.0, c1);
  // starts: d / Rq (floored); "last one small" at the stress-free volume J0^2 = K / (2 C3)
  // (the pattern of the minimizer at large |D|); equal stretches at J0. Newton starts from the
  // lowest of the first two, the others are tried only when the result is not certified.
  const double J0 = p.C3 > 0.0 ? std::sqrt(p.K / (2.0 * p.C3)) : 1.0;
  Vec<N> starts[3];
  double lsum = 0.0;
  for (int i = 0; i < N; ++i) starts[0][i] = std::log(std::max(p.d[i] / p.Rq, floor));
  for (int i = 0; i < N - 1; ++i) {
    starts[1][i] = starts[0][i];
    lsum += starts[0][i];
  }
  starts[1][N - 1] = std::min(std::log(J0) - lsum, starts[0][N - 1]);
  starts[2].setConstant(std::log(J0) / N);
  double m0, m1;
  if (starts[1][N - 1] < starts[0][N - 1] && p.value(starts[1], m1) < p.value(starts[0], m0)) {
    std::swap(starts[0], starts[1]);
  }
  Vec<N> s = starts[0];
  NewtonResult r = newton<N>(p, s);
  t = s.array().exp();
  if (r.converged && certify_comp<N>(p, t, r.f)) return true;
  // not certified (large volume change): try the other starts and keep the best
  for (int k = 1; k < 3; ++k) {
    Vec<N>& s2 = starts[k];
    NewtonResult r2 = newton<N>(p, s2);
    if (r2.converged && (!r.converged || r2.f < r.f)) {
      r = r2;
      s = s2;
    }
  }
  t = s.array().exp();
  return r.converged;
}

}  // namespace

// ------------------------------------------------------------------------------------------

StrainStep::StrainStep(const Material& material, double Rq) : material_(material), Rq_(Rq) {}

namespace {

/// [LTL87 (5.4)-(5.5)] E = Q diag(t) R^T, with D = Q diag(d) R^T the signed SVD and t = reduced(d)
/// the minimizer of the reduced problem in the singular values; returns reduced's flag.
template <int N, class Reduced>
bool solve_in_frame(const Mat<N>& D, Mat<N>& E, const Reduced& reduced) {
  Mat<N> Q, R;
  Vec<N> d, t;
  signed_svd(D, Q, d, R);
  const bool ok = reduced(d, t);
  E.noalias() = Q * t.asDiagonal() * R.transpose();
  return ok;
}

}  // namespace

/// [LTL87 (4.6), (5.2)-(5.8)] plane strain.
bool StrainStep::solve(const Eigen::Matrix2d& D, Eigen::Matrix2d& E) const {
  return solve_in_frame<2>(D, E, [&](const Vec<2>& d, Vec<2>& t) {
    if (material_.principal()) {
      Eigen::Vector3d t3;
      const bool ok = minimize_principal(material_, Rq_, {d[0], d[1], 0.0}, true, t3);
      t = t3.head<2>();
      return ok;
    }
    if (material_.incompressible()) {
      double t1 = 1.0;
      const bool ok = solve_mr2(0.5 * Rq_ + material_.C2, d[0], d[1], t1);
      t << t1, 1.0 / t1;
      return ok;
    }
    const ReducedComp<2> p{Rq_, material_.C3, 2.0 * (material_.C1 + material_.C3), d};
    return minimize_comp<2>(p, t);
  });
}

/// [LTL87 (4.6), (5.2)-(5.8)] 3-D.
bool StrainStep::solve(const Eigen::Matrix3d& D, Eigen::Matrix3d& E) const {
  return solve_in_frame<3>(D, E, [&](const Vec<3>& d, Vec<3>& t) {
    if (material_.principal()) {
      Eigen::Vector3d t3;
      const bool ok = minimize_principal(material_, Rq_, d, false, t3);
      t = t3;
      return ok;
    }
    if (material_.incompressible()) {
      const ReducedMR3 p{Rq_, material_.C2, d};
      double x[3];
      const bool ok = solve_mr3_dual(p, x) || minimize_mr3(p, x);
      t << x[0], x[1], x[2];
      return ok;
    }
    const ReducedComp<3> p{Rq_, material_.C3, 2.0 * (material_.C1 + material_.C3), d};
    return minimize_comp<3>(p, t);
  });
}

double StrainStep::objective(const Eigen::Matrix2d& D, const Eigen::Matrix2d& E) const {
  if (material_.incompressible() && !(std::abs(E.determinant() - 1.0) <= 1e-8)) return kInf;
  const double w = material_.W(E);
  if (!(w < kInf)) return kInf;
  const double E2 = E.squaredNorm() + 1.0;  // |diag(E, 1)|^2
  return 0.5 * Rq_ * E2 + w - material_.C1 * E2 - (D.array() * E.array()).sum();
}

double StrainStep::objective(const Eigen::Matrix3d& D, const Eigen::Matrix3d& E) const {
  if (material_.incompressible() && !(std::abs(E.determinant() - 1.0) <= 1e-8)) return kInf;
  const double w = material_.W(E);
  if (!(w < kInf)) return kInf;
  const double E2 = E.squaredNorm();
  return 0.5 * Rq_ * E2 + w - material_.C1 * E2 - (D.array() * E.array()).sum();
}

}  // namespace ltl
