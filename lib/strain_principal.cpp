// The local strain step (4.6) for the incompressible laws in principal stretches, Ogden and
// Gent (material.hpp, paper_notes/materials.md), by the reduction of section 5 (5.4)-(5.5):
// E = Q diag(t) R^T in the frame of the signed SVD of D, t minimizing a function of 1 (plane
// strain) or 2 (3-D) log stretches.
#include "strain_principal.hpp"

#include "log_newton.hpp"

namespace ltl {

namespace {

using namespace log_newton;

/// Incompressible laws in principal stretches (Ogden, Gent; materials.md): with
/// What = W - C1 |E|^2 (4.6) becomes, on E = Q diag(t) R^T,
///   f(t) = sum_i ((Rq/2 - C1) t_i^2 - d_i t_i) + W(t),   t_1 t_2 t_3 = 1,
/// in log variables sigma = A s: 3-D (M = 2) sigma = (s_1, s_2, -s_1 - s_2); plane strain
/// (M = 1, t_3 = 1, d_3 = 0) sigma = (s, -s, 0).
template <int M>
struct ReducedPrincipal {
  const Material* m;
  double a;  // Rq - 2 C1
  Eigen::Vector3d d;

  Eigen::Vector3d sigma(const Vec<M>& s) const {
    if constexpr (M == 2) return {s[0], s[1], -s[0] - s[1]};
    return {s[0], -s[0], 0.0};
  }
  double value(const Vec<M>& s, double& mag) const {
    const Eigen::Vector3d t = sigma(s).array().exp();
    const double w = m->W_principal(t);
    mag = std::abs(w);
    double f = w;
    for (int i = 0; i < 3; ++i) {
      const double q = 0.5 * a * t[i] * t[i], l = d[i] * t[i];
      f += q - l;
      mag += std::abs(q) + std::abs(l);
    }
    return f;
  }
  double eval(const Vec<M>& s, Vec<M>& g, Mat<M>& H, double& rel, double& mag) const {
    const Eigen::Vector3d t = sigma(s).array().exp();
    Eigen::Vector3d gw, gm;
    Eigen::Matrix3d Hw;
    const double w = m->W_principal(t, &gw, &Hw, &gm);
    double f = w;
    mag = std::abs(w);
    Eigen::Vector3d gs, sc;  // gradient in sigma, and the magnitudes of its terms
    for (int i = 0; i < 3; ++i) {
      const double q = a * t[i] * t[i], l = d[i] * t[i];
      f += 0.5 * q - l;
      mag += 0.5 * std::abs(q) + std::abs(l);
      gs[i] = q - l + gw[i];
      sc[i] = std::abs(q) + std::abs(l) + gm[i];
      Hw(i, i) += 2.0 * q - l;
    }
    Eigen::Matrix<double, 3, M> A;
    if constexpr (M == 2) {
      A << 1, 0, 0, 1, -1, -1;
    } else {
      A << 1, -1, 0;
    }
    g = A.transpose() * gs;
    H = A.transpose() * Hw * A;
    const Vec<M> scale = A.cwiseAbs().transpose() * sc;
    rel = (g.cwiseAbs().array() / scale.array().max(1e-300)).maxCoeff();
    return f;
  }
  void canonical(Vec<M>& s) const {  // t sorted decreasingly (d is)
    if constexpr (M == 2) {
      double x = s[0], y = s[1], z = -s[0] - s[1];
      if (x < y) std::swap(x, y);
      if (y < z) std::swap(y, z);
      if (x < y) std::swap(x, y);
      s << x, y;
    } else {
      s[0] = std::abs(s[0]);
    }
  }
};

/// [LTL87 (4.6), (5.5)] Minimizer of ReducedPrincipal<M> from three starts (d / Rq put on det = 1,
/// floored; "two large, one small"; the identity), the lowest converged one kept. There is no
/// certificate of global minimality for these laws (section5.md covers (1.5) and the Fig 3 law):
/// the starts are the safeguard. Returns t sorted decreasingly.
template <int M>
bool minimize_reduced(const ReducedPrincipal<M>& p, Eigen::Vector3d& t) {
  const double Rq = p.a + 2.0 * p.m->C1;
  const double floor = 1e-2 * std::max(1.0, p.d[0] / Rq);
  Eigen::Vector3d l;
  for (int i = 0; i < 3; ++i) l[i] = std::log(std::max(p.d[i] / Rq, floor));
  Vec<M> starts[3];
  if constexpr (M == 2) {
    const double lm = l.sum() / 3.0;
    starts[0] << l[0] - lm, l[1] - lm;
    starts[1] << std::max(l[0], 0.0), std::max(l[1], 0.0);
  } else {
    starts[0] << 0.5 * (l[0] - l[1]);
    starts[1] << std::max(l[0], 0.0);
  }
  starts[2].setZero();
  bool found = false;
  double best = kInf;
  for (Vec<M>& s : starts) {
    double mag;  // a start outside the domain (Gent) is moved towards the identity, inside
    for (int k = 0; k < 60 && !(p.value(s, mag) < kInf); ++k) s *= 0.5;
    if (!(p.value(s, mag) < kInf)) continue;
    const NewtonResult r = newton<M>(p, s);
    if (r.converged && r.f < best) {
      best = r.f;
      t = p.sigma(s).array().exp();
      found = true;
    }
  }
  return found;
}

}  // namespace

bool minimize_principal(const Material& m, double Rq, const Eigen::Vector3d& d, bool plane,
                        Eigen::Vector3d& t) {
  if (plane) return minimize_reduced<1>(ReducedPrincipal<1>{&m, Rq - 2.0 * m.C1, d}, t);
  return minimize_reduced<2>(ReducedPrincipal<2>{&m, Rq - 2.0 * m.C1, d}, t);
}

}  // namespace ltl
