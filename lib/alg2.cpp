#include "alg2.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "error.hpp"
#include "iteration.hpp"
#include "measures.hpp"

namespace ltl {

namespace {
using clock_type = std::chrono::steady_clock;
double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}
}  // namespace

Solver::Solver(const Problem& problem) : problem_(problem) {
  problem_.validate();
  const Mesh& mesh = problem_.mesh;
  const int dim = mesh.dim, nc = mesh.num_cells(), nn = mesh.num_nodes();
  const AlgorithmParams& alg = problem_.algorithm;
  const double Rq = alg.R * alg.q, Rqc = alg.R * alg.q_c;

  // The split (2.5)-(2.6) of W: C1 |F|^2 in the global quadratic, the rest local. In plane strain
  // the incompressible Mooney-Rivlin C2 term is C2 (|F|^2 + 1) on det F = 1, so by default it
  // joins the global quadratic on the full gradient (DiscretizationChoice::c2_pointwise).
  split_ = problem_.material;
  if (problem_.discretization.c2_pointwise && dim == 2 && split_.incompressible()) {
    split_.C1 += split_.C2;
    split_.C2 = 0;
  }

  cells_ = cell_operators(mesh);
  // Mean-det incompressibility (DiscretizationChoice::mean_det): the point gradients at the
  // cell quadrature points (triangles: degree 4, exact for det(delta), quadratic on affine P2
  // triangles; hexahedra: the 2x2x2 Gauss rule of mean dilatation).
  mean_det_ = problem_.discretization.mean_det && split_.incompressible() && split_.C2 == 0;
  if (mean_det_) {
    std::vector<Eigen::Triplet<double>> g, gt;
    std::vector<double> w;
    for (int c = 0; c < nc; ++c) {
      int k = 0;
      for_each_quadrature_point(mesh, c, [&](const Eigen::MatrixXd& grad, double wt) {
        const int q = static_cast<int>(w.size());
        for (int a = 0; a < grad.rows(); ++a)
          for (int j = 0; j < dim; ++j) {
            g.emplace_back(dim * q + j, mesh.cells(c, a), grad(a, j));
            gt.emplace_back(mesh.cells(c, a), dim * q + j, wt * grad(a, j));
          }
        w.push_back(wt);
        ++k;
      });
      if (c == 0) nq_ = k;
      if (k != nq_) throw Error(cat(mesh.source, ": cell ", c, " has ", k, " quadrature points"));
    }
    const int nq = static_cast<int>(w.size());
    Gq_.resize(dim * nq, nn);
    Gq_.setFromTriplets(g.begin(), g.end());
    GqT_w_.resize(nn, dim * nq);
    GqT_w_.setFromTriplets(gt.begin(), gt.end());
    wq_ = Eigen::Map<const Eigen::VectorXd>(w.data(), nq);
    Jtarget_ = Eigen::VectorXd::Ones(nc);
    GQ_.resize(dim * nq, dim);
    Sq_.resize(dim * nq, dim);
  }
  if (problem_.contact) {
    const ContactCondition& cc = *problem_.contact;
    const Mesh::Boundary& boundary = mesh.boundary(cc.group, "contact.group");
    facets_ = std::make_unique<FacetOperators>(
        contact_points(mesh, boundary, problem_.discretization.nodal_contact));
    ContactSurface surface;
    surface.dim = dim;
    surface.area = facets_->area;
    surface.centre = facets_->centre;
    surface.N = cc.plane_normal.head(dim);
    // Initial gap g_s = (p0 - x_s) . N at each facet centre or node (paper_notes/section6.md).
    surface.gap.resize(facets_->size());
    for (int f = 0; f < facets_->size(); ++f)
      surface.gap(f) = (cc.plane_point.head(dim) - facets_->centre.col(f)).dot(surface.N);
    surface.vertices = facets_->vertices;
    const double scale = std::max(1.0, mesh.X.cwiseAbs().maxCoeff());
    for (int f = 0; f < facets_->size(); ++f)
      if (surface.gap(f) < -1e-10 * scale)
        throw Error(cat(mesh.source, ": contact ",
                        problem_.discretization.nodal_contact ? "node " : "facet ", f, " of '",
                        cc.group, "' starts inside the obstacle (gap ", surface.gap(f),
                        " m at its centre): check contact.plane_point and contact.plane_normal "
                        "(the normal points into the obstacle)"));
    Adhesion adhesion = cc.adhesion;
    adhesion.dt = problem_.time.dt;
    contact_ = std::make_unique<ContactStep>(surface, adhesion, Rqc);
    area_c_ = facets_->area.sum();
  }

  // Dirichlet data per component: fixed parts, symmetry planes, prescribed displacements.
  bc_.fixed.assign(dim, {});
  bc_.value = Eigen::MatrixXd::Zero(nn, dim);
  for (const auto& d : problem_.dirichlet) {
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      x.head(dim) = mesh.X.row(node).transpose();
      const Eigen::Vector3d value = d.field(x);
      for (int c : d.components) {
        bc_.fixed[c].push_back(node);
        bc_.value(node, c) = value(c);
      }
    }
  }
  for (auto& f : bc_.fixed) {
    std::sort(f.begin(), f.end());
    f.erase(std::unique(f.begin(), f.end()), f.end());
  }

  // (4.5): K assembled and factorized once.
  // Mean-det's proximal term gamma (L - GbarT Gbar) on the fluctuations (discretization.md):
  // implicit in K, the same operator lagged on the right-hand side, so it cancels at a fixed point.
  gamma_ = mean_det_ ? 2 * Rq : 0.0;
  if (mean_det_) {
    fluctuation_laplacian_ = cells_.laplacian - SpMat(cells_.GbarT_vol * cells_.Gbar);
    fluctuation_laplacian_.prune(0.0);
  }
  const SpMat K = global_matrix(cells_, facets_.get(), split_.C1 + gamma_ / 2, Rq - gamma_, Rqc);
  global_ = std::make_unique<GlobalStep>(K, bc_);
  strain_ = std::make_unique<StrainStep>(split_, Rq);

  F_ext_ = body_load(mesh, problem_.body_force);
  for (const auto& t : problem_.tractions)
    F_ext_ += surface_load(mesh, mesh.boundary(t.group, t.origin), t.g);
  F_dead_ = F_ext_;

  Id_ = Eigen::MatrixXd::Zero(dim * nc, dim);
  vol_rows_.resize(dim * nc);
  for (int c = 0; c < nc; ++c) {
    Id_.block(dim * c, 0, dim, dim).setIdentity();
    vol_rows_.segment(dim * c, dim).setConstant(cells_.vol(c));
  }
  norm_I_ = std::sqrt(alg.q * cells_.vol.sum() * dim);

  // Anderson weights: sqrt(q |O_e|) / ||I||_q per cell row, sqrt(q_c |G_s|) / ||I||_q per facet.
  w_cell_ = (alg.q * vol_rows_).cwiseSqrt() / norm_I_;
  if (facets_) w_facet_ = (alg.q_c * facets_->area).cwiseSqrt() / norm_I_;
  if (alg.acceleration == Acceleration::Anderson) {
    const Eigen::Index nf = facets_ ? facets_->size() : 0;
    Eigen::Index n = dim * dim * nc + dim * nf;              // lambda, lambda_c
    if (alg.accelerate != Accelerated::Multipliers) n *= 2;  // E, e
    if (alg.accelerate == Accelerated::All) n += nf;         // beta
    // Mean-det: the lagged fluctuation terms make u part of the state the map acts on, so u is
    // extrapolated with the rest, weighted like a gradient, sqrt(q |Omega| / #nodes) / h.
    if (mean_det_) {
      n += dim * nn;
      const double vol = cells_.vol.sum(), h = std::pow(vol / nc, 1.0 / dim);
      w_u_ = std::sqrt(alg.q * vol / nn) / (h * norm_I_);
    }
    anderson_ = std::make_unique<Anderson>(n, alg.depth);
    x_.resize(n);
    g_.resize(n);
  }

  rhs_.resize(nn, dim);
  GU_.resize(dim * nc, dim);
  T_.resize(dim * nc, dim);
  if (facets_) {
    ubar_rows_.resize(facets_->size(), dim);
    ubar_.resize(dim, facets_->size());
    c_rows_.resize(facets_->size(), dim);
  }
}

