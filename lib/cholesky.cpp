// Sparse Cholesky: CHOLMOD's supernodal factorization, our own supernodal sweeps (cholesky.hpp).
#include "cholesky.hpp"

#include <cholmod.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include <algorithm>
#include <chrono>

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

/// CHOLMOD's view of the lower triangle `lower` (compressed), without a copy.
cholmod_sparse lower_view(SpMat& lower) {
  cholmod_sparse S{};
  S.nrow = S.ncol = static_cast<size_t>(lower.rows());
  S.nzmax = static_cast<size_t>(lower.nonZeros());
  S.p = lower.outerIndexPtr();
  S.i = lower.innerIndexPtr();
  S.x = lower.valuePtr();
  S.stype = -1;  // symmetric, lower triangle stored
  S.itype = CHOLMOD_INT;
  S.xtype = CHOLMOD_REAL;
  S.dtype = CHOLMOD_DOUBLE;
  S.sorted = 1;
  S.packed = 1;
  return S;
}

}  // namespace

/// CHOLMOD's state and the factor it owns (freed together, also when the constructor throws).
struct Cholesky::Common {
  cholmod_common c;
  cholmod_factor* L = nullptr;
  Common() {
    cholmod_start(&c);
    c.print = 1;  // errors only: a non-positive-definite matrix is reported by us
  }
  ~Common() {
    cholmod_free_factor(&L, &c);
    cholmod_finish(&c);
  }
};

Cholesky::Cholesky(const SpMat& A, int columns, const std::string& what, const std::string& hint,
                   const std::vector<int>& order)
    : common_(std::make_unique<Common>()), n_(static_cast<int>(A.rows())), columns_(columns) {
  using clock = std::chrono::steady_clock;
  if (columns < 1 || columns > 3)
    throw Error(cat(what, ": ", columns, " right-hand sides per solve; the sweeps take 1 to 3"));
  if (!order.empty() && static_cast<int>(order.size()) != n_)
    throw Error(cat(what, ": a given order of ", order.size(), " rows for ", n_, " rows"));
  SpMat lower = A.triangularView<Eigen::Lower>();
  lower.makeCompressed();
  cholmod_sparse S = lower_view(lower);
  cholmod_common& cm = common_->c;
  // Supernodal LL' factorization (BLAS-3, fast for every size), kept as is.
  cm.supernodal = CHOLMOD_SUPERNODAL;
  cm.final_asis = 1;
  std::vector<int> given = order;
  if (!given.empty()) {
    cm.nmethods = 1;
    cm.method[0].ordering = CHOLMOD_GIVEN;
  } else {
    cm.nmethods = 3;
    cm.method[0].ordering = CHOLMOD_AMD;
    cm.method[1].ordering = CHOLMOD_METIS;
    cm.method[2].ordering = CHOLMOD_NESDIS;
  }
  const auto t0 = clock::now();
  L_ = common_->L = cholmod_analyze_p(&S, given.empty() ? nullptr : given.data(), nullptr, 0, &cm);
  const auto t1 = clock::now();
  const bool ok = L_ && cholmod_factorize(&S, L_, &cm) && L_->minor == L_->n;
  const auto t2 = clock::now();
  if (!L_ || cm.status < CHOLMOD_OK)
    throw Error(cat(what, ": CHOLMOD failed (status ", cm.status, "; out of memory?)"));
  analyze_seconds_ = std::chrono::duration<double>(t1 - t0).count();
  factorize_seconds_ = std::chrono::duration<double>(t2 - t1).count();
  lnz_ = cm.lnz;
  rcond_ = ok ? cholmod_rcond(L_, &cm) : 0.0;
  if (!ok || !(rcond_ > kMinRcond))
    throw Error(cat(what, ": the Cholesky factorization failed (condition estimate ", rcond_,
                    "): the matrix is singular or not positive definite. ", hint));
  const int* p = static_cast<const int*>(L_->Perm);
  perm_.resize(n_);
  for (int k = 0; k < n_; ++k) perm_[k] = p ? p[k] : k;
  // The work blocks, allocated once.
  block_.assign(static_cast<std::size_t>(n_) * columns_, 0.0);
  const int* pi = static_cast<const int*>(L_->pi);
  int maxrow = 0;
  for (std::size_t sn = 0; sn < L_->nsuper; ++sn) maxrow = std::max(maxrow, pi[sn + 1] - pi[sn]);
  work_.resize(static_cast<std::size_t>(maxrow) * columns_);
}

Cholesky::~Cholesky() = default;

double Cholesky::predicted_nonzeros(const SpMat& A) {
  SpMat lower = A.triangularView<Eigen::Lower>();
  lower.makeCompressed();
  cholmod_sparse S = lower_view(lower);
  Common common;
  common.c.nmethods = 1;
  common.c.method[0].ordering = CHOLMOD_AMD;
  common.c.supernodal = CHOLMOD_SIMPLICIAL;  // the count only: no supernodal symbolic pass
  common.L = cholmod_analyze(&S, &common.c);
  if (!common.L) throw Error("the analysis of the global matrix (4.5) failed (out of memory?)");
  return common.c.lnz;
}

double Cholesky::entries() const {
  return static_cast<double>(L_->xsize);
}

void Cholesky::solve_in_place() {
  const SuperView v(L_);
  double *Y = block_.data(), *W = work_.data();
  switch (columns_) {
    case 1:
      super_forward<1>(v, Y, W);
      super_backward<1>(v, Y, W);
      break;
    case 2:
      super_forward<2>(v, Y, W);
      super_backward<2>(v, Y, W);
      break;
    default:
      super_forward<3>(v, Y, W);
      super_backward<3>(v, Y, W);
  }
}

}  // namespace ltl
