// Newton's method on ALG2's discrete problem (newton.hpp).
#include "newton.hpp"

#include <Eigen/CholmodSupport>
#include <Eigen/UmfPackSupport>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "error.hpp"

namespace ltl {

namespace {
using Triplets = std::vector<Eigen::Triplet<double>>;
template <int d>
using Mat = Eigen::Matrix<double, d, d>;

/// cof A, so that d det A / dA = cof A.
template <int d>
Mat<d> cof(const Mat<d>& A) {
  Mat<d> C;
  if constexpr (d == 2) {
    C << A(1, 1), -A(1, 0), -A(0, 1), A(0, 0);
  } else {
    C.col(0) = A.col(1).cross(A.col(2));
    C.col(1) = A.col(2).cross(A.col(0));
    C.col(2) = A.col(0).cross(A.col(1));
  }
  return C;
}

/// d/dt cof(A + t H) at t = 0 (the second derivative of det).
template <int d>
Mat<d> dcof(const Mat<d>& A, const Mat<d>& H) {
  if constexpr (d == 2) {
    return cof<2>(H);
  } else {
    Mat<3> C;
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      C.col(k) = H.col(k1).cross(A.col(k2)) + A.col(k1).cross(H.col(k2));
    }
    return C;
  }
}

/// [K, -B^T, C^T; -B, 0, 0; C, 0, 0] (du, dp, dmu) = (r1, r2, r3), the KKT system of a Newton
/// step (u free dofs first, then the n_p pressures and the n_c active contact forces, as
/// triplets of the full matrix), solved by the augmented Lagrangian of the linear system: with
/// the row weights W_e = 1 / |B_e|^2 and Wc_s = 1 / |C_s|^2,
///   (K + kappa B^T W B + kappa_c C^T Wc C) du = r1 + B^T dp - kappa B^T W r2 - C^T dmu
///                                            + kappa_c C^T Wc r3,
///   dp <- dp - kappa W (B du + r2),   dmu <- dmu + kappa_c Wc (C du - r3),
/// which is the exact KKT solution at its fixed point and converges like (1 + kappa s)^-1 per
/// sweep; kappa = kappa_c = 1e4 times K's mean diagonal (B^T W B and C^T Wc C are projections).
/// The matrix is
/// factorized by CHOLMOD (supernodal LL', analyzed once per Newton phase); false when it is not
/// positive definite (K not positive on the constraints' kernel: the caller damps).
using Factor = Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower>;
bool solve_kkt(const Triplets& kkt, const Eigen::VectorXd& rhs, int nu, int np, int nc, Factor& llt,
               bool& analyzed, Eigen::VectorXd& dx) {
  // The blocks K (lower triangle), B and C, and each constraint row's entries.
  Triplets ta, tb, tc;
  std::vector<std::vector<std::pair<int, double>>> rows(np + nc);
  Eigen::VectorXd diag = Eigen::VectorXd::Zero(nu);
  for (const auto& e : kkt) {
    if (e.row() < nu && e.col() < nu) {
      if (e.row() >= e.col()) ta.push_back(e);
      if (e.row() == e.col()) diag(e.row()) += e.value();
    } else if (e.row() >= nu && e.col() < nu) {
      const int r = e.row() - nu;
      const double v = r < np ? -e.value() : e.value();  // B = -(its block), C = its block
      (r < np ? tb : tc).emplace_back(r < np ? r : r - np, e.col(), v);
      rows[r].emplace_back(e.col(), v);
    }
  }
  SpMat B(np, nu), C(nc, nu);
  B.setFromTriplets(tb.begin(), tb.end());
  C.setFromTriplets(tc.begin(), tc.end());
  const Eigen::VectorXd r1 = rhs.head(nu), r2 = rhs.segment(nu, np), r3 = rhs.tail(nc);
  // Row weights W_e = 1 / |B_e|^2 (and C's), and kappa (W B^T B and Wc C^T C are projections).
  Eigen::VectorXd W(np), Wc(nc);
  for (int e = 0; e < np; ++e) W(e) = 1 / std::max(B.row(e).squaredNorm(), 1e-300);
  for (int k = 0; k < nc; ++k) Wc(k) = 1 / std::max(C.row(k).squaredNorm(), 1e-300);
  const double kd = nu ? diag.cwiseAbs().mean() : 1.0;
  const double kappa = 1e4 * kd, kappa_c = 1e4 * kd;
  // A = K + kappa B^T W B + kappa_c C^T Wc C, the outer products of the rows (lower triangle).
  for (int r = 0; r < np + nc; ++r) {
    const double w = r < np ? kappa * W(r) : kappa_c * Wc(r - np);
    for (const auto& [i, bi] : rows[r])
      for (const auto& [j, bj] : rows[r])
        if (i >= j) ta.emplace_back(i, j, w * bi * bj);
  }
  SpMat A(nu, nu);
  A.setFromTriplets(ta.begin(), ta.end());
  // The pattern of A is K's (the projections and the damping stay inside K's cell blocks), the
  // same at every step: analyzed once.
  if (!analyzed) {
    llt.cholmod().print = 0;  // "not positive definite" is an answer here, not a warning
    llt.analyzePattern(A);
    analyzed = true;
  }
  llt.factorize(A);
  if (llt.info() != Eigen::Success) return false;
  Eigen::VectorXd dp = Eigen::VectorXd::Zero(np), dmu = Eigen::VectorXd::Zero(nc), du;
  const Eigen::VectorXd fixed = r1 - kappa * (B.transpose() * W.asDiagonal() * r2) +
                                kappa_c * (C.transpose() * Wc.asDiagonal() * r3);
  for (int sweep = 0; sweep < 100; ++sweep) {
    du = llt.solve(fixed + B.transpose() * dp - C.transpose() * dmu);
    const Eigen::VectorXd c1 = B * du + r2, c2 = C * du - r3;
    dp -= kappa * W.asDiagonal() * c1;
    dmu += kappa_c * Wc.asDiagonal() * c2;
    // Converged when the constraints hold to round-off of the step: |c| / |B_e| <= 1e-13 |du|.
    const double step = std::max(du.cwiseAbs().maxCoeff(), 1e-300);
    auto largest = [](const Eigen::VectorXd& v) {
      return v.size() ? v.cwiseAbs().maxCoeff() : 0.0;  // (maxCoeff of an empty vector is UB)
    };
    if (largest(c1.cwiseProduct(W.cwiseSqrt())) <= 1e-13 * step &&
        largest(c2.cwiseProduct(Wc.cwiseSqrt())) <= 1e-13 * step)
      break;
  }
  if (!du.allFinite()) return false;
  dx.resize(nu + np + nc);
  dx << du, dp, dmu;
  return true;
}

/// The same KKT system by UMFPACK's sparse LU (symmetric indefinite: the fall-back of
/// solve_kkt when the augmented tangent is not positive definite). False when singular.
bool solve_kkt_lu(const Triplets& kkt, const Eigen::VectorXd& rhs, Eigen::VectorXd& dx) {
  SpMat A(rhs.size(), rhs.size());
  A.setFromTriplets(kkt.begin(), kkt.end());
  Eigen::UmfPackLU<SpMat> lu;
  lu.compute(A);
  if (lu.info() != Eigen::Success) return false;
  dx = lu.solve(rhs);
  return dx.allFinite();
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

std::string Newton::unsupported(const Discretization& disc) {
  const auto& contact = disc.problem().contact;
  if (contact && (contact->adhesion.kappa > 0 || contact->adhesion.w > 0))
    return "the glue (contact.w, contact.kappa > 0) is not treated by the Newton phase";
  return "";
}

Newton::Newton(const Discretization& disc) : disc_(disc) {
  const std::string why = unsupported(disc);
  if (!why.empty()) throw Error(cat("algorithm.solver = \"newton\": ", why, "; use \"alg2\""));
  const Mesh& mesh = disc.problem().mesh;
  dim_ = disc.dim();
  const int d = dim_, nc = disc.num_cells(), nn = disc.num_nodes();
  npc_ = static_cast<int>(mesh.cells.cols());
  incompressible_ = disc.split().incompressible();
  nodes_.resize(static_cast<std::size_t>(nc) * npc_);
  const CellOperators& ops = disc.cells();
  gbar_.assign(nc, Eigen::MatrixXd::Zero(npc_, d));
  for (int e = 0; e < nc; ++e) {
    for (int a = 0; a < npc_; ++a) nodes_[e * npc_ + a] = mesh.cells(e, a);
    // The mean gradients as ALG2 uses them: row d e + j of Gbar at the cell's nodes.
    for (int j = 0; j < d; ++j)
      for (SpMatR::InnerIterator it(ops.Gbar, d * e + j); it; ++it)
        for (int a = 0; a < npc_; ++a)
          if (mesh.cells(e, a) == it.col()) gbar_[e](a, j) = it.value();
  }
  if (incompressible_) {
    if (disc.mean_det()) {
      for (int e = 0; e < nc; ++e) {
        int k = 0;
        for_each_quadrature_point(mesh, e, [&](const Eigen::MatrixXd& grad, double w) {
          gq_.push_back(grad);
          wq_.push_back(w);
          ++k;
        });
        nq_ = k;
      }
    } else {
      nq_ = 1;
      for (int e = 0; e < nc; ++e) {
        gq_.push_back(gbar_[e]);
        wq_.push_back(ops.vol(e));
      }
    }
  }
  // 2 C1 (L - GbarT_vol Gbar) on each component: the intra-cell fluctuation of C1 |grad u|^2.
  const SpMat Lf = ops.laplacian - SpMat(ops.GbarT_vol * ops.Gbar);
  Triplets t;
  const double C1 = disc.split().C1;
  for (int k = 0; k < Lf.outerSize(); ++k)
    for (SpMat::InnerIterator it(Lf, k); it; ++it)
      for (int i = 0; i < d; ++i)
        t.emplace_back(d * it.row() + i, d * it.col() + i, 2 * C1 * it.value());
  fluct_.resize(d * nn, d * nn);
  fluct_.setFromTriplets(t.begin(), t.end());
  fluct_.prune(0.0);

  free_.assign(static_cast<std::size_t>(d) * nn, 0);
  for (int i = 0; i < d; ++i)
    for (int a : disc.dirichlet().fixed[i]) free_[d * a + i] = -1;
  for (int& f : free_)
    if (f >= 0) f = nfree_++;
  if (const FacetOperators* pts = disc.facets()) {
    const double h = std::pow(disc.volume() / nc, 1.0 / d);
    c_ = 0.02 * C1 * pts->area / h;
  }
}

Newton::Unknowns Newton::unknowns(const State& s) const {
  const int d = dim_, nc = disc_.num_cells();
  Unknowns x;
  x.u = s.u;
  const Material& m = disc_.split();
  if (incompressible_) {
    x.p.resize(nc);
    for (int e = 0; e < nc; ++e) {
      const Eigen::MatrixXd E = cell_tensor(s.E, e), L = cell_tensor(s.lambda, e);
      Eigen::MatrixXd dW(d, d), C(d, d);
      if (d == 2) {
        dW = m.dW(Eigen::Matrix2d(E));
        C = cof<2>(Eigen::Matrix2d(E));
      } else {
        dW = m.dW(Eigen::Matrix3d(E));
        C = cof<3>(Eigen::Matrix3d(E));
      }
      x.p(e) = (L - 2 * m.C1 * E + dW).cwiseProduct(C).sum() / C.squaredNorm();
    }
  }
  if (const FacetOperators* pts = disc_.facets()) {
    const Eigen::VectorXd N = disc_.surface().N;
    x.mu = pts->area.cwiseProduct((-(s.lambda_c.transpose() * N)).cwiseMax(0.0));
  }
  return x;
}

void Newton::to_state(const Unknowns& x, State& s) const {
  const int d = dim_, nc = disc_.num_cells();
  const Material& m = disc_.split();
  s.u = x.u;
  const Eigen::MatrixXd GU = disc_.cells().Gbar * x.u;
  for (int e = 0; e < nc; ++e) {
    Eigen::MatrixXd F = GU.block(d * e, 0, d, d).transpose();
    F.diagonal().array() += 1.0;
    Eigen::MatrixXd L(d, d);
    if (d == 2) {
      const Eigen::Matrix2d F2 = F;
      L = 2 * m.C1 * F2 - m.dW(F2) + (incompressible_ ? x.p(e) : 0.0) * cof<2>(F2);
    } else {
      const Eigen::Matrix3d F3 = F;
      L = 2 * m.C1 * F3 - m.dW(F3) + (incompressible_ ? x.p(e) : 0.0) * cof<3>(F3);
    }
    s.E.block(d * e, 0, d, d) = F.transpose();
    s.lambda.block(d * e, 0, d, d) = L.transpose();
  }
  if (const FacetOperators* pts = disc_.facets()) {
    s.e = (pts->mean * x.u).transpose();
    const Eigen::VectorXd N = disc_.surface().N;
    for (int k = 0; k < pts->size(); ++k) s.lambda_c.col(k) = -(x.mu(k) / pts->area(k)) * N;
  }
}

// [(2.2), (2.7)] Per cell: the energy at the mean gradient, vol dW(Fbar) : Gbar v, with its
// Hessian; the constraint G_e = sum_k w_k det F_k - |O_e| with its gradient
// sum_k w_k cof F_k : grad v and, times -p_e, its Hessian sum_k w_k dcof F_k[grad du] : grad v.
template <int d>
void Newton::assemble(const Unknowns& x, Eigen::VectorXd* Ru, Eigen::VectorXd* G, Triplets* K,
                      Triplets* B) const {
  const int nc = disc_.num_cells(), n = npc_;
  const Material& m = disc_.split();
  const Eigen::VectorXd& vol = disc_.cells().vol;
  Eigen::MatrixXd ue(n, d), Ke(d * n, d * n);
  Eigen::VectorXd be(d * n);
  // The fourth-order tangents as (d*d) x (d*d) matrices, column k d + l = the derivative in the
  // direction E_kl (entry i d + j), and their contraction with two gradient tables:
  //   Ke(d a + i, d b + k) += c sum_{j,l} T(i d + j, k d + l) g(a, j) h(b, l).
  using Tangent = Eigen::Matrix<double, d * d, d * d>;
  Tangent T;
  auto contract = [&](const Tangent& A, const Eigen::MatrixXd& g, double c) {
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        for (int i = 0; i < d; ++i)
          for (int k = 0; k < d; ++k) {
            double v = 0;
            for (int j = 0; j < d; ++j)
              for (int l = 0; l < d; ++l) v += A(i * d + j, k * d + l) * g(a, j) * g(b, l);
            Ke(d * a + i, d * b + k) += c * v;
          }
  };
  // r(d a + i) += c sum_j P(i, j) g(a, j)
  auto add_row = [&](const Mat<d>& P, const Eigen::MatrixXd& g, double c, Eigen::VectorXd& r,
                     const int* nodes) {
    for (int a = 0; a < n; ++a)
      for (int i = 0; i < d; ++i) {
        double v = 0;
        for (int j = 0; j < d; ++j) v += P(i, j) * g(a, j);
        r(nodes ? d * nodes[a] + i : d * a + i) += c * v;
      }
  };
  for (int e = 0; e < nc; ++e) {
    const int* nodes = &nodes_[static_cast<std::size_t>(e) * n];
    for (int a = 0; a < n; ++a) ue.row(a) = x.u.row(nodes[a]);
    const Eigen::MatrixXd& gb = gbar_[e];
    Mat<d> F = Mat<d>::Identity() + ue.transpose() * gb;
    if (Ru) add_row(m.dW(F), gb, vol(e), *Ru, nodes);
    if (K) {
      Ke.setZero();
      for (int k = 0; k < d; ++k)
        for (int l = 0; l < d; ++l) {
          Mat<d> H = Mat<d>::Zero();
          H(k, l) = 1;
          const Mat<d> dP = m.d2W(F, H);
          for (int i = 0; i < d; ++i)
            for (int j = 0; j < d; ++j) T(i * d + j, k * d + l) = dP(i, j);
        }
      contract(T, gb, vol(e));
    }
    if (incompressible_) {
      double Ge = -vol(e);
      be.setZero();
      const double p = x.p.size() ? x.p(e) : 0.0;
      for (int q = nq_ * e; q < nq_ * (e + 1); ++q) {
        const Eigen::MatrixXd& g = gq_[q];
        const double w = wq_[q];
        const Mat<d> Fq = Mat<d>::Identity() + ue.transpose() * g;
        Ge += w * Fq.determinant();
        add_row(cof<d>(Fq), g, w, be, nullptr);
        if (K && p != 0) {
          for (int k = 0; k < d; ++k)
            for (int l = 0; l < d; ++l) {
              Mat<d> H = Mat<d>::Zero();
              H(k, l) = 1;
              const Mat<d> dC = dcof<d>(Fq, H);
              for (int i = 0; i < d; ++i)
                for (int j = 0; j < d; ++j) T(i * d + j, k * d + l) = dC(i, j);
            }
          contract(T, g, -p * w);
        }
      }
      if (G) (*G)(e) = Ge;
      if (Ru)
        for (int a = 0; a < n; ++a)
          for (int i = 0; i < d; ++i) (*Ru)(d * nodes[a] + i) -= p * be(d * a + i);
      if (B)
        for (int a = 0; a < n; ++a)
          for (int i = 0; i < d; ++i) B->emplace_back(e, d * nodes[a] + i, be(d * a + i));
    }
    if (K)
      for (int a = 0; a < n; ++a)
        for (int i = 0; i < d; ++i)
          for (int b = 0; b < n; ++b)
            for (int k = 0; k < d; ++k)
              K->emplace_back(d * nodes[a] + i, d * nodes[b] + k, Ke(d * a + i, d * b + k));
  }
}

void Newton::residual(const Unknowns& x, const Eigen::MatrixXd& F, Eigen::VectorXd& Ru,
                      Eigen::VectorXd& G) const {
  const int d = dim_, nn = disc_.num_nodes();
  Ru.setZero(d * nn);
  G.setZero(incompressible_ ? disc_.num_cells() : 0);
  if (d == 2)
    assemble<2>(x, &Ru, &G, nullptr, nullptr);
  else
    assemble<3>(x, &Ru, &G, nullptr, nullptr);
  Eigen::VectorXd uflat(d * nn), Fflat(d * nn);
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < d; ++i) uflat(d * a + i) = x.u(a, i), Fflat(d * a + i) = F(a, i);
  Ru += fluct_ * uflat - Fflat;
  // The contact forces: mu_s N (x) mean_s, the reaction of the plane (1.1).
  if (const FacetOperators* pts = disc_.facets()) {
    const Eigen::VectorXd& N = disc_.surface().N;
    for (int s = 0; s < pts->size(); ++s)
      for (SpMatR::InnerIterator it(pts->mean, s); it; ++it)
        for (int i = 0; i < d; ++i) Ru(d * it.col() + i) += x.mu(s) * it.value() * N(i);
  }
}

Eigen::SparseMatrix<double> Newton::tangent(const Unknowns& x) const {
  Triplets t;
  if (dim_ == 2)
    assemble<2>(x, nullptr, nullptr, &t, nullptr);
  else
    assemble<3>(x, nullptr, nullptr, &t, nullptr);
  SpMat K(fluct_.rows(), fluct_.cols());
  K.setFromTriplets(t.begin(), t.end());
  return K + fluct_;
}

Eigen::SparseMatrix<double> Newton::constraint_gradient(const Eigen::MatrixXd& u) const {
  Triplets t;
  Unknowns x;
  x.u = u;
  if (dim_ == 2)
    assemble<2>(x, nullptr, nullptr, nullptr, &t);
  else
    assemble<3>(x, nullptr, nullptr, nullptr, &t);
  SpMat B(incompressible_ ? disc_.num_cells() : 0, fluct_.cols());
  B.setFromTriplets(t.begin(), t.end());
  return B;
}

double Newton::min_det(const Eigen::MatrixXd& u) const {
  const int d = dim_, nc = disc_.num_cells(), n = npc_;
  double m = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd ue(n, d);
  for (int e = 0; e < nc; ++e) {
    for (int a = 0; a < n; ++a) ue.row(a) = u.row(nodes_[static_cast<std::size_t>(e) * n + a]);
    Eigen::MatrixXd F = Eigen::MatrixXd::Identity(d, d) + ue.transpose() * gbar_[e];
    m = std::min(m, F.determinant());
    for (int q = nq_ * e; q < nq_ * (e + 1); ++q) {
      F = Eigen::MatrixXd::Identity(d, d) + ue.transpose() * gq_[q];
      m = std::min(m, F.determinant());
    }
  }
  return m;
}

Newton::Result Newton::solve(State& s, const Eigen::MatrixXd& F, const AlgorithmParams& alg,
                             StepReport& report,
                             const std::function<void(const IterationRecord&)>& progress) const {
  using clock_type = std::chrono::steady_clock;
  const auto t_start = clock_type::now();
  const int d = dim_, nc = disc_.num_cells();
  const FacetOperators* pts = disc_.facets();
  const int np = pts ? pts->size() : 0;
  const Eigen::VectorXd N = pts ? disc_.surface().N : Eigen::VectorXd();
  const Eigen::VectorXd& vol = disc_.cells().vol;
  Result result;
  const double wall0 = report.history.empty() ? 0.0 : report.history.back().wall;
  Unknowns x = unknowns(s);
  Eigen::VectorXd Ru, G;

  // The load scale of the force residual: the largest nodal load, or without loads the largest
  // nodal force of the start (reactions included).
  residual(x, F, Ru, G);
  double Fs = F.cwiseAbs().maxCoeff();
  if (!(Fs > 0)) {
    const double h = std::pow(disc_.volume() / nc, 1.0 / d);
    Fs = std::max(Ru.cwiseAbs().maxCoeff(), 1e-8 * disc_.split().C1 * std::pow(h, d - 1));
  }
  constexpr double constraint_tol = 1e-10;

  // The scaled residual at x: forces on free dofs / Fs, G_e / |O_e|, complementarity / Fs.
  struct Measures {
    double merit = 0, force = 0, constraint = 0;
  };
  Eigen::VectorXd gapv(np), comp(np);
  auto measure = [&](const Unknowns& y, Eigen::VectorXd& ru, Eigen::VectorXd& g) {
    Measures mm;
    residual(y, F, ru, g);
    double f2 = 0;
    for (int k = 0; k < ru.size(); ++k)
      if (free_[k] >= 0) {
        f2 += ru(k) * ru(k);
        mm.force = std::max(mm.force, std::abs(ru(k)));
      }
    mm.force /= Fs;
    double g2 = 0;
    for (int e = 0; e < g.size(); ++e) {
      const double ge = g(e) / vol(e);
      g2 += ge * ge;
      mm.constraint = std::max(mm.constraint, std::abs(ge));
    }
    double c2 = 0;
    if (pts) {
      gapv = (pts->mean * y.u) * N - disc_.surface().gap;  // N . ubar - g (> 0: penetration)
      for (int k = 0; k < np; ++k) {
        comp(k) = y.mu(k) - std::max(0.0, y.mu(k) + c_(k) * gapv(k));
        c2 += comp(k) * comp(k);
        mm.force = std::max(mm.force, std::abs(comp(k)) / Fs);
      }
    }
    mm.merit = std::sqrt((f2 + c2) / (Fs * Fs) + g2);
    return mm;
  };
  auto admissible = [&](const Unknowns& y) { return min_det(y.u) > 0; };

  Measures cur = measure(x, Ru, G);
  Unknowns trial;
  Eigen::VectorXd Ru_t, G_t;
  std::vector<int> active(np), prev_active;
  Factor llt;
  bool analyzed = false;
  const int max_newton = std::max(1, alg.newton_max_iter);
  double damping = 0;
  for (int it = 1;; ++it) {
    // Converged: forces and complementarity at force_tol, constraints at constraint_tol, and
    // the active set of the last step unchanged.
    if (it > 1 && cur.force <= alg.force_tol && cur.constraint <= constraint_tol &&
        active == prev_active) {
      result.converged = true;
      result.status = cat("converged (Newton, ", result.iterations, " iterations)");
      break;
    }
    if (report.iterations >= alg.max_iter) {
      result.status =
          cat("iteration cap reached (", alg.max_iter,
              " iterations) without convergence (Newton, force residual ", cur.force, ")");
      break;
    }
    if (it > max_newton) {
      result.status = cat("Newton: no convergence in ", max_newton, " iterations (force residual ",
                          cur.force, ")");
      break;
    }
    IterationRecord rec;
    auto t0 = clock_type::now();
    // The active set of the semismooth step: mu_s + c_s (N . ubar_s - g_s) > 0.
    prev_active = active;
    int nA = 0;
    std::vector<int> aidx(np, -1);
    for (int k = 0; k < np; ++k) {
      active[k] = x.mu(k) + c_(k) * gapv(k) > 0;
      if (active[k]) aidx[k] = nA++;
    }
    // The inactive forces vanish: set them, and the residual follows (linear in mu).
    Unknowns base = x;
    for (int k = 0; k < np; ++k)
      if (!active[k]) base.mu(k) = 0;
    residual(base, F, Ru, G);
    // [K, -B^T, C_A^T; -B, 0, 0; C_A, 0, 0] (du, dp, dmu_A) = (-R_u, G, g_A - N . ubar_A).
    Triplets t, tb;
    if (d == 2)
      assemble<2>(base, nullptr, nullptr, &t, &tb);
    else
      assemble<3>(base, nullptr, nullptr, &t, &tb);
    for (int k = 0; k < fluct_.outerSize(); ++k)
      for (SpMat::InnerIterator i(fluct_, k); i; ++i) t.emplace_back(i.row(), i.col(), i.value());
    const int np_ = incompressible_ ? nc : 0, n = nfree_ + np_ + nA;
    Triplets kkt;
    kkt.reserve(t.size() + 2 * tb.size() + 2 * d * nA);
    Eigen::VectorXd diag = Eigen::VectorXd::Zero(nfree_);
    for (const auto& e : t)
      if (free_[e.row()] >= 0 && free_[e.col()] >= 0) {
        kkt.emplace_back(free_[e.row()], free_[e.col()], e.value());
        if (e.row() == e.col()) diag(free_[e.row()]) += e.value();
      }
    // Levenberg-Marquardt damping of the u block (0: Newton's step), see below.
    if (damping > 0)
      for (int k = 0; k < nfree_; ++k) kkt.emplace_back(k, k, damping * std::abs(diag(k)));
    for (const auto& e : tb)
      if (free_[e.col()] >= 0) {
        kkt.emplace_back(free_[e.col()], nfree_ + e.row(), -e.value());
        kkt.emplace_back(nfree_ + e.row(), free_[e.col()], -e.value());
      }
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (int k = 0; k < Ru.size(); ++k)
      if (free_[k] >= 0) rhs(free_[k]) = -Ru(k);
    for (int e = 0; e < np_; ++e) rhs(nfree_ + e) = G(e);
    if (pts) {
      gapv = (pts->mean * base.u) * N - disc_.surface().gap;
      for (int k = 0; k < np; ++k) {
        if (!active[k]) continue;
        const int r = nfree_ + np_ + aidx[k];
        bool any = false;
        for (SpMatR::InnerIterator i(pts->mean, k); i; ++i)
          for (int j = 0; j < d; ++j)
            if (free_[d * i.col() + j] >= 0 && N(j) != 0) {
              kkt.emplace_back(free_[d * i.col() + j], r, i.value() * N(j));
              kkt.emplace_back(r, free_[d * i.col() + j], i.value() * N(j));
              any = true;
            }
        if (any)
          rhs(r) = -gapv(k);
        else
          kkt.emplace_back(r, r, 1.0);  // a point whose normal motion is prescribed: mu stays
      }
    }
    rec.t_strain = seconds_since(t0);
    t0 = clock_type::now();
    Eigen::VectorXd dx;
    bool solved = solve_kkt(kkt, rhs, nfree_, np_, nA, llt, analyzed, dx);
    // The augmented tangent is not positive definite (a saddle of the energy on the constraints,
    // e.g. a compressed block under a dead load): the KKT system itself, by sparse LU.
    if (!solved) solved = solve_kkt_lu(kkt, rhs, dx);
    rec.t_global = seconds_since(t0);
    if (!solved) {  // singular: damp more, same point
      ++result.iterations;
      ++report.newton_iterations;
      rec.n = ++report.iterations;
      rec.wall = wall0 + seconds_since(t_start);
      rec.r_G = cur.force;
      rec.r_B = cur.constraint;
      rec.accelerated = -1;
      report.history.push_back(rec);
      if (progress) progress(report.history.back());
      damping = damping > 0 ? 10 * damping : 1e-4;
      if (damping > 1e6) {
        result.status = "Newton: the tangent stays singular even with damping";
        break;
      }
      active = prev_active;
      continue;
    }
    // Backtracking on the merit, keeping det F > 0 at every point: alpha = 1, 1/2, ... 1/8. No
    // decrease: the same point again with 10 times the damping (Levenberg-Marquardt, which turns
    // the step towards a scaled residual step); a full step lowers it 4 times, to 0 below 1e-8.
    double alpha = 1;
    Measures next;
    bool accepted = false;
    for (int ls = 0; ls < 4; ++ls, alpha /= 2) {
      trial = base;
      for (int a = 0; a < disc_.num_nodes(); ++a)
        for (int i = 0; i < d; ++i)
          if (free_[d * a + i] >= 0) trial.u(a, i) += alpha * dx(free_[d * a + i]);
      for (int e = 0; e < np_; ++e) trial.p(e) += alpha * dx(nfree_ + e);
      for (int k = 0; k < np; ++k)
        if (active[k]) trial.mu(k) += alpha * dx(nfree_ + np_ + aidx[k]);
      if (!admissible(trial)) continue;
      next = measure(trial, Ru_t, G_t);
      if (std::isfinite(next.merit) && next.merit <= (1 - 1e-4 * alpha) * cur.merit) {
        accepted = true;
        break;
      }
    }
    ++result.iterations;
    ++report.newton_iterations;
    rec.n = ++report.iterations;
    rec.wall = wall0 + seconds_since(t_start);
    if (!accepted) {  // recorded with the residuals of the point it stays at
      rec.r_G = cur.force;
      rec.r_B = cur.constraint;
      rec.accelerated = -1;
      report.history.push_back(rec);
      if (progress) progress(report.history.back());
      damping = damping > 0 ? 10 * damping
                            : (std::getenv("LTL_D0") ? std::atof(std::getenv("LTL_D0")) : 1e-4);
      if (damping > 1e6) {
        result.status =
            cat("Newton: no decrease of the residual (", cur.merit, ") even along a damped step");
        break;
      }
      active = prev_active;
      continue;
    }
    if (alpha == 1) damping = damping / 4 < 1e-8 ? 0.0 : damping / 4;
    x = trial;
    cur = next;
    std::swap(Ru, Ru_t);
    std::swap(G, G_t);
    rec.r_G = cur.force;
    rec.r_B = cur.constraint;
    report.history.push_back(rec);
    result.forces.push_back(cur.force);
    if (progress) progress(report.history.back());
  }
  result.force_residual = cur.force;
  if (result.converged) to_state(x, s);
  return result;
}

template void Newton::assemble<2>(const Unknowns&, Eigen::VectorXd*, Eigen::VectorXd*, Triplets*,
                                  Triplets*) const;
template void Newton::assemble<3>(const Unknowns&, Eigen::VectorXd*, Eigen::VectorXd*, Triplets*,
                                  Triplets*) const;

}  // namespace ltl