State Solver::initial_state() const {
  const int dim = this->dim(), nc = problem_.mesh.num_cells();
  State s;
  s.u = bc_.value;
  s.E = Id_;
  s.lambda = 2 * split_.C1 * Id_;
  const int nf = facets_ ? facets_->size() : 0;
  s.e = Eigen::MatrixXd::Zero(dim, nf);
  s.lambda_c = Eigen::MatrixXd::Zero(dim, nf);
  s.beta = Eigen::VectorXd::Constant(nf, problem_.contact ? problem_.contact->beta0 : 0.0);
  (void)nc;
  return s;
}

// [LTL87 (4.1), (4.5)] Right-hand side
//   L(v) = f.v + g.v + sum_e |O_e| [R q (E_e - I) + lambda_e - 2 C1 I] : Gbar_e(v)
//          + sum_s |G_s| [R q_c e_s + lambda_c_s] . vbar_s
// then one triangular solve per distinct Dirichlet set against the stored factor.
void Solver::global_solve(State& s) {
  const AlgorithmParams& alg = problem_.algorithm;
  const double Rq = alg.R * alg.q, C1 = split_.C1;
  T_ = Rq * (s.E - Id_) + s.lambda - 2 * C1 * Id_;
  rhs_.noalias() = cells_.GbarT_vol * T_;
  rhs_ += F_ext_;
  if (mean_det_) {  // the pressure's work on the fluctuations, lagged
    fluctuation(s.u, &s.lambda, &s.E, nullptr, &Sq_);
    rhs_.noalias() += gamma_ * (fluctuation_laplacian_ * s.u);
    rhs_.noalias() += GqT_w_ * Sq_;
  }
  if (facets_) {
    c_rows_ = (alg.R * alg.q_c * s.e + s.lambda_c).transpose();
    rhs_.noalias() += facets_->meanT_area * c_rows_;
  }
  global_->solve(rhs_, s.u);
}

