#include "alg2.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "error.hpp"
#include "fixed_point.hpp"
#include "measures.hpp"
#include "mpi_comm.hpp"
#include "mpi_newton.hpp"

namespace ltl {

namespace {
using clock_type = std::chrono::steady_clock;
double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}
}  // namespace

Solver::Solver(Problem problem, Ranks ranks)
    : Solver(discretize(std::move(problem), ranks), ranks) {}

Solver::Solver(Discretization discretization, Ranks ranks) : disc_(std::move(discretization)) {
  const auto t0 = clock_type::now();
  const int dim = disc_.dim(), nc = disc_.num_cells(), nn = disc_.num_nodes();
  const ContactPoints* points = disc_.points();
  const int n_points = points ? points->size() : 0;
  const AlgorithmParams& a = alg();
  norm_I_ = std::sqrt(a.q * disc_.volume() * dim);
  if (ranks == Ranks::All) distribute();  // alg2_mpi.cpp
  if (!points_distributed()) {            // every point on this rank
    all_points_.resize(n_points);
    for (int k = 0; k < n_points; ++k) all_points_[k] = k;
  }
  precompute(a.R);

  // Anderson weights: sqrt(q |O_e|) / ||I||_q per cell row, sqrt(q_c |G_s|) / ||I||_q per point.
  // Distributed: the rows of the rank's cells (own_cells(), the iterate's rows).
  const std::vector<int>& own = own_cells();
  const int n_own = static_cast<int>(own.size());
  if (dist_) {
    w_cell_.resize(dim * static_cast<Eigen::Index>(n_own));
    for (int k = 0; k < n_own; ++k)
      w_cell_.segment(dim * k, dim).setConstant(std::sqrt(a.q * disc_.cell_volume(own[k], k)));
    w_cell_ /= norm_I_;
  } else {
    w_cell_ = (a.q * disc_.volume_rows()).cwiseSqrt() / norm_I_;
  }
  if (points) w_point_ = (a.q_c * points->area).cwiseSqrt() / norm_I_;
  // The packed iterate: lambda, lambda_c; E, e unless only the multipliers are accelerated; beta
  // with "all". Mean-det: the lagged fluctuation terms make u part of the state the map acts on,
  // so u is extrapolated with the rest, weighted like a gradient, sqrt(q |Omega| / #nodes) / h.
  // Distributed, the cells' part (first) is the rank's rows, and so is the points' part when
  // the contact step is distributed (the rank's points, own_points(); else every point, the same on
  // every rank); the rest (u) is the same on every rank.
  const Eigen::Index n_packed = static_cast<Eigen::Index>(own_points().size());  // packed points
  const int G = a.accelerate != Accelerated::Multipliers ? 2 : 1;
  const Eigen::Index cells_part = G * dim * dim * static_cast<Eigen::Index>(n_own),
                     points_part =
                         G * dim * n_packed + (a.accelerate == Accelerated::All ? n_packed : 0);
  packed_size_ = cells_part + points_part;
  if (dist_) packed_distributed_ = cells_part + (points_distributed() ? points_part : 0);
  if (disc_.mean_det()) {
    packed_size_ += dim * nn;
    const double h = std::pow(disc_.volume() / nc, 1.0 / dim);
    w_u_ = std::sqrt(a.q * disc_.volume() / nn) / (h * norm_I_);
  }

  make_work();
  if (a.solver == NonlinearSolver::Newton) {
    // Its linear systems by GMRES + AMG when the global step is CG + AMG (a factorization would
    // not fit; newton_krylov.hpp), else by CHOLMOD's (or over the ranks MUMPS's) factor.
    // Distributed: its linear systems over the ranks (mpi_newton, or newton_krylov's distributed
    // GMRES + GAMG when the global step is the distributed CG + GAMG), its cells the rank's
    // cells of the partition (ALG2's), its rows those of the global step.
    const bool krylov = distributed() ? distributed_cg_gamg() && distributed_newton_solves()
                                      : global_ && global_->solver() == GlobalSolver::CgAmg;
    newton_ = std::make_unique<Newton>(disc_, krylov, cell_partition());
  }
  if (dist_) release_after_setup();  // alg2_mpi.cpp
  setup_seconds_ = disc_.build_seconds() + seconds_since(t0);
}

