// The global step (4.1): the matrix of (4.5) and the Dirichlet grouping (global_step.hpp).
#include "global_step.hpp"

#include <algorithm>
#include <chrono>
#include <map>

#include "cholesky.hpp"
#include "error.hpp"

namespace ltl {

SpMat global_matrix(const CellOperators& cells, const FacetOperators* facets, double C1, double Rq,
                    double Rqc) {
  SpMat K = 2 * C1 * cells.laplacian;
  SpMat mean_grad = SpMat(cells.GbarT_vol * cells.Gbar);
  K += Rq * mean_grad;
  if (facets && facets->size() > 0) {
    SpMat mean = SpMat(facets->meanT_area * facets->mean);
    K += Rqc * mean;
  }
  K.prune(0.0);
  return K;
}

/// One distinct Dirichlet set: its factor, and the mesh node of each row of the factor's
/// permuted system (so that the permutation is folded into the gather and the scatter).
struct GlobalStep::Group {
  std::vector<int> components;
  std::vector<int> node;  ///< #free, mesh node of each row of the permuted system
  Eigen::MatrixXd shift;  ///< #free x #components, K_fd u_d in the permuted order, constant
  std::unique_ptr<Cholesky> factor;
  int rows() const { return static_cast<int>(node.size()); }
  int cols() const { return static_cast<int>(components.size()); }
};

GlobalStep::GlobalStep(const SpMat& K, const DirichletData& bc) : bc_(bc) {
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
  std::vector<int> base_order;        // mesh nodes in the fill-reducing order of the first group
  std::vector<char> base_free(n, 0);  // free nodes of the first group
  for (int gi : process) {
    Group& g = *groups_[gi];
    const auto& fixed = bc.fixed[g.components[0]];
    std::vector<int> local(n, -1), free_nodes;
    std::vector<char> is_fixed(n, 0);
    for (int i : fixed) is_fixed[i] = 1;
    for (int i = 0; i < n; ++i)
      if (!is_fixed[i]) {
        local[i] = static_cast<int>(free_nodes.size());
        free_nodes.push_back(i);
      }
    const int nf = static_cast<int>(free_nodes.size()), nc = static_cast<int>(g.components.size());
    // K_ff (lower triangle is enough) and the constant shift K_fd u_d.
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(K.nonZeros());
    Eigen::MatrixXd shift = Eigen::MatrixXd::Zero(nf, nc);
    for (int col = 0; col < n; ++col)
      for (SpMat::InnerIterator it(K, col); it; ++it) {
        const int row = static_cast<int>(it.row());
        if (local[row] < 0) continue;
        if (local[col] >= 0) {
          if (local[row] >= local[col]) t.emplace_back(local[row], local[col], it.value());
        } else {
          for (int k = 0; k < nc; ++k)
            shift(local[row], k) += it.value() * bc.value(col, g.components[k]);
        }
      }
    SpMat Kff(nf, nf);
    Kff.setFromTriplets(t.begin(), t.end());
    bool induced = !base_order.empty();
    for (int i = 0; i < n && induced; ++i)
      if (local[i] >= 0 && !base_free[i]) induced = false;
    std::vector<int> order;
    if (induced) {
      order.reserve(nf);
      for (int node : base_order)
        if (local[node] >= 0) order.push_back(local[node]);
    }
    std::string comps;
    for (int c : g.components) comps += std::string(comps.empty() ? "" : ", ") + "xyz"[c];
    g.factor = std::make_unique<Cholesky>(
        Kff, nc,
        cat("global matrix (4.5), displacement component(s) ", comps, " (", nf, " free nodes)"),
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
      g.node[k] = free_nodes[perm[k]];
      g.shift.row(k) = shift.row(perm[k]);
    }
    if (base_order.empty()) {
      base_order = g.node;
      for (int node : free_nodes) base_free[node] = 1;
    }
  }
}

GlobalStep::~GlobalStep() = default;

int GlobalStep::factor_rows(int k) const {
  return groups_.at(k)->rows();
}
int GlobalStep::factor_columns(int k) const {
  return groups_.at(k)->cols();
}
const Cholesky& GlobalStep::factor(int k) const {
  return *groups_.at(k)->factor;
}

void GlobalStep::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u) {
  const auto t0 = std::chrono::steady_clock::now();
  u.resize(b.rows(), b.cols());
  const int ng = static_cast<int>(groups_.size());
  double work = 0;
  for (const auto& g : groups_) work += g->factor->nonzeros();
  auto one = [&](Group& g) {
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
#pragma omp parallel for schedule(dynamic, 1) if (ng > 1 && work >= kParallelMinNnz)
  for (int k = 0; k < ng; ++k) one(*groups_[k]);
  solve_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ++solve_calls_;
}

}  // namespace ltl