// [LTL87 (4.6), (5.2)-(5.8)] Cell by cell, D = R q (I + Gbar u) - lambda and E = argmin J_E.
// The blocks are transposed tensors; the energies are isotropic, so solving on D^T gives E^T.
namespace {
template <int d>
int strain_loop(const StrainStep& step, double Rq, const Eigen::MatrixXd& GU,
                const Eigen::MatrixXd& lambda, const Eigen::VectorXd* J, Eigen::MatrixXd& E) {
  const int nc = static_cast<int>(GU.rows() / d);
  int failures = 0;
#pragma omp parallel for schedule(static) reduction(+ : failures)
  for (int c = 0; c < nc; ++c) {
    Eigen::Matrix<double, d, d> D =
        Rq * GU.template block<d, d>(d * c, 0) - lambda.template block<d, d>(d * c, 0);
    D.diagonal().array() += Rq;
    Eigen::Matrix<double, d, d> Ec;
    // Mean-det: det E = J_c. The local energy is (R q / 2)|E|^2 - D : E (C2 = 0), homogeneous
    // of degree 2 under E = s Ehat, so E = s argmin over det Ehat = 1 with D / s, s = J_c^(1/d).
    const double s = J ? (d == 2 ? std::sqrt((*J)(c)) : std::cbrt((*J)(c))) : 1.0;
    if (!(s > 0)) {
      ++failures;
      continue;
    }
    if (!step.solve(D / s, Ec)) ++failures;
    E.template block<d, d>(d * c, 0) = s * Ec;
  }
  return failures;
}
}  // namespace

