#include "global_step.hpp"

#include <cholmod.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include <algorithm>
#include <chrono>
#include <map>

#include "error.hpp"

namespace ltl {

namespace {

// ------------------------------------------------------------------------------------------
// Supernodal triangular sweeps on CHOLMOD's supernodal LL' factor, for NR = 1..3 right-hand
// sides stored interleaved (row k of the permuted system at Y[NR k .. NR k + NR - 1]).
//
// Supernode s holds the columns k1 = super[s] .. k2 - 1 (nscol of them) as a dense column-major
// block of nsrow rows (leading dimension nsrow) at x + px[s]; its row indices are
// s_[pi[s] .. pi[s + 1]), the first nscol of which are k1 .. k2 - 1. Each sweep copies the
// supernode's rows into a small dense buffer W (its own rows from Y, the rows below it gathered),
// then works column by column on the contiguous part of each column from the diagonal down:
// one axpy per column (forward), one dot product per column (backward). Why not
// cholmod_super_lsolve / ltsolve (one BLAS call per supernode), measured in
// paper_notes/performance.md: with a few right-hand sides OpenBLAS's dtrsm/dgemm pack every
// block first, and on this machine the hardware prefetcher loses two interleaved column streams
// and ascending columns visited in descending supernode order. These loops read L exactly once
// per sweep, ascending in the forward sweep and strictly descending (supernodes, columns and
// rows) in the backward one, which the prefetcher follows; the dot products use four partial
// sums so that they are not bound by the latency of the additions.

struct SuperView {
  int nsuper;
  const int *super, *pi, *px, *s;
  const double* x;
  explicit SuperView(const cholmod_factor* L)
      : nsuper(static_cast<int>(L->nsuper)),
        super(static_cast<const int*>(L->super)),
        pi(static_cast<const int*>(L->pi)),
        px(static_cast<const int*>(L->px)),
        s(static_cast<const int*>(L->s)),
        x(static_cast<const double*>(L->x)) {}
};

/// w[NR i + c] -= a[i] x[c] for i in [lo, hi).
template <int NR>
inline void axpy_rows(const double* a, const double* x, double* w, int lo, int hi) {
#ifdef __SSE2__
  if constexpr (NR == 2) {
    const __m128d xv = _mm_set_pd(x[1], x[0]);
    for (int i = lo; i < hi; ++i)
      _mm_storeu_pd(w + 2 * i,
                    _mm_sub_pd(_mm_loadu_pd(w + 2 * i), _mm_mul_pd(_mm_set1_pd(a[i]), xv)));
    return;
  }
#endif
#pragma omp simd
  for (int i = lo; i < hi; ++i)
    for (int c = 0; c < NR; ++c) w[NR * i + c] -= a[i] * x[c];
}

/// t[c] = sum over i in [lo, hi) of a[i] w[NR i + c], rows visited in descending order, with
/// four partial sums.
template <int NR>
inline void dot_rows_desc(const double* a, const double* w, int lo, int hi, double* t) {
  double s[4][NR] = {};
  int i = hi - 1;
  for (; i - 3 >= lo; i -= 4)
    for (int c = 0; c < NR; ++c) {
      s[0][c] += a[i] * w[NR * i + c];
      s[1][c] += a[i - 1] * w[NR * (i - 1) + c];
      s[2][c] += a[i - 2] * w[NR * (i - 2) + c];
      s[3][c] += a[i - 3] * w[NR * (i - 3) + c];
    }
  for (; i >= lo; --i)
    for (int c = 0; c < NR; ++c) s[0][c] += a[i] * w[NR * i + c];
  for (int c = 0; c < NR; ++c) t[c] = (s[0][c] + s[1][c]) + (s[2][c] + s[3][c]);
}

/// Forward sweep L y = b, in place on Y; W: workspace of NR * (largest nsrow).
template <int NR>
void super_forward(const SuperView& L, double* Y, double* W) {
  for (int sn = 0; sn < L.nsuper; ++sn) {
    const int k1 = L.super[sn], nscol = L.super[sn + 1] - k1;
    const int nsrow = L.pi[sn + 1] - L.pi[sn];
    const double* A = L.x + L.px[sn];
    const int* rows = L.s + L.pi[sn];
    double* y = Y + static_cast<std::ptrdiff_t>(NR) * k1;
    std::copy(y, y + NR * nscol, W);
    std::fill(W + NR * nscol, W + NR * nsrow, 0.0);
    for (int j = 0; j < nscol; ++j) {
      const double* a = A + static_cast<std::ptrdiff_t>(j) * nsrow;
      double x[NR];
      for (int c = 0; c < NR; ++c) W[NR * j + c] = x[c] = W[NR * j + c] / a[j];
      axpy_rows<NR>(a, x, W, j + 1, nsrow);
    }
    std::copy(W, W + NR * nscol, y);
    for (int i = nscol; i < nsrow; ++i)
      for (int c = 0; c < NR; ++c)
        Y[NR * static_cast<std::ptrdiff_t>(rows[i]) + c] += W[NR * i + c];
  }
}

/// Backward sweep L^T x = y, in place on Y.
template <int NR>
void super_backward(const SuperView& L, double* Y, double* W) {
  for (int sn = L.nsuper - 1; sn >= 0; --sn) {
    const int k1 = L.super[sn], nscol = L.super[sn + 1] - k1;
    const int nsrow = L.pi[sn + 1] - L.pi[sn];
    const double* A = L.x + L.px[sn];
    const int* rows = L.s + L.pi[sn];
    double* y = Y + static_cast<std::ptrdiff_t>(NR) * k1;
    for (int i = nsrow - 1; i >= nscol; --i)
      for (int c = 0; c < NR; ++c) W[NR * i + c] = Y[NR * static_cast<std::ptrdiff_t>(rows[i]) + c];
    for (int j = nscol - 1; j >= 0; --j) {
      const double* a = A + static_cast<std::ptrdiff_t>(j) * nsrow;
      double t[NR];
      dot_rows_desc<NR>(a, W, j + 1, nsrow, t);
      for (int c = 0; c < NR; ++c) W[NR * j + c] = (y[NR * j + c] - t[c]) / a[j];
    }
    std::copy(W, W + NR * nscol, y);
  }
}

}  // namespace

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

/// One distinct Dirichlet set. Rows of the work block are in the factor's fill-reducing order:
/// row k is the free node node[k] (= free_nodes[L->Perm[k]]), so the permutation that
/// cholmod_solve would apply is folded into the gather and the scatter.
struct GlobalStep::Group {
  std::vector<int> components;
  std::vector<int> node;  ///< #free, mesh node of each row of the permuted system
  Eigen::MatrixXd shift;  ///< #free x #components, K_fd u_d in the permuted order, constant
  cholmod_common common;  ///< one per group: groups may be solved concurrently
  cholmod_factor* L = nullptr;
  Storage storage = Storage::Supernodal;
  std::vector<double> Yi, Ei;  ///< Supernodal: interleaved #free x #components block; W buffer
  cholmod_dense* Y = nullptr;  ///< CHOLMOD paths: #free x #components, column-major
  cholmod_dense* E = nullptr;  ///< CholmodSupernodal: workspace, #components x L->maxesize
  cholmod_dense* X = nullptr;  ///< Simplicial: solution returned by cholmod_solve2
  cholmod_dense* W = nullptr;  ///< Simplicial: cholmod_solve2 workspaces
  cholmod_dense* W2 = nullptr;
  double lnz = 0;

