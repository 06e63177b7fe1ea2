// GMRES with the augmented-Lagrangian block preconditioner and GAMG for a Newton step's KKT
// system; see newton_krylov.hpp.
#include "newton_krylov.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "cg_amg.hpp"  // initialize_petsc
#include "error.hpp"
#include "mpi_comm.hpp"

#ifdef LTL_HAVE_PETSC
#include <petscksp.h>
#endif

namespace ltl {

bool NewtonKrylov::available() {
#ifdef LTL_HAVE_PETSC
  return true;
#else
  return false;
#endif
}

double NewtonKrylov::option(const char* name, double fallback) {
#ifdef LTL_HAVE_PETSC
  initialize_petsc();
  PetscReal v = fallback;
  PetscBool set = PETSC_FALSE;
  if (PetscOptionsGetReal(nullptr, nullptr, name, &v, &set) || !set) return fallback;
  return v;
#else
  (void)name;
  return fallback;
#endif
}

#ifndef LTL_HAVE_PETSC

struct NewtonKrylov::Impl {};
NewtonKrylov::NewtonKrylov(int, const Eigen::MatrixXd&, const Eigen::MatrixXi&,
                           const std::vector<char>&, const std::vector<int>*) {
  throw Error(
      "Newton's Krylov solves (algorithm.solver = \"newton\" with global_solver = \"cg-amg\") "
      "need PETSc, and this build has none: install it (Debian: apt-get install petsc-dev) and "
      "rebuild with -DLTL_WITH_PETSC=ON, or use global_solver = \"cholesky\"");
}
NewtonKrylov::~NewtonKrylov() = default;
void NewtonKrylov::zero() {}
void NewtonKrylov::add(int, const int*, const double*) {}
void NewtonKrylov::add_row(int, int, const int*, const double*) {}
void NewtonKrylov::finish(double) {}
NewtonKrylov::Result NewtonKrylov::solve(const SpMatR&, const Eigen::VectorXd&, Eigen::VectorXd,
                                         const Eigen::VectorXd&, double, Eigen::VectorXd&,
                                         Eigen::VectorXd&) {
  return {};
}
double NewtonKrylov::matrix_nonzeros() const {
  return 0;
}
int NewtonKrylov::rows() const {
  return 0;
}
bool NewtonKrylov::owns(int) const {
  return true;
}

#else

namespace {
void check(PetscErrorCode ierr, const char* call) {
  if (ierr)
    throw Error(cat("Newton's Krylov solve: PETSc's ", call, " failed (PETSc error ", ierr, ")"));
}
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

struct NewtonKrylov::Impl {
  MPI_Comm comm = PETSC_COMM_SELF;
  int n = 0;        ///< dofs (the u block), every rank's
  int n_own = 0;    ///< this rank's rows of A (n on one process)
  PetscInt r0 = 0;  ///< this rank's first row of A
  /// The row of A of each node's first dof, its dof i at that row + i (empty: a dof's row is the
  /// dof itself, one process; per node, not per dof: #nodes entries, not dim #nodes), and the
  /// first row of each rank's block (P + 1).
  int dim = 1;
  std::vector<PetscInt> node_row;
  std::vector<int> offset;
  std::vector<PetscInt> fixed_rows, idx;  ///< this rank's prescribed rows; a block's rows
  Mat A = nullptr;                        ///< the augmented tangent, every dof
  PC amg = nullptr;
  // The work of a solve: the shell operator [A, G^T; G, 0], its vectors, the blocks' views.
  Mat M = nullptr, G = nullptr;
  Vec x = nullptr, b = nullptr, vu = nullptr, wu = nullptr, vq = nullptr, wq = nullptr;
  Vec t = nullptr;  ///< r_u - G^T y_q
  int m = -1;       ///< this rank's rows of G of the operator M
  const Eigen::VectorXd* schur_inv = nullptr;
  PetscInt at(int k) const {
    return k < 0 ? -1 : (node_row.empty() ? k : node_row[k / dim] + k % dim);
  }
  void release_system() {
    for (Vec* v : {&x, &b, &vq, &wq})
      if (*v) VecDestroy(v);
    if (M) MatDestroy(&M);
  }
  ~Impl() {
    if (!mpi::collective_teardown()) return;  // left to the job's end
    release_system();
    for (Vec* v : {&vu, &wu, &t})
      if (*v) VecDestroy(v);
    if (G) MatDestroy(&G);
    if (amg) PCDestroy(&amg);
    if (A) MatDestroy(&A);
  }
};

namespace {
using CVec = Eigen::Map<const Eigen::VectorXd>;

/// Destroys a PETSc object at the end of a scope, unless it was destroyed before (null then).
template <class T, PetscErrorCode (*destroy)(T*)>
struct Destroyed {
  T& object;
  ~Destroyed() { destroy(&object); }
};

/// A vector of `local` entries (this rank's) of PETSc's layout over comm, viewing an array later
/// (VecPlaceArray).
Vec view(MPI_Comm comm, int local) {
  Vec v = nullptr;
  check(VecCreateMPIWithArray(comm, 1, local, PETSC_DECIDE, nullptr, &v), "VecCreateMPIWithArray");
  return v;
}

/// y = M x: y_u = A x_u + G^T x_q, y_q = G x_u (the blocks: views of this rank's entries).
PetscErrorCode kkt_mult(Mat M, Vec xv, Vec yv) {
  NewtonKrylov::Impl* m = nullptr;
  PetscCall(MatShellGetContext(M, &m));
  const PetscScalar* xa = nullptr;
  PetscScalar* ya = nullptr;
  PetscCall(VecGetArrayRead(xv, &xa));
  PetscCall(VecGetArray(yv, &ya));
  PetscCall(VecPlaceArray(m->vu, xa));
  PetscCall(VecPlaceArray(m->vq, xa + m->n_own));
  PetscCall(VecPlaceArray(m->wu, ya));
  PetscCall(VecPlaceArray(m->wq, ya + m->n_own));
  PetscCall(MatMult(m->A, m->vu, m->wu));
  PetscCall(MatMultTransposeAdd(m->G, m->vq, m->wu, m->wu));
  PetscCall(MatMult(m->G, m->vu, m->wq));
  for (Vec v : {m->vu, m->vq, m->wu, m->wq}) PetscCall(VecResetArray(v));
  PetscCall(VecRestoreArrayRead(xv, &xa));
  PetscCall(VecRestoreArray(yv, &ya));
  return 0;
}

/// y = P^{-1} r, P = [A, G^T; 0, S_hat]: y_q = S_hat^{-1} r_q, y_u = AMG(A)(r_u - G^T y_q).
PetscErrorCode block_apply(PC pc, Vec rv, Vec yv) {
  NewtonKrylov::Impl* m = nullptr;
  PetscCall(PCShellGetContext(pc, &m));
  const PetscScalar* ra = nullptr;
  PetscScalar* ya = nullptr;
  PetscCall(VecGetArrayRead(rv, &ra));
  PetscCall(VecGetArray(yv, &ya));
  const int n = m->n_own, k = m->m;
  for (int i = 0; i < k; ++i) ya[n + i] = (*m->schur_inv)(i)*ra[n + i];
  PetscCall(VecPlaceArray(m->vu, ra));
  PetscCall(VecPlaceArray(m->wq, ya + n));
  PetscCall(VecPlaceArray(m->wu, ya));
  PetscCall(MatMultTranspose(m->G, m->wq, m->t));
  PetscCall(VecAYPX(m->t, -1.0, m->vu));
  PetscCall(PCApply(m->amg, m->t, m->wu));
  for (Vec v : {m->vu, m->wq, m->wu}) PetscCall(VecResetArray(v));
  PetscCall(VecRestoreArrayRead(rv, &ra));
  PetscCall(VecRestoreArray(yv, &ya));
  return 0;
}
}  // namespace

NewtonKrylov::NewtonKrylov(int dim, const Eigen::MatrixXd& X, const Eigen::MatrixXi& cells,
                           const std::vector<char>& fixed, const std::vector<int>* node_rank)
    : impl_(std::make_unique<Impl>()) {
  initialize_petsc();
  Impl& m = *impl_;
  const int nn = static_cast<int>(X.rows()), nc = static_cast<int>(cells.rows());
  const int npc = static_cast<int>(cells.cols());
  m.n = dim * nn;
  m.dim = dim;
  if (static_cast<int>(fixed.size()) != m.n)
    throw Error(cat("NewtonKrylov: ", fixed.size(), " dof flags for ", m.n, " dofs"));
  const int P = mpi::size(), me = mpi::rank();
  const bool split = node_rank && P > 1;
  if (split) {  // a node's dofs on the rows of its rank, nodes in their order within a block
    if (static_cast<int>(node_rank->size()) != nn)
      throw Error(cat("NewtonKrylov: ranks of ", node_rank->size(), " nodes for ", nn, " nodes"));
    m.comm = PETSC_COMM_WORLD;
    m.offset.assign(P + 1, 0);
    for (int a = 0; a < nn; ++a) {
      const int r = (*node_rank)[a];
      if (r < 0 || r >= P) throw Error(cat("NewtonKrylov: node ", a, " on rank ", r, " of ", P));
      m.offset[r + 1] += dim;
    }
    for (int r = 0; r < P; ++r) m.offset[r + 1] += m.offset[r];
    std::vector<int> next(m.offset.begin(), m.offset.end() - 1);
    m.node_row.resize(nn);
    for (int a = 0; a < nn; ++a) {
      m.node_row[a] = next[(*node_rank)[a]];
      next[(*node_rank)[a]] += dim;
    }
    m.r0 = m.offset[me];
    m.n_own = m.offset[me + 1] - m.offset[me];
  } else {
    m.offset = {0, m.n};
    m.n_own = m.n;
  }
  for (int k = 0; k < m.n; ++k)
    if (fixed[k] && owns(k)) m.fixed_rows.push_back(m.at(k));
  check(MatCreate(m.comm, &m.A), "MatCreate");
  check(MatSetSizes(m.A, m.n_own, m.n_own, m.n, m.n), "MatSetSizes");
  check(MatSetType(m.A, split ? MATMPIAIJ : MATSEQAIJ), "MatSetType");
  check(MatSetBlockSize(m.A, dim), "MatSetBlockSize");
  {  // node a couples with every node of its cells, dim x dim blocks: counted per owned row, in
     // this rank's columns (the diagonal block) and in other ranks' (the off-diagonal block)
    std::vector<int> start(nn + 1, 0), cells_of(static_cast<std::size_t>(nc) * npc);
    for (int e = 0; e < nc; ++e)
      for (int j = 0; j < npc; ++j) ++start[cells(e, j) + 1];
    for (int a = 0; a < nn; ++a) start[a + 1] += start[a];
    {
      std::vector<int> fill(start.begin(), start.end() - 1);
      for (int e = 0; e < nc; ++e)
        for (int j = 0; j < npc; ++j) cells_of[fill[cells(e, j)]++] = e;
    }
    std::vector<PetscInt> dnz(m.n_own, 0), onz(m.n_own, 0);
    std::vector<int> stamp(nn, -1);
    for (int a = 0; a < nn; ++a) {
      if (!owns(dim * a)) continue;
      int here = 0, there = 0;
      for (int k = start[a]; k < start[a + 1]; ++k)
        for (int j = 0; j < npc; ++j) {
          const int b = cells(cells_of[k], j);
          if (stamp[b] != a) stamp[b] = a, ++(owns(dim * b) ? here : there);
        }
      for (int i = 0; i < dim; ++i) {
        dnz[m.at(dim * a + i) - m.r0] = dim * std::max(here, 1);
        onz[m.at(dim * a + i) - m.r0] = dim * there;
      }
    }
    check(MatSeqAIJSetPreallocation(m.A, 0, dnz.data()), "MatSeqAIJSetPreallocation");
    check(MatMPIAIJSetPreallocation(m.A, 0, dnz.data(), 0, onz.data()),
          "MatMPIAIJSetPreallocation");
  }
  {  // the rigid-body modes of the coordinates (translations, rotations), this rank's nodes
    Vec coords;
    check(VecCreateMPI(m.comm, m.n_own, m.n, &coords), "VecCreateMPI");
    check(VecSetBlockSize(coords, dim), "VecSetBlockSize");
    PetscScalar* c = nullptr;
    check(VecGetArray(coords, &c), "VecGetArray");
    for (int a = 0; a < nn; ++a)
      if (owns(dim * a))
        for (int i = 0; i < dim; ++i) c[m.at(dim * a + i) - m.r0] = X(a, i);
    check(VecRestoreArray(coords, &c), "VecRestoreArray");
    MatNullSpace nsp = nullptr;
    check(MatNullSpaceCreateRigidBody(coords, &nsp), "MatNullSpaceCreateRigidBody");
    check(MatSetNearNullSpace(m.A, nsp), "MatSetNearNullSpace");
    MatNullSpaceDestroy(&nsp);
    VecDestroy(&coords);
  }
  check(PCCreate(m.comm, &m.amg), "PCCreate");
  check(PCSetType(m.amg, PCGAMG), "PCSetType");
  check(PCGAMGSetType(m.amg, PCGAMGAGG), "PCGAMGSetType");
  check(PCSetOptionsPrefix(m.amg, "ltl_newton_amg_"), "PCSetOptionsPrefix");
  // Our default, unless given: 4 Chebyshev iterations (of Jacobi, GAMG's smoother) on every
  // level, where GAMG's default is 2 (paper_notes/newton.md, "Krylov solves": SSOR does better on
  // small gutters, but its block inverses meet singular node blocks of the coarse operators).
  {
    const char* name = "-ltl_newton_amg_mg_levels_ksp_max_it";
    PetscBool given = PETSC_FALSE;
    check(PetscOptionsHasName(nullptr, nullptr, name, &given), "PetscOptionsHasName");
    if (!given) check(PetscOptionsSetValue(nullptr, name, "4"), "PetscOptionsSetValue");
  }
  check(PCSetFromOptions(m.amg), "PCSetFromOptions");
  m.vu = view(m.comm, m.n_own);
  m.wu = view(m.comm, m.n_own);
  check(VecCreateMPI(m.comm, m.n_own, m.n, &m.t), "VecCreateMPI");
}

NewtonKrylov::~NewtonKrylov() = default;

bool NewtonKrylov::owns(int k) const {
  const PetscInt r = impl_->at(k);
  return r >= impl_->r0 && r < impl_->r0 + impl_->n_own;
}

void NewtonKrylov::zero() {
  check(MatZeroEntries(impl_->A), "MatZeroEntries");
}

void NewtonKrylov::add(int n, const int* dofs, const double* v) {
  Impl& m = *impl_;
  m.idx.resize(n);
  for (int j = 0; j < n; ++j) m.idx[j] = m.at(dofs[j]);
  check(MatSetValues(m.A, n, m.idx.data(), n, m.idx.data(), v, ADD_VALUES), "MatSetValues");
}

void NewtonKrylov::add_row(int row, int n, const int* cols, const double* v) {
  Impl& m = *impl_;
  m.idx.resize(n);
  for (int j = 0; j < n; ++j) m.idx[j] = m.at(cols[j]);
  const PetscInt r = m.at(row);
  check(MatSetValues(m.A, 1, &r, n, m.idx.data(), v, ADD_VALUES), "MatSetValues");
}

void NewtonKrylov::finish(double fixed_diagonal) {
  Impl& m = *impl_;
  for (PetscInt r : m.fixed_rows)
    check(MatSetValue(m.A, r, r, fixed_diagonal, ADD_VALUES), "MatSetValue");
  check(MatAssemblyBegin(m.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(m.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
}

double NewtonKrylov::matrix_nonzeros() const {
  MatInfo info;
  if (MatGetInfo(impl_->A, MAT_LOCAL, &info)) return 0.0;
  return info.nz_used;
}

int NewtonKrylov::rows() const {
  return impl_->n_own;
}

NewtonKrylov::Result NewtonKrylov::solve(const SpMatR& G, const Eigen::VectorXd& schur_inv,
                                         Eigen::VectorXd f, const Eigen::VectorXd& g, double rtol,
                                         Eigen::VectorXd& du, Eigen::VectorXd& dq) {
  Impl& m = *impl_;
  Result res;
  const int k = static_cast<int>(G.rows());
  if (G.cols() != m.n || schur_inv.size() != k || f.size() != m.n || g.size() != k)
    throw Error("NewtonKrylov::solve: the sizes of G, schur_inv, f and g do not match");
  auto t0 = std::chrono::steady_clock::now();
  // f's parts added into this rank's rows of the u block (theirs travel at the assembly); then f,
  // whole-size, is released before the AMG set-up and GMRES's basis are made.
  Vec bu = nullptr;
  check(VecDuplicate(m.t, &bu), "VecDuplicate");
  const Destroyed<Vec, VecDestroy> bu_guard{bu};
  {
    std::vector<PetscInt> rows;
    std::vector<PetscScalar> values;
    for (int j = 0; j < m.n; ++j)
      if (f(j) != 0) rows.push_back(m.at(j)), values.push_back(f(j));
    Eigen::VectorXd().swap(f);
    check(VecSetValues(bu, static_cast<PetscInt>(rows.size()), rows.data(), values.data(),
                       ADD_VALUES),
          "VecSetValues");
  }
  check(VecAssemblyBegin(bu), "VecAssemblyBegin");
  check(VecAssemblyEnd(bu), "VecAssemblyEnd");
  // The V-cycle of this A: GAMG's hierarchy set up again (the values changed).
  check(PCSetOperators(m.amg, m.A, m.A), "PCSetOperators");
  check(PCSetUp(m.amg), "PCSetUp (the AMG hierarchy of the augmented tangent)");
  res.setup_seconds = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  m.schur_inv = &schur_inv;
  // The system's layout: this rank's rows of A, then its k rows of G; made again when a rank's k
  // changed (the active contact rows), on every rank (PETSc's layouts are collective).
  double changed = m.m != k;
  if (!m.node_row.empty()) mpi::max(&changed, 1);
  if (changed > 0) {
    m.release_system();
    const int local = m.n_own + k;
    check(MatCreateShell(m.comm, local, local, PETSC_DETERMINE, PETSC_DETERMINE, &m, &m.M),
          "MatCreateShell");
    check(MatShellSetOperation(m.M, MATOP_MULT, reinterpret_cast<void (*)(void)>(kkt_mult)),
          "MatShellSetOperation");
    check(MatCreateVecs(m.M, &m.x, &m.b), "MatCreateVecs");
    m.vq = view(m.comm, k);
    m.wq = view(m.comm, k);
    m.m = k;
  }
  {  // G in PETSc's layout: this rank's k rows, the columns of A's rows
    if (m.G) MatDestroy(&m.G);
    std::vector<PetscInt> dnz(k, 0), onz(k, 0), cols;
    std::vector<PetscScalar> vals;
    for (int i = 0; i < k; ++i)
      for (SpMatR::InnerIterator it(G, i); it; ++it)
        ++(owns(static_cast<int>(it.col())) ? dnz[i] : onz[i]);
    check(
        MatCreateAIJ(m.comm, k, m.n_own, PETSC_DETERMINE, m.n, 0, dnz.data(), 0, onz.data(), &m.G),
        "MatCreateAIJ");
    PetscInt g0 = 0;
    check(MatGetOwnershipRange(m.G, &g0, nullptr), "MatGetOwnershipRange");
    for (int i = 0; i < k; ++i) {
      cols.clear();
      vals.clear();
      for (SpMatR::InnerIterator it(G, i); it; ++it) {
        cols.push_back(m.at(static_cast<int>(it.col())));
        vals.push_back(it.value());
      }
      const PetscInt r = g0 + i;
      check(MatSetValues(m.G, 1, &r, static_cast<PetscInt>(cols.size()), cols.data(), vals.data(),
                         INSERT_VALUES),
            "MatSetValues");
    }
    check(MatAssemblyBegin(m.G, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
    check(MatAssemblyEnd(m.G, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
  }
  {  // b: f's rows of this rank (bu), then g
    const PetscScalar* cu = nullptr;
    PetscScalar* a = nullptr;
    check(VecGetArrayRead(bu, &cu), "VecGetArrayRead");
    check(VecGetArray(m.b, &a), "VecGetArray");
    std::copy(cu, cu + m.n_own, a);
    std::copy(g.data(), g.data() + k, a + m.n_own);
    check(VecRestoreArray(m.b, &a), "VecRestoreArray");
    check(VecRestoreArrayRead(bu, &cu), "VecRestoreArrayRead");
    VecDestroy(&bu);  // (null for the guard)
  }
  check(VecSet(m.x, 0.0), "VecSet");
  KSP ksp = nullptr;
  check(KSPCreate(m.comm, &ksp), "KSPCreate");
  const Destroyed<KSP, KSPDestroy> guard{ksp};
  check(KSPSetOperators(ksp, m.M, m.M), "KSPSetOperators");
  check(KSPSetType(ksp, KSPGMRES), "KSPSetType");
  check(KSPGMRESSetRestart(ksp, kRestart), "KSPGMRESSetRestart");
  check(KSPSetPCSide(ksp, PC_RIGHT), "KSPSetPCSide");
  check(KSPSetNormType(ksp, KSP_NORM_UNPRECONDITIONED), "KSPSetNormType");
  check(KSPSetTolerances(ksp, rtol, 0.0, 1e30, kMaxIterations), "KSPSetTolerances");
  PC pc;
  check(KSPGetPC(ksp, &pc), "KSPGetPC");
  check(PCSetType(pc, PCSHELL), "PCSetType");
  check(PCShellSetContext(pc, &m), "PCShellSetContext");
  check(PCShellSetApply(pc, block_apply), "PCShellSetApply");
  check(KSPSetOptionsPrefix(ksp, "ltl_newton_"), "KSPSetOptionsPrefix");
  check(KSPSetFromOptions(ksp), "KSPSetFromOptions");
  check(KSPSolve(ksp, m.b, m.x), "KSPSolve");
  KSPConvergedReason reason;
  PetscInt its = 0;
  PetscReal rn = 0, bn = 0;
  KSPGetConvergedReason(ksp, &reason);
  KSPGetIterationNumber(ksp, &its);
  KSPGetResidualNorm(ksp, &rn);
  VecNorm(m.b, NORM_2, &bn);
  res.iterations = static_cast<int>(its);
  res.residual = bn > 0 ? rn / bn : 0.0;
  res.converged = reason > 0;
  if (!res.converged) res.reason = KSPConvergedReasons[reason];
  KSPDestroy(&ksp);  // GMRES's basis released before du is gathered whole (null for the guard)
  // du whole on every rank: the ranks' blocks of rows gathered, in the dofs' order; dq this
  // rank's rows.
  const PetscScalar* c = nullptr;
  check(VecGetArrayRead(m.x, &c), "VecGetArrayRead");
  dq = CVec(c + m.n_own, k);
  if (m.node_row.empty()) {
    du = CVec(c, m.n);
  } else {
    std::vector<double> rows(m.n);
    std::copy(c, c + m.n_own, rows.begin() + m.r0);
    mpi::gather(rows.data(), m.offset);
    du.resize(m.n);
    for (int j = 0; j < m.n; ++j) du(j) = rows[m.at(j)];
  }
  check(VecRestoreArrayRead(m.x, &c), "VecRestoreArrayRead");
  res.solve_seconds = seconds_since(t0);
  return res;
}

#endif

}  // namespace ltl
