// The local adhesion / contact step [LTL87 (4.7), (6.1)-(6.8)]; see contact_step.hpp and
// paper_notes/section6.md.
#include "contact_step.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <stdexcept>
#include <string>

#include "adhesion_kernel.hpp"

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

std::string point_str(int s) {
  return "contact point " + std::to_string(s);
}

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("ContactStep: " + what);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// The point problem
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

double ContactStep::point_objective(const Vector3d& a, double aa, double b, double Rqc,
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
  return point_objective(a, aa, b, Rqc, kappa, project(a / c, N, gap), gamma);
}

PointSolution ContactStep::solve_point(const Vector3d& a_in, double aa, double b, double Rqc,
                                       double kappa, const Vector3d& N_in, double gap, int dim,
                                       double beta_current) {
  Vector3d a = a_in, N = N_in;
  if (dim == 2) a(2) = N(2) = 0.0;
  const double beta_keep = std::clamp(beta_current, 0.0, 1.0);
  PointSolution sol;

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
// The contact points
// ---------------------------------------------------------------------------------------------

void ContactStep::set_Rqc(double Rqc) {
  if (!(Rqc > 0.0) || !std::isfinite(Rqc)) fail("Rqc = R q_c must be > 0");
  Rqc_ = Rqc;
}

ContactStep::ContactStep(const ContactPoints& points, const Adhesion& adhesion, double Rqc)
    : points_(&points), adhesion_(adhesion), Rqc_(Rqc) {
  const int dim = points_->dim;
  if (dim != 2 && dim != 3) fail("points.dim = " + std::to_string(dim) + ", expected 2 or 3");
  const int n = points_->size();
  if (points_->centre.rows() != dim || points_->centre.cols() != n)
    fail("points.centre is " + std::to_string(points_->centre.rows()) + " x " +
         std::to_string(points_->centre.cols()) + ", expected dim x #points = " +
         std::to_string(dim) + " x " + std::to_string(n) + " (#points = points.area.size())");
  if (points_->gap.size() != n)
    fail("points.gap has " + std::to_string(points_->gap.size()) +
         " entries, expected #points = " + std::to_string(n));
  if (points_->N.size() != dim)
    fail("points.N has " + std::to_string(points_->N.size()) +
         " entries, expected dim = " + std::to_string(dim));
  const double Nn = points_->N.norm();
  if (!(Nn > 0.0) || !std::isfinite(Nn)) fail("points.N must be a nonzero finite vector");
  for (int s = 0; s < n; ++s) {
    if (!(points_->area(s) > 0.0) || !std::isfinite(points_->area(s)))
      fail("points.area(" + std::to_string(s) + ") = " + std::to_string(points_->area(s)) + " on " +
           point_str(s) + ", must be > 0");
    if (!std::isfinite(points_->gap(s))) fail("points.gap is not finite on " + point_str(s));
  }
  if (!(Rqc > 0.0) || !std::isfinite(Rqc)) fail("Rqc = R q_c must be > 0");
  if (!(adhesion_.kappa >= 0.0) || !std::isfinite(adhesion_.kappa))
    fail("adhesion.kappa = 1/eps must be >= 0 (0: no glue)");
  if (!(adhesion_.d0 >= 0.0) || !std::isfinite(adhesion_.d0))
    fail("adhesion.d0 must be >= 0 (0: no dissipation)");
  if (!(adhesion_.dt > 0.0) || !std::isfinite(adhesion_.dt)) fail("adhesion.dt must be > 0");
  if (!std::isfinite(adhesion_.w)) fail("adhesion.w must be finite");

  N3_.setZero();
  N3_.head(dim) = points_->N / Nn;

  // [LTL87 (6.4)-(6.5)] the kernel k_ss' (adhesion_kernel.hpp), sparse; empty without
  // dissipation: no #points^2 buffer in either case.
  k_ = adhesion_.d0 > 0.0 ? adhesion_kernel_sparse(points, adhesion_.d0, adhesion_.exact_kernel)
                          : Eigen::SparseMatrix<double>(n, n);
  k_.makeCompressed();
  kt_ = k_.transpose();
  kdiag_ = k_.diagonal();
}

double ContactStep::kernel_bytes() const {
  auto bytes = [](const Eigen::SparseMatrix<double>& m) {
    return static_cast<double>(m.nonZeros()) * (sizeof(double) + sizeof(int)) +
           static_cast<double>(m.outerSize() + 1) * sizeof(int);
  };
  return bytes(k_) + bytes(kt_) + static_cast<double>(kdiag_.size()) * sizeof(double);
}

/// sum over s' of k_ss' (beta_s' - beta_prev_s'): row s of k is column s of kt.
static double kernel_row_dot(const Eigen::SparseMatrix<double>& kt, int s,
                             const Eigen::Ref<const Eigen::VectorXd>& beta,
                             const Eigen::Ref<const Eigen::VectorXd>& beta_prev) {
  double sum = 0.0;
  for (Eigen::SparseMatrix<double>::InnerIterator it(kt, s); it; ++it)
    sum += it.value() * (beta(it.row()) - beta_prev(it.row()));
  return sum;
}

void ContactStep::solve(ConstMatRef ubar, ConstMatRef lambda_c, ConstVecRef beta_prev, MatRef e,
                        VecRef beta, int sweeps, int first, int end) const {
  const int n = points_->size(), dim = points_->dim;
  if (end < 0) end = n;
  if (ubar.rows() != n || ubar.cols() != dim || lambda_c.rows() != n || lambda_c.cols() != dim ||
      e.rows() != n || e.cols() != dim || beta_prev.size() != n || beta.size() != n)
    fail("solve(): ubar, lambda_c, e must be #points x dim and beta_prev, beta #points (dim = " +
         std::to_string(dim) + ", #points = " + std::to_string(n) + ")");
  const double dt = adhesion_.dt, w = adhesion_.w, kappa = adhesion_.kappa;
  const bool dissipation = adhesion_.d0 > 0.0;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (int s = first; s < end; ++s) {
      Vector3d a = Vector3d::Zero();
      a.head(dim) = (Rqc_ * ubar.row(s) - lambda_c.row(s)).transpose();  // (6.3)
      double aa = 0.0, b = w;
      if (dissipation) {
        const double kss = kdiag_(s);
        aa = kss / dt;  // (6.4)
        // (6.5), with the newest beta of the other points (Gauss-Seidel).
        const double others =
            kernel_row_dot(kt_, s, beta, beta_prev) - kss * (beta(s) - beta_prev(s));
        b = w - others / dt + kss * beta_prev(s) / dt;
      }
      const PointSolution sol =
          solve_point(a, aa, b, Rqc_, kappa, N3_, points_->gap(s), dim, beta(s));
      e.row(s) = sol.e.head(dim).transpose();
      beta(s) = sol.beta;
    }
  }
}