int Solver::strain_solve(const Eigen::MatrixXd& lambda, State& s) {
  const double Rq = problem_.algorithm.R * problem_.algorithm.q;
  const Eigen::VectorXd* J = mean_det_ ? &Jtarget_ : nullptr;
  return dim() == 2 ? strain_loop<2>(*strain_, Rq, GU_, lambda, J, s.E)
                    : strain_loop<3>(*strain_, Rq, GU_, lambda, J, s.E);
}

// [(2.7), discretization.md] Per cell, with F_k = I + (point gradient at quadrature point k)
// and Fbar = I + (their cell mean):
//   c_e = (1/|O_e|) sum_k w_k det F_k - det Fbar,   force block p_e (cof F_k - cof Fbar),
// p_e = lambda_e : E_e / (d det E_e). In 2-D cof is linear, so c_e is the mean of det(delta_k)
// and the force block p_e cof(delta_k), delta_k = F_k - Fbar. The blocks are transposed tensors;
// det and cof commute with the transpose.
namespace {
template <int d>
Eigen::Matrix<double, d, d> cofactor(const Eigen::Matrix<double, d, d>& A) {
  Eigen::Matrix<double, d, d> C;
  if constexpr (d == 2) {
    C << A(1, 1), -A(1, 0), -A(0, 1), A(0, 0);
  } else {
    C.row(0) = A.row(1).cross(A.row(2));
    C.row(1) = A.row(2).cross(A.row(0));
    C.row(2) = A.row(0).cross(A.row(1));
  }
  return C;
}

template <int d>
void fluctuation_loop(const Eigen::MatrixXd& GQ, const Eigen::VectorXd& wq,
                      const Eigen::VectorXd& vol, int nq, const Eigen::MatrixXd* lambda,
                      const Eigen::MatrixXd* E, Eigen::VectorXd* c, Eigen::MatrixXd* force) {
  using Mat = Eigen::Matrix<double, d, d>;
  const int nc = static_cast<int>(vol.size());
#pragma omp parallel for schedule(static)
  for (int e = 0; e < nc; ++e) {
    Mat Fbar = Mat::Zero();
    for (int k = 0; k < nq; ++k) {
      const int q = nq * e + k;
      Fbar += wq(q) * GQ.block<d, d>(d * q, 0);
    }
    Fbar /= vol(e);
    Fbar.diagonal().array() += 1.0;
    double p = 0;
    if (lambda) {
      const Mat Ee = E->block<d, d>(d * e, 0);
      p = (lambda->block<d, d>(d * e, 0).cwiseProduct(Ee)).sum() / (d * Ee.determinant());
    }
    const Mat cof_bar = (d == 3 && force) ? cofactor<d>(Fbar) : Mat::Zero();
    double mean_det = 0;
    for (int k = 0; k < nq; ++k) {
      const int q = nq * e + k;
      Mat F = GQ.block<d, d>(d * q, 0);
      F.diagonal().array() += 1.0;
      if constexpr (d == 2) {  // the linear term cancels exactly: det and cof of delta directly
        mean_det += wq(q) * (F - Fbar).determinant();
        if (force) force->block<d, d>(d * q, 0) = p * cofactor<d>(F - Fbar);
      } else {
        mean_det += wq(q) * F.determinant();
        if (force) force->block<d, d>(d * q, 0) = p * (cofactor<d>(F) - cof_bar);
      }
    }
    if (c) (*c)(e) = d == 2 ? mean_det / vol(e) : mean_det / vol(e) - Fbar.determinant();
  }
}
}  // namespace

void Solver::fluctuation(const Eigen::MatrixXd& u, const Eigen::MatrixXd* lambda,
                         const Eigen::MatrixXd* E, Eigen::VectorXd* c,
                         Eigen::MatrixXd* force) const {
  GQ_.noalias() = Gq_ * u;
  if (dim() == 2)
    fluctuation_loop<2>(GQ_, wq_, cells_.vol, nq_, lambda, E, c, force);
  else
    fluctuation_loop<3>(GQ_, wq_, cells_.vol, nq_, lambda, E, c, force);
}

