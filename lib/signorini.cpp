#include "signorini.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "error.hpp"
#include "fixed_point.hpp"

namespace ltl {

namespace {

using clock_type = std::chrono::steady_clock;
double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}

// [LTL87 (7.1)] Element stiffness of cell c, (dim npc)^2, interleaved local dofs:
//   Ke(d a + i, d b + j) =
//       integral lam dNa_i dNb_j + mu (dNa_j dNb_i + delta_ij grad Na . grad Nb),
// with the quadrature of fe.hpp (for_each_quadrature_point).
Eigen::MatrixXd element_stiffness(const Mesh& mesh, int c, double lam, double mu) {
  const int d = mesh.dim, npc = mesh.nodes_per_cell();
  Eigen::MatrixXd Ke = Eigen::MatrixXd::Zero(d * npc, d * npc);
  for_each_quadrature_point(mesh, c, [&](const Eigen::MatrixXd& g, double w) {
    const Eigen::MatrixXd gg = g * g.transpose();
    for (int a = 0; a < npc; ++a)
      for (int b = 0; b < npc; ++b)
        for (int i = 0; i < d; ++i)
          for (int j = 0; j < d; ++j)
            Ke(d * a + i, d * b + j) +=
                w * (lam * g(a, i) * g(b, j) + mu * (g(a, j) * g(b, i) + (i == j ? gg(a, b) : 0)));
  });
  return Ke;
}

void require(bool ok, const std::string& what) {
  if (!ok) throw Error("Signorini problem: " + what);
}

}  // namespace

void SignoriniProblem::validate() const {
  const int dim = mesh.dim;
  require(dim == 2 || dim == 3,
          cat(mesh.source, ": the mesh has dimension ", dim, "; expected 2 (plane strain) or 3"));
  require(mesh.num_cells() > 0, cat(mesh.source, ": the mesh has no cells"));
  require(std::isfinite(E) && E > 0,
          cat("E = ", E,
              " Pa: Young's modulus must be > 0 (7.1 needs a positive definite "
              "elasticity tensor)"));
  require(std::isfinite(nu) && nu > -1 && nu < 0.5,
          cat("nu = ", nu,
              ": Poisson's ratio must lie in (-1, 0.5) (0.5 is incompressible: use "
              "the finite-elasticity solver, alg2.hpp)"));
  require(body_force.allFinite(), "body_force must be finite");
  for (const auto& d : dirichlet) {
    const std::string who = d.origin.empty() ? "a Dirichlet condition" : d.origin;
    mesh.boundary(d.group, who);
    require(!d.components.empty(),
            cat("the Dirichlet condition on '", d.group, "' lists no component"));
    for (int c : d.components)
      require(c >= 0 && c < dim, cat("the Dirichlet condition on '", d.group, "' has component ", c,
                                     "; components are 0..", dim - 1));
  }
  for (const auto& t : tractions)
    mesh.boundary(t.group, t.origin.empty() ? "a traction" : t.origin);
  require(!contact_group.empty(), "contact_group is empty: name the boundary group Gamma_c");
  mesh.boundary(contact_group, "the Signorini contact group");
  const double n = plane_normal.head(dim).norm();
  require(plane_normal.allFinite() && plane_point.allFinite() && n > 0,
          cat("plane_normal = (", plane_normal.head(dim).transpose(),
              "): give a nonzero normal of the rigid plane, pointing into the obstacle"));
  require(std::abs(n - 1) < 1e-10, cat("plane_normal = (", plane_normal.head(dim).transpose(),
                                       ") has length ", n, ": it must be a unit vector"));
  const AlgorithmParams& a = algorithm;
  require(std::isfinite(a.R) && a.R > 0, cat("algorithm.R = ", a.R, ": must be > 0 (3.2)"));
  require(std::isfinite(a.q_c) && a.q_c > 0,
          cat("algorithm.q_c = ", a.q_c, " Pa/m: must be > 0 (3.3)"));
  if (a.update == Update::BermudezMoreno)
    require(
        a.rho > 0.5 && a.rho <= 1,
        cat("algorithm.rho = ", a.rho, ": the Bermudez-Moreno update (7.10) needs 1/2 < rho <= 1"));
  else
    require(a.rho > 0 && a.rho < 2,
            cat("algorithm.rho = ", a.rho, ": the Uzawa update (4.3) needs 0 < rho < 2"));
  require(a.tol > 0, cat("algorithm.tol = ", a.tol, ": must be > 0"));
  require(a.max_iter >= 1, cat("algorithm.max_iter = ", a.max_iter, ": must be >= 1"));
  require(a.blowup > 1, cat("algorithm.blowup = ", a.blowup, ": must be > 1"));
}

