// The global step (4.1): the matrix of (4.5) and the Dirichlet grouping (global_step.hpp).
#include "global_step.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "cg_amg.hpp"
#include "cholesky.hpp"
#include "error.hpp"

namespace ltl {

// Assembled in the Laplacian's pattern, which holds every term's (nodes sharing a cell; a
// contact facet's nodes share its cell): one copy of L, the mean-gradient term added cell by
// cell, the contact term (surface-sized) entry by entry; no sparse product or sum of the size of
// K is formed.
SpMat global_matrix(const CellOperators& cells, const ContactPoints* points, double C1, double Rq,
                    double Rqc) {
  SpMat K = cells.laplacian;
  K.makeCompressed();
  for (Eigen::Index k = 0; k < K.nonZeros(); ++k) K.valuePtr()[k] *= 2 * C1;
  // The entry (i, j) of the pattern, or nullptr.
  auto entry = [&K](int i, int j) -> double* {
    const int *begin = K.innerIndexPtr() + K.outerIndexPtr()[j],
              *end = K.innerIndexPtr() + K.outerIndexPtr()[j + 1];
    const int* at = std::lower_bound(begin, end, i);
    return at != end && *at == i ? K.valuePtr() + (at - K.innerIndexPtr()) : nullptr;
  };
  // R q sum_e |O_e| Gbar_e^T Gbar_e over the held cells: held cell k's rows of Gbar hold its
  // nodes, in the same order.
  const int nh = static_cast<int>(cells.cell.size());
  const int dim = nh > 0 ? static_cast<int>(cells.Gbar.rows() / nh) : 1;
  for (int k = 0; k < nh; ++k) {
    const int c = cells.cell[k];
    const Eigen::Index r0 = cells.Gbar.outerIndexPtr()[dim * k];
    const int npc = static_cast<int>(cells.Gbar.outerIndexPtr()[dim * k + 1] - r0);
    const int* node = cells.Gbar.innerIndexPtr() + r0;
    for (int a = 0; a < npc; ++a)
      for (int b = 0; b < npc; ++b) {
        double m = 0;
        for (int j = 0; j < dim; ++j) {
          const double* g = cells.Gbar.valuePtr() + cells.Gbar.outerIndexPtr()[dim * k + j];
          m += g[a] * g[b];
        }
        double* at = entry(node[a], node[b]);
        if (!at)  // cell_operators' layout: L holds every pair of nodes of a cell
          throw Error(cat("global matrix (4.5): nodes ", node[a], " and ", node[b], " of cell ", c,
                          " are not in the Laplacian's pattern"));
        *at += Rq * cells.vol(k) * m;
      }
  }
  if (!cells.node.empty()) {  // some cells: from their nodes' columns to the mesh's numbering
    const int nn = cells.num_nodes;
    SpMat whole(nn, nn);
    whole.resizeNonZeros(K.nonZeros());
    std::fill(whole.outerIndexPtr(), whole.outerIndexPtr() + nn + 1, 0);
    for (int j = 0; j < K.cols(); ++j)
      whole.outerIndexPtr()[cells.node[j] + 1] = K.outerIndexPtr()[j + 1] - K.outerIndexPtr()[j];
    for (int j = 0; j < nn; ++j) whole.outerIndexPtr()[j + 1] += whole.outerIndexPtr()[j];
    for (Eigen::Index k = 0; k < K.nonZeros(); ++k) {  // node[] is increasing: the order stays
      whole.innerIndexPtr()[k] = cells.node[K.innerIndexPtr()[k]];
      whole.valuePtr()[k] = K.valuePtr()[k];
    }
    K.swap(whole);
  }
  if (points && points->size() > 0) {
    SpMatR work;  // meanT_area, made again on a rank's discretization (contact_points.hpp)
    const SpMat mean = SpMat(points->meanT_area_of(work) * points->mean);
    bool in_pattern = true;
    for (int j = 0; j < mean.outerSize() && in_pattern; ++j)
      for (SpMat::InnerIterator it(mean, j); it; ++it)
        if (!entry(static_cast<int>(it.row()), j)) in_pattern = false;
    if (in_pattern) {
      for (int j = 0; j < mean.outerSize(); ++j)
        for (SpMat::InnerIterator it(mean, j); it; ++it)
          *entry(static_cast<int>(it.row()), j) += Rqc * it.value();
    } else {
      K += Rqc * mean;
    }
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

/// K restricted to the free nodes of a Dirichlet set, and the constant shift K_fd u_d of its
/// components. Cholesky: Kff, the lower triangle in compressed columns; CG + AMG: KffR, both
/// triangles in compressed rows (the rows of K itself, PETSc's layout). Both are written in
/// place in two passes over K (count, then fill), without a triplet list: the free nodes keep
/// their order, so the entries arrive sorted.
struct Restricted {
  std::vector<int> free_nodes, local;
  SpMat Kff;
  SpMatR KffR;
  Eigen::MatrixXd shift;
};

void restrict_to_free(const SpMat& K, const DirichletData& bc, const std::vector<int>& components,
                      bool lower_only, Restricted& r) {
  const int n = static_cast<int>(K.rows());
  std::vector<char> is_fixed(n, 0);
  for (int i : bc.fixed[components[0]]) is_fixed[i] = 1;
  r.local.assign(n, -1);
  for (int i = 0; i < n; ++i)
    if (!is_fixed[i]) {
      r.local[i] = static_cast<int>(r.free_nodes.size());
      r.free_nodes.push_back(i);
    }
  const int nf = static_cast<int>(r.free_nodes.size()), nc = static_cast<int>(components.size());
  r.shift = Eigen::MatrixXd::Zero(nf, nc);
  // Pass 1: the shift, and the entries per column (lower) or per row (both triangles).
  std::vector<int> count(static_cast<std::size_t>(nf) + 1, 0);
  for (int col = 0; col < n; ++col)
    for (SpMat::InnerIterator it(K, col); it; ++it) {
      const int row = static_cast<int>(it.row());
      if (r.local[row] < 0) continue;
      if (r.local[col] >= 0) {
        if (!lower_only || r.local[row] >= r.local[col])
          ++count[1 + (lower_only ? r.local[col] : r.local[row])];
      } else {
        for (int k = 0; k < nc; ++k)
          r.shift(r.local[row], k) += it.value() * bc.value_at(col, components[k]);
      }
    }
  for (int i = 0; i < nf; ++i) count[i + 1] += count[i];
  auto fill = [&](auto& M) {  // pass 2: the entries, at count[outer]++
    M.resize(nf, nf);
    M.resizeNonZeros(count[nf]);
    std::copy(count.begin(), count.end(), M.outerIndexPtr());
    for (int col = 0; col < n; ++col) {
      const int lc = r.local[col];
      if (lc < 0) continue;
      for (SpMat::InnerIterator it(K, col); it; ++it) {
        const int lr = r.local[it.row()];
        if (lr < 0 || (lower_only && lr < lc)) continue;
        const int outer = lower_only ? lc : lr, inner = lower_only ? lr : lc;
        M.innerIndexPtr()[count[outer]] = inner;
        M.valuePtr()[count[outer]++] = it.value();
      }
    }
  };
  if (lower_only)
    fill(r.Kff);
  else
    fill(r.KffR);
}

/// The name of a Dirichlet set's matrix in errors.
std::string describe(const std::vector<int>& components, int free_nodes) {
  std::string comps;
  for (int c : components) comps += std::string(comps.empty() ? "" : ", ") + "xyz"[c];
  return cat("global matrix (4.5), displacement component(s) ", comps, " (", free_nodes,
             " free nodes)");
}

}  // namespace

double GlobalStep::predicted_factor_nonzeros(const SpMat& K, const DirichletData& bc,
                                             int newton_dim) {
  // The Dirichlet set with the fewest fixed nodes is the largest matrix; the others are no larger.
  std::set<std::vector<int>> sets(bc.fixed.begin(), bc.fixed.end());
  std::size_t fewest = 0;
  for (std::size_t i = 1; i < bc.fixed.size(); ++i)
    if (bc.fixed[i].size() < bc.fixed[fewest].size()) fewest = i;
  Restricted r;
  restrict_to_free(K, bc, {static_cast<int>(fewest)}, true, r);
  return static_cast<double>(sets.size() + newton_dim * newton_dim) *
         Cholesky::predicted_nonzeros(r.Kff);
}

GlobalStep::GlobalStep(const SpMat& K, const DirichletData& bc, GlobalSolver solver,
                       const Eigen::MatrixXd* X, int newton_dim, const AutoLimits* limits)
    : GlobalStep(SpMat(K), bc, solver, X, newton_dim, limits) {}

double DirichletData::value_at(int a, int i) const {
  const std::vector<int>& f = fixed[i];
  const auto it = std::lower_bound(f.begin(), f.end(), a);
  return it != f.end() && *it == a ? value[i][it - f.begin()] : 0.0;
}

void DirichletData::impose(Eigen::MatrixXd& u, int i, double scale) const {
  for (std::size_t k = 0; k < fixed[i].size(); ++k) u(fixed[i][k], i) = scale * value[i][k];
}

void DirichletData::check(int nodes) const {
  if (value.size() != fixed.size())
    throw Error(cat("Dirichlet data: values for ", value.size(), " components, fixed nodes for ",
                    fixed.size()));
  for (std::size_t i = 0; i < fixed.size(); ++i) {
    const std::vector<int>& f = fixed[i];
    if (value[i].size() != f.size())
      throw Error(cat("Dirichlet data, component ", i, ": ", value[i].size(), " values for ",
                      f.size(), " fixed nodes"));
    for (std::size_t k = 0; k < f.size(); ++k)
      if (f[k] < 0 || f[k] >= nodes || (k > 0 && f[k] <= f[k - 1]))
        throw Error(cat("Dirichlet data, component ", i, ": fixed node ", f[k], " at ", k,
                        " is out of 0 .. ", nodes - 1, " or not after ", k > 0 ? f[k - 1] : -1,
                        " (the list must be sorted, without repeats)"));
  }
}

double DirichletData::max_abs_value() const {
  double m = 0;
  for (const std::vector<double>& v : value)
    for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

std::vector<std::vector<int>> components_by_dirichlet_set(const DirichletData& bc) {
  std::vector<std::vector<int>> groups;
  std::map<std::vector<int>, std::size_t> by_set;
  for (int i = 0; i < static_cast<int>(bc.fixed.size()); ++i) {
    const auto [it, fresh] = by_set.emplace(bc.fixed[i], groups.size());
    if (fresh) groups.emplace_back();
    groups[it->second].push_back(i);
  }
  return groups;
}

GlobalStep::GlobalStep(SpMat&& K, const DirichletData& bc, GlobalSolver solver,
                       const Eigen::MatrixXd* X, int newton_dim, const AutoLimits* limits)
    : bc_(bc) {
  const int n = static_cast<int>(K.rows());
  bc.check(n);
  // One group per distinct Dirichlet set.
  for (std::vector<int>& components : components_by_dirichlet_set(bc)) {
    groups_.push_back(std::make_unique<Group>());
    groups_.back()->components = std::move(components);
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
  // Auto: CG + AMG when the factors would not fit (global_step.hpp), the Newton phase's with
  // them.
  if (solver == GlobalSolver::Auto) {
    solver = GlobalSolver::Cholesky;
    const AutoLimits rule = limits ? *limits : AutoLimits();
    if (CgAmg::available() &&
        rule.cg_amg(n, [&] { return 8.0 * predicted_factor_nonzeros(K, bc, newton_dim); }))
      solver = GlobalSolver::CgAmg;
  }
  solver_ = solver;
  if (solver_ == GlobalSolver::CgAmg && (!X || X->rows() != n))
    throw Error(cat("global matrix (4.5): CG + AMG needs the ", n, " nodes' coordinates"));
  if (solver_ == GlobalSolver::CgAmg) {
    // Every Dirichlet set's matrix first, then K freed, then the hierarchies one by one: K is
    // not resident while GAMG's setup reaches its peak (the restricted matrices are the
    // hierarchies' finest operators, held by PETSc in place).
    std::vector<Restricted> rs(groups_.size());
    for (int gi : process) restrict_to_free(K, bc, groups_[gi]->components, false, rs[gi]);
    SpMat().swap(K);
    for (int gi : process) {
      Group& g = *groups_[gi];
      Restricted& r = rs[gi];
      const int nf = static_cast<int>(r.free_nodes.size());
      // The rows in the mesh's order; the hierarchy on the free nodes' coordinates.
      Eigen::MatrixXd Xf(nf, X->cols());
      for (int k = 0; k < nf; ++k) Xf.row(k) = X->row(r.free_nodes[k]);
      g.amg = std::make_unique<CgAmg>(std::move(r.KffR), Xf, describe(g.components, nf));
      g.node = std::move(r.free_nodes);
      g.shift = std::move(r.shift);
      std::vector<int>().swap(r.local);
      g.b.resize(nf);
      g.x.resize(nf);
    }
    return;
  }
  std::vector<int> base_order;        // mesh nodes in the fill-reducing order of the first group
  std::vector<char> base_free(n, 0);  // free nodes of the first group
  for (int gi : process) {
    Group& g = *groups_[gi];
    Restricted r;
    restrict_to_free(K, bc, g.components, true, r);
    if (gi == process.back()) SpMat().swap(K);  // the last set's matrix is made: K is done
    const int nf = static_cast<int>(r.free_nodes.size()), nc = g.cols();
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
        r.Kff, nc, describe(g.components, nf),
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
    bc_.impose(u, c, scale_);
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
      bc_.impose(u, c, scale_);  // column c alone: the groups' columns are distinct
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