Eigen::VectorXd Solver::fluctuation_det(const Eigen::MatrixXd& u) const {
  Eigen::VectorXd c = Eigen::VectorXd::Zero(problem_.mesh.num_cells());
  if (mean_det_) fluctuation(u, nullptr, nullptr, &c, nullptr);
  return c;
}

Eigen::MatrixXd Solver::fluctuation_force(const State& s) const {
  if (!mean_det_) return Eigen::MatrixXd::Zero(problem_.mesh.num_nodes(), dim());
  Eigen::MatrixXd S(Sq_.rows(), Sq_.cols());
  fluctuation(s.u, &s.lambda, &s.E, nullptr, &S);
  return GqT_w_ * S;
}

// [LTL87 (4.7), sec. 6] Facet means of u, then Gauss-Seidel over the contact facets.
void Solver::contact_solve(const Eigen::MatrixXd& lambda_c, const Eigen::VectorXd& beta_prev,
                           State& s) {
  contact_->solve(ubar_, lambda_c, beta_prev, s.e, s.beta, problem_.algorithm.contact_sweeps);
}

// [LTL87 (4.1)-(4.3) / (7.7)-(7.10)] One ALG2 iteration: s = (E, e, beta, lambda, lambda_c) ->
// its successor, u recomputed. Returns the residual parts of the iteration: r_G (change of the
// local variables) and r_B (constraint residual after the local steps), scaled by ||I||_q.
IterationRecord Solver::iterate(State& s, const Eigen::VectorXd& beta_prev, int& strain_failures) {
  const AlgorithmParams& alg = problem_.algorithm;
  const double Rq = alg.R * alg.q, Rqc = alg.R * alg.q_c;
  const bool bm = alg.update == Update::BermudezMoreno;
  IterationRecord rec;
  E_prev_ = s.E;
  if (facets_) {
    e_prev_ = s.e;
    beta_prev_iter_ = s.beta;
  }
  const int sweeps = bm ? 1 : alg.sweeps;
  for (int k = 0; k < sweeps; ++k) {
    // Phase 1, (4.1) / (7.7): global step for u, then Gbar u and the facet means ubar.
    auto t0 = clock_type::now();
    global_solve(s);
    GU_.noalias() = cells_.Gbar * s.u;
    if (mean_det_) {  // the local constraint det E_e = 1 - c_e(u)
      fluctuation(s.u, nullptr, nullptr, &Jtarget_, nullptr);
      Jtarget_ = 1.0 - Jtarget_.array();
    }
    if (facets_) {
      ubar_rows_.noalias() = facets_->mean * s.u;
      ubar_ = ubar_rows_.transpose();
    }
    rec.t_global += seconds_since(t0);
    // Multipliers seen by the local steps: lambda^{n-1} (Uzawa) or the half step (7.8) with the
    // previous local variables G^{n-1} (Bermudez-Moreno).
    const Eigen::MatrixXd* lambda = &s.lambda;
    const Eigen::MatrixXd* lambda_c = &s.lambda_c;
    if (bm) {
      t0 = clock_type::now();
      lambda_half_ = s.lambda - Rq * (Id_ + GU_ - s.E);
      lambda = &lambda_half_;
      if (facets_) {
        lambda_c_half_ = s.lambda_c - Rqc * (ubar_ - s.e);
        lambda_c = &lambda_c_half_;
      }
      rec.t_update += seconds_since(t0);
    }
    // Phase 2, (4.2) = (4.6) + (4.7) / (7.9): local steps for E per cell, {e, beta} per facet.
    t0 = clock_type::now();
    strain_failures += strain_solve(*lambda, s);
    rec.t_strain += seconds_since(t0);
    if (facets_) {
      t0 = clock_type::now();
      contact_solve(*lambda_c, beta_prev, s);
      rec.t_contact += seconds_since(t0);
    }
  }
  // Phase 3, (4.3) / (7.10): multiplier update.
  auto t0 = clock_type::now();
  update_multipliers(s);
  residuals(s, rec);
  rec.t_update += seconds_since(t0);
  return rec;
}

