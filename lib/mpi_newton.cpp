// Newton's linear systems by MUMPS over the MPI ranks; see mpi_newton.hpp.
#include "mpi_newton.hpp"

#include <algorithm>
#include <chrono>
#include <string>
#include <tuple>

#include "error.hpp"
#include "mpi_comm.hpp"
#include "mpi_global.hpp"

#ifdef LTL_HAVE_MPI
#include <petscmat.h>
#endif

namespace ltl {

namespace {
NewtonSolveStats stats_;
}  // namespace

NewtonSolveStats& newton_solve_stats() {
  return stats_;
}

NewtonRows::NewtonRows(const std::vector<int>& free_of_dof, int d, const Eigen::MatrixXd& X,
                       int extra) {
  const int nn = static_cast<int>(X.rows()), P = mpi::size();
  int nfree = 0;
  std::vector<int> nodes;  // the nodes with a free dof
  for (int a = 0; a < nn; ++a) {
    bool any = false;
    for (int i = 0; i < d; ++i)
      if (free_of_dof[d * a + i] >= 0) any = true, ++nfree;
    if (any) nodes.push_back(a);
  }
  nodes = slab_order(std::move(nodes), X);
  const std::vector<int> nb = mpi::blocks(static_cast<int>(nodes.size()), P);
  const std::vector<int> eb = mpi::blocks(extra, P);
  perm.assign(nfree + extra, -1);
  offset.assign(P + 1, 0);
  int g = 0;
  for (int r = 0; r < P; ++r) {
    offset[r] = g;
    for (int k = nb[r]; k < nb[r + 1]; ++k)
      for (int i = 0; i < d; ++i)
        if (free_of_dof[d * nodes[k] + i] >= 0) perm[free_of_dof[d * nodes[k] + i]] = g++;
    for (int k = eb[r]; k < eb[r + 1]; ++k) perm[nfree + k] = g++;
  }
  offset[P] = g;
}

#ifndef LTL_HAVE_MPI

bool distributed_newton_solves() {
  return false;
}

struct DistributedCholesky::Impl {};
DistributedCholesky::DistributedCholesky(NewtonRows) {
  throw Error("the distributed Newton solve needs MPI and PETSc: build with -DLTL_WITH_MPI=ON");
}
DistributedCholesky::~DistributedCholesky() = default;
bool DistributedCholesky::factorize(const Eigen::SparseMatrix<double>&) {
  return false;
}
void DistributedCholesky::solve(const Eigen::VectorXd&, Eigen::VectorXd&) {}

struct DistributedLU::Impl {};
DistributedLU::DistributedLU() {
  throw Error("the distributed Newton solve needs MPI and PETSc: build with -DLTL_WITH_MPI=ON");
}
DistributedLU::~DistributedLU() = default;
bool DistributedLU::solve(const Eigen::SparseMatrix<double>&, const NewtonRows&,
                          const Eigen::VectorXd&, Eigen::VectorXd&) {
  return false;
}

#else

bool distributed_newton_solves() {
  return !mpi::option("-ltl_mpi_newton_replicated");
}

namespace {
using SpMat = Eigen::SparseMatrix<double>;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void check(PetscErrorCode ierr, const char* what, const char* call) {
  if (ierr) throw Error(cat(what, ": PETSc's ", call, " failed (PETSc error ", ierr, ")"));
}

/// One distributed MUMPS factorization of a matrix whose owned rows come from the values of a
/// whole (replicated) Eigen matrix: the CSR of the owned rows (global columns) and, per entry,
/// the position of its value in the Eigen matrix's values.
struct Factored {
  const char* what = "";
  std::vector<PetscInt> ia, ja;
  std::vector<int> src;
  std::vector<PetscScalar> va;
  std::vector<double> x;  ///< the solution in the PETSc order, gathered
  std::vector<int> offset;
  std::vector<int> perm;
  int n = 0, first = 0, own = 0;
  Mat A = nullptr, F = nullptr;
  Vec b = nullptr, xv = nullptr;
  ~Factored() { reset(); }
  void reset() {
    if (F) MatDestroy(&F);
    if (A) MatDestroy(&A);
    if (b) VecDestroy(&b);
    if (xv) VecDestroy(&xv);
  }
  /// The owned rows of M under perm; symmetric_lower: M holds the lower triangle of a symmetric
  /// matrix, inserted in both triangles.
  void build(const SpMat& M, const std::vector<int>& p, const std::vector<int>& off,
             bool symmetric_lower) {
    perm = p;
    offset = off;
    const int me = mpi::rank();
    n = offset.back(), first = offset[me], own = offset[me + 1] - first;
    std::vector<std::tuple<int, int, int> > e;  // (owned row, global column, value position)
    for (int c = 0; c < M.outerSize(); ++c)
      for (int q = M.outerIndexPtr()[c]; q < M.outerIndexPtr()[c + 1]; ++q) {
        const int pr = perm[M.innerIndexPtr()[q]], pc = perm[c];
        if (pr >= first && pr < first + own) e.emplace_back(pr - first, pc, q);
        if (symmetric_lower && pr != pc && pc >= first && pc < first + own)
          e.emplace_back(pc - first, pr, q);
      }
    std::sort(e.begin(), e.end());
    ia.assign(own + 1, 0);
    ja.resize(e.size());
    src.resize(e.size());
    va.resize(e.size());
    for (std::size_t k = 0; k < e.size(); ++k) {
      ja[k] = std::get<1>(e[k]);
      src[k] = std::get<2>(e[k]);
      ++ia[std::get<0>(e[k]) + 1];
    }
    for (int r = 0; r < own; ++r) ia[r + 1] += ia[r];
    x.assign(n, 0.0);
  }
  /// The matrix (created at the first call, its values set at the next ones) from M's values.
  void set_values(const SpMat& M) {
    for (std::size_t k = 0; k < src.size(); ++k) va[k] = M.valuePtr()[src[k]];
    if (!A) {
      check(MatCreateMPIAIJWithArrays(PETSC_COMM_WORLD, own, own, n, n, ia.data(), ja.data(),
                                      va.data(), &A),
            what, "MatCreateMPIAIJWithArrays");
      check(MatCreateVecs(A, &xv, &b), what, "MatCreateVecs");
      return;
    }
    for (int r = 0; r < own; ++r) {
      const PetscInt row = first + r;
      check(MatSetValues(A, 1, &row, ia[r + 1] - ia[r], ja.data() + ia[r], va.data() + ia[r],
                         INSERT_VALUES),
            what, "MatSetValues");
    }
    check(MatAssemblyBegin(A, MAT_FINAL_ASSEMBLY), what, "MatAssemblyBegin");
    check(MatAssemblyEnd(A, MAT_FINAL_ASSEMBLY), what, "MatAssemblyEnd");
  }
  /// MUMPS's factor matrix, with PETSc's MUMPS conventions of mpi_global.cpp: twice the
  /// workspace estimate (ICNTL(14) = 100 %); ICNTL(13) = 1: the inertia counted on every front.
  void new_factor(MatFactorType type) {
    check(MatGetFactor(A, MATSOLVERMUMPS, type, &F), what, "MatGetFactor");
    check(MatMumpsSetIcntl(F, 14, 100), what, "MatMumpsSetIcntl");
    if (type == MAT_FACTOR_CHOLESKY) check(MatMumpsSetIcntl(F, 13, 1), what, "MatMumpsSetIcntl");
  }
  /// Did the last factorization fail on some rank (MUMPS's error, a zero pivot)? Collective.
  bool failed() {
    MatFactorError err = MAT_FACTOR_NOERROR;
    check(MatFactorGetError(F, &err), what, "MatFactorGetError");
    double f = err != MAT_FACTOR_NOERROR ? 1.0 : 0.0;
    mpi::sum(&f, 1);
    return f > 0;
  }
  /// x = F^{-1} b: b's owned rows in, the solution gathered to every rank, back in b's order.
  void solve(const Eigen::VectorXd& rhs, Eigen::VectorXd& out) {
    PetscScalar* pb = nullptr;
    check(VecGetArray(b, &pb), what, "VecGetArray");
    for (int k = 0; k < static_cast<int>(perm.size()); ++k)
      if (perm[k] >= first && perm[k] < first + own) pb[perm[k] - first] = rhs(k);
    check(VecRestoreArray(b, &pb), what, "VecRestoreArray");
    check(MatSolve(F, b, xv), what, "MatSolve");
    const PetscScalar* px = nullptr;
    check(VecGetArrayRead(xv, &px), what, "VecGetArrayRead");
    std::copy(px, px + own, x.begin() + first);
    check(VecRestoreArrayRead(xv, &px), what, "VecRestoreArrayRead");
    mpi::gather(x.data(), offset);
    out.resize(static_cast<Eigen::Index>(perm.size()));
    for (int k = 0; k < static_cast<int>(perm.size()); ++k) out(k) = x[perm[k]];
  }
};
}  // namespace

struct DistributedCholesky::Impl {
  NewtonRows rows;
  Factored f;
  bool analyzed = false;
};

DistributedCholesky::DistributedCholesky(NewtonRows rows) : impl_(new Impl{std::move(rows), {}}) {
  impl_->f.what = "Newton's augmented tangent (MUMPS, distributed)";
}
DistributedCholesky::~DistributedCholesky() = default;

// [(2.2), (2.7), (1.1)] The augmented tangent of the Newton step (newton_kkt.cpp), analyzed at the
// first call, factorized numerically at each: positive definite iff MUMPS's LDL' has no
// negative pivot (the inertia), the condition CHOLMOD's LL' checks in the serial solver.
bool DistributedCholesky::factorize(const SpMat& L) {
  Impl& m = *impl_;
  Factored& f = m.f;
  NewtonSolveStats& st = stats_;
  auto t0 = std::chrono::steady_clock::now();
  MatFactorInfo info;
  check(MatFactorInfoInitialize(&info), f.what, "MatFactorInfoInitialize");
  if (!m.analyzed) {
    f.build(L, m.rows.perm, m.rows.offset, true);
    f.set_values(L);
    check(MatSetOption(f.A, MAT_SYMMETRIC, PETSC_TRUE), f.what, "MatSetOption");
    check(MatSetOption(f.A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE), f.what, "MatSetOption");
    f.new_factor(MAT_FACTOR_CHOLESKY);
    check(MatCholeskyFactorSymbolic(f.F, f.A, nullptr, &info), f.what, "MatCholeskyFactorSymbolic");
    m.analyzed = true;
    ++st.mumps_analyses;
    st.mumps_analysis_s += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
  } else {
    f.set_values(L);
  }
  check(MatCholeskyFactorNumeric(f.F, f.A, &info), f.what, "MatCholeskyFactorNumeric");
  ++st.mumps_factorizations;
  bool ok = !f.failed();
  if (ok) {
    PetscInt neg = 0;  // INFOG(12); a zero pivot is MUMPS's failure (INFOG(1) = -10) above
    check(MatGetInertia(f.F, &neg, nullptr, nullptr), f.what, "MatGetInertia");
    ok = neg == 0;
  } else {  // a failed MUMPS instance is not factorized again: analyze afresh next time
    f.reset();
    m.analyzed = false;
  }
  st.mumps_factor_s += seconds_since(t0);
  return ok;
}

void DistributedCholesky::solve(const Eigen::VectorXd& b, Eigen::VectorXd& x) {
  const auto t0 = std::chrono::steady_clock::now();
  impl_->f.solve(b, x);
  ++stats_.mumps_solves;
  stats_.mumps_solve_s += seconds_since(t0);
}

struct DistributedLU::Impl {
  Factored f;
  std::vector<int> outer, inner;  ///< the pattern analyzed
};

DistributedLU::DistributedLU() : impl_(new Impl) {
  impl_->f.what = "Newton's KKT system (MUMPS LU, distributed)";
}
DistributedLU::~DistributedLU() = default;

// [(2.2), (2.7), (1.1)] The KKT system of the Newton step in full (newton_kkt.cpp, lu_step).
bool DistributedLU::solve(const SpMat& A, const NewtonRows& rows, const Eigen::VectorXd& rhs,
                          Eigen::VectorXd& x) {
  Impl& m = *impl_;
  Factored& f = m.f;
  NewtonSolveStats& st = stats_;
  const auto t0 = std::chrono::steady_clock::now();
  const int* o = A.outerIndexPtr();
  const int* in = A.innerIndexPtr();
  const bool same = f.F && m.outer.size() == static_cast<std::size_t>(A.outerSize() + 1) &&
                    std::equal(m.outer.begin(), m.outer.end(), o) &&
                    m.inner.size() == static_cast<std::size_t>(A.nonZeros()) &&
                    std::equal(m.inner.begin(), m.inner.end(), in) && f.perm == rows.perm;
  MatFactorInfo info;
  check(MatFactorInfoInitialize(&info), f.what, "MatFactorInfoInitialize");
  if (!same) {  // a new pattern (the active set, the betas at a bound): analyzed again
    f.reset();
    f.build(A, rows.perm, rows.offset, false);
    f.set_values(A);
    f.new_factor(MAT_FACTOR_LU);
    check(MatLUFactorSymbolic(f.F, f.A, nullptr, nullptr, &info), f.what, "MatLUFactorSymbolic");
    m.outer.assign(o, o + A.outerSize() + 1);
    m.inner.assign(in, in + A.nonZeros());
    ++st.mumps_lu_analyses;
  } else {
    f.set_values(A);
  }
  check(MatLUFactorNumeric(f.F, f.A, &info), f.what, "MatLUFactorNumeric");
  ++st.mumps_lu_factorizations;
  bool ok = !f.failed();
  if (ok) {
    f.solve(rhs, x);
    ok = x.allFinite();
  } else {
    f.reset();
  }
  st.mumps_lu_s += seconds_since(t0);
  return ok;
}

#endif

}  // namespace ltl