// [LTL87 (4.5)] K assembled with R q and R q_c and factorized; the local steps built with them.
// Mean-det's proximal term gamma (L - GbarT Gbar) on the fluctuations (discretization.md) is
// implicit in K and the same operator lagged on the right-hand side, so it cancels at a fixed
// point.
void Solver::precompute(double R) {
  const AlgorithmParams& a = alg();
  const double Rq = R * a.q, Rqc = R * a.q_c;
  R_ = R;
  gamma_ = disc_.mean_det() ? 2 * Rq : 0.0;
  SpMat K = global_matrix(disc_.cells(), points_in_K(), disc_.split().C1 + gamma_ / 2, Rq - gamma_,
                          Rqc);  // this rank's part when the discretization is partial
  // a substep's value scale, kept
  const double scale = global_ ? global_->value_scale() : dist_ ? distributed_value_scale() : 1.0;
  global_.reset();  // release the old factor before the new one is computed
  if (!dist_ || !distributed_global_step(K, scale)) {  // the distributed KSP (alg2_mpi.cpp)
    // K is consumed by the global step (freed before the factorization / AMG setup's peak).
    global_ = std::make_unique<GlobalStep>(std::move(K), disc_.dirichlet(), a.global_solver,
                                           &problem().mesh.X, newton_dim());
    global_->set_value_scale(scale);
  }
  ++factorizations_;
  strain_ = std::make_unique<StrainStep>(disc_.split(), Rq);
  if (disc_.points()) {
    if (contact_) {
      contact_->set_Rqc(Rqc);  // the adhesion kernel does not depend on R
    } else {
      std::vector<Adhesion> adhesion;  // each obstacle's glue, with the time step
      for (const ContactCondition& cc : problem().contacts) {
        adhesion.push_back(cc.adhesion);
        adhesion.back().dt = problem().time.dt;
      }
      contact_ = std::make_unique<ContactSteps>(disc_.obstacle_points(), adhesion, Rqc);
    }
  }
}

State Solver::initial_state(bool whole) const {
  const int dim = this->dim();
  const int n_points = disc_.points() ? disc_.points()->size() : 0;
  State s;
  s.u = Eigen::MatrixXd::Zero(disc_.problem().mesh.num_nodes(), dim);
  for (int i = 0; i < dim; ++i) disc_.dirichlet().impose(s.u, i, 1.0);
  if (!whole) layer_rows(s.u);  // with a ghost layer, its rows (the state between steps)
  s.E = whole || !rows_between_steps()
            ? disc_.identity()
            : Eigen::MatrixXd(identity_rows(dim, static_cast<int>(disc_.held_cells().size())));
  s.lambda = 2 * disc_.split().C1 * s.E;
  s.e = Eigen::MatrixXd::Zero(n_points, dim);
  s.lambda_c = Eigen::MatrixXd::Zero(n_points, dim);
  s.beta = Eigen::VectorXd::Zero(n_points);
  for (int k = 0; k < disc_.num_obstacles(); ++k)  // each obstacle's beta_0 on its points
    s.beta.segment(disc_.points()->offset[k], disc_.obstacle_points()[k].size())
        .setConstant(problem().contacts[k].beta0);
  return s;
}

// [LTL87 (4.1), (4.5)] Right-hand side
//   L(v) = f.v + g.v + sum_e |O_e| [R q (E_e - I) + lambda_e - 2 C1 I] : Gbar_e(v)
//          + sum_s |G_s| [R q_c e_s + lambda_c_s] . vbar_s
// (+ mean-det's lagged fluctuation terms), then one triangular solve per distinct Dirichlet set
// against the stored factor; then Gbar u, the contact means ubar and the mean-det targets J.
void Solver::global_phase(State& s, GlobalOutput& g) {
  if (dist_) return global_phase_distributed(s, g);  // alg2_mpi.cpp
  const AlgorithmParams& a = alg();
  const double Rq = R_ * a.q;
  const CellOperators& cells = disc_.cells();
  const ContactPoints* points = disc_.points();
  const auto I = identity_rows(dim(), disc_.num_cells());
  T_ = Rq * (s.E - I) + s.lambda - 2 * disc_.split().C1 * I;
  rhs_.noalias() = cells.GbarT_vol * T_;
  disc_.add_dead_load(rhs_, load_factor_);
  if (disc_.mean_det())  // the pressure's work and gamma (L - GbarT_vol Gbar) u, lagged
    disc_.fluctuation(s.u, &s.lambda, &s.E, nullptr, &rhs_, gamma_);
  if (points) rhs_.noalias() += points->meanT_area * (R_ * a.q_c * s.e + s.lambda_c);
  global_->solve(rhs_, s.u);

  g.GU.noalias() = cells.Gbar * s.u;
  if (disc_.mean_det()) {  // the local constraint det E_e = 1 - c_e(u)
    disc_.fluctuation(s.u, nullptr, nullptr, &g.J, nullptr);
    g.J = 1.0 - g.J.array();
  }
  if (points) g.ubar.noalias() = points->mean * s.u;
}