// [LTL87 (4.3)] Uzawa: lambda -= rho R q (I + Gbar u - E), lambda_c -= rho R q_c (ubar - e).
// [LTL87 (7.10)] Bermudez-Moreno: the same from the half step (7.8) with factor 2 rho - 1.
void Solver::update_multipliers(State& s) {
  const AlgorithmParams& alg = problem_.algorithm;
  const double Rq = alg.R * alg.q, Rqc = alg.R * alg.q_c;
  if (alg.update == Update::BermudezMoreno) {
    s.lambda = lambda_half_ - (2 * alg.rho - 1) * Rq * (Id_ + GU_ - s.E);
    if (facets_) s.lambda_c = lambda_c_half_ - (2 * alg.rho - 1) * Rqc * (ubar_ - s.e);
  } else {
    s.lambda -= alg.rho * Rq * (Id_ + GU_ - s.E);
    if (facets_) s.lambda_c -= alg.rho * Rqc * (ubar_ - s.e);
  }
}

// [LTL87 (4.4)] The residual parts with the weights of (3.3):
//   r_B = ||(I + Gbar u - E, ubar - e)|| / ||I||_q,
//   r_G = ||(E - E^{n-1}, e - e^{n-1})|| / ||I||_q + RMS(beta - beta^{n-1}).
void Solver::residuals(const State& s, IterationRecord& rec) const {
  const AlgorithmParams& alg = problem_.algorithm;
  double B2 = 0, G2 = 0, beta2 = 0;
  const Eigen::Index rows = GU_.rows();
  const int dim = this->dim();
#pragma omp parallel for schedule(static) reduction(+ : B2, G2)
  for (Eigen::Index r = 0; r < rows; ++r) {
    double b = 0, g = 0;
    for (int i = 0; i < dim; ++i) {
      const double Bri = (i == r % dim ? 1.0 : 0.0) + GU_(r, i) - s.E(r, i);
      const double Gri = s.E(r, i) - E_prev_(r, i);
      b += Bri * Bri;
      g += Gri * Gri;
    }
    B2 += vol_rows_(r) * b;
    G2 += vol_rows_(r) * g;
  }
  B2 *= alg.q;
  G2 *= alg.q;
  if (facets_) {
    for (int f = 0; f < facets_->size(); ++f) {
      const double a = facets_->area(f);
      B2 += alg.q_c * a * (ubar_.col(f) - s.e.col(f)).squaredNorm();
      G2 += alg.q_c * a * (s.e.col(f) - e_prev_.col(f)).squaredNorm();
      beta2 += a * std::pow(s.beta(f) - beta_prev_iter_(f), 2);
    }
  }
  rec.r_B = std::sqrt(B2) / norm_I_;
  rec.r_G = std::sqrt(G2) / norm_I_ + (facets_ ? std::sqrt(beta2 / area_c_) : 0.0);
}

namespace {
// z[k .. k + size) <-> a matrix scaled by a weight per row (cells) or per column (facets).
using Map = Eigen::Map<Eigen::MatrixXd>;
using ConstMap = Eigen::Map<const Eigen::MatrixXd>;
}  // namespace

