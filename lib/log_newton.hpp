// Safeguarded Newton's method in log variables s_i = ln t_i for the reduced problems of the
// local strain step (4.6), section 5 (5.5)-(5.8): shared by strain_step.cpp (the paper's laws)
// and strain_principal.cpp (Ogden, Gent). A problem P provides value(s, mag), eval(s, g, H,
// rel, mag) (value, gradient, Hessian, relative gradient, round-off scale) and canonical(s).
// Fixed-size Eigen types only: no allocation, safe to call concurrently.
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace ltl::log_newton {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();
/// Convergence test of the scalar Newton iterations: every gradient component below kGradTol
/// times the sum of the magnitudes of the terms it is made of (round-off is a few eps of that).
constexpr double kGradTol = 1e-14;
/// Accepted instead when the Newton step no longer moves the iterate (round-off floor).
constexpr double kGradFloor = 1e-12;
constexpr int kMaxIter = 100;
/// Largest step in a log variable per iteration (a factor e on t).
constexpr double kMaxStep = 1.0;

template <int M>
using Vec = Eigen::Matrix<double, M, 1>;
template <int M>
using Mat = Eigen::Matrix<double, M, M>;

/// Newton direction -H^{-1} g when H is positive definite (returns true); otherwise the
/// "saddle-free" direction -|H|^{-1} g, with |H| = V |Lambda| V^T and |lambda| floored at
/// 1e-8 max |lambda|: a descent direction that moves away from negative curvature.
template <int M>
inline bool newton_direction(const Mat<M>& H, const Vec<M>& g, Vec<M>& p) {
  // positive definite (leading minors > 0): explicit solve with the adjugate
  if constexpr (M == 2) {
    const double det = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
    if (H(0, 0) > 0.0 && det > 0.0) {
      p << -(H(1, 1) * g[0] - H(0, 1) * g[1]) / det, -(H(0, 0) * g[1] - H(1, 0) * g[0]) / det;
      return true;
    }
  } else if constexpr (M == 3) {
    const double m01 = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
    const Mat<3> C = [&] {
      Mat<3> c;
      c.col(0) = H.col(1).cross(H.col(2));
      c.col(1) = H.col(2).cross(H.col(0));
      c.col(2) = H.col(0).cross(H.col(1));
      return c;
    }();
    const double det = H.col(0).dot(C.col(0));
    if (H(0, 0) > 0.0 && m01 > 0.0 && det > 0.0) {
      p = -(C * g) / det;  // H symmetric: H^{-1} = cof(H)^T / det = cof(H) / det
      return true;
    }
  } else {
    if (H(0, 0) > 0.0) {
      p[0] = -g[0] / H(0, 0);
      return true;
    }
  }
  Eigen::SelfAdjointEigenSolver<Mat<M>> es;
  if constexpr (M == 1) {
    p[0] = -g[0] / std::max(std::abs(H(0, 0)), 1e-300);
    return false;
  } else {
    es.computeDirect(H);
    Vec<M> lam = es.eigenvalues().cwiseAbs();
    const double floor = 1e-8 * lam.maxCoeff() + 1e-300;
    lam = lam.cwiseMax(floor);
    p = -es.eigenvectors() * ((es.eigenvectors().transpose() * g).cwiseQuotient(lam));
    return false;
  }
}

struct NewtonResult {
  double f = kInf;
  double rel = kInf;
  bool converged = false;
};

/// Safeguarded Newton in log variables: modified Hessian, step capped at kMaxStep, Armijo
/// backtracking (up to the round-off of f), iterates kept sorted (canonical). Converged when
/// rel <= kGradTol, or <= kGradFloor once the step no longer changes s.
template <int M, class P>
inline NewtonResult newton(const P& prob, Vec<M>& s) {
  NewtonResult res;
  Vec<M> g, p, sn, gn;
  Mat<M> H, Hn;
  prob.canonical(s);
  double mag;
  double f = prob.eval(s, g, H, res.rel, mag);
  for (int it = 0; it < kMaxIter && res.rel > kGradTol; ++it) {
    newton_direction<M>(H, g, p);
    const double pmax = p.cwiseAbs().maxCoeff();
    if (!(pmax < kInf)) break;
    double alpha = pmax > kMaxStep ? kMaxStep / pmax : 1.0;
    // Armijo, up to the round-off of f: a decrease below eps |terms| cannot be seen, and
    // must not stop a Newton step that the gradient still asks for.
    const double slope = g.dot(p), noise = 16.0 * kEps * mag;
    sn = s + alpha * p;
    prob.canonical(sn);
    double reln, magn;
    double fn = prob.eval(sn, gn, Hn, reln, magn);
    bool ok = fn <= f + 1e-4 * alpha * slope + noise;
    for (int k = 0; k < 60 && !ok; ++k) {
      alpha *= 0.5;
      sn = s + alpha * p;
      fn = prob.value(sn, magn);
      ok = fn <= f + 1e-4 * alpha * slope + noise;
      if (ok) {
        prob.canonical(sn);
        fn = prob.eval(sn, gn, Hn, reln, magn);
      }
    }
    if (!ok) break;  // no decrease representable: we sit at the round-off floor
    const double moved = (sn - s).cwiseAbs().maxCoeff();
    s = sn;
    f = fn;
    g = gn;
    H = Hn;
    res.rel = reln;
    mag = magn;
    if (moved <= 4.0 * kEps * (1.0 + s.cwiseAbs().maxCoeff())) break;
  }
  res.f = f;
  res.converged = res.rel <= kGradTol || res.rel <= kGradFloor;
  return res;
}

}  // namespace ltl::log_newton