  Group() {
    cholmod_start(&common);
    common.print = 1;  // errors only: a non-positive-definite matrix is reported by us
  }
  ~Group() {
    cholmod_free_dense(&W2, &common);
    cholmod_free_dense(&W, &common);
    cholmod_free_dense(&X, &common);
    cholmod_free_dense(&E, &common);
    cholmod_free_dense(&Y, &common);
    cholmod_free_factor(&L, &common);
    cholmod_finish(&common);
  }
  int rows() const { return static_cast<int>(node.size()); }
  int cols() const { return static_cast<int>(components.size()); }

  /// Element (k, j) of the right-hand side / solution block is at data()[k * rs() + j * cs()].
  double* data() { return storage == Storage::Supernodal ? Yi.data() : static_cast<double*>(Y->x); }
  std::ptrdiff_t rs() const { return storage == Storage::Supernodal ? cols() : 1; }
  std::ptrdiff_t cs() const { return storage == Storage::Supernodal ? 1 : rows(); }

  /// The block <- K_ff^{-1} block (both sweeps, no permutation: the block is already permuted).
  /// Returns where the solution is (same layout).
  const double* solve_in_place() {
    switch (storage) {
      case Storage::Supernodal: {
        const SuperView v(L);
        switch (cols()) {
          case 1:
            super_forward<1>(v, Yi.data(), Ei.data());
            super_backward<1>(v, Yi.data(), Ei.data());
            break;
          case 2:
            super_forward<2>(v, Yi.data(), Ei.data());
            super_backward<2>(v, Yi.data(), Ei.data());
            break;
          default:
            super_forward<3>(v, Yi.data(), Ei.data());
            super_backward<3>(v, Yi.data(), Ei.data());
        }
        return Yi.data();
      }
      case Storage::CholmodSupernodal:
        cholmod_super_lsolve(L, Y, E, &common);
        cholmod_super_ltsolve(L, Y, E, &common);
        return static_cast<const double*>(Y->x);
      default:
        // CHOLMOD_LDLt on an LL' factor is L L' x = b, without L->Perm.
        cholmod_solve2(CHOLMOD_LDLt, L, Y, nullptr, &X, nullptr, &W, &W2, &common);
        return static_cast<const double*>(X->x);
    }
  }
};

GlobalStep::GlobalStep(const SpMat& K, const DirichletData& bc, Storage storage) : bc_(bc) {
  using clock = std::chrono::steady_clock;
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
    // K_ff (lower triangle is enough for CHOLMOD) and the constant shift K_fd u_d.
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
    Kff.makeCompressed();
    cholmod_sparse A{};
    A.nrow = A.ncol = static_cast<size_t>(nf);
    A.nzmax = static_cast<size_t>(Kff.nonZeros());
    A.p = Kff.outerIndexPtr();
    A.i = Kff.innerIndexPtr();
    A.x = Kff.valuePtr();
    A.stype = -1;  // symmetric, lower triangle stored
    A.itype = CHOLMOD_INT;
    A.xtype = CHOLMOD_REAL;
    A.dtype = CHOLMOD_DOUBLE;
    A.sorted = 1;
    A.packed = 1;
    // Supernodal LL' factorization (BLAS-3, fast for every size), kept as is.
    g.common.supernodal = CHOLMOD_SUPERNODAL;
    g.common.final_asis = 1;
    bool induced = !base_order.empty();
    for (int i = 0; i < n && induced; ++i)
      if (local[i] >= 0 && !base_free[i]) induced = false;
    std::vector<int> user_perm;
    if (induced) {
      g.common.nmethods = 1;
      g.common.method[0].ordering = CHOLMOD_GIVEN;
      user_perm.reserve(nf);
      for (int node : base_order)
        if (local[node] >= 0) user_perm.push_back(local[node]);
    } else {
      g.common.nmethods = 3;
      g.common.method[0].ordering = CHOLMOD_AMD;
      g.common.method[1].ordering = CHOLMOD_METIS;
      g.common.method[2].ordering = CHOLMOD_NESDIS;
    }
    const auto t0 = clock::now();
    g.L = cholmod_analyze_p(&A, induced ? user_perm.data() : nullptr, nullptr, 0, &g.common);
    const auto t1 = clock::now();
    const bool ok = g.L && cholmod_factorize(&A, g.L, &g.common) && g.L->minor == g.L->n;
    const auto t2 = clock::now();
    if (!g.L || g.common.status < CHOLMOD_OK)
      throw Error(cat("global matrix (4.5): CHOLMOD failed (status ", g.common.status,
                      "; out of memory?) for ", nf, " free nodes"));
    analyze_seconds_ += std::chrono::duration<double>(t1 - t0).count();
    factorize_seconds_ += std::chrono::duration<double>(t2 - t1).count();
    g.lnz = g.common.lnz;
    factor_nnz_ += g.lnz;
    const double rcond = ok ? cholmod_rcond(g.L, &g.common) : 0.0;
    min_rcond_ = std::min(min_rcond_, rcond);
    if (!ok || !(rcond > kMinRcond)) {
      std::string comps;
      for (int c : g.components) comps += std::string(comps.empty() ? "" : ", ") + "xyz"[c];
      throw Error(
          cat("global matrix (4.5): the Cholesky factorization failed for displacement "
              "component(s) ",
              comps, " (", nf, " free nodes, condition estimate ", rcond,
              "): the matrix is singular or not positive definite. ",
              "Most likely a rigid motion is not removed: fix part of the boundary, add "
              "a symmetry plane, or give the contact surface q_c > 0."));
    }
    g.storage = storage == Storage::Auto ? Storage::Supernodal : storage;
    if (g.storage == Storage::Simplicial) {
      // simplicial LL', packed, monotonic: same numbers, column storage
      if (!cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, g.L, &g.common))
        throw Error(cat("global matrix (4.5): CHOLMOD could not convert the factor (status ",
                        g.common.status, ")"));
    }
    // The permuted order of the rows, and the work blocks (allocated once).
    const int* perm = static_cast<const int*>(g.L->Perm);
    g.node.resize(nf);
    g.shift.resize(nf, nc);
    for (int k = 0; k < nf; ++k) {
      const int j = perm ? perm[k] : k;
      g.node[k] = free_nodes[j];
      g.shift.row(k) = shift.row(j);
    }
    if (base_order.empty()) {
      base_order = g.node;
      for (int node : free_nodes) base_free[node] = 1;
    }
    if (g.storage == Storage::Supernodal) {
      g.Yi.resize(static_cast<std::size_t>(nf) * nc);
      const int* pi = static_cast<const int*>(g.L->pi);
      int maxrow = 0;
      for (std::size_t sn = 0; sn < g.L->nsuper; ++sn)
        maxrow = std::max(maxrow, pi[sn + 1] - pi[sn]);
      g.Ei.resize(static_cast<std::size_t>(maxrow) * nc);
    } else {
      g.Y = cholmod_allocate_dense(nf, nc, nf, CHOLMOD_REAL, &g.common);
      if (g.storage == Storage::CholmodSupernodal)
        g.E = cholmod_allocate_dense(nc, g.L->maxesize, nc, CHOLMOD_REAL, &g.common);
      if (!g.Y || (g.storage == Storage::CholmodSupernodal && !g.E))
        throw Error(cat("global matrix (4.5): out of memory for the solve workspace"));
    }
  }
}