template <class S, class Cells, class Facets, class Beta, class U>
void Solver::for_each_packed(S& s, Cells&& cells, Facets&& facets, Beta&& beta, U&& u) const {
  const AlgorithmParams& alg = problem_.algorithm;
  const double Rq = alg.R * alg.q, Rqc = alg.R * alg.q_c;
  const bool G = alg.accelerate != Accelerated::Multipliers;
  if (G) cells(s.E, 1.0);
  cells(s.lambda, 1 / Rq);
  if (facets_) {
    if (G) facets(s.e, 1.0);
    facets(s.lambda_c, 1 / Rqc);
    if (alg.accelerate == Accelerated::All)
      for (int f = 0; f < facets_->size(); ++f)
        beta(s.beta(f), std::sqrt(facets_->area(f) / area_c_));
  }
  if (mean_det_) u(s.u);
}

void Solver::pack(const State& s, Eigen::VectorXd& z) const {
  double* p = z.data();
  for_each_packed(
      s,
      [&](const Eigen::MatrixXd& A, double c) {
        Map(p, A.rows(), A.cols()) = c * (A.array().colwise() * w_cell_.array()).matrix();
        p += A.size();
      },
      [&](const Eigen::MatrixXd& A, double c) {
        Map(p, A.rows(), A.cols()) =
            c * (A.array().rowwise() * w_facet_.transpose().array()).matrix();
        p += A.size();
      },
      [&](double b, double w) { *p++ = w * b; },
      [&](const Eigen::MatrixXd& u) { Map(p, u.rows(), u.cols()) = w_u_ * u; });
}

void Solver::unpack(const Eigen::VectorXd& z, State& s) const {
  const double* p = z.data();
  for_each_packed(
      s,
      [&](Eigen::MatrixXd& A, double c) {
        A = (ConstMap(p, A.rows(), A.cols()).array().colwise() / (c * w_cell_.array())).matrix();
        p += A.size();
      },
      [&](Eigen::MatrixXd& A, double c) {
        A = (ConstMap(p, A.rows(), A.cols()).array().rowwise() / (c * w_facet_.transpose().array()))
                .matrix();
        p += A.size();
      },
      [&](double& b, double w) { b = *p++ / w; },
      [&](Eigen::MatrixXd& u) { u = ConstMap(p, u.rows(), u.cols()) / w_u_; });
}

StepReport Solver::solve_step(State& s, const Eigen::VectorXd& beta_prev,
                              const std::function<void(const IterationRecord&)>& progress) {
  StepReport report;
  IterationPolicy policy(problem_.algorithm, report, progress);
  // Anderson with a safeguard that can only help: an accelerated iterate is kept when its merit
  // r_G + r_B (measured by the iteration that follows it) does not exceed the merit of the
  // iterate it was extrapolated from; otherwise the plain iterate replaces it and the history
  // restarts.
  if (anderson_) anderson_->restart();
  bool extrapolated = false;  // is s an accelerated iterate?
  double merit_before = 0;    // merit of the iterate s was extrapolated from
  for (int n = 1;; ++n) {
    if (anderson_) pack(s, x_);
    int failures = 0;
    IterationRecord rec = iterate(s, beta_prev, failures);
    rec.n = n;
    const double merit = rec.r_G + rec.r_B;
    bool reject = false;
    if (extrapolated) {
      reject = !(merit <= merit_before) || failures > 0 || !s.u.allFinite();
      rec.accelerated = reject ? -1 : 1;
      ++(reject ? report.rejected : report.accepted);
    }
    if (!reject) report.strain_failures += failures;
    policy.record(rec);
    extrapolated = false;
    if (reject) {
      s = plain_;  // the plain iterate G(x^{n-1})
      anderson_->restart();
      if (policy.capped(n)) break;
      continue;
    }
    if (policy.stop(rec, s.u.allFinite())) break;
    if (anderson_) {
      pack(s, g_);
      if (anderson_->step(x_, g_) > 0) {
        plain_ = s;
        unpack(g_, s);
        extrapolated = true;
        merit_before = merit;
      }
    }
  }
  const EquilibriumMeasure eq = equilibrium_measure(*this, s);
  report.force_residual = eq.force_residual;
  report.det_error = eq.det_error;
  report.penetration = eq.penetration;
  return report;
}