// [LTL87 (4.6), (5.2)-(5.8)] Cell by cell, D = R q (I + Gbar u) - lambda and E = argmin J_E.
// The blocks are transposed tensors; the energies are isotropic, so solving on D^T gives E^T.
// Every row block of the arrays (a rank's cells when distributed).
namespace {
template <int d>
int strain_loop(const StrainStep& step, double Rq, const Eigen::MatrixXd& GU,
                const Eigen::MatrixXd& lambda, const Eigen::VectorXd* J, Eigen::MatrixXd& E) {
  int failures = 0;
  const int n = static_cast<int>(GU.rows() / d);
#pragma omp parallel for schedule(static) reduction(+ : failures)
  for (int k = 0; k < n; ++k) {
    Eigen::Matrix<double, d, d> D =
        Rq * GU.template block<d, d>(d * k, 0) - lambda.template block<d, d>(d * k, 0);
    D.diagonal().array() += Rq;
    Eigen::Matrix<double, d, d> Ec;
    // Mean-det: det E = J_c. The local energy is (R q / 2)|E|^2 - D : E (C2 = 0), homogeneous
    // of degree 2 under E = s Ehat, so E = s argmin over det Ehat = 1 with D / s, s = J_c^(1/d).
    const double s = J ? (d == 2 ? std::sqrt((*J)(k)) : std::cbrt((*J)(k))) : 1.0;
    if (!(s > 0)) {
      ++failures;
      continue;
    }
    if (!step.solve(D / s, Ec)) ++failures;
    E.template block<d, d>(d * k, 0) = s * Ec;
  }
  return failures;
}
}  // namespace

// [LTL87 (4.2) = (4.6) + (4.7)] The local steps: E per cell (sec. 5), then Gauss-Seidel over the
// contact points for {e, beta} (sec. 6), against the multipliers lambda, lambda_c.
int Solver::local_phase(const GlobalOutput& g, const Eigen::MatrixXd& lambda,
                        const Eigen::MatrixXd& lambda_c, const Eigen::VectorXd& beta_prev, State& s,
                        IterationRecord& rec) {
  const double Rq = R_ * alg().q;
  const Eigen::VectorXd* J = disc_.mean_det() ? &g.J : nullptr;
  auto t0 = clock_type::now();
  int failures = dim() == 2 ? strain_loop<2>(*strain_, Rq, g.GU, lambda, J, s.E)
                            : strain_loop<3>(*strain_, Rq, g.GU, lambda, J, s.E);
  rec.t_strain += seconds_since(t0);
  if (contact_) {
    t0 = clock_type::now();
    // this rank's points (all unless distributed), a run of the point index at a time
    mpi::for_each_run(own_points(), [&](int f0, int n, int) {
      contact_->solve(g.ubar, lambda_c, beta_prev, s.e, s.beta, alg().contact_sweeps, f0, f0 + n);
    });
    rec.t_contact += seconds_since(t0);
  }
  if (dist_) {
    double f = failures;
    sum_over_ranks(&f, 1);
    failures = static_cast<int>(f);
  }
  return failures;
}

// [LTL87 (7.8)] lambda^{n-1/2} = lambda^{n-1} - R q B(u^n, G^{n-1}) (and the same for lambda_c).
// On this rank's rows (all of them unless distributed).
void Solver::half_step(const GlobalOutput& g, const State& s, Multipliers& m) const {
  const double Rq = R_ * alg().q, Rqc = R_ * alg().q_c;
  const auto I = identity_rows(dim(), static_cast<int>(own_cells().size()));
  m.lambda = s.lambda - Rq * (I + g.GU - s.E);
  if (contact_) {
    m.lambda_c.resize(s.lambda_c.rows(), s.lambda_c.cols());
    mpi::for_each_run(own_points(), [&](int f0, int n, int) {
      m.lambda_c.middleRows(f0, n) =
          s.lambda_c.middleRows(f0, n) - Rqc * (g.ubar.middleRows(f0, n) - s.e.middleRows(f0, n));
    });
  }
}