Eigen::VectorXd signorini_projection(const Eigen::VectorXd& uN, const Eigen::VectorXd& lambda_c,
                                     double Rqc, const Eigen::VectorXd& g) {
  return (uN - lambda_c / Rqc).cwiseMin(g);
}

SpMat elasticity_matrix(const Mesh& mesh, double E, double nu) {
  const int dim = mesh.dim, npc = mesh.nodes_per_cell(), nc = mesh.num_cells();
  // Lame constants; in plane strain the 2-D tensor is the 3-D one restricted to eps_i3 = 0.
  const double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(static_cast<std::size_t>(nc) * dim * npc * dim * npc);
  auto scatter = [&](int c, const auto& Ke) {
    for (int a = 0; a < npc; ++a)
      for (int b = 0; b < npc; ++b)
        for (int i = 0; i < dim; ++i)
          for (int j = 0; j < dim; ++j)
            t.emplace_back(dim * mesh.cells(c, a) + i, dim * mesh.cells(c, b) + j,
                           Ke(dim * a + i, dim * b + j));
  };
  if ((dim == 2 && npc == 6) || (dim == 3 && npc == 8)) {
    for (int c = 0; c < nc; ++c) scatter(c, element_stiffness(mesh, c, lam, mu));
  } else {
    throw Error(cat(mesh.source,
                    ": elasticity_matrix supports P2 triangles (6 nodes) in 2-D and "
                    "H8 hexahedra in 3-D; got ",
                    npc, "-node cells in ", dim, "-D"));
  }
  SpMat A(dim * mesh.num_nodes(), dim * mesh.num_nodes());
  A.setFromTriplets(t.begin(), t.end());
  return A;
}

SignoriniSolver::~SignoriniSolver() = default;