GlobalStep::~GlobalStep() = default;

int GlobalStep::factor_rows(int k) const {
  return static_cast<int>(groups_.at(k)->node.size());
}
int GlobalStep::factor_columns(int k) const {
  return static_cast<int>(groups_.at(k)->components.size());
}
double GlobalStep::factor_nonzeros(int k) const {
  return groups_.at(k)->lnz;
}
double GlobalStep::factor_entries(int k) const {
  const cholmod_factor* L = groups_.at(k)->L;
  return static_cast<double>(L->is_super ? L->xsize : L->nzmax);
}
GlobalStep::Storage GlobalStep::storage(int k) const {
  return groups_.at(k)->storage;
}

void GlobalStep::solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u) {
  const auto t0 = std::chrono::steady_clock::now();
  u.resize(b.rows(), b.cols());
  const int ng = static_cast<int>(groups_.size());
  double work = 0;
  for (const auto& g : groups_) work += g->lnz;
  auto one = [&](Group& g) {
    const int nf = g.rows(), nc = g.cols();
    const std::ptrdiff_t rs = g.rs(), cs = g.cs();
    double* y = g.data();
    for (int k = 0; k < nc; ++k) {  // block = (b - K_fd u_d) on the free nodes, permuted
      const double* bk = b.col(g.components[k]).data();
      const double* sh = g.shift.col(k).data();
      double* yk = y + k * cs;
      for (int i = 0; i < nf; ++i) yk[i * rs] = bk[g.node[i]] - sh[i];
    }
    const double* x = g.solve_in_place();
    for (int k = 0; k < nc; ++k) {
      const int c = g.components[k];
      double* uc = u.col(c).data();
      const double* xk = x + k * cs;
      for (int i = 0; i < nf; ++i) uc[g.node[i]] = xk[i * rs];
      for (int i : bc_.fixed[c]) uc[i] = bc_.value(i, c);
    }
  };
  // Distinct factors are independent (and each has its own cholmod_common): solve them
  // concurrently when they are worth a parallel region.
#pragma omp parallel for schedule(dynamic, 1) if (ng > 1 && work >= kParallelMinNnz)
  for (int k = 0; k < ng; ++k) one(*groups_[k]);
  solve_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ++solve_calls_;
}

}  // namespace ltl
