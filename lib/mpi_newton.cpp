// Newton's linear systems by MUMPS over the MPI ranks; see mpi_newton.hpp.
#include "mpi_newton.hpp"

#include <algorithm>
#include <chrono>
#include <string>
#include <tuple>

#include "error.hpp"
#include "mpi_comm.hpp"

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

NewtonRows::NewtonRows(const std::vector<int>& free_of_dof, int d,
                       const std::vector<int>& node_rank, int extra) {
  const int nn = static_cast<int>(node_rank.size()), P = mpi::size();
  if (static_cast<int>(free_of_dof.size()) != d * nn)
    throw Error(
        cat("NewtonRows: ", free_of_dof.size(), " dofs for ", nn, " nodes of dimension ", d));
  std::vector<int> count(P + 1, 0);  // free dofs per rank, then their first PETSc rows
  int nfree = 0;
  for (int a = 0; a < nn; ++a) {
    if (node_rank[a] < 0 || node_rank[a] >= P)
      throw Error(cat("NewtonRows: node ", a, " on rank ", node_rank[a], " of ", P));
    for (int i = 0; i < d; ++i)
      if (free_of_dof[d * a + i] >= 0) ++count[node_rank[a] + 1], ++nfree;
  }
  const std::vector<int> eb = mpi::blocks(extra, P);
  offset.assign(P + 1, 0);
  for (int r = 0; r < P; ++r) offset[r + 1] = offset[r] + count[r + 1] + eb[r + 1] - eb[r];
  perm.assign(nfree + extra, -1);
  std::vector<int> next(offset.begin(), offset.end() - 1);
  for (int a = 0; a < nn; ++a)
    for (int i = 0; i < d; ++i)
      if (const int k = free_of_dof[d * a + i]; k >= 0) perm[k] = next[node_rank[a]]++;
  for (int r = 0; r < P; ++r)
    for (int k = eb[r]; k < eb[r + 1]; ++k) perm[nfree + k] = next[r]++;
}

#ifndef LTL_HAVE_MPI

bool distributed_newton_solves() {
  return false;
}