// [LTL87 (4.3)] Uzawa: lambda -= rho R q (I + Gbar u - E), lambda_c -= rho R q_c (ubar - e).
// [LTL87 (7.10)] Bermudez-Moreno: the same from the half step (7.8) with factor 2 rho - 1.
void Solver::update_phase(const GlobalOutput& g, const Multipliers* half, State& s) const {
  const AlgorithmParams& a = alg();
  const double Rq = R_ * a.q, Rqc = R_ * a.q_c;
  const double step = half ? 2 * a.rho - 1 : a.rho;
  const auto I = identity_rows(dim(), static_cast<int>(own_cells().size()));
  if (half) s.lambda = half->lambda;
  s.lambda -= step * Rq * (I + g.GU - s.E);
  if (contact_)
    mpi::for_each_run(own_points(), [&](int f0, int n, int) {
      if (half) s.lambda_c.middleRows(f0, n) = half->lambda_c.middleRows(f0, n);
      s.lambda_c.middleRows(f0, n) -=
          step * Rqc * (g.ubar.middleRows(f0, n) - s.e.middleRows(f0, n));
    });
}

// [LTL87 (4.1)-(4.3) / (7.7)-(7.10)] One ALG2 iteration, in three phases.
IterationRecord Solver::iterate(State& s, const Eigen::VectorXd& beta_prev, int& strain_failures) {
  const bool bm = alg().update == Update::BermudezMoreno;
  IterationRecord rec;
  prev_.E = s.E;
  if (contact_) {
    prev_.e = s.e;
    prev_.beta = s.beta;
  }
  GlobalOutput& g = global_out_;
  const int sweeps = bm ? 1 : alg().sweeps;
  for (int k = 0; k < sweeps; ++k) {
    // Phase 1, (4.1) / (7.7): the global step for u.
    auto t0 = clock_type::now();
    global_phase(s, g);
    rec.t_global += seconds_since(t0);
    // The multipliers the local steps see: lambda^{n-1} (Uzawa) or the half step (7.8) with the
    // previous local variables G^{n-1} (Bermudez-Moreno).
    t0 = clock_type::now();
    if (bm) half_step(g, s, half_);
    rec.t_update += seconds_since(t0);
    // Phase 2, (4.2) = (4.6) + (4.7) / (7.9): the local steps.
    strain_failures += local_phase(g, bm ? half_.lambda : s.lambda,
                                   bm ? half_.lambda_c : s.lambda_c, beta_prev, s, rec);
  }
  // Phase 3, (4.3) / (7.10): the multiplier update.
  auto t0 = clock_type::now();
  update_phase(g, bm ? &half_ : nullptr, s);
  residuals(g, s, prev_, rec, iterate_finite_);
  rec.t_update += seconds_since(t0);
  return rec;
}

// [LTL87 (4.4)] The residual parts with the weights of (3.3):
//   r_B = ||(I + Gbar u - E, ubar - e)|| / ||I||_q,
//   r_G = ||(E - E^{n-1}, e - e^{n-1})|| / ||I||_q + RMS(beta - beta^{n-1}).
void Solver::residuals(const GlobalOutput& g, const State& s, const State& prev,
                       IterationRecord& rec, bool& finite) const {
  const AlgorithmParams& a = alg();
  double B2 = 0, G2 = 0, beta2 = 0;
  const int dim = this->dim();
  const std::vector<int>& cells = own_cells();
  const Eigen::Index nr = dim * static_cast<Eigen::Index>(cells.size());
#pragma omp parallel for schedule(static) reduction(+ : B2, G2)
  for (Eigen::Index k = 0; k < nr; ++k) {
    const double v = disc_.cell_volume(cells[k / dim], static_cast<int>(k / dim));
    double b = 0, gr = 0;
    for (int i = 0; i < dim; ++i) {
      const double Bri = (i == k % dim ? 1.0 : 0.0) + g.GU(k, i) - s.E(k, i);
      const double Gri = s.E(k, i) - prev.E(k, i);
      b += Bri * Bri;
      gr += Gri * Gri;
    }
    B2 += v * b;
    G2 += v * gr;
  }
  B2 *= a.q;
  G2 *= a.q;
  if (const ContactPoints* points = disc_.points()) {
    for (int f : residual_points()) {
      const double w = points->area(f);
      B2 += a.q_c * w * (g.ubar.row(f) - s.e.row(f)).squaredNorm();
      G2 += a.q_c * w * (s.e.row(f) - prev.e.row(f)).squaredNorm();
      beta2 += w * std::pow(s.beta(f) - prev.beta(f), 2);
    }
  }
  finite = s.u.allFinite();
  if (dist_) {
    double parts[4] = {B2, G2, beta2, finite ? 0.0 : 1.0};
    sum_over_ranks(parts, 4);
    B2 = parts[0], G2 = parts[1], beta2 = parts[2], finite = parts[3] == 0;
  }
  rec.r_B = std::sqrt(B2) / norm_I_;
  rec.r_G =
      std::sqrt(G2) / norm_I_ + (disc_.points() ? std::sqrt(beta2 / disc_.contact_area()) : 0.0);
}