SignoriniSolver::SignoriniSolver(const SignoriniProblem& problem) : problem_(problem) {
  problem_.validate();
  const Mesh& mesh = problem_.mesh;
  const int dim = mesh.dim, nn = mesh.num_nodes(), ndof = dim * nn;
  const AlgorithmParams& alg = problem_.algorithm;
  const double Rqc = alg.R * alg.q_c;

  // Gamma_c: facet means, areas, initial gaps g_s = (x_plane - x_s) . N at the facet centres.
  points_ = facet_mean_points(mesh, mesh.boundary(problem_.contact_group, "contact_group"));
  const int n_points = points_.size();
  N_ = problem_.plane_normal.head(dim);
  g_.resize(n_points);
  const double scale = std::max(1.0, mesh.X.cwiseAbs().maxCoeff());
  for (int s = 0; s < n_points; ++s) {
    g_(s) = (problem_.plane_point.head(dim) - points_.centre.col(s)).dot(N_);
    if (g_(s) < -1e-10 * scale)
      throw Error(cat(mesh.source, ": contact facet ", s, " of '", problem_.contact_group,
                      "' (centre ", points_.centre.col(s).transpose(),
                      ") starts inside the obstacle (gap ", g_(s),
                      " m): check plane_point and plane_normal (the normal points into the "
                      "obstacle)"));
  }
  area_c_ = points_.area.sum();

  // [LTL87 (7.4)] M_N: row s holds N . vbar_s as a functional of the interleaved dofs.
  {
    std::vector<Eigen::Triplet<double>> t;
    for (int s = 0; s < n_points; ++s)
      for (SpMatR::InnerIterator it(points_.mean, s); it; ++it)
        for (int i = 0; i < dim; ++i)
          if (N_(i) != 0) t.emplace_back(s, dim * it.col() + i, it.value() * N_(i));
    MN_.resize(n_points, ndof);
    MN_.setFromTriplets(t.begin(), t.end());
    MNT_W_ = SpMatR(MN_.transpose()) * points_.area.asDiagonal();
  }

  // Loads f, g (consistent nodal forces), flattened later.
  F_ext_ = body_load(mesh, problem_.body_force);
  for (const auto& t : problem_.tractions)
    F_ext_ += surface_load(mesh, mesh.boundary(t.group, t.origin), t.g);

  // Dirichlet degrees of freedom (fixed parts, symmetry planes, prescribed displacements).
  std::vector<char> fixed(ndof, 0);
  u_fixed_ = Eigen::VectorXd::Zero(ndof);
  for (const auto& d : problem_.dirichlet)
    for (int node : mesh.boundary_nodes(d.group, d.origin)) {
      Eigen::Vector3d x = Eigen::Vector3d::Zero();
      x.head(dim) = mesh.X.row(node).transpose();
      const Eigen::Vector3d value = d.field(x);
      for (int c : d.components) {
        fixed[dim * node + c] = 1;
        u_fixed_(dim * node + c) = value(c);
      }
    }
  std::vector<int> index(ndof, -1);
  for (int k = 0; k < ndof; ++k)
    if (!fixed[k]) {
      index[k] = static_cast<int>(free_.size());
      free_.push_back(k);
    }
  const int nfree = static_cast<int>(free_.size());
  if (nfree == 0) throw Error(cat(mesh.source, ": every degree of freedom is prescribed"));

  // [LTL87 (4.5), (7.7)] K = A + R q_c M_N^T W M_N, restricted to the free dofs; the columns of
  // the fixed dofs go to the right-hand side once (shift = K_fd u_d).
  A_ = elasticity_matrix(mesh, problem_.E, problem_.nu);
  const SpMat C = SpMat(MN_.transpose()) * points_.area.asDiagonal() * SpMat(MN_);
  const SpMat K = A_ + Rqc * C;
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(K.nonZeros());
  shift_ = Eigen::VectorXd::Zero(nfree);
  for (int j = 0; j < K.outerSize(); ++j)
    for (SpMat::InnerIterator it(K, j); it; ++it) {
      const int r = index[it.row()], c = index[j];
      if (r < 0) continue;
      if (c >= 0) {
        if (r >= c) t.emplace_back(r, c, it.value());
      } else {
        shift_(r) += it.value() * u_fixed_(j);
      }
    }
  SpMat Kff(nfree, nfree);
  Kff.setFromTriplets(t.begin(), t.end());
  llt_ = std::make_unique<Cholesky>(
      Kff, 1,
      cat(mesh.source, ": the Signorini global matrix A + R q_c M_N^T W M_N (", nfree,
          " free dofs)"),
      "A rigid motion is left free: add a fixed part or symmetry plane, or check the contact "
      "group and normal.");
  factorize_seconds_ = llt_->analyze_seconds() + llt_->factorize_seconds();
  rcond_ = llt_->rcond();
  // The factor's order folded into the gather and the scatter of global_solve.
  dof_.resize(nfree);
  Eigen::VectorXd shift_perm(nfree);
  for (int k = 0; k < nfree; ++k) {
    dof_[k] = free_[llt_->perm()[k]];
    shift_perm(k) = shift_(llt_->perm()[k]);
  }
  shift_ = shift_perm;

  const Eigen::MatrixXd Ft = F_ext_.transpose();
  f_flat_ = Eigen::Map<const Eigen::VectorXd>(Ft.data(), Ft.size());
  rhs_full_.resize(ndof);
  U_.resize(ndof);
}

Eigen::VectorXd SignoriniSolver::normal_mean(const Eigen::MatrixXd& u) const {
  const Eigen::MatrixXd ut = u.transpose();  // dim x #nodes: interleaved when flattened
  return MN_ * Eigen::Map<const Eigen::VectorXd>(ut.data(), ut.size());
}

// [LTL87 (4.1), (7.7)] (A + R q_c M_N^T W M_N) u = f + g + M_N^T W (R q_c H + lambda_c), with u
// prescribed on the Dirichlet dofs; one triangular solve against the stored factor.
void SignoriniSolver::global_solve(const Eigen::VectorXd& H, const Eigen::VectorXd& lambda_c,
                                   Eigen::MatrixXd& u) {
  const AlgorithmParams& alg = problem_.algorithm;
  const int dim = this->dim(), nn = problem_.mesh.num_nodes();
  rhs_full_ = f_flat_;
  rhs_full_.noalias() += MNT_W_ * (alg.R * alg.q_c * H + lambda_c);
  double* y = llt_->block();
  for (std::size_t k = 0; k < dof_.size(); ++k) y[k] = rhs_full_(dof_[k]) - shift_(k);
  llt_->solve_in_place();
  U_ = u_fixed_;
  for (std::size_t k = 0; k < dof_.size(); ++k) U_(dof_[k]) = y[k];
  u = Eigen::Map<const Eigen::MatrixXd>(U_.data(), dim, nn).transpose();
}