double ContactStep::energy(ConstMatRef e, ConstVecRef beta, ConstVecRef beta_prev) const {
  const int n = points_->size(), dim = points_->dim;
  if (e.rows() != n || e.cols() != dim || beta.size() != n || beta_prev.size() != n)
    fail("energy(): e must be #points x dim and beta, beta_prev #points");
  double E = 0.0;
  for (int s = 0; s < n; ++s) {
    if (!(beta(s) >= 0.0 && beta(s) <= 1.0)) return kInf;
    const double en = e.row(s).dot(N3_.head(dim).transpose()), g = points_->gap(s);
    if (en > g + 1e-10 * (e.row(s).norm() + std::abs(g))) return kInf;
    E += points_->area(s) * (0.5 * adhesion_.kappa * beta(s) * beta(s) * e.row(s).squaredNorm() -
                             adhesion_.w * beta(s));
  }
  if (adhesion_.d0 > 0.0) {
    double D = 0.0;
    for (int s = 0; s < n; ++s)
      D += points_->area(s) * (beta(s) - beta_prev(s)) * kernel_row_dot(kt_, s, beta, beta_prev);
    E += D / (2.0 * adhesion_.dt);
  }
  return E;
}

double ContactStep::local_objective(ConstMatRef ubar, ConstMatRef lambda_c, ConstVecRef beta_prev,
                                    ConstMatRef e, ConstVecRef beta) const {
  const int n = points_->size(), dim = points_->dim;
  if (ubar.rows() != n || ubar.cols() != dim || lambda_c.rows() != n || lambda_c.cols() != dim)
    fail("local_objective(): ubar and lambda_c must be #points x dim");
  double J = energy(e, beta, beta_prev);
  for (int s = 0; s < n; ++s)
    J += points_->area(s) * (0.5 * Rqc_ * e.row(s).squaredNorm() -
                             (Rqc_ * ubar.row(s) - lambda_c.row(s)).dot(e.row(s)));
  return J;
}

}  // namespace ltl
