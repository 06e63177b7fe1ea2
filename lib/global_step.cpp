#include "global_step.hpp"

#include <algorithm>
#include <chrono>
#include <map>

#include "error.hpp"

namespace ltl {

SpMat global_matrix(const CellOperators& cells, const FacetOperators* facets, double C1,
                    double Rq, double Rqc) {
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

GlobalStep::GlobalStep(const SpMat& K, const DirichletData& bc) : bc_(bc) {
  using clock = std::chrono::steady_clock;
  const int n = static_cast<int>(K.rows()), dim = static_cast<int>(bc.fixed.size());
  // One group per distinct Dirichlet set.
  std::map<std::vector<int>, int> by_set;
  for (int i = 0; i < dim; ++i) {
    auto it = by_set.find(bc.fixed[i]);
    if (it == by_set.end()) {
      by_set[bc.fixed[i]] = static_cast<int>(groups_.size());
      groups_.emplace_back();
      groups_.back().components.push_back(i);
    } else {
      groups_[it->second].components.push_back(i);
    }
  }
  for (auto& g : groups_) {
    const auto& fixed = bc.fixed[g.components[0]];
    std::vector<int> local(n, -1);
    std::vector<char> is_fixed(n, 0);
    for (int i : fixed) is_fixed[i] = 1;
    for (int i = 0; i < n; ++i)
      if (!is_fixed[i]) {
        local[i] = static_cast<int>(g.free_nodes.size());
        g.free_nodes.push_back(i);
      }
    const int nf = static_cast<int>(g.free_nodes.size()), nc = static_cast<int>(g.components.size());
    // K_ff (lower triangle is enough for CHOLMOD) and the constant shift K_fd u_d.
    std::vector<Eigen::Triplet<double>> t;
    t.reserve(K.nonZeros());
    g.shift = Eigen::MatrixXd::Zero(nf, nc);
    for (int col = 0; col < n; ++col)
      for (SpMat::InnerIterator it(K, col); it; ++it) {
        const int row = static_cast<int>(it.row());
        if (local[row] < 0) continue;
        if (local[col] >= 0) {
          if (local[row] >= local[col]) t.emplace_back(local[row], local[col], it.value());
        } else {
          for (int k = 0; k < nc; ++k)
            g.shift(local[row], k) += it.value() * bc.value(col, g.components[k]);
        }
      }
    SpMat Kff(nf, nf);
    Kff.setFromTriplets(t.begin(), t.end());
    g.llt = std::make_unique<Factor>();
    const auto t0 = clock::now();
    g.llt->analyzePattern(Kff);
    const auto t1 = clock::now();
    g.llt->factorize(Kff);
    const auto t2 = clock::now();
    analyze_seconds_ += std::chrono::duration<double>(t1 - t0).count();
    factorize_seconds_ += std::chrono::duration<double>(t2 - t1).count();
    factor_nnz_ += g.llt->cholmod().lnz;
    const double rcond = g.llt->info() == Eigen::Success ? g.llt->rcond() : 0.0;
    min_rcond_ = std::min(min_rcond_, rcond);
    if (g.llt->info() != Eigen::Success || !(rcond > kMinRcond)) {
      std::string comps;
      for (int c : g.components) comps += std::string(comps.empty() ? "" : ", ") + "xyz"[c];
      throw Error(cat("global matrix (4.5): the Cholesky factorization failed for displacement "
                      "component(s) ",
                      comps, " (", nf, " free nodes, condition estimate ", rcond,
                      "): the matrix is singular or not positive definite. ",
                      "Most likely a rigid motion is not removed: fix part of the boundary, add "
                      "a symmetry plane, or give the contact surface q_c > 0."));
    }
    g.rhs.resize(nf, nc);
    g.x.resize(nf, nc);
  }
}

void GlobalStep::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u) {
  u.resize(b.rows(), b.cols());
  for (auto& g : groups_) {
    const int nf = static_cast<int>(g.free_nodes.size());
    for (std::size_t k = 0; k < g.components.size(); ++k) {
      const int c = g.components[k];
      for (int i = 0; i < nf; ++i) g.rhs(i, k) = b(g.free_nodes[i], c);
    }
    g.rhs -= g.shift;
    g.x = g.llt->solve(g.rhs);
    for (std::size_t k = 0; k < g.components.size(); ++k) {
      const int c = g.components[k];
      for (int i : bc_.fixed[c]) u(i, c) = bc_.value(i, c);
      for (int i = 0; i < nf; ++i) u(g.free_nodes[i], c) = g.x(i, k);
    }
  }
}

}  // namespace ltl
