// Newton's method on ALG2's discrete problem (newton.hpp): the linear system of a step, by the
// augmented Lagrangian (CHOLMOD) or in full by sparse LU, and the glue's terms [LTL87 (2.2)].
// In a distributed Solver both by MUMPS over the MPI ranks (mpi_newton.hpp), or with the global
// step on CG + GAMG the augmented system by GMRES + GAMG over the ranks (newton_krylov.hpp).
#include <Eigen/CholmodSupport>
#include <Eigen/UmfPackSupport>
#include <chrono>

#include "error.hpp"
#include "mpi_comm.hpp"
#include "mpi_newton.hpp"
#include "newton.hpp"
#include "newton_krylov.hpp"

namespace ltl {

namespace {
using Triplets = std::vector<Eigen::Triplet<double>>;
using Factor = Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower>;
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// Calls emit(dof_a, dof_b, v) for the glue's block of the tangent in u, dof numbering d a + i:
///   sum_s |G_s| kappa beta_s^2 (mean_s (x) mean_s) (x) I_dim,
/// the Hessian in u of sum_s |G_s| (kappa/2) beta_s^2 |ubar_s|^2 (2.2).
template <class Emit>
void for_each_glue_uu(const ContactPoints& pts, const Eigen::VectorXd& beta, double kappa, int d,
                      Emit emit) {
  for (int s = 0; s < pts.size(); ++s) {
    const double c = pts.area(s) * kappa * beta(s) * beta(s);
    if (c == 0) continue;
    for (SpMatR::InnerIterator a(pts.mean, s); a; ++a)
      for (SpMatR::InnerIterator b(pts.mean, s); b; ++b)
        for (int i = 0; i < d; ++i)
          emit(d * a.col() + i, d * b.col() + i, c * a.value() * b.value());
  }
}
}  // namespace

// The work of augmented_step kept across Newton iterations: the matrix (pattern_'s), its
// factor (analyzed once), the cells' constraint gradients. In a distributed Solver the factor and
// the LU are MUMPS's over the ranks (mpi_newton.hpp), with the LU's rows.
struct Newton::Scatter {
  SpMat A;
  Factor llt;
  bool analyzed = false;
  std::vector<Eigen::VectorXd> be;  ///< per cell, dG_e/du on the cell's local dofs
  std::unique_ptr<DistributedCholesky> mumps;
  std::unique_ptr<DistributedLU> mumps_lu;
  std::unique_ptr<NewtonRows> lu_rows;
  std::unique_ptr<NewtonKrylov> krylov;  ///< the Krylov solves (Newton's krylov_)
};

// [K, -B^T, C^T; -B, 0, 0; C, 0, 0] (du, dp, dmu) = (-R_u, G, -gap) as in solve_kkt, with
// K + kappa B^T W B + kappa_c C^T Wc C scattered straight into the values of pattern_, or with
// the distributed solves added into PETSc's matrix (DistributedCholesky). On several ranks
// (split_) each adds its cells' terms (with their fluctuation blocks), rank 0 the contact points;
// the damping goes to the owner of each row (PETSc's matrix) or to rank 0 (pattern_, whose values
// are then summed over the ranks: every rank holds the whole matrix). Each multiplier sweep sums
// the cells' part of the right-hand side over the ranks, and each rank updates its cells'
// pressures.
bool Newton::augmented_step(const Unknowns& base, const Eigen::VectorXd& Ru,
                            const Eigen::VectorXd& G, const Eigen::VectorXd& gap,
                            const std::vector<int>& active, double damping, double rtol, Scatter& w,
                            Eigen::VectorXd& dx) const {
  if (w.krylov) return krylov_step(base, Ru, G, gap, active, damping, rtol, w, dx);
  const int d = dim_, nc = disc_.num_cells(), dn = d * npc_;
  const int np = incompressible_ ? nc : 0, npts = static_cast<int>(active.size());
  // Where the terms go: the values of pattern_ (serial, or summed over the ranks afterwards), or
  // PETSc's distributed matrix (w.mumps: each rank adds its terms, mpi_newton.hpp).
  DistributedCholesky* mumps = w.mumps.get();
  if (!mumps && w.A.size() == 0) w.A = pattern_;
  double* A = mumps ? nullptr : w.A.valuePtr();
  if (mumps)
    mumps->zero();
  else
    std::fill(A, A + w.A.nonZeros(), 0.0);
  w.be.resize(np ? cells_.size() : 0);  // the rank's cells: cell e at slot_[e]
  auto fdof = [&](int e, int r) { return free_[d * cell_nodes(e)[r / d] + r % d]; };
  std::vector<int> dofs(dn);
  Eigen::VectorXd diag = Eigen::VectorXd::Zero(nfree_);
  // A cell's block M (dn x dn) into the matrix.
  auto add_cell = [&](int e, const Eigen::MatrixXd& M) {
    if (mumps) {
      for (int r = 0; r < dn; ++r) dofs[r] = fdof(e, r);
      mumps->add(dn, dofs.data(), M.data());
      return;
    }
    const int* pos = &cell_pos_[static_cast<std::size_t>(slot_[e]) * dn * dn];
    for (int r = 0; r < dn; ++r)
      for (int c = 0; c < dn; ++c)
        if (pos[r * dn + c] >= 0) A[pos[r * dn + c]] += M(r, c);
  };
  // The tangent's diagonal (for kappa and the damping), summed as the matrix sums it.
  const CellSink sink = [&](int e, const Eigen::MatrixXd& Ke, const Eigen::VectorXd& be) {
    add_cell(e, Ke);
    for (int r = 0; r < dn; ++r)
      if (fdof(e, r) >= 0) diag(fdof(e, r)) += Ke(r, r);
    if (np) w.be[slot_[e]] = be;
  };
  if (d == 2)
    assemble<2>(base, nullptr, nullptr, nullptr, nullptr, &sink, split_);
  else
    assemble<3>(base, nullptr, nullptr, nullptr, nullptr, &sink, split_);
  const bool lead = !split_ || mpi::rank() == 0;  // adds the terms that are not per cell
  if (split_) mpi::sum(diag.data(), nfree_);
  const double kappa = 1e4 * (nfree_ ? diag.cwiseAbs().mean() : 1.0);
  // The constraint rows: W_e = 1 / |B_e|^2 over the free dofs, their outer products.
  Eigen::VectorXd W = Eigen::VectorXd::Zero(np);
  static const std::vector<int> none;
  const std::vector<int>& own = np ? cells_ : none;  // this rank's cells
  Eigen::MatrixXd bb(dn, dn);
  for (int e : own) {
    double b2 = 0;
    const Eigen::VectorXd& be = w.be[slot_[e]];
    for (int r = 0; r < dn; ++r)
      if (fdof(e, r) >= 0) b2 += be(r) * be(r);
    W(e) = 1 / std::max(b2, 1e-300);
    bb.noalias() = (kappa * W(e)) * be * be.transpose();
    add_cell(e, bb);
  }
  std::vector<int> act;
  Eigen::VectorXd Wc(npts);
  Eigen::MatrixXd cc;
  for (int k = 0; k < npts; ++k) {
    if (!active[k] || point_dofs_[k].empty()) continue;
    act.push_back(k);
    const std::vector<double>& cf = point_coef_[k];
    double c2 = 0;
    for (double v : cf) c2 += v * v;
    Wc(k) = 1 / c2;
    const int m = static_cast<int>(cf.size());
    if (!lead) continue;
    if (mumps) {
      const Eigen::Map<const Eigen::VectorXd> c(cf.data(), m);
      cc.noalias() = (kappa * Wc(k)) * c * c.transpose();
      mumps->add(m, point_dofs_[k].data(), cc.data());
      continue;
    }
    for (int a = 0; a < m; ++a)
      for (int b = 0; b < m; ++b)
        if (point_pos_[k][a * m + b] >= 0)
          A[point_pos_[k][a * m + b]] += kappa * Wc(k) * cf[a] * cf[b];
  }
  if (damping > 0)
    for (int k = 0; k < nfree_; ++k) {
      const double v = damping * std::abs(diag(k));
      if (mumps && mumps->owns(k))
        mumps->add_entry(k, k, v);
      else if (!mumps && lead)
        A[diag_pos_[k]] += v;
    }
  Eigen::VectorXd().swap(diag);  // whole-size: not held through the factorization (as Krylov)
  if (split_ && !mumps) mpi::sum(A, w.A.nonZeros());
  NewtonSolveStats& st = newton_solve_stats();
  auto t0 = std::chrono::steady_clock::now();
  if (mumps) {
    if (!mumps->factorize()) return false;
  } else {
    if (!w.analyzed) {
      w.llt.cholmod().print = 0;  // "not positive definite" is an answer here, not a warning
      w.llt.analyzePattern(w.A);
      w.analyzed = true;
      st.cholmod_factor_nonzeros = w.llt.cholmod().lnz;
      ++st.cholmod_analyses;
      st.cholmod_analysis_s += seconds_since(t0);
      t0 = std::chrono::steady_clock::now();
    }
    w.llt.factorize(w.A);
    ++st.cholmod_factorizations;
    st.cholmod_factor_s += seconds_since(t0);
    if (w.llt.info() != Eigen::Success) return false;
  }
  // The multiplier sweeps: B du = sum over the cell's free dofs, B^T dp scattered back.
  Eigen::VectorXd r1(nfree_), du, rhs(nfree_);
  for (int k = 0; k < static_cast<int>(free_.size()); ++k)
    if (free_[k] >= 0) r1(free_[k]) = -Ru(k);
  Eigen::VectorXd dp = Eigen::VectorXd::Zero(np);
  std::vector<double> dmu(npts, 0.0);
  auto Bdu = [&](int e, const Eigen::VectorXd& v) {
    double s = 0;
    for (int r = 0; r < dn; ++r)
      if (fdof(e, r) >= 0) s += w.be[slot_[e]](r) * v(fdof(e, r));
    return s;
  };
  auto Cdu = [&](int k, const Eigen::VectorXd& v) {
    double s = 0;
    for (std::size_t a = 0; a < point_dofs_[k].size(); ++a)
      s += point_coef_[k][a] * v(point_dofs_[k][a]);
    return s;
  };
  for (int sweep = 0; sweep < 100; ++sweep) {
    // rhs = r1 + B^T (dp - kappa W r2) - C^T (dmu - kappa_c Wc r3), r2 = G, r3 = -gap.
    if (lead)
      rhs = r1;
    else
      rhs.setZero();
    for (int e : own) {
      const double y = dp(e) - kappa * W(e) * G(e);
      for (int r = 0; r < dn; ++r)
        if (fdof(e, r) >= 0) rhs(fdof(e, r)) += w.be[slot_[e]](r) * y;
    }
    if (lead)
      for (int k : act) {
        const double y = dmu[k] - kappa * Wc(k) * (-gap(k));
        for (std::size_t a = 0; a < point_dofs_[k].size(); ++a)
          rhs(point_dofs_[k][a]) -= point_coef_[k][a] * y;
      }
    if (split_) mpi::sum(rhs.data(), nfree_);
    if (w.mumps) {
      w.mumps->solve(rhs, du);
    } else {
      t0 = std::chrono::steady_clock::now();
      du = w.llt.solve(rhs);
      ++st.cholmod_solves;
      st.cholmod_solve_s += seconds_since(t0);
    }
    double worst = 0;
    for (int e : own) {
      const double c1 = Bdu(e, du) + G(e);
      dp(e) -= kappa * W(e) * c1;
      worst = std::max(worst, std::abs(c1) * std::sqrt(W(e)));
    }
    if (split_) mpi::max(&worst, 1);  // the points' part is the same on every rank
    for (int k : act) {
      const double c2 = Cdu(k, du) + gap(k);
      dmu[k] += kappa * Wc(k) * c2;
      worst = std::max(worst, std::abs(c2) * std::sqrt(Wc(k)));
    }
    // Converged when the constraints hold to round-off of the step.
    if (worst <= 1e-13 * std::max(du.cwiseAbs().maxCoeff(), 1e-300)) break;
  }
  if (split_) mpi::sum(dp.data(), np);  // each rank's cells' pressures, zero elsewhere
  if (!du.allFinite()) return false;
  // dx in the layout of the KKT system: du, dp, then the active points' dmu in order.
  int nA = 0;
  for (int k = 0; k < npts; ++k) nA += active[k];
  dx.resize(nfree_ + np + nA);
  dx.head(nfree_) = du;
  dx.segment(nfree_, np) = dp;
  for (int k = 0, a = 0; k < npts; ++k)
    if (active[k]) dx(nfree_ + np + a++) = dmu[k];
  return true;
}

// The system of augmented_step by GMRES (newton_krylov.hpp): A = K + kappa (B^T W B + C^T Wc C)
// with a moderate kappa (the AMG V-cycle must see A; a multiple of K's mean diagonal a, PETSc
// option -ltl_newton_penalty, default 10), the rows scaled by d = a sqrt(W) (forces) and the
// multipliers by 1 / d (lengths). The Schur complement's inverse is -(kappa W + S0^{-1}) / d^2
// with S0 = |O_e| / mu for a cell (the pressure mass over the shear modulus mu = 2 C1, as for the
// divergence: B_e du is the cell's volume change) and C diag(A)^{-1} C^T for a contact point.
bool Newton::krylov_step(const Unknowns& base, const Eigen::VectorXd& Ru, const Eigen::VectorXd& G,
                         const Eigen::VectorXd& gap, const std::vector<int>& active, double damping,
                         double rtol, Scatter& w, Eigen::VectorXd& dx) const {
  const int d = dim_, nc = disc_.num_cells(), dn = d * npc_, ndof = static_cast<int>(free_.size());
  const int np = incompressible_ ? nc : 0, npts = static_cast<int>(active.size());
  // On several ranks (split_) each adds its cells' terms and holds their constraint rows; the
  // lead (rank 0) adds the contact points' and holds their rows (as augmented_step does); a term
  // every rank knows (the residual, the damping) goes in by the rank that owns its row.
  const bool lead = !split_ || mpi::rank() == 0;
  NewtonKrylov& kr = *w.krylov;
  const auto t0 = std::chrono::steady_clock::now();
  kr.zero();
  w.be.resize(np ? cells_.size() : 0);  // the rank's cells: cell e at slot_[e]
  Eigen::VectorXd diag = Eigen::VectorXd::Zero(ndof);
  std::vector<int> dofs(dn);
  auto cell_dofs = [&](int e) {
    for (int r = 0; r < dn; ++r) {
      const int k = d * cell_nodes(e)[r / d] + r % d;
      dofs[r] = free_[k] >= 0 ? k : -1;
    }
  };
  const CellSink sink = [&](int e, const Eigen::MatrixXd& Ke, const Eigen::VectorXd& be) {
    cell_dofs(e);
    kr.add(dn, dofs.data(), Ke.data());  // symmetric: its storage order does not matter
    for (int r = 0; r < dn; ++r)
      if (dofs[r] >= 0) diag(dofs[r]) += Ke(r, r);
    if (np) w.be[slot_[e]] = be;
  };
  if (d == 2)
    assemble<2>(base, nullptr, nullptr, nullptr, nullptr, &sink, split_);
  else
    assemble<3>(base, nullptr, nullptr, nullptr, nullptr, &sink, split_);
  if (split_) mpi::sum(diag.data(), ndof);  // the tangent's diagonal, as the matrix sums it
  double a = 0;
  for (int k = 0; k < ndof; ++k)
    if (free_[k] >= 0) a += std::abs(diag(k));
  a = nfree_ ? a / nfree_ : 1.0;
  const double kappa = NewtonKrylov::option("-ltl_newton_penalty", 10.0) * a;
  const double mu = 2 * disc_.split().C1;
  const Eigen::VectorXd& vol = volumes();
  // The constraint rows of this rank, scaled, and their part of A and of the right-hand side:
  // its cells', then (the lead) the active contact points'.
  static const std::vector<int> none;
  const std::vector<int>& own = np ? cells_ : none;
  std::vector<int> act;
  if (lead)
    for (int k = 0; k < npts; ++k)
      if (active[k] && !point_dofs_[k].empty()) act.push_back(k);
  const int no = static_cast<int>(own.size()), m = no + static_cast<int>(act.size());
  Eigen::VectorXd f = Eigen::VectorXd::Zero(ndof), g(m), sinv(m), scale(m);
  for (int k = 0; k < ndof; ++k)
    if (free_[k] >= 0 && kr.owns(k)) f(k) = -Ru(k);
  std::vector<Eigen::Triplet<double>> tg;
  tg.reserve(static_cast<std::size_t>(no) * dn);
  Eigen::MatrixXd blk(dn, dn);
  for (int i = 0; i < no; ++i) {
    const int e = own[i];
    cell_dofs(e);
    const Eigen::VectorXd& be = w.be[slot_[e]];
    double b2 = 0;
    for (int r = 0; r < dn; ++r)
      if (dofs[r] >= 0) b2 += be(r) * be(r);
    const double W = 1 / std::max(b2, 1e-300);
    blk.noalias() = (kappa * W) * be * be.transpose();
    kr.add(dn, dofs.data(), blk.data());
    scale(i) = a * std::sqrt(W);
    for (int r = 0; r < dn; ++r)
      if (dofs[r] >= 0) {
        tg.emplace_back(i, dofs[r], -scale(i) * be(r));
        f(dofs[r]) -= kappa * W * G(e) * be(r);
      }
    g(i) = scale(i) * G(e);
    sinv(i) = -(kappa * W + mu / vol(e)) / (scale(i) * scale(i));
  }
  std::vector<int> pd;  // a point's dofs and block, reused
  Eigen::MatrixXd pb;
  for (int j = 0; j < static_cast<int>(act.size()); ++j) {
    const int k = act[j], row = no + j;
    const std::vector<double>& cf = point_coef_[k];
    const int n = static_cast<int>(cf.size());
    pd.resize(n);
    pb.resize(n, n);
    double c2 = 0, s0 = 0;
    for (int q = 0; q < n; ++q) {
      pd[q] = dof_of_free_[point_dofs_[k][q]];
      c2 += cf[q] * cf[q];
      s0 += cf[q] * cf[q] / std::max(std::abs(diag(pd[q])), 1e-300);
    }
    const double Wc = 1 / c2;
    for (int p = 0; p < n; ++p)
      for (int q = 0; q < n; ++q) pb(p, q) = kappa * Wc * cf[p] * cf[q];
    kr.add(n, pd.data(), pb.data());
    scale(row) = a * std::sqrt(Wc);
    for (int q = 0; q < n; ++q) {
      tg.emplace_back(row, pd[q], scale(row) * cf[q]);
      f(pd[q]) -= kappa * Wc * gap(k) * cf[q];
    }
    g(row) = -scale(row) * gap(k);
    sinv(row) = -(kappa * Wc + 1 / s0) / (scale(row) * scale(row));
  }
  if (damping > 0)
    for (int k = 0; k < ndof; ++k)
      if (free_[k] >= 0 && kr.owns(k)) {
        const double v = damping * std::abs(diag(k));
        kr.add_row(k, 1, &k, &v);
      }
  kr.finish(a);
  Eigen::VectorXd().swap(diag);  // whole-size: not held through the solve
  SpMatR Gs(m, ndof);
  Gs.setFromTriplets(tg.begin(), tg.end());
  std::vector<Eigen::Triplet<double>>().swap(tg);
  NewtonSolveStats& st = newton_solve_stats();
  st.krylov_setup_s += seconds_since(t0);  // the assembly, and below the AMG set-up
  Eigen::VectorXd du, dq;
  const NewtonKrylov::Result r = kr.solve(Gs, sinv, std::move(f), g, rtol, du, dq);
  ++st.krylov_solves;
  st.krylov_rows = kr.rows();
  st.krylov_constraint_rows = m;
  st.krylov_nonzeros = kr.matrix_nonzeros();
  st.krylov_iterations += r.iterations;
  st.krylov_max_iterations = std::max<long>(st.krylov_max_iterations, r.iterations);
  st.krylov_setup_s += r.setup_seconds;
  st.krylov_solve_s += r.solve_seconds;
  // The same verdict on every rank (the solve's is; a non-finite value may be one rank's).
  double bad = !r.converged || !du.allFinite() || !dq.allFinite();
  if (split_) mpi::max(&bad, 1);
  if (bad > 0) {
    ++st.krylov_failures;
    return false;
  }
  int nA = 0;
  for (int k = 0; k < npts; ++k) nA += active[k];
  dx = Eigen::VectorXd::Zero(nfree_ + np + nA);
  for (int k = 0; k < ndof; ++k)
    if (free_[k] >= 0) dx(free_[k]) = du(k);
  for (int i = 0; i < no; ++i) dx(nfree_ + own[i]) = scale(i) * dq(i);
  for (int k = 0, i = 0, j = 0; k < npts; ++k) {
    if (!active[k]) continue;
    if (j < static_cast<int>(act.size()) && act[j] == k) {
      dx(nfree_ + np + i) = scale(no + j) * dq(no + j);
      ++j;
    }
    ++i;
  }
  // The multipliers: each rank's rows, summed (every other rank's entries are 0 here).
  if (split_) mpi::sum(dx.data() + nfree_, np + nA);
  return true;
}

void Newton::ScatterDeleter::operator()(Scatter* w) const {
  delete w;
}
Newton::ScatterPtr Newton::new_scatter() const {
  ScatterPtr w(new Scatter);
  const bool over_ranks = distributed_ && distributed_newton_solves();  // mpi_newton.hpp
  if (over_ranks && !krylov_)
    w->mumps = std::make_unique<DistributedCholesky>(NewtonRows(free_, dim_, node_rank_, 0), dim_,
                                                     disc_.problem().mesh.cells, free_);
  if (over_ranks) w->mumps_lu = std::make_unique<DistributedLU>();  // glued or indefinite steps
  if (krylov_) {  // over the ranks: the rows of node_rank_, this rank's cells (newton_krylov.hpp)
    std::vector<char> fixed(free_.size());
    for (std::size_t k = 0; k < free_.size(); ++k) fixed[k] = free_[k] < 0;
    w->krylov =
        std::make_unique<NewtonKrylov>(dim_, disc_.problem().mesh.X, disc_.problem().mesh.cells,
                                       fixed, over_ranks ? &node_rank_ : nullptr);
  }
  return w;
}

void Newton::set_glue(const ContactSteps& steps, const Eigen::VectorXd& beta_prev) {
  glued_ = steps.glued();
  if (!glued_) return;
  if (steps.size() != 1)
    throw Error("Newton: glue on one of several obstacles (refused by Problem::validate)");
  const ContactStep& contact = steps[0];
  const Adhesion& ad = contact.adhesion();
  const int np = disc_.points()->size();
  glue_.kappa = ad.kappa, glue_.w = ad.w, glue_.dt = ad.dt;
  if (glue_.k.rows() != np) glue_.k = contact.kernel();
  glue_.beta_prev = beta_prev;
  // The scale of the box NCP: the beta-stiffness of the dissipation and the Dupre energy, or
  // (neither) that of the glue's spring at a thousandth of the mesh size.
  const double h = std::pow(disc_.volume() / disc_.num_cells(), 1.0 / dim_);
  glue_.a.resize(np);
  for (int s = 0; s < np; ++s) {
    glue_.a(s) = glue_.w + glue_.k.coeff(s, s) / glue_.dt;
    if (!(glue_.a(s) > 0)) glue_.a(s) = 1e-6 * glue_.kappa * h * h;
  }
}

// [(2.2), (6.1)-(6.5)] g_s = kappa beta_s |ubar_s|^2 - w + (1/dt) sum_s' k_ss' (beta_s' - bp_s').
Eigen::VectorXd Newton::glue_gradient(const Unknowns& x) const {
  if (!glued_) return Eigen::VectorXd();
  const Eigen::MatrixXd ubar = disc_.points()->mean * x.u;  // #points x dim
  return glue_.kappa * x.beta.cwiseProduct(ubar.rowwise().squaredNorm()) -
         Eigen::VectorXd::Constant(x.beta.size(), glue_.w) +
         glue_.k * (x.beta - glue_.beta_prev) / glue_.dt;
}

void Newton::add_glue_kkt(const Unknowns& x, const std::vector<int>& bstate, int ob, Triplets& kkt,
                          Eigen::VectorXd& rhs) const {
  const ContactPoints& pts = *disc_.points();
  const int d = dim_, np = pts.size();
  for_each_glue_uu(pts, x.beta, glue_.kappa, d, [&](int r, int c, double v) {
    if (free_[r] >= 0 && free_[c] >= 0) kkt.emplace_back(free_[r], free_[c], v);
  });
  const Eigen::MatrixXd ubar = pts.mean * x.u;
  const Eigen::VectorXd g = glue_gradient(x);
  for (int s = 0; s < np; ++s) {
    // d(force on u)/d beta_s = 2 |G_s| kappa beta_s ubar_s (x) mean_s; the free beta's row is
    // |G_s| dg_s, its transpose in u (the Hessian of (2.2) in (u, beta) is symmetric).
    const double c = 2 * pts.area(s) * glue_.kappa * x.beta(s);
    for (SpMatR::InnerIterator a(pts.mean, s); a; ++a)
      for (int i = 0; i < d; ++i) {
        const int f = free_[d * a.col() + i];
        if (f < 0) continue;
        const double v = c * ubar(s, i) * a.value();
        kkt.emplace_back(f, ob + s, v);
        if (bstate[s] == 0) kkt.emplace_back(ob + s, f, v);
      }
    if (bstate[s] != 0) {  // at its bound: d beta_s = 0 (base holds the bound)
      kkt.emplace_back(ob + s, ob + s, 1.0);
      rhs(ob + s) = 0;
      continue;
    }
    kkt.emplace_back(ob + s, ob + s, pts.area(s) * glue_.kappa * ubar.row(s).squaredNorm());
    rhs(ob + s) = -pts.area(s) * g(s);
  }
  // (|G_s| / dt) k_ss' on the free betas' rows: k is stored by columns, so walk them.
  for (int c = 0; c < np; ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator k(glue_.k, c); k; ++k)
      if (bstate[k.row()] == 0)
        kkt.emplace_back(ob + k.row(), ob + c, pts.area(k.row()) * k.value() / glue_.dt);
}

// [K, -B^T, C_A^T, Kub; -B, 0, 0, 0; C_A, 0, 0, 0; Kbu, 0, 0, Kbb] (du, dp, dmu_A, dbeta) =
// (-R_u, G, g_A - N . ubar_A, -|G| g) with the rows of the betas at a bound replaced by
// dbeta_s = 0.
bool Newton::lu_step(const Unknowns& base, const Eigen::VectorXd& Ru, const Eigen::VectorXd& G,
                     const Eigen::VectorXd& gap, const std::vector<int>& active,
                     const std::vector<int>& bstate, double damping, Scatter& w,
                     Eigen::VectorXd& dx) const {
  const int d = dim_, np_ = incompressible_ ? disc_.num_cells() : 0;
  const ContactPoints* pts = disc_.points();
  const int npts = static_cast<int>(active.size());
  int nA = 0;
  for (int a : active) nA += a;
  const int nb = glued_ ? npts : 0;
  const int n = nfree_ + np_ + nA + nb;
  Triplets t, tb;
  if (d == 2)
    assemble<2>(base, nullptr, nullptr, &t, &tb, nullptr, split_);
  else
    assemble<3>(base, nullptr, nullptr, &t, &tb, nullptr, split_);
  gather_triplets(t);  // on several ranks every rank's cells: the system is whole on every rank
  gather_triplets(tb);
  Triplets kkt;
  kkt.reserve(t.size() + 2 * tb.size() + 2 * d * nA);
  Eigen::VectorXd diag = Eigen::VectorXd::Zero(nfree_);
  for (const auto& e : t)
    if (free_[e.row()] >= 0 && free_[e.col()] >= 0) {
      kkt.emplace_back(free_[e.row()], free_[e.col()], e.value());
      if (e.row() == e.col()) diag(free_[e.row()]) += e.value();
    }
  // Levenberg-Marquardt damping of the u block (0: Newton's step), see Newton::solve.
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
    const Eigen::MatrixXd& N = pts->normals;  // row k: N_k of the obstacle of point k
    for (int k = 0, a = 0; k < npts; ++k) {
      if (!active[k]) continue;
      const int r = nfree_ + np_ + a++;
      bool any = false;
      for (SpMatR::InnerIterator i(pts->mean, k); i; ++i)
        for (int j = 0; j < d; ++j)
          if (free_[d * i.col() + j] >= 0 && N(k, j) != 0) {
            kkt.emplace_back(free_[d * i.col() + j], r, i.value() * N(k, j));
            kkt.emplace_back(r, free_[d * i.col() + j], i.value() * N(k, j));
            any = true;
          }
      if (any)
        rhs(r) = -gap(k);
      else
        kkt.emplace_back(r, r, 1.0);  // a point whose normal motion is prescribed: mu stays
    }
  }
  if (nb) add_glue_kkt(base, bstate, nfree_ + np_ + nA, kkt, rhs);
  SpMat A(n, n);
  A.setFromTriplets(kkt.begin(), kkt.end());
  if (w.mumps_lu) {  // the u rows on their nodes' ranks, the others in blocks (mpi_newton.hpp)
    if (!w.lu_rows || static_cast<int>(w.lu_rows->perm.size()) != n)
      w.lu_rows = std::make_unique<NewtonRows>(free_, d, node_rank_, n - nfree_);
    return w.mumps_lu->solve(A, *w.lu_rows, rhs, dx);
  }
  const auto t0 = std::chrono::steady_clock::now();
  Eigen::UmfPackLU<SpMat> lu;
  lu.compute(A);
  ++newton_solve_stats().umfpack_factorizations;
  if (lu.info() != Eigen::Success) return false;
  dx = lu.solve(rhs);
  newton_solve_stats().umfpack_s += seconds_since(t0);
  return dx.allFinite();
}

// The glue's share of residual() and tangent() (newton.cpp).
void Newton::add_glue_force(const Unknowns& x, Eigen::VectorXd& Ru) const {
  if (!glued_) return;
  const ContactPoints& pts = *disc_.points();
  const Eigen::MatrixXd ubar = pts.mean * x.u;
  for (int s = 0; s < pts.size(); ++s) {
    const double c = pts.area(s) * glue_.kappa * x.beta(s) * x.beta(s);
    for (SpMatR::InnerIterator a(pts.mean, s); a; ++a)
      for (int i = 0; i < dim_; ++i) Ru(dim_ * a.col() + i) += c * a.value() * ubar(s, i);
  }
}

void Newton::add_glue_tangent(const Unknowns& x, Triplets& t) const {
  if (!glued_) return;
  for_each_glue_uu(*disc_.points(), x.beta, glue_.kappa, dim_,
                   [&](int r, int c, double v) { t.emplace_back(r, c, v); });
}

}  // namespace ltl
