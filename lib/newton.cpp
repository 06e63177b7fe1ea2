// Newton's method on ALG2's discrete problem (newton.hpp).
#include "newton.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "cofactor.hpp"
#include "error.hpp"
#include "mpi_comm.hpp"
#include "mpi_global.hpp"
#include "mpi_newton.hpp"

namespace ltl {

namespace {
using Triplets = std::vector<Eigen::Triplet<double>>;
template <int d>
using Mat = Eigen::Matrix<double, d, d>;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

Newton::Newton(const Discretization& disc, bool krylov, const mpi::Partition* cells)
    : disc_(disc), distributed_(cells != nullptr), krylov_(krylov) {
  const Mesh& mesh = disc.problem().mesh;
  dim_ = disc.dim();
  const int d = dim_, nc = disc.num_cells(), nn = disc.num_nodes();
  npc_ = static_cast<int>(mesh.cells.cols());
  split_ = distributed_ && mpi::size() > 1;
  incompressible_ = disc.split().incompressible();
  free_.assign(static_cast<std::size_t>(d) * nn, 0);
  for (int i = 0; i < d; ++i)
    for (int a : disc.dirichlet().fixed[i]) free_[d * a + i] = -1;
  for (int& f : free_)
    if (f >= 0) f = nfree_++;
  // This rank's cells: its cells of the Solver's partition (ALG2's cells), every cell on one
  // process; the per-cell data below is built for them. With the distributed solves a node's
  // rows are on the rank of node_ranks, the smallest among its cells' ranks (the global step's
  // rows): a cell's terms land in its rank's rows but at the interfaces of the parts, whose
  // nodes are on the other side's rows or its own.
  if (cells && (cells->offset.size() != static_cast<std::size_t>(mpi::size()) + 1 ||
                static_cast<int>(cells->order.size()) != nc))
    throw Error(cat("Newton: a partition of ", cells->order.size(), " cells into ",
                    cells->offset.size() - 1, " parts for ", nc, " cells on ", mpi::size(),
                    " ranks"));
  if (split_) {
    cells_ = cells->items(mpi::rank());
  } else {
    cells_.resize(nc);
    for (int e = 0; e < nc; ++e) cells_[e] = e;
  }
  if (distributed_ && distributed_newton_solves()) node_rank_ = node_ranks(mesh, *cells);
  if (disc.partial()) whole_vol_ = cell_volumes(mesh);
  slot_.assign(nc, -1);
  for (std::size_t k = 0; k < cells_.size(); ++k) slot_[cells_[k]] = static_cast<int>(k);
  nodes_.resize(cells_.size() * npc_);
  for (std::size_t k = 0; k < cells_.size(); ++k)
    for (int a = 0; a < npc_; ++a) nodes_[k * npc_ + a] = mesh.cells(cells_[k], a);
  // Per cell of this rank, from the sums of cell_integrals (fe.cpp), from which the
  // discretization's cell operators are built too: the mean
  // gradient gbar_e = (1 / |O_e|) sum_q w_q grad_q, the constraint points (mean-det: the
  // quadrature points; det-mean: gbar_e with weight |O_e|), and the fluctuation block
  // 2 C1 (L_e - |O_e| gbar_e gbar_e^T) with L_e = sum_q w_q grad_q grad_q^T.
  const double C1 = disc.split().C1;
  const bool mean_det = incompressible_ && disc.mean_det();
  const int n = npc_;
  gbar_.reserve(cells_.size());
  lf_.resize(cells_.size() * n * n);
  nq_ = incompressible_ && !mean_det ? 1 : 0;
  Eigen::MatrixXd gint, Le;
  for (std::size_t k = 0; k < cells_.size(); ++k) {
    const int e = cells_[k];
    const double vol = cell_integrals(mesh, e, gint, Le);
    gbar_.push_back((1.0 / vol) * gint);
    Eigen::Map<Eigen::MatrixXd>(&lf_[k * n * n], n, n) =
        2 * C1 * (Le - gint * gbar_.back().transpose());
    if (mean_det) {
      int q = 0;
      for_each_quadrature_point(mesh, e, [&](const Eigen::MatrixXd& grad, double w) {
        gq_.push_back(grad), wq_.push_back(w), ++q;
      });
      nq_ = q;
    } else if (incompressible_) {
      gq_.push_back(gbar_.back()), wq_.push_back(vol);
    }
  }

  if (const ContactPoints* pts = disc.points()) {
    const double h = std::pow(disc.volume() / nc, 1.0 / d);
    c_ = 0.02 * C1 * pts->area / h;
  }

  // The contact points' free dofs and their coefficients in N . ubar_s.
  if (const ContactPoints* pts = disc.points()) {
    const Eigen::MatrixXd& N = pts->normals;  // row k: N_k of the obstacle of point k
    const int np = pts->size();
    point_dofs_.resize(np), point_coef_.resize(np), point_pos_.resize(np);
    for (int k = 0; k < np; ++k)
      for (SpMatR::InnerIterator it(pts->mean, k); it; ++it)
        for (int j = 0; j < d; ++j)
          if (free_[d * it.col() + j] >= 0 && N(k, j) != 0) {
            point_dofs_[k].push_back(free_[d * it.col() + j]);
            point_coef_[k].push_back(it.value() * N(k, j));
          }
  }
  if (krylov_) {  // PETSc's matrix holds its own pattern (newton_krylov.hpp)
    dof_of_free_.resize(nfree_);
    for (int k = 0; k < static_cast<int>(free_.size()); ++k)
      if (free_[k] >= 0) dof_of_free_[free_[k]] = k;
    return;
  }
  // Distributed solves: PETSc's matrix holds the pattern, each rank its rows (mpi_newton.hpp).
  if (distributed_ && distributed_newton_solves()) return;
  // The pattern of the augmented tangent: every pair of free dofs of a cell (lower triangle), the
  // diagonal; the constraint rows (cells, contact points) and the fluctuation term stay inside.
  const int dn = d * npc_;
  Triplets tp;
  for (int k = 0; k < nfree_; ++k) tp.emplace_back(k, k, 0.0);
  // Every cell (the replicated solves on several ranks hold the whole pattern): the mesh's.
  auto fdof = [&](int e, int r) { return free_[d * mesh.cells(e, r / d) + r % d]; };
  for (int e = 0; e < nc; ++e)
    for (int r = 0; r < dn; ++r)
      for (int c = 0; c < dn; ++c)
        if (fdof(e, r) >= 0 && fdof(e, c) >= 0 && fdof(e, r) >= fdof(e, c))
          tp.emplace_back(fdof(e, r), fdof(e, c), 0.0);
  pattern_.resize(nfree_, nfree_);
  pattern_.setFromTriplets(tp.begin(), tp.end());
  pattern_.makeCompressed();
  auto position = [&](int row, int col) {  // of (row, col), row >= col, in pattern_'s values
    const int* begin = pattern_.innerIndexPtr() + pattern_.outerIndexPtr()[col];
    const int* end = pattern_.innerIndexPtr() + pattern_.outerIndexPtr()[col + 1];
    const int* it = std::lower_bound(begin, end, row);
    if (it == end || *it != row) throw Error("Newton: an entry outside the tangent's pattern");
    return static_cast<int>(it - pattern_.innerIndexPtr());
  };
  cell_pos_.assign(cells_.size() * dn * dn, -1);
  for (int e : cells_)
    for (int r = 0; r < dn; ++r)
      for (int c = 0; c < dn; ++c)
        if (fdof(e, r) >= 0 && fdof(e, c) >= 0 && fdof(e, r) >= fdof(e, c))
          cell_pos_[(static_cast<std::size_t>(slot_[e]) * dn + r) * dn + c] =
              position(fdof(e, r), fdof(e, c));
  diag_pos_.resize(nfree_);
  for (int k = 0; k < nfree_; ++k) diag_pos_[k] = position(k, k);
  for (std::size_t k = 0; k < point_dofs_.size(); ++k)
    for (int a : point_dofs_[k])
      for (int b : point_dofs_[k]) point_pos_[k].push_back(a >= b ? position(a, b) : -1);
}

Newton::Holdings Newton::holdings() const {
  Holdings h;
  h.cells = static_cast<int>(cells_.size());
  for (const Eigen::MatrixXd& g : gbar_) h.cell_data += 8.0 * g.size();
  for (const Eigen::MatrixXd& g : gq_) h.cell_data += 8.0 * g.size();
  h.cell_data += 8.0 * (wq_.size() + lf_.size()) + 4.0 * nodes_.size();
  h.positions = 4.0 * cell_pos_.size();
  auto sparse = [](const SpMat& A) { return 12.0 * A.nonZeros() + 4.0 * (A.outerSize() + 1); };
  h.whole = 4.0 * (free_.size() + node_rank_.size() + diag_pos_.size() + dof_of_free_.size()) +
            sparse(pattern_) + 8.0 * whole_vol_.size();
  return h;
}

void Newton::gather_triplets(Triplets& t) const {
  if (!split_) return;
  const int P = mpi::size(), me = mpi::rank();
  std::vector<double> count(P, 0.0);
  count[me] = static_cast<double>(t.size());
  mpi::sum(count.data(), P);
  std::vector<int> offset(P + 1, 0);  // 3 values per triplet: row, column, value
  for (int r = 0; r < P; ++r) offset[r + 1] = offset[r] + 3 * static_cast<int>(count[r]);
  std::vector<double> all(offset[P]);
  double* mine = all.data() + offset[me];
  for (const Eigen::Triplet<double>& e : t) {
    *mine++ = e.row(), *mine++ = e.col(), *mine++ = e.value();
  }
  mpi::gather(all.data(), offset);
  t.clear();
  t.reserve(offset[P] / 3);
  for (int k = 0; k < offset[P]; k += 3)
    t.emplace_back(static_cast<int>(all[k]), static_cast<int>(all[k + 1]), all[k + 2]);
}

bool Newton::on_rows(const State& s) const {
  return split_ && s.E.rows() == dim_ * static_cast<Eigen::Index>(cells_.size());
}

Newton::Unknowns Newton::unknowns(const State& s) const {
  const int nc = disc_.num_cells();
  Unknowns x;
  x.u = s.u;
  const Material& m = disc_.split();
  if (incompressible_) {  // the rank's cells' pressures (every cell on one rank), then summed
    const bool rows = on_rows(s);
    x.p = Eigen::VectorXd::Zero(nc);
    for (std::size_t k = 0; k < cells_.size(); ++k) {
      const int e = cells_[k], at = rows ? static_cast<int>(k) : e;
      x.p(e) = m.pressure(cell_tensor(s.E, at), cell_tensor(s.lambda, at));
    }
    if (split_) mpi::sum(x.p.data(), nc);
  }
  if (const ContactPoints* pts = disc_.points()) {
    Eigen::MatrixXd lc = s.lambda_c;  // #points x dim; with glue, less the glue's force
    if (glued_) {
      x.beta = s.beta;
      for (int k = 0; k < pts->size(); ++k)
        lc.row(k) += glue_.kappa * s.beta(k) * s.beta(k) * s.e.row(k);
    }
    // mu_s = |G_s| max(0, -lambda_c_s . N_k): the force of point s's obstacle k.
    x.mu = pts->area.cwiseProduct((-disc_.normal_component(lc)).cwiseMax(0.0));
  }
  return x;
}

std::optional<State> Newton::current_state(const State& form) const {
  if (!current_) return std::nullopt;
  std::optional<State> s = form;  // the shapes; every field is overwritten but beta (no glue)
  to_state(*current_, *s);
  return s;
}

void Newton::to_state(const Unknowns& x, State& s) const {
  const int d = dim_;
  const Material& m = disc_.split();
  s.u = x.u;
  // E = Fbar = I + Gbar_e u on this rank's cells. Given on the rank's rows (on_rows), E and lambda
  // stay there; whole on several ranks, the others' cells are theirs: zero here, then the sum
  // over the ranks makes E and lambda whole on every rank.
  const bool rows = on_rows(s);
  if (split_ && !rows) s.E.setZero(), s.lambda.setZero();
  Eigen::MatrixXd ue(npc_, d);
  for (std::size_t k = 0; k < cells_.size(); ++k) {
    const int e = cells_[k], at = rows ? static_cast<int>(k) : e;
    for (int a = 0; a < npc_; ++a) ue.row(a) = x.u.row(nodes_[k * npc_ + a]);
    Eigen::MatrixXd F = ue.transpose() * gbar_[k];
    F.diagonal().array() += 1.0;
    const Eigen::MatrixXd L = m.multiplier(F, incompressible_ ? x.p(e) : 0.0);
    s.E.block(d * at, 0, d, d) = F.transpose();
    s.lambda.block(d * at, 0, d, d) = L.transpose();
  }
  if (split_ && !rows) {
    mpi::sum(s.E.data(), s.E.size());
    mpi::sum(s.lambda.data(), s.lambda.size());
  }
  if (const ContactPoints* pts = disc_.points()) {
    s.e = pts->mean * x.u;
    for (int k = 0; k < pts->size(); ++k)
      s.lambda_c.row(k) = -(x.mu(k) / pts->area(k)) * pts->normals.row(k);
    if (glued_) {
      s.beta = x.beta;
      for (int k = 0; k < pts->size(); ++k)
        s.lambda_c.row(k) -= glue_.kappa * x.beta(k) * x.beta(k) * s.e.row(k);
    }
  }
}

// [(2.2), (2.7)] Per cell: the energy at the mean gradient, vol dW(Fbar) : Gbar v, with its
// Hessian; the constraint G_e = sum_k w_k det F_k - |O_e| with its gradient
// sum_k w_k cof F_k : grad v and, times -p_e, its Hessian sum_k w_k dcof F_k[grad du] : grad v.
template <int d>
void Newton::assemble(const Unknowns& x, Eigen::VectorXd* Ru, Eigen::VectorXd* G, Triplets* K,
                      Triplets* B, const CellSink* on_cell, bool own) const {
  const int n = npc_, nce = own ? static_cast<int>(cells_.size()) : disc_.num_cells();
  if (!own && split_) throw Error("Newton: the cells of another rank (their data is theirs)");
  const Material& m = disc_.split();
  const Eigen::VectorXd& vol = volumes();
  Eigen::MatrixXd ue(n, d), fe(n, d), Ke(d * n, d * n);
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
  for (int k = 0; k < nce; ++k) {
    const int e = cells_[k];  // the slot of cell e is k
    const int* nodes = &nodes_[static_cast<std::size_t>(k) * n];
    for (int a = 0; a < n; ++a) ue.row(a) = x.u.row(nodes[a]);
    const Eigen::MatrixXd& gb = gbar_[k];
    const Eigen::Map<const Eigen::MatrixXd> lf(&lf_[static_cast<std::size_t>(k) * n * n], n, n);
    Mat<d> F = Mat<d>::Identity() + ue.transpose() * gb;
    if (Ru) {
      add_row(m.dW(F), gb, vol(e), *Ru, nodes);
      // The fluctuation's force lf ue on each component (the quadratic C1 |grad u - Gbar u|^2).
      fe.noalias() = lf * ue;
      for (int a = 0; a < n; ++a)
        for (int i = 0; i < d; ++i) (*Ru)(d * nodes[a] + i) += fe(a, i);
    }
    if (K || on_cell) {
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
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b)
          for (int i = 0; i < d; ++i) Ke(d * a + i, d * b + i) += lf(a, b);
    }
    if (incompressible_) {
      double Ge = -vol(e);
      be.setZero();
      const double p = x.p.size() ? x.p(e) : 0.0;
      for (int q = nq_ * k; q < nq_ * (k + 1); ++q) {
        const Eigen::MatrixXd& g = gq_[q];
        const double w = wq_[q];
        const Mat<d> Fq = Mat<d>::Identity() + ue.transpose() * g;
        Ge += w * Fq.determinant();
        add_row(cofactor<d>(Fq), g, w, be, nullptr);
        if ((K || on_cell) && p != 0) {
          for (int k = 0; k < d; ++k)
            for (int l = 0; l < d; ++l) {
              Mat<d> H = Mat<d>::Zero();
              H(k, l) = 1;
              const Mat<d> dC = cofactor_derivative<d>(Fq, H);
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
    if (on_cell) (*on_cell)(e, Ke, be);
  }
}

void Newton::residual(const Unknowns& x, const Eigen::MatrixXd& f, Eigen::VectorXd& Ru,
                      Eigen::VectorXd& G, double load_factor) const {
  const int d = dim_, nn = disc_.num_nodes();
  Ru.setZero(d * nn);
  G.setZero(incompressible_ ? disc_.num_cells() : 0);
  // On several ranks each sums its cells, then the sums are summed (the terms below are whole).
  if (d == 2)
    assemble<2>(x, &Ru, &G, nullptr, nullptr, nullptr, split_);
  else
    assemble<3>(x, &Ru, &G, nullptr, nullptr, nullptr, split_);
  if (split_) {
    mpi::sum(Ru.data(), Ru.size());
    mpi::sum(G.data(), G.size());
  }
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < d; ++i) Ru(d * a + i) -= load_factor * f(a, i);
  // The contact forces: mu_s N (x) mean_s, the reaction of the plane (1.1).
  if (const ContactPoints* pts = disc_.points()) {
    const Eigen::MatrixXd& N = pts->normals;  // row s: N_k of the obstacle of point s
    for (int s = 0; s < pts->size(); ++s)
      for (SpMatR::InnerIterator it(pts->mean, s); it; ++it)
        for (int i = 0; i < d; ++i) Ru(d * it.col() + i) += x.mu(s) * it.value() * N(s, i);
  }
  add_glue_force(x, Ru);
}

Eigen::SparseMatrix<double> Newton::tangent(const Unknowns& x) const {
  Triplets t;
  if (dim_ == 2)
    assemble<2>(x, nullptr, nullptr, &t, nullptr, nullptr, split_);
  else
    assemble<3>(x, nullptr, nullptr, &t, nullptr, nullptr, split_);
  gather_triplets(t);
  add_glue_tangent(x, t);
  const int ndof = dim_ * disc_.num_nodes();
  SpMat K(ndof, ndof);
  K.setFromTriplets(t.begin(), t.end());
  return K;
}

Eigen::SparseMatrix<double> Newton::constraint_gradient(const Eigen::MatrixXd& u) const {
  Triplets t;
  Unknowns x;
  x.u = u;
  if (dim_ == 2)
    assemble<2>(x, nullptr, nullptr, nullptr, &t, nullptr, split_);
  else
    assemble<3>(x, nullptr, nullptr, nullptr, &t, nullptr, split_);
  gather_triplets(t);
  SpMat B(incompressible_ ? disc_.num_cells() : 0, dim_ * disc_.num_nodes());
  B.setFromTriplets(t.begin(), t.end());
  return B;
}

template <int d>
double Newton::min_det(const Eigen::MatrixXd& u) const {
  const int n = npc_;
  double m = std::numeric_limits<double>::infinity();
  // F = I + sum_a u_a (x) g_a for a gradient table g (n x d), without temporaries.
  auto det_F = [&](const int* nodes, const Eigen::MatrixXd& g) {
    Mat<d> F = Mat<d>::Identity();
    for (int a = 0; a < n; ++a)
      for (int i = 0; i < d; ++i)
        for (int j = 0; j < d; ++j) F(i, j) += u(nodes[a], i) * g(a, j);
    return F.determinant();
  };
  for (std::size_t k = 0; k < cells_.size(); ++k) {  // the rank's cells (all on one rank)
    const int* nodes = &nodes_[k * n];
    m = std::min(m, det_F(nodes, gbar_[k]));
    for (int q = nq_ * static_cast<int>(k); q < nq_ * static_cast<int>(k + 1); ++q)
      m = std::min(m, det_F(nodes, gq_[q]));
  }
  if (split_) {  // the smallest over the ranks
    double v = -m;
    mpi::max(&v, 1);
    m = -v;
  }
  return m;
}

Newton::Result Newton::solve(State& s, const Eigen::MatrixXd& f, double load_factor,
                             const AlgorithmParams& alg, StepReport& report,
                             const std::function<void(const IterationRecord&)>& progress) const {
  using clock_type = std::chrono::steady_clock;
  const auto t_start = clock_type::now();
  const int d = dim_, nc = disc_.num_cells();
  const ContactPoints* pts = disc_.points();
  const int np = pts ? pts->size() : 0;
  const Eigen::VectorXd& vol = volumes();
  Result result;
  const double wall0 = report.history.empty() ? 0.0 : report.history.back().wall;
  Unknowns x = unknowns(s);
  Eigen::VectorXd Ru, G;
  current_ = &x;  // x's place stays (its swaps with trial exchange contents)
  struct Reset {
    const Unknowns*& at;
    ~Reset() { at = nullptr; }
  } reset{current_};

  // The load scale of the force residual: the largest nodal load, or without loads the largest
  // nodal force of the start (reactions included).
  residual(x, f, Ru, G, load_factor);
  double Fs = std::abs(load_factor) * f.cwiseAbs().maxCoeff();  // max |fl(factor f)|, exactly
  if (!(Fs > 0)) {
    const double h = std::pow(disc_.volume() / nc, 1.0 / d);
    Fs = std::max(Ru.cwiseAbs().maxCoeff(), 1e-8 * disc_.split().C1 * std::pow(h, d - 1));
  }
  constexpr double constraint_tol = 1e-10;

  // The scaled residual at x: forces on free dofs / Fs, G_e / |O_e|, complementarity / Fs.
  struct Measures {
    double merit = 0, force = 0, constraint = 0;
  };
  Eigen::VectorXd gapv(np), comp(np), gb;
  // (score: of a residual already evaluated at y; measure: evaluates it first.)
  auto score = [&](const Unknowns& y, const Eigen::VectorXd& ru, const Eigen::VectorXd& g) {
    Measures mm;
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
      // N_k . ubar_s - g_s (> 0: penetration), per (point, obstacle)
      gapv = disc_.normal_component(pts->mean * y.u) - pts->gap;
      for (int k = 0; k < np; ++k) {
        comp(k) = y.mu(k) - std::max(0.0, y.mu(k) + c_(k) * gapv(k));
        c2 += comp(k) * comp(k);
        mm.force = std::max(mm.force, std::abs(comp(k)) / Fs);
      }
    }
    if (glued_) {  // the box NCP of beta: phi_s = beta_s - clamp(beta_s - g_s / a_s, 0, 1)
      gb = glue_gradient(y);
      for (int k = 0; k < np; ++k) {
        const double phi = y.beta(k) - std::clamp(y.beta(k) - gb(k) / glue_.a(k), 0.0, 1.0);
        g2 += phi * phi;
        mm.constraint = std::max(mm.constraint, std::abs(phi));
      }
    }
    mm.merit = std::sqrt((f2 + c2) / (Fs * Fs) + g2);
    return mm;
  };
  auto measure = [&](const Unknowns& y, Eigen::VectorXd& ru, Eigen::VectorXd& g) {
    residual(y, f, ru, g, load_factor);
    return score(y, ru, g);
  };
  auto admissible = [&](const Unknowns& y) {
    return (d == 2 ? min_det<2>(y.u) : min_det<3>(y.u)) > 0;
  };

  Measures cur = score(x, Ru, G);  // Ru, G at x: evaluated above for the load scale
  Unknowns trial;
  Eigen::VectorXd Ru_t, G_t, mu_x, beta_x;
  bool residual_at_x = true;  // Ru, G hold x's residual (not a base's with forces released)
  std::vector<int> active(np), prev_active, bstate(glued_ ? np : 0), prev_bstate;
  const ScatterPtr scatter = new_scatter();
  const int max_newton = std::max(1, alg.newton_max_iter);
  double damping = 0;
  for (int it = 1;; ++it) {
    // Converged: forces and complementarity at force_tol, constraints at constraint_tol, and
    // the active set of the last step unchanged.
    if (it > 1 && cur.force <= alg.force_tol && cur.constraint <= constraint_tol &&
        active == prev_active && bstate == prev_bstate) {
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
    if (pts) gapv = disc_.normal_component(pts->mean * x.u) - pts->gap;
    if (glued_) gb = glue_gradient(x);
    prev_active = active;
    int nA = 0;
    std::vector<int> aidx(np, -1);
    for (int k = 0; k < np; ++k) {
      active[k] = x.mu(k) + c_(k) * gapv(k) > 0;
      if (active[k]) aidx[k] = nA++;
    }
    // The betas at a bound: beta_s - g_s / a_s outside [0, 1].
    prev_bstate = bstate;
    for (int k = 0; k < static_cast<int>(bstate.size()); ++k) {
      const double t = x.beta(k) - gb(k) / glue_.a(k);
      bstate[k] = t <= 0 ? -1 : (t >= 1 ? 1 : 0);
    }
    // The inactive forces vanish and the betas at a bound take it: set them, and the residual
    // follows. The step starts from base, which is x with those forces and betas set: set in
    // place (u and p, whole on every rank, are not copied), x's own kept to restore if the step
    // is not taken.
    Unknowns& base = x;
    mu_x = x.mu;
    beta_x = x.beta;
    bool released = false;
    for (int k = 0; k < np; ++k)
      if (!active[k] && base.mu(k) != 0) base.mu(k) = 0, released = true;
    for (int k = 0; k < static_cast<int>(bstate.size()); ++k) {
      const double bound = bstate[k] < 0 ? 0.0 : 1.0;
      if (bstate[k] != 0 && base.beta(k) != bound) base.beta(k) = bound, released = true;
    }
    if (released || !residual_at_x)
      residual(base, f, Ru, G, load_factor);  // else Ru, G are x's already
    residual_at_x = !released;
    // [K, -B^T, C_A^T; -B, 0, 0; C_A, 0, 0] (du, dp, dmu_A) = (-R_u, G, g_A - N . ubar_A), gapv
    // (x's) being base's too: base differs from x in mu and beta only.
    const int np_ = incompressible_ ? nc : 0;
    rec.t_strain = seconds_since(t0);
    t0 = clock_type::now();
    Eigen::VectorXd dx;
    // The glued system is solved by LU (newton.hpp); so is an indefinite augmented tangent (a
    // saddle of the energy on the constraints, e.g. a compressed block under a dead load).
    // Krylov solves: inexact Newton, the relative residual asked tightening with the merit. Their
    // failure is answered by damping, not by the LU (a factorization that would not fit).
    const double rtol = std::clamp(1e-2 * cur.merit, 1e-10, 1e-4);
    // The last line search's point and residual (whole-size) are not held through the solve, the
    // phase's peak: the line search below makes them again.
    trial = Unknowns();
    Eigen::VectorXd().swap(Ru_t);
    Eigen::VectorXd().swap(G_t);
    bool solved = !glued_ && augmented_step(base, Ru, G, gapv, active, damping, rtol, *scatter, dx);
    if (!solved && (!krylov_ || glued_))
      solved = lu_step(base, Ru, G, gapv, active, bstate, damping, *scatter, dx);
    rec.t_global = seconds_since(t0);
    // A step not taken (singular system, or no decrease of the merit): recorded with the
    // residuals of the point it stays at, which is tried again with 10 times the damping; false
    // when the damping exceeds 1e6 (the phase fails).
    auto stay = [&]() {
      ++result.iterations;
      ++report.newton_iterations;
      rec.n = ++report.iterations;
      rec.wall = wall0 + seconds_since(t_start);
      rec.r_G = cur.force;
      rec.r_B = cur.constraint;
      rec.accelerated = -1;
      report.history.push_back(rec);
      damping = damping > 0 ? 10 * damping : 1e-4;
      x.mu = mu_x;
      x.beta = beta_x;
      active = prev_active;
      bstate = prev_bstate;
      if (progress) progress(report.history.back());  // x the point it stays at (current_state)
      return damping <= 1e6;
    };
    if (!solved) {  // singular: damp more, same point
      if (stay()) continue;
      result.status = "Newton: the tangent stays singular even with damping";
      break;
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
      for (int k = 0; k < static_cast<int>(bstate.size()); ++k)
        trial.beta(k) += alpha * dx(nfree_ + np_ + nA + k);
      if (!admissible(trial)) continue;
      next = measure(trial, Ru_t, G_t);
      if (std::isfinite(next.merit) && next.merit <= (1 - 1e-4 * alpha) * cur.merit) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (stay()) continue;
      result.status =
          cat("Newton: no decrease of the residual (", cur.merit, ") even along a damped step");
      break;
    }
    ++result.iterations;
    ++report.newton_iterations;
    rec.n = ++report.iterations;
    rec.wall = wall0 + seconds_since(t_start);
    // A full step lowers the damping; a step the line search had to cut to 1/8 raises it (the
    // direction is poorly scaled: the damped one is the better one). Measured on Fig 6: 38 -> 29
    // outer iterations; the other cases of newton.md unchanged.
    if (alpha == 1)
      damping = damping / 4 < 1e-8 ? 0.0 : damping / 4;
    else if (alpha <= 0.125)
      damping = damping > 0 ? 4 * damping : 1e-4;
    std::swap(x, trial);  // trial's arrays are reused by the next line search
    cur = next;
    std::swap(Ru, Ru_t);
    std::swap(G, G_t);
    residual_at_x = true;
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
                                  Triplets*, const CellSink*, bool) const;
template void Newton::assemble<3>(const Unknowns&, Eigen::VectorXd*, Eigen::VectorXd*, Triplets*,
                                  Triplets*, const CellSink*, bool) const;

}  // namespace ltl