SignoriniSolution SignoriniSolver::solve(
    const std::function<void(const IterationRecord&)>& progress) {
  const int n_points = points_.size();
  return solve(g_.cwiseMin(0.0), Eigen::VectorXd::Zero(n_points), progress);
}

// The Signorini iteration (4.1)-(4.3) / (7.7)-(7.10) on (H, lambda_c) as a fixed-point map of
// the driver (fixed_point.hpp). The packed iterate weighs each facet by sqrt(|G_s|) and the
// multiplier by 1 / R q_c, as in (3.3).
class SignoriniSolver::Map final : public FixedPointMap {
 public:
  Map(SignoriniSolver& solver, SignoriniSolution& sol)
      : S_(solver),
        sol_(sol),
        nf_(solver.points_.size()),
        Rqc_(solver.problem_.algorithm.R * solver.problem_.algorithm.q_c),
        w_(solver.points_.area.cwiseSqrt().array()),
        H_prev_(nf_),
        lambda_half_(nf_),
        B_(nf_) {}
  Eigen::Index packed_size() const override { return 2 * nf_; }
  void pack(Eigen::VectorXd& z) const override {
    z.head(nf_) = (w_ * sol_.H.array()).matrix();
    z.tail(nf_) = (w_ * sol_.lambda_c.array() / Rqc_).matrix();
  }
  void unpack(const Eigen::VectorXd& z) override {
    sol_.H = (z.head(nf_).array() / w_).matrix();
    sol_.lambda_c = (z.tail(nf_).array() / w_ * Rqc_).matrix();
  }
  bool finite() const override { return sol_.u.allFinite(); }
  void keep_plain() override {
    H_plain_ = sol_.H;
    lambda_plain_ = sol_.lambda_c;
  }
  void restore_plain() override {
    sol_.H = H_plain_;
    sol_.lambda_c = lambda_plain_;
  }

  IterationRecord apply(int&) override {
    const AlgorithmParams& alg = S_.problem_.algorithm;
    const bool bm = alg.update == Update::BermudezMoreno;
    IterationRecord rec;
    H_prev_ = sol_.H;
    // (4.1) / (7.7) global step with (H^{n-1}, lambda_c^{n-1}).
    auto t0 = clock_type::now();
    S_.global_solve(sol_.H, sol_.lambda_c, sol_.u);
    sol_.uN = S_.normal_mean(sol_.u);
    rec.t_global = seconds_since(t0);
    // (7.8) Bermudez-Moreno half step with the previous local variable H^{n-1}.
    t0 = clock_type::now();
    const Eigen::VectorXd* lambda = &sol_.lambda_c;
    if (bm) {
      lambda_half_ = sol_.lambda_c - Rqc_ * (sol_.uN - H_prev_);
      lambda = &lambda_half_;
    }
    rec.t_update = seconds_since(t0);
    // (4.2) / (7.9) local step: the projection onto {H <= g}.
    t0 = clock_type::now();
    sol_.H = signorini_projection(sol_.uN, *lambda, Rqc_, S_.g_);
    rec.t_contact = seconds_since(t0);
    // (4.3) / (7.10) multiplier update, and the two residual parts.
    t0 = clock_type::now();
    B_ = sol_.uN - sol_.H;  // B(u^n, H^n) (7.4)
    if (bm)
      sol_.lambda_c = lambda_half_ - (2 * alg.rho - 1) * Rqc_ * B_;
    else
      sol_.lambda_c -= alg.rho * Rqc_ * B_;
    const double U = std::max(sol_.u.rowwise().norm().maxCoeff(), 1e-300);
    rec.r_B = rms(B_) / U;
    rec.r_G = rms(sol_.H - H_prev_) / U;
    rec.t_update += seconds_since(t0);
    return rec;
  }

 private:
  double rms(const Eigen::VectorXd& x) const {
    return std::sqrt(S_.points_.area.dot(x.cwiseAbs2()) / S_.area_c_);
  }
  SignoriniSolver& S_;
  SignoriniSolution& sol_;
  const int nf_;
  const double Rqc_;
  const Eigen::ArrayXd w_;
  Eigen::VectorXd H_prev_, lambda_half_, B_, H_plain_, lambda_plain_;
};

