// One sparse Cholesky factorization, for the two matrices that ALG2 factorizes once per run: the
// global matrix of (4.5) (global_step.hpp, one factor per distinct Dirichlet set) and the
// Signorini matrix of (7.7) (signorini.hpp).
//
// The factorization is CHOLMOD's supernodal LL' (BLAS-3) with the best (least nnz(L)) of the
// AMD, METIS and nested-dissection orderings, or an order given by the caller. The solves do not
// go through CHOLMOD: the caller gathers its right-hand sides straight into a persistent block in
// the factor's order (the permutation folded into its gather and scatter: nothing is allocated),
// and solve_in_place() sweeps the supernodal factor with our own loops, which read each stored
// entry of L once per sweep for all the columns of the block (cholesky.cpp says why not
// cholmod_solve / cholmod_super_lsolve; paper_notes/performance.md measures it).
//
// A matrix that is not positive definite, or whose reciprocal condition estimate is below
// kMinRcond, is a clear Error naming the matrix and what to check.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "fe.hpp"

struct cholmod_factor_struct;

namespace ltl {

/// The linear solver of the global step (4.5): sparse Cholesky, CG + AMG (PETSc), or chosen by
/// the predicted factor size (global_step.hpp); algorithm.global_solver.
enum class GlobalSolver { Auto, Cholesky, CgAmg };

class Cholesky {
 public:
  /// Factors whose reciprocal condition estimate is below this are refused as singular.
  static constexpr double kMinRcond = 1e-14;

  /// Analyzes and factorizes the symmetric matrix A (its lower triangle is read), for blocks
  /// of `columns` right-hand sides (1 to 3). `order` (optional, a permutation of 0..n-1) is the
  /// fill-reducing order to use: row k of the permuted system is row order[k] of A. On failure
  /// throws Error("<what>: ... <hint>"): `what` names the matrix (and its size), `hint` says
  /// what to check.
  Cholesky(const SpMat& A, int columns, const std::string& what, const std::string& hint,
           const std::vector<int>& order = {});
  ~Cholesky();
  /// nnz(L) of the factor of A (lower triangle read) under the AMD ordering, from CHOLMOD's
  /// symbolic analysis alone: no numerical factorization, memory O(nnz(A)).
  static double predicted_nonzeros(const SpMat& A);
  Cholesky(const Cholesky&) = delete;
  Cholesky& operator=(const Cholesky&) = delete;

  int rows() const { return n_; }
  int columns() const { return columns_; }
  /// The fill-reducing order: row k of the permuted system is row perm()[k] of A.
  const std::vector<int>& perm() const { return perm_; }
  /// The right-hand-side / solution block, in the permuted order with the columns interleaved:
  /// entry (k, j) is block()[columns() * k + j].
  double* block() { return block_.data(); }
  /// block <- A^{-1} block: forward and backward sweeps, allocation-free.
  void solve_in_place();

  double rcond() const { return rcond_; }   ///< CHOLMOD reciprocal condition estimate
  double nonzeros() const { return lnz_; }  ///< nnz(L)
  double entries() const;                   ///< values stored (with supernodal padding)
  double analyze_seconds() const { return analyze_seconds_; }
  double factorize_seconds() const { return factorize_seconds_; }
  /// The CHOLMOD factor itself (the benchmark compares CHOLMOD's own solves on it).
  const cholmod_factor_struct* factor() const { return L_; }

 private:
  struct Common;  // cholmod_common, one per factor: factors may be solved concurrently
  std::unique_ptr<Common> common_;
  cholmod_factor_struct* L_ = nullptr;  ///< owned by common_
  int n_ = 0, columns_ = 0;
  std::vector<int> perm_;
  std::vector<double> block_, work_;
  double rcond_ = 0, lnz_ = 0, analyze_seconds_ = 0, factorize_seconds_ = 0;
};

}  // namespace ltl
