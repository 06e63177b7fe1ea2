// The global step (4.1): the matrix of (4.5) and the Dirichlet grouping (global_step.hpp).
#include "global_step.hpp"

#include <algorithm>
#include <chrono>
#include <map>
#include <set>

#include "cg_amg.hpp"
#include "cholesky.hpp"
#include "error.hpp"

namespace ltl {

SpMat global_matrix(const CellOperators& cells, const ContactPoints* points, double C1, double Rq,
                    double Rqc) {
  SpMat K = 2 * C1 * cells.laplacian;
  SpMat mean_grad = SpMat(cells.GbarT_vol * cells.Gbar);
  K += Rq * mean_grad;
  if (points && points->size() > 0) {
    SpMat mean = SpMat(points->meanT_area * points->mean);
    K += Rqc * mean;
  }
  K.prune(0.0);
  return K;
}

/// One distinct Dirichlet set: its factor (or CG + AMG), and the mesh node of each row of the
/// system (in the factor's permuted order, so that the permutation is folded into the gather and
/// the scatter).
struct GlobalStep::Group {
  std::vector<int> components;
  std::vector<int> node;  ///< #free, mesh node of each row of the (permuted) system
  Eigen::MatrixXd shift;  ///< #free x #components, K_fd u_d in the rows' order, constant
  std::unique_ptr<Cholesky> factor;
  std::unique_ptr<CgAmg> amg;
  std::vector<double> b, x;  ///< CG + AMG: one column's right-hand side and iterate
  int rows() const { return static_cast<int>(node.size()); }
  int cols() const { return static_cast<int>(components.size()); }
};

namespace {

/// K restricted to the free nodes of a Dirichlet set (lower triangle only, or both), and the
/// constant shift K_fd u_d of its components.
struct Restricted {
  std::vector<int> free_nodes, local;
  SpMat Kff;
  Eigen::MatrixXd shift;
};

Restricted restrict_to_free(const SpMat& K, const DirichletData& bc,
                            const std::vector<int>& components, bool lower_only) {
  const int n = static_cast<int>(K.rows());
  Restricted r;
  std::vector<char> is_fixed(n, 0);
  for (int i : bc.fixed[components[0]]) is_fixed[i] = 1;
  r.local.assign(n, -1);
  for (int i = 0; i < n; ++i)
    if (!is_fixed[i]) {
      r.local[i] = static_cast<int>(r.free_nodes.size());
      r.free_nodes.push_back(i);
    }
  const int nf = static_cast<int>(r.free_nodes.size()), nc = static_cast<int>(components.size());
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(K.nonZeros());
  r.shift = Eigen::MatrixXd::Zero(nf, nc);
  for (int col = 0; col < n; ++col)
    for (SpMat::InnerIterator it(K, col); it; ++it) {
      const int row = static_cast<int>(it.row());
      if (r.local[row] < 0) continue;
      if (r.local[col] >= 0) {
        if (!lower_only || r.local[row] >= r.local[col])
          t.emplace_back(r.local[row], r.local[col], it.value());
      } else {
        for (int k = 0; k < nc; ++k)
          r.shift(r.local[row], k) += it.value() * bc.value(col, components[k]);
      }
    }
  r.Kff.resize(nf, nf);
  r.Kff.setFromTriplets(t.begin(), t.end());
  return r;
}

}  // namespace

double GlobalStep::predicted_factor_nonzeros(const SpMat& K, const DirichletData& bc) {
  // The Dirichlet set with the fewest fixed nodes is the largest matrix; the others are no larger.
  std::set<std::vector<int>> sets(bc.fixed.begin(), bc.fixed.end());
  std::size_t fewest = 0;
  for (std::size_t i = 1; i < bc.fixed.size(); ++i)
    if (bc.fixed[i].size() < bc.fixed[fewest].size()) fewest = i;
  const Restricted r = restrict_to_free(K, bc, {static_cast<int>(fewest)}, true);
  return static_cast<double>(sets.size()) * Cholesky::predicted_nonzeros(r.Kff);
}

GlobalStep::GlobalStep(const SpMat& K, const DirichletData& bc, GlobalSolver solver,
                       const Eigen::MatrixXd* X)
    : bc_(bc) {
  const int n = static_cast<int>(K.rows()), dim = static_cast<int>(bc.fixed.size());
  // One group per distinct Dirichlet set.
  std::map<std::vector<int>, int> by_set;
  for (int i = 0; i < dim; ++i) {
    auto it = by_set.find(bc.fixed[i]);
    if (it == by_set.end()) {
      by_set[bc.fixed[i]] = static_cast<int>(groups_.size());
      groups_.push_back(std::make_unique<Group>());
      groups_.back()->components.push_back(i);
    } else {
      groups_[it->second]->components.push_back(i);
    }
  }
  // Fill-reducing ordering: the best (least nnz(L)) of AMD, METIS and CHOLMOD's nested
  // dissection, computed once for the group with the fewest fixed nodes and induced on the other
  // groups when their free nodes are a subset of its own (symmetry planes): the induced order of
  // a subgraph fills no more than the restriction of the fill of the whole graph.
  std::vector<int> process(groups_.size());
  for (std::size_t k = 0; k < process.size(); ++k) process[k] = static_cast<int>(k);
  std::stable_sort(process.begin(), process.end(), [&](int a, int b) {
    return bc.fixed[groups_[a]->components[0]].size() < bc.fixed[groups_[b]->components[0]].size();
  });
  // Auto: CG + AMG when the factors would not fit (global_step.hpp).
  if (solver == GlobalSolver::Auto) {
    solver = GlobalSolver::Cholesky;
    if (CgAmg::available() && n > kAutoMinRows &&
        8.0 * predicted_factor_nonzeros(K, bc) > kAutoFactorBytes)
      solver = GlobalSolver::CgAmg;
  }
  solver_ = solver;
  if (solver_ == GlobalSolver::CgAmg && (!X || X->rows() != n))
    throw Error(cat("global matrix (4.5): CG + AMG needs the ", n, " nodes' coordinates"));
  std::vector<int> base_order;        // mesh nodes in the fill-reducing order of the first group
  std::vector<char> base_free(n, 0);  // free nodes of the first group
  for (int gi : process) {
    Group& g = *groups_[gi];
    const bool cg = solver_ == GlobalSolver::CgAmg;
    Restricted r = restrict_to_free(K, bc, g.components, !cg);
    const int nf = static_cast<int>(r.free_nodes.size()), nc = g.cols();
    std::string comps;
    for (int c : g.components) comps += std::string(comps.empty() ? "" : ", ") + "xyz"[c];
    const std::string what =
        cat("global matrix (4.5), displacement component(s) ", comps, " (", nf, " free nodes)");
    if (cg) {  // the rows in the mesh's order; the hierarchy on the free nodes' coordinates
      Eigen::MatrixXd Xf(nf, X->cols());
      for (int k = 0; k < nf; ++k) Xf.row(k) = X->row(r.free_nodes[k]);
      g.amg = std::make_unique<CgAmg>(r.Kff, Xf, what);
      g.node = r.free_nodes;
      g.shift = r.shift;
      g.b.resize(nf);
      g.x.resize(nf);
      continue;
    }
    bool induced = !base_order.empty();
    for (int i = 0; i < n && induced; ++i)
      if (r.local[i] >= 0 && !base_free[i]) induced = false;
    std::vector<int> order;
    if (induced) {
      order.reserve(nf);
      for (int node : base_order)
        if (r.local[node] >= 0) order.push_back(r.local[node]);
    }
    g.factor = std::make_unique<Cholesky>(
        r.Kff, nc, what,
        "Most likely a rigid motion is not removed: fix part of the boundary, add a symmetry "
        "plane, or give the contact surface q_c > 0.",
        order);
    analyze_seconds_ += g.factor->analyze_seconds();
    factorize_seconds_ += g.factor->factorize_seconds();
    factor_nnz_ += g.factor->nonzeros();
    min_rcond_ = std::min(min_rcond_, g.factor->rcond());
    // The permuted order of the rows.
    const std::vector<int>& perm = g.factor->perm();
    g.node.resize(nf);
    g.shift.resize(nf, nc);
    for (int k = 0; k < nf; ++k) {
      g.node[k] = r.free_nodes[perm[k]];
      g.shift.row(k) = r.shift.row(perm[k]);
    }
    if (base_order.empty()) {
      base_order = g.node;
      for (int node : r.free_nodes) base_free[node] = 1;
    }
  }
}

GlobalStep::~GlobalStep() = default;

// [LTL87 (4.5)] CG + AMG for one Dirichlet set, component by component, each warm-started from
// the previous iterate u on the free nodes (cg_amg.hpp).
void GlobalStep::iterate(Group& g, const Eigen::MatrixXd& b, Eigen::MatrixXd& u) const {
  const int nf = g.rows();
  for (int k = 0; k < g.cols(); ++k) {
    const int c = g.components[k];
    for (int i = 0; i < nf; ++i) {
      g.b[i] = b(g.node[i], c) - scale_ * g.shift(i, k);
      g.x[i] = u(g.node[i], c);
    }
    g.amg->solve(g.b.data(), g.x.data());
    for (int i = 0; i < nf; ++i) u(g.node[i], c) = g.x[i];
    for (int i : bc_.fixed[c]) u(i, c) = scale_ * bc_.value(i, c);
  }
}

int GlobalStep::factor_rows(int k) const {
  return groups_.at(k)->rows();
}
int GlobalStep::factor_columns(int k) const {
  return groups_.at(k)->cols();
}
const Cholesky& GlobalStep::factor(int k) const {
  if (!groups_.at(k)->factor) throw Error("the global step has no Cholesky factor (CG + AMG)");
  return *groups_.at(k)->factor;
}

template <class F>
double GlobalStep::amg_sum(const F& f) const {
  double s = 0;
  for (const auto& g : groups_)
    if (g->amg) s += f(*g->amg);
  return s;
}

long GlobalStep::cg_iterations() const {
  return static_cast<long>(amg_sum([](const CgAmg& a) { return a.iterations(); }));
}
long GlobalStep::cg_solves() const {
  return static_cast<long>(amg_sum([](const CgAmg& a) { return a.solves(); }));
}
double GlobalStep::amg_setup_seconds() const {
  return amg_sum([](const CgAmg& a) { return a.setup_seconds(); });
}
double GlobalStep::amg_nonzeros() const {
  return amg_sum([](const CgAmg& a) { return a.hierarchy_nonzeros(); });
}
double GlobalStep::amg_bytes() const {
  return amg_sum([](const CgAmg& a) { return a.hierarchy_bytes(); });
}

void GlobalStep::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u) {
  const auto t0 = std::chrono::steady_clock::now();
  // CG + AMG warm-starts from u: keep the previous iterate when it has the right shape.
  if (u.rows() != b.rows() || u.cols() != b.cols()) u = Eigen::MatrixXd::Zero(b.rows(), b.cols());
  const bool amg = solver_ == GlobalSolver::CgAmg;
  const int ng = static_cast<int>(groups_.size());
  double work = 0;
  for (const auto& g : groups_) work += g->factor ? g->factor->nonzeros() : 0.0;
  auto one = [&](Group& g) {
    if (g.amg) {
      iterate(g, b, u);
      return;
    }
    const int nf = g.rows(), nc = g.cols();
    double* y = g.factor->block();  // row k, column j at y[nc k + j]
    for (int k = 0; k < nc; ++k) {  // block = (b - K_fd u_d) on the free nodes, permuted
      const double* bk = b.col(g.components[k]).data();
      const double* sh = g.shift.col(k).data();
      for (int i = 0; i < nf; ++i) y[nc * i + k] = bk[g.node[i]] - scale_ * sh[i];
    }
    g.factor->solve_in_place();
    for (int k = 0; k < nc; ++k) {
      const int c = g.components[k];
      double* uc = u.col(c).data();
      for (int i = 0; i < nf; ++i) uc[g.node[i]] = y[nc * i + k];
      for (int i : bc_.fixed[c]) uc[i] = scale_ * bc_.value(i, c);
    }
  };
  // Distinct factors are independent (and each has its own CHOLMOD state): solve them
  // concurrently when they are worth a parallel region.
#pragma omp parallel for schedule(dynamic, 1) if (ng > 1 && work >= kParallelMinNnz && !amg)
  for (int k = 0; k < ng; ++k) one(*groups_[k]);
  solve_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ++solve_calls_;
}

}  // namespace ltl