struct DistributedCholesky::Impl {};
DistributedCholesky::DistributedCholesky(NewtonRows, int, const Eigen::MatrixXi&,
                                         const std::vector<int>&) {
  throw Error("the distributed Newton solve needs MPI and PETSc: build with -DLTL_WITH_MPI=ON");
}
DistributedCholesky::~DistributedCholesky() = default;
void DistributedCholesky::zero() {}
void DistributedCholesky::add(int, const int*, const double*) {}
void DistributedCholesky::add_entry(int, int, double) {}
bool DistributedCholesky::owns(int) const {
  return false;
}
bool DistributedCholesky::factorize() {
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
  ~Factored() {
    if (mpi::collective_teardown()) reset();  // else left to the job's end
  }
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
  /// MUMPS's workspace beyond its own estimate, percent (ICNTL(14)): 20 (MUMPS's default; the
  /// PETSc option -ltl_mumps_workspace sets another, for measurement and the tests) until a
  /// factorization finds it short, then 100 (refactorize_with_more_workspace). Twice the estimate
  /// from the start cost rank 0 of 2 ranks 0.39 GB more on the 102 400-cell gutter (mpi.md).
  int workspace = first_workspace();
  static int first_workspace() {
    PetscInt v = 20;
    PetscBool set = PETSC_FALSE;
    check(PetscOptionsGetInt(nullptr, nullptr, "-ltl_mumps_workspace", &v, &set), "MUMPS",
          "PetscOptionsGetInt");
    return static_cast<int>(v);
  }
  /// MUMPS's factor matrix, with PETSc's MUMPS conventions of mpi_global.cpp: the workspace
  /// above; ICNTL(13) = 1: the inertia counted on every front.
  void new_factor(MatFactorType type) {
    check(MatGetFactor(A, MATSOLVERMUMPS, type, &F), what, "MatGetFactor");
    check(MatMumpsSetIcntl(F, 14, workspace), what, "MatMumpsSetIcntl");
    if (type == MAT_FACTOR_CHOLESKY) check(MatMumpsSetIcntl(F, 13, 1), what, "MatMumpsSetIcntl");
  }
  /// A new factor of A, analyzed (MUMPS's symbolic phase).
  void analyze(MatFactorType type) {
    new_factor(type);
    MatFactorInfo fi;
    check(MatFactorInfoInitialize(&fi), what, "MatFactorInfoInitialize");
    if (type == MAT_FACTOR_CHOLESKY)
      check(MatCholeskyFactorSymbolic(F, A, nullptr, &fi), what, "MatCholeskyFactorSymbolic");
    else
      check(MatLUFactorSymbolic(F, A, nullptr, nullptr, &fi), what, "MatLUFactorSymbolic");
  }
  /// The numerical factorization of the analyzed factor at A's values.
  void factor_numeric(MatFactorType type) {
    MatFactorInfo fi;
    check(MatFactorInfoInitialize(&fi), what, "MatFactorInfoInitialize");
    if (type == MAT_FACTOR_CHOLESKY)
      check(MatCholeskyFactorNumeric(F, A, &fi), what, "MatCholeskyFactorNumeric");
    else
      check(MatLUFactorNumeric(F, A, &fi), what, "MatLUFactorNumeric");
  }
  /// After a failed numerical factorization: when MUMPS found its workspace short (INFOG(1) = -8
  /// or -9, global: the same on every rank) and it was not yet twice the estimate, the factor is
  /// analyzed and factorized again with 100 %; true when it was. Collective.
  bool refactorize_with_more_workspace(MatFactorType type) {
    PetscInt info = 0;
    check(MatMumpsGetInfog(F, 1, &info), what, "MatMumpsGetInfog");
    if ((info != -8 && info != -9) || workspace >= 100) return false;
    workspace = 100;
    MatDestroy(&F);
    analyze(type);
    factor_numeric(type);
    ++stats_.mumps_workspace_retries;
    return true;
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
  std::vector<PetscInt> idx;  ///< add's PETSc indices
};

// The owned rows' pattern: row k (a free dof of node a) holds the free dofs of every node that
// shares a cell with a, both triangles; built from the mesh, without the whole pattern.
DistributedCholesky::DistributedCholesky(NewtonRows rows, int d, const Eigen::MatrixXi& cells,
                                         const std::vector<int>& free_of_dof)
    : impl_(new Impl{std::move(rows), {}, false, {}}) {
  Factored& f = impl_->f;
  f.what = "Newton's augmented tangent (MUMPS, distributed)";
  f.perm = impl_->rows.perm;
  f.offset = impl_->rows.offset;
  const int me = mpi::rank();
  f.n = f.offset.back(), f.first = f.offset[me], f.own = f.offset[me + 1] - f.first;
  const int nn = static_cast<int>(free_of_dof.size()) / d;
  auto owned = [&](int a) {  // does node a have a free dof in this rank's rows?
    for (int i = 0; i < d; ++i) {
      const int k = free_of_dof[d * a + i];
      if (k >= 0 && f.perm[k] >= f.first && f.perm[k] < f.first + f.own) return true;
    }
    return false;
  };
  std::vector<int> local(nn, -1);
  int nl = 0;
  for (int a = 0; a < nn; ++a)
    if (owned(a)) local[a] = nl++;
  std::vector<std::vector<int> > near(nl);  // per owned node, the nodes that share a cell with it
  const int nc = static_cast<int>(cells.rows()), npc = static_cast<int>(cells.cols());
  for (int e = 0; e < nc; ++e)
    for (int p = 0; p < npc; ++p)
      if (const int a = local[cells(e, p)]; a >= 0)
        for (int q = 0; q < npc; ++q) near[a].push_back(cells(e, q));
  std::vector<std::vector<PetscInt> > cols(f.own);
  for (int a = 0; a < nn; ++a) {
    if (local[a] < 0) continue;
    std::vector<int>& m = near[local[a]];
    std::sort(m.begin(), m.end());
    m.erase(std::unique(m.begin(), m.end()), m.end());
    std::vector<PetscInt> c;
    for (int b : m)
      for (int j = 0; j < d; ++j)
        if (free_of_dof[d * b + j] >= 0) c.push_back(f.perm[free_of_dof[d * b + j]]);
    std::sort(c.begin(), c.end());
    for (int i = 0; i < d; ++i)
      if (const int k = free_of_dof[d * a + i]; k >= 0) cols[f.perm[k] - f.first] = c;
    std::vector<int>().swap(m);
  }
  f.ia.assign(f.own + 1, 0);
  for (int r = 0; r < f.own; ++r) f.ia[r + 1] = f.ia[r] + static_cast<PetscInt>(cols[r].size());
  f.ja.resize(f.ia[f.own]);
  for (int r = 0; r < f.own; ++r) std::copy(cols[r].begin(), cols[r].end(), &f.ja[f.ia[r]]);
  f.va.assign(f.ja.size(), 0.0);
  f.x.assign(f.n, 0.0);
  check(MatCreateMPIAIJWithArrays(PETSC_COMM_WORLD, f.own, f.own, f.n, f.n, f.ia.data(),
                                  f.ja.data(), f.va.data(), &f.A),
        f.what, "MatCreateMPIAIJWithArrays");
  check(MatCreateVecs(f.A, &f.xv, &f.b), f.what, "MatCreateVecs");
  check(MatSetOption(f.A, MAT_NEW_NONZERO_LOCATION_ERR, PETSC_TRUE), f.what, "MatSetOption");
  check(MatSetOption(f.A, MAT_SYMMETRIC, PETSC_TRUE), f.what, "MatSetOption");
  check(MatSetOption(f.A, MAT_SYMMETRY_ETERNAL, PETSC_TRUE), f.what, "MatSetOption");
  std::vector<PetscInt>().swap(f.ia);  // PETSc holds its copy
  std::vector<PetscInt>().swap(f.ja);
  std::vector<PetscScalar>().swap(f.va);
}
DistributedCholesky::~DistributedCholesky() = default;

void DistributedCholesky::zero() {
  check(MatZeroEntries(impl_->f.A), impl_->f.what, "MatZeroEntries");
}

void DistributedCholesky::add(int n, const int* free, const double* v) {
  Impl& m = *impl_;
  m.idx.resize(n);
  for (int k = 0; k < n; ++k) m.idx[k] = free[k] >= 0 ? m.f.perm[free[k]] : -1;
  // v is symmetric: its storage order does not matter; negative indices are left out.
  check(MatSetValues(m.f.A, n, m.idx.data(), n, m.idx.data(), v, ADD_VALUES), m.f.what,
        "MatSetValues");
}

void DistributedCholesky::add_entry(int row, int col, double v) {
  const Factored& f = impl_->f;
  check(MatSetValue(f.A, f.perm[row], f.perm[col], v, ADD_VALUES), f.what, "MatSetValue");
}

bool DistributedCholesky::owns(int k) const {
  const Factored& f = impl_->f;
  return f.perm[k] >= f.first && f.perm[k] < f.first + f.own;
}

// [(2.2), (2.7), (1.1)] The augmented tangent of the Newton step (newton_kkt.cpp), its terms
// summed by the assembly, analyzed at the first call, factorized numerically at each: positive
// definite iff MUMPS's LDL' has no negative pivot (the inertia), the condition CHOLMOD's LL'
// checks in the serial solver.
bool DistributedCholesky::factorize() {
  Impl& m = *impl_;
  Factored& f = m.f;
  NewtonSolveStats& st = stats_;
  auto t0 = std::chrono::steady_clock::now();
  check(MatAssemblyBegin(f.A, MAT_FINAL_ASSEMBLY), f.what, "MatAssemblyBegin");
  PetscInt stashed = 0, reallocs = 0, bstashed = 0, breallocs = 0;
  check(MatStashGetInfo(f.A, &stashed, &reallocs, &bstashed, &breallocs), f.what,
        "MatStashGetInfo");
  st.mumps_offrank_entries += stashed + bstashed;
  check(MatAssemblyEnd(f.A, MAT_FINAL_ASSEMBLY), f.what, "MatAssemblyEnd");
  if (!m.analyzed) {
    f.analyze(MAT_FACTOR_CHOLESKY);
    m.analyzed = true;
    ++st.mumps_analyses;
    st.mumps_analysis_s += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
  }
  f.factor_numeric(MAT_FACTOR_CHOLESKY);
  ++st.mumps_factorizations;
  bool ok = !f.failed() || (f.refactorize_with_more_workspace(MAT_FACTOR_CHOLESKY) && !f.failed());
  if (ok) {
    PetscInt neg = 0;  // INFOG(12); a zero pivot is MUMPS's failure (INFOG(1) = -10) above
    check(MatGetInertia(f.F, &neg, nullptr, nullptr), f.what, "MatGetInertia");
    ok = neg == 0;
    PetscInt mb = 0;
    check(MatMumpsGetInfog(f.F, 18, &mb), f.what, "MatMumpsGetInfog");
    st.mumps_factor_bytes = 1e6 * static_cast<double>(mb);
  } else {  // a failed MUMPS instance is not factorized again: analyze afresh next time
    MatDestroy(&f.F);
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
  if (!same) {  // a new pattern (the active set, the betas at a bound): analyzed again
    f.reset();
    f.build(A, rows.perm, rows.offset, false);
    f.set_values(A);
    f.analyze(MAT_FACTOR_LU);
    m.outer.assign(o, o + A.outerSize() + 1);
    m.inner.assign(in, in + A.nonZeros());
    ++st.mumps_lu_analyses;
  } else {
    f.set_values(A);
  }
  f.factor_numeric(MAT_FACTOR_LU);
  ++st.mumps_lu_factorizations;
  bool ok = !f.failed() || (f.refactorize_with_more_workspace(MAT_FACTOR_LU) && !f.failed());
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