namespace {
// z[k .. k + size) <-> a matrix scaled by a weight per row (cells, and the contact points,
// #points x dim, packed point by point: row-major).
using Map = Eigen::Map<Eigen::MatrixXd>;
using ConstMap = Eigen::Map<const Eigen::MatrixXd>;
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using RowMap = Eigen::Map<RowMajor>;
using ConstRowMap = Eigen::Map<const RowMajor>;
}  // namespace

template <class S, class Cells, class Points, class Beta, class U>
void Solver::for_each_packed(S& s, Cells&& cells, Points&& points, Beta&& beta, U&& u) const {
  const AlgorithmParams& a = alg();
  const double Rq = R_ * a.q, Rqc = R_ * a.q_c;
  const bool G = a.accelerate != Accelerated::Multipliers;
  if (G) cells(s.E, 1.0);
  cells(s.lambda, 1 / Rq);
  if (const ContactPoints* f = disc_.points()) {
    const std::vector<int>& own = own_points();  // all unless distributed; by runs
    if (G) mpi::for_each_run(own, [&](int f0, int n, int) { points(s.e, 1.0, f0, n); });
    mpi::for_each_run(own, [&](int f0, int n, int) { points(s.lambda_c, 1 / Rqc, f0, n); });
    if (a.accelerate == Accelerated::All)
      for (int k : own) beta(s.beta(k), std::sqrt(f->area(k) / disc_.contact_area()));
  }
  if (disc_.mean_det()) u(s.u);
}