void Solver::set_load_factor(double factor) {
  if (!std::isfinite(factor)) throw Error(cat("load factor ", factor, ": must be finite"));
  load_factor_ = factor;
  F_ext_ = factor * F_dead_;  // same size: no allocation
}

Eigen::MatrixXd Solver::piola(const State& s) const {
  return 2 * split_.C1 * s.E - s.lambda;
}

Eigen::MatrixXd Solver::cauchy(const State& s) const {
  const int d = dim(), nc = problem_.mesh.num_cells();
  const Eigen::MatrixXd P = piola(s);
  Eigen::MatrixXd sigma(d * nc, d);
  for (int c = 0; c < nc; ++c) {
    const Eigen::MatrixXd Eb = s.E.block(d * c, 0, d, d), Pb = P.block(d * c, 0, d, d);
    sigma.block(d * c, 0, d, d) = Eb.transpose() * Pb / Eb.determinant();  // (P E^T)^T / det E
  }
  return sigma;
}

Eigen::VectorXd Solver::pressure(const State& s) const {
  const int d = dim(), nc = problem_.mesh.num_cells();
  const Eigen::MatrixXd sigma = cauchy(s);
  Eigen::VectorXd p(nc);
  for (int c = 0; c < nc; ++c) p(c) = -sigma.block(d * c, 0, d, d).trace() / d;
  return p;
}

Eigen::VectorXd Solver::contact_pressure(const State& s) const {
  if (!problem_.contact) return {};
  return -(s.lambda_c.transpose() * problem_.contact->plane_normal.head(dim()));
}

Eigen::VectorXd Solver::contact_gap(const State& s) const {
  if (!contact_) return {};
  return contact_->surface().gap - s.e.transpose() * contact_->surface().N;
}

double Solver::energy(const State& s, const Eigen::VectorXd& beta_prev) const {
  const int d = dim(), nc = problem_.mesh.num_cells();
  const Material& m = split_;
  double J = 0;
  for (int c = 0; c < nc; ++c) {
    if (d == 2)
      J += cells_.vol(c) * m.W(Eigen::Matrix2d(s.E.block<2, 2>(2 * c, 0).transpose()));
    else
      J += cells_.vol(c) * m.W(Eigen::Matrix3d(s.E.block<3, 3>(3 * c, 0).transpose()));
  }
  const Eigen::MatrixXd GU = cells_.Gbar * s.u;
  const double grad2 = (s.u.transpose() * (cells_.laplacian * s.u)).trace();
  const double mean2 = (GU.array().square().colwise() * vol_rows_.array()).sum();
  J += m.C1 * (grad2 - mean2) - (F_ext_.array() * s.u.array()).sum();
  if (contact_) J += contact_->energy(s.e, s.beta, beta_prev);
  return J;
}

Eigen::MatrixXd Solver::energy_gradient(const Eigen::MatrixXd& u) const {
  const int d = dim(), nc = problem_.mesh.num_cells();
  const Material& m = split_;
  const Eigen::MatrixXd GU = cells_.Gbar * u;
  Eigen::MatrixXd P(d * nc, d);
  for (int c = 0; c < nc; ++c) {
    if (d == 2) {
      const Eigen::Matrix2d F = Eigen::Matrix2d::Identity() + GU.block<2, 2>(2 * c, 0).transpose();
      P.block<2, 2>(2 * c, 0) = m.dW(F).transpose();
    } else {
      const Eigen::Matrix3d F = Eigen::Matrix3d::Identity() + GU.block<3, 3>(3 * c, 0).transpose();
      P.block<3, 3>(3 * c, 0) = m.dW(F).transpose();
    }
  }
  Eigen::MatrixXd g =
      cells_.GbarT_vol * P + 2 * m.C1 * (cells_.laplacian * u - cells_.GbarT_vol * GU) - F_ext_;
  for (int c = 0; c < d; ++c)
    for (int i : bc_.fixed[c]) g(i, c) = 0;
  return g;
}

}  // namespace ltl