SignoriniSolution SignoriniSolver::solve(
    const Eigen::VectorXd& H0, const Eigen::VectorXd& lambda_c0,
    const std::function<void(const IterationRecord&)>& progress) {
  const AlgorithmParams& alg = problem_.algorithm;
  const int n_points = points_.size();
  if (H0.size() != n_points || lambda_c0.size() != n_points)
    throw Error(
        cat("SignoriniSolver::solve: H0 and lambda_c0 must have one entry per contact "
            "facet (",
            n_points, "); got ", H0.size(), " and ", lambda_c0.size()));
  SignoriniSolution sol;
  sol.H = H0;
  sol.lambda_c = lambda_c0;
  Map map(*this, sol);
  drive(map, alg, sol.report, progress);
  sol.p = -sol.lambda_c;
  sol.gap = g_ - sol.uN;
  return sol;
}

ContactZone contact_zone(const Eigen::VectorXd& s_lo, const Eigen::VectorXd& s_hi,
                         const Eigen::VectorXd& p, const Eigen::VectorXd& gap,
                         const Eigen::VectorXd& area, double rel_threshold) {
  const int n_points = static_cast<int>(p.size());
  if (s_lo.size() != n_points || s_hi.size() != n_points || gap.size() != n_points ||
      area.size() != n_points)
    throw Error("contact_zone: s_lo, s_hi, p, gap and area must have one entry per facet");
  std::vector<int> order(n_points);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return s_lo(a) + s_hi(a) < s_lo(b) + s_hi(b); });
  ContactZone z;
  if (n_points == 0) return z;
  auto l = [&](int k) { return s_lo(order[k]); };
  auto r = [&](int k) { return s_hi(order[k]); };
  auto centre = [&](int k) { return 0.5 * (l(k) + r(k)); };
  auto P = [&](int k) { return p(order[k]); };
  auto G = [&](int k) { return gap(order[k]); };
  z.force = area.dot(p);
  z.peak_max = p.maxCoeff();
  if (!(z.peak_max > 0)) return z;
  const double threshold = rel_threshold * z.peak_max;
  int last = -1;
  double m2 = 0;
  for (int k = 0; k < n_points; ++k)
    if (P(k) > threshold) {
      ++z.active;
      last = k;
      const double h = r(k) - l(k);
      m2 += area(order[k]) * P(k) * (centre(k) * centre(k) + h * h / 12);
    }
  // Second moment: for p = p0 sqrt(1 - s^2/a^2), integral p s^2 / integral p = a^2 / 4.
  z.half_width_moment = std::sqrt(std::max(0.0, 4 * m2 / z.force));
  z.half_width_last = r(last);
  z.half_width = r(last);
  // Edge from the gaps of the first two free facets k1, k2: facet means of g = D (s - a)_+^{3/2},
  //   gbar_j(a) = (2 D / (5 h_j)) [(r_j - a)_+^{5/2} - (l_j - a)_+^{5/2}],
  // a = root of gbar_k1(a) / gbar_k2(a) = gap_k1 / gap_k2 (decreasing in a), by bisection in
  // [l_last, r_k1].
  const int k1 = last + 1, k2 = last + 2;
  if (k2 < n_points && G(k1) > 0 && G(k2) > G(k1)) {
    auto mean = [&](int j, double a) {
      return (std::pow(std::max(r(j) - a, 0.0), 2.5) - std::pow(std::max(l(j) - a, 0.0), 2.5)) /
             (r(j) - l(j));
    };
    const double target = G(k1) / G(k2);
    double lo = l(last), hi = r(k1);
    auto ratio = [&](double a) { return mean(k1, a) / mean(k2, a); };
    if (ratio(lo) <= target) {
      z.half_width = lo;
    } else {
      for (int it = 0; it < 200 && hi - lo > 1e-15 * std::abs(hi); ++it) {
        const double mid = 0.5 * (lo + hi);
        (ratio(mid) > target ? lo : hi) = mid;
      }
      z.half_width = 0.5 * (lo + hi);
    }
  }
  // Peak: p^2 = p0^2 - c s^2 through the first two facet centres (exact for Hertz at centres).
  if (last >= 1) {
    const double s1 = centre(0), s2 = centre(1), q1 = P(0) * P(0), q2 = P(1) * P(1);
    z.peak = std::sqrt(std::max(0.0, (q1 * s2 * s2 - q2 * s1 * s1) / (s2 * s2 - s1 * s1)));
  } else {
    z.peak = P(0);
  }
  return z;
}

}  // namespace ltl