void Solver::pack(const State& s, Eigen::VectorXd& z) const {
  double* p = z.data();
  for_each_packed(
      s,
      [&](const Eigen::MatrixXd& A, double c) {
        Map(p, A.rows(), A.cols()) = c * (A.array().colwise() * w_cell_.array()).matrix();
        p += A.size();
      },
      [&](const Eigen::MatrixXd& A, double c, int f0, int n) {
        RowMap(p, n, A.cols()) =
            c * (A.middleRows(f0, n).array().colwise() * w_point_.segment(f0, n).array()).matrix();
        p += n * A.cols();
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
      [&](Eigen::MatrixXd& A, double c, int f0, int n) {
        A.middleRows(f0, n) =
            (ConstRowMap(p, n, A.cols()).array().colwise() / (c * w_point_.segment(f0, n).array()))
                .matrix();
        p += n * A.cols();
      },
      [&](double& b, double w) { b = *p++ / w; },
      [&](Eigen::MatrixXd& u) { u = ConstMap(p, u.rows(), u.cols()) / w_u_; });
}

// ALG2 as a fixed-point map of the driver: the iterate is the caller's state; one application is
// iterate(); adaptive R is the map's own check after an iteration.
class Solver::Alg2Map final : public FixedPointMap {
 public:
  Alg2Map(Solver& solver, State& s, const Eigen::VectorXd& beta_prev)
      : solver_(solver), s_(s), beta_prev_(beta_prev) {}
  Eigen::Index packed_size() const override { return solver_.packed_size_; }
  Eigen::Index packed_distributed() const override { return solver_.packed_distributed_; }
  void pack(Eigen::VectorXd& z) const override { solver_.pack(s_, z); }
  void unpack(const Eigen::VectorXd& z) override { solver_.unpack(z, s_); }
  IterationRecord apply(int& failures) override {
    return solver_.iterate(s_, beta_prev_, failures);
  }
  bool finite() const override { return solver_.iterate_finite_; }  // after apply()
  void keep_plain() override { plain_ = s_; }
  void restore_plain() override { s_ = plain_; }
  // Adaptive R: a new R re-factorizes K (the packed multipliers are scaled by 1 / R q, so the
  // acceleration's history restarts).
  bool after_iteration(const IterationRecord& rec) override {
    const AlgorithmParams& a = solver_.alg();
    if (!(a.adaptive_R && rec.n % a.adapt_every == 0 && solver_.adapt_R(rec, s_))) return false;
    ++R_changes;
    return true;
  }
  // Distributed, at the iterate's rows on a ghost layer, else on the state between steps made
  // from it (Solver::equilibrium_error_of).
  double equilibrium_error() const override { return solver_.equilibrium_error_of(s_); }
  int R_changes = 0;

 private:
  Solver& solver_;
  State& s_;
  const Eigen::VectorXd& beta_prev_;
  State plain_;
};

void Solver::make_work() {
  const int dim = disc_.dim(), n_own = static_cast<int>(own_cells().size());
  rhs_.resize(rhs_rows(), dim);
  T_.resize(dim * static_cast<Eigen::Index>(n_own), dim);
  global_out_.GU.resize(T_.rows(), dim);
  prev_.E.resize(T_.rows(), dim);
  global_out_.J = Eigen::VectorXd::Ones(n_own);
  if (const ContactPoints* points = disc_.points()) global_out_.ubar.resize(points->size(), dim);
}

void Solver::release_work() {
  for (Eigen::MatrixXd* A :
       {&rhs_, &T_, &global_out_.GU, &global_out_.ubar, &prev_.E, &half_.lambda, &half_.lambda_c})
    Eigen::MatrixXd().swap(*A);
  Eigen::VectorXd().swap(global_out_.J);
}

// [LTL87 (2.1)] One time step: ALG2 (the driver, fixed_point.hpp) to its tolerance, or with
// algorithm.solver = "newton" ALG2 into Newton's basin and then Newton on the same discrete
// problem (newton.hpp). A Newton phase that fails goes back to ALG2's iterate, which goes on to
// a switch 10 times smaller; after the third failure ALG2 runs to its own tolerance.
//
// Distributed, the iterations run on the rank's rows of E and lambda (own_rows): s's E and
// lambda are released at the start of each ALG2 phase and at its end the state between steps is
// made (between_steps: E and lambda stay on the rank's rows, u on the ghost layer's), so that no
// iteration moves or holds a whole cell field. The Newton phase takes that state too (its E and
// lambda on the rank's rows, Newton::on_rows; u made whole, whole_u) and leaves it with u whole;
// a whole state (a discretization of every cell) and u are cut to the rank's rows before the
// step's measure (hold_rows).
StepReport Solver::solve_step(State& s, const Eigen::VectorXd& beta_prev,
                              const std::function<void(const IterationRecord&)>& progress) {
  StepReport report;
  adaptive_R_.start_step();
  State own;
  Alg2Map map(*this, dist_ ? own : s, beta_prev);
  const auto drive_alg2 = [&](const AlgorithmParams& params) {
    make_work();  // after a Newton phase (release_work); else the same sizes: nothing allocated
    if (dist_) own = own_rows(s);
    {
      // The iterate a callback asks for (iterate_to_writer) is on these rows until the phase
      // ends, or an Interrupted from the callback leaves it.
      alg2_rows_ = dist_ ? &own : nullptr;
      struct Reset {
        const State*& at;
        ~Reset() { at = nullptr; }
      } reset{alg2_rows_};
      drive(map, params, report, progress);
    }
    if (dist_) {
      s = between_steps(std::move(own));  // E and lambda on the rank's rows, u on the layer's
      own = State();
    }
  };
  const AlgorithmParams& a = alg();
  if (!newton_) {
    drive_alg2(a);
  } else {
    AlgorithmParams phase = a;
    double to_switch = a.newton_switch;
    for (;;) {
      const bool last = report.newton_attempts >= 3 || to_switch <= a.tol;
      phase.tol = last ? a.tol : to_switch;
      if (!last) phase.stopping = Stopping::Paper;  // the switch to Newton is on r_G + r_B
      // ALG2 stalled above the switch (e.g. R too small for the stresses) hands over too.
      phase.stagnation_window = last ? a.stagnation_window : 100;
      report.converged = false;
      drive_alg2(phase);
      const bool alg2_done = report.converged && phase.tol <= a.tol;
      const bool capped = !report.converged && report.iterations >= a.max_iter;
      const bool stalled = !report.converged && report.status.rfind("stagnated", 0) == 0;
      double not_finite = s.u.allFinite() ? 0 : 1;  // u on the ranks' layers: on every rank
      if (u_on_layer()) mpi::max(&not_finite, 1);
      if (!(report.converged || capped || stalled) || not_finite > 0 || report.newton_attempts >= 3)
        break;
      ++report.newton_attempts;
      whole_u(s.u);  // the Newton phase's unknowns are whole (newton.hpp)
      if (contact_) newton_->set_glue(*contact_, beta_prev);
      const bool glued = contact_ && contact_->glued();
      const State before = glued ? s : State();
      release_work();
      Newton::Result r = newton_->solve(s, disc_.dead_load(), load_factor_, a, report, progress);
      if (r.converged && glued && !local_contact_step_holds(s, beta_prev)) {
        s = before;
        r.converged = false;
        r.status = "Newton: a state the local contact step leaves (another branch of the glue)";
      }
      if (r.converged) {
        report.converged = true;
        report.status = r.status;
        break;
      }
      report.converged = alg2_done;  // ALG2's own answer stands; its state is s
      report.status = cat(alg2_done ? "converged (ALG2; " : "", r.status, alg2_done ? ")" : "");
      if (alg2_done || capped) break;
      if (!stalled) to_switch /= 10;
    }
  }
  hold_rows(s);  // after a Newton phase (whole): the state between steps
  IterateRows at;
  const EquilibriumMeasure eq =
      equilibrium_measure(discretization(), s, load_factor_, state_rows(at));
  report.force_residual = eq.force_residual;
  report.det_error = eq.det_error;
  report.det_min = eq.det_min;
  report.penetration = eq.penetration;
  report.R = R_;
  report.R_changes = map.R_changes;
  return report;
}

bool Solver::local_contact_step_holds(const State& s, const Eigen::VectorXd& beta_prev) const {
  const Eigen::MatrixXd ubar = disc_.points()->mean * s.u;
  Eigen::MatrixXd e = s.e;
  Eigen::VectorXd beta = s.beta;
  contact_->solve(ubar, s.lambda_c, beta_prev, e, beta, 1);
  const double scale = std::max(ubar.cwiseAbs().maxCoeff(), 1e-300);
  return (beta - s.beta).cwiseAbs().maxCoeff() <= 1e-6 &&
         (e - s.e).cwiseAbs().maxCoeff() <= 1e-6 * scale;
}

bool Solver::adapt_R(const IterationRecord& rec, State& s) {
  const double R = adaptive_R_.next(rec, R_, factorizations_, s);
  if (R == R_) return false;
  precompute(R);
  return true;
}

void Solver::set_load_factor(double factor) {
  if (!std::isfinite(factor)) throw Error(cat("load factor ", factor, ": must be finite"));
  load_factor_ = factor;
  set_displacement_factor(factor);  // prescribed displacements follow the same factor
}

void Solver::set_displacement_factor(double factor) {
  if (!std::isfinite(factor)) throw Error(cat("displacement factor ", factor, ": must be finite"));
  if (global_) global_->set_value_scale(factor);
  if (dist_) set_distributed_value_scale(factor);
}

double Solver::largest_load() const {
  return ltl::largest_load(disc_, load_factor_);
}

double Solver::energy(const State& s, const Eigen::VectorXd& beta_prev) const {
  if (u_on_layer() && s.u.rows() != disc_.num_nodes()) {  // u on the layer's rows: made whole
    State w = s;
    whole_u(w.u);
    return energy(w, beta_prev);
  }
  // On a rank that kept its own nodes' loads (release_after_setup), the load's work of the
  // nodes each rank owns, summed over the ranks.
  double J = disc_.loads_kept()
                 ? disc_.elastic_energy(s, Eigen::MatrixXd()) - load_factor_ * owned_load_work(s.u)
                 : disc_.elastic_energy(s, external_load());
  if (contact_) J += contact_->energy(s.e, s.beta, beta_prev);
  return J;
}

}  // namespace ltl
