// GMRES with the augmented-Lagrangian block preconditioner and GAMG for a Newton step's KKT
// system; see newton_krylov.hpp.
#include "newton_krylov.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "cg_amg.hpp"  // initialize_petsc
#include "error.hpp"

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
NewtonKrylov::NewtonKrylov(int, const Eigen::MatrixXd&, const std::vector<int>&, int,
                           const std::vector<char>&) {
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
NewtonKrylov::Result NewtonKrylov::solve(const SpMatR&, const Eigen::VectorXd&,
                                         const Eigen::VectorXd&, const Eigen::VectorXd&, double,
                                         Eigen::VectorXd&, Eigen::VectorXd&) {
  return {};
}
double NewtonKrylov::matrix_nonzeros() const {
  return 0;
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
  int n = 0;  ///< dofs (the u block)
  std::vector<PetscInt> fixed_dofs, idx;
  Mat A = nullptr;  ///< the augmented tangent, every dof
  PC amg = nullptr;
  // The work of a solve: the shell operator [A, G^T; G, 0], its vectors, the u block's views.
  Mat M = nullptr;
  Vec x = nullptr, b = nullptr, vu = nullptr, wu = nullptr;
  int m = -1;  ///< rows of G of the operator M
  const SpMatR* G = nullptr;
  const Eigen::VectorXd* schur_inv = nullptr;
  Eigen::VectorXd t;  ///< r_u - G^T y_q
  void release_system() {
    if (M) MatDestroy(&M);
    if (x) VecDestroy(&x);
    if (b) VecDestroy(&b);
  }
  ~Impl() {
    release_system();
    if (vu) VecDestroy(&vu);
    if (wu) VecDestroy(&wu);
    if (amg) PCDestroy(&amg);
    if (A) MatDestroy(&A);
  }
};

namespace {
using CVec = Eigen::Map<const Eigen::VectorXd>;
using MVec = Eigen::Map<Eigen::VectorXd>;

/// op(vu, wu) with vu viewing x and wu viewing y: the u block of the KKT vectors, no copy.
template <class Op>
PetscErrorCode on_u_block(NewtonKrylov::Impl* m, const double* x, double* y, Op op) {
  PetscCall(VecPlaceArray(m->vu, x));
  PetscCall(VecPlaceArray(m->wu, y));
  PetscCall(op(m->vu, m->wu));
  PetscCall(VecResetArray(m->vu));
  PetscCall(VecResetArray(m->wu));
  return 0;
}

/// y = M x: y_u = A x_u + G^T x_q, y_q = G x_u.
PetscErrorCode kkt_mult(Mat M, Vec xv, Vec yv) {
  NewtonKrylov::Impl* m = nullptr;
  PetscCall(MatShellGetContext(M, &m));
  const PetscScalar* xa = nullptr;
  PetscScalar* ya = nullptr;
  PetscCall(VecGetArrayRead(xv, &xa));
  PetscCall(VecGetArray(yv, &ya));
  PetscCall(on_u_block(m, xa, ya, [m](Vec x, Vec y) { return MatMult(m->A, x, y); }));
  const int n = m->n, k = m->G->rows();
  CVec xu(xa, n), xq(xa + n, k);
  MVec yu(ya, n), yq(ya + n, k);
  yu.noalias() += m->G->transpose() * xq;
  yq.noalias() = *m->G * xu;
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
  const int n = m->n, k = m->G->rows();
  MVec yq(ya + n, k);
  yq = m->schur_inv->cwiseProduct(CVec(ra + n, k));
  m->t = CVec(ra, n);
  m->t.noalias() -= m->G->transpose() * yq;
  PetscCall(on_u_block(m, m->t.data(), ya, [m](Vec x, Vec y) { return PCApply(m->amg, x, y); }));
  PetscCall(VecRestoreArrayRead(rv, &ra));
  PetscCall(VecRestoreArray(yv, &ya));
  return 0;
}
}  // namespace

NewtonKrylov::NewtonKrylov(int dim, const Eigen::MatrixXd& X, const std::vector<int>& cell_nodes,
                           int npc, const std::vector<char>& fixed)
    : impl_(std::make_unique<Impl>()) {
  initialize_petsc();
  Impl& m = *impl_;
  const int nn = static_cast<int>(X.rows()), nc = static_cast<int>(cell_nodes.size()) / npc;
  m.n = dim * nn;
  if (static_cast<int>(fixed.size()) != m.n)
    throw Error(cat("NewtonKrylov: ", fixed.size(), " dof flags for ", m.n, " dofs"));
  for (int k = 0; k < m.n; ++k)
    if (fixed[k]) m.fixed_dofs.push_back(k);
  // The pattern: node a couples with every node of its cells, dim x dim blocks.
  std::vector<int> start(nn + 1, 0), cells_of(static_cast<std::size_t>(nc) * npc);
  for (int v : cell_nodes) ++start[v + 1];
  for (int a = 0; a < nn; ++a) start[a + 1] += start[a];
  {
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int e = 0; e < nc; ++e)
      for (int j = 0; j < npc; ++j) cells_of[fill[cell_nodes[e * npc + j]]++] = e;
  }
  std::vector<PetscInt> nnz(m.n);
  std::vector<int> stamp(nn, -1);
  for (int a = 0; a < nn; ++a) {
    int count = 0;
    for (int k = start[a]; k < start[a + 1]; ++k)
      for (int j = 0; j < npc; ++j) {
        const int b = cell_nodes[cells_of[k] * npc + j];
        if (stamp[b] != a) stamp[b] = a, ++count;
      }
    for (int i = 0; i < dim; ++i) nnz[dim * a + i] = dim * std::max(count, 1);
  }
  check(MatCreate(PETSC_COMM_SELF, &m.A), "MatCreate");
  check(MatSetSizes(m.A, m.n, m.n, m.n, m.n), "MatSetSizes");
  check(MatSetType(m.A, MATSEQAIJ), "MatSetType");
  check(MatSetBlockSize(m.A, dim), "MatSetBlockSize");
  check(MatSeqAIJSetPreallocation(m.A, 0, nnz.data()), "MatSeqAIJSetPreallocation");
  {  // the rigid-body modes of the coordinates (translations, rotations)
    Vec coords;
    check(VecCreateSeq(PETSC_COMM_SELF, m.n, &coords), "VecCreateSeq");
    check(VecSetBlockSize(coords, dim), "VecSetBlockSize");
    PetscScalar* c = nullptr;
    check(VecGetArray(coords, &c), "VecGetArray");
    for (int a = 0; a < nn; ++a)
      for (int i = 0; i < dim; ++i) c[dim * a + i] = X(a, i);
    check(VecRestoreArray(coords, &c), "VecRestoreArray");
    MatNullSpace nsp = nullptr;
    check(MatNullSpaceCreateRigidBody(coords, &nsp), "MatNullSpaceCreateRigidBody");
    check(MatSetNearNullSpace(m.A, nsp), "MatSetNearNullSpace");
    MatNullSpaceDestroy(&nsp);
    VecDestroy(&coords);
  }
  check(PCCreate(PETSC_COMM_SELF, &m.amg), "PCCreate");
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
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, m.n, nullptr, &m.vu), "VecCreateSeqWithArray");
  check(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, m.n, nullptr, &m.wu), "VecCreateSeqWithArray");
}

NewtonKrylov::~NewtonKrylov() = default;

void NewtonKrylov::zero() {
  check(MatZeroEntries(impl_->A), "MatZeroEntries");
}

void NewtonKrylov::add(int n, const int* dofs, const double* v) {
  std::vector<PetscInt>& idx = impl_->idx;
  idx.assign(dofs, dofs + n);
  check(MatSetValues(impl_->A, n, idx.data(), n, idx.data(), v, ADD_VALUES), "MatSetValues");
}

void NewtonKrylov::add_row(int row, int n, const int* cols, const double* v) {
  std::vector<PetscInt>& idx = impl_->idx;
  idx.assign(cols, cols + n);
  const PetscInt r = row;
  check(MatSetValues(impl_->A, 1, &r, n, idx.data(), v, ADD_VALUES), "MatSetValues");
}

void NewtonKrylov::finish(double fixed_diagonal) {
  Impl& m = *impl_;
  for (PetscInt k : m.fixed_dofs)
    check(MatSetValue(m.A, k, k, fixed_diagonal, ADD_VALUES), "MatSetValue");
  check(MatAssemblyBegin(m.A, MAT_FINAL_ASSEMBLY), "MatAssemblyBegin");
  check(MatAssemblyEnd(m.A, MAT_FINAL_ASSEMBLY), "MatAssemblyEnd");
}

double NewtonKrylov::matrix_nonzeros() const {
  MatInfo info;
  if (MatGetInfo(impl_->A, MAT_LOCAL, &info)) return 0.0;
  return info.nz_used;
}

NewtonKrylov::Result NewtonKrylov::solve(const SpMatR& G, const Eigen::VectorXd& schur_inv,
                                         const Eigen::VectorXd& f, const Eigen::VectorXd& g,
                                         double rtol, Eigen::VectorXd& du, Eigen::VectorXd& dq) {
  Impl& m = *impl_;
  Result res;
  const int k = static_cast<int>(G.rows()), N = m.n + k;
  if (G.cols() != m.n || schur_inv.size() != k || f.size() != m.n || g.size() != k)
    throw Error("NewtonKrylov::solve: the sizes of G, schur_inv, f and g do not match");
  auto t0 = std::chrono::steady_clock::now();
  // The V-cycle of this A: GAMG's hierarchy set up again (the values changed).
  check(PCSetOperators(m.amg, m.A, m.A), "PCSetOperators");
  check(PCSetUp(m.amg), "PCSetUp (the AMG hierarchy of the augmented tangent)");
  res.setup_seconds = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  m.G = &G;
  m.schur_inv = &schur_inv;
  m.t.resize(m.n);
  if (m.m != k) {
    m.release_system();
    check(MatCreateShell(PETSC_COMM_SELF, N, N, N, N, &m, &m.M), "MatCreateShell");
    check(MatShellSetOperation(m.M, MATOP_MULT, reinterpret_cast<void (*)(void)>(kkt_mult)),
          "MatShellSetOperation");
    check(VecCreateSeq(PETSC_COMM_SELF, N, &m.x), "VecCreateSeq");
    check(VecDuplicate(m.x, &m.b), "VecDuplicate");
    m.m = k;
  }
  PetscScalar* a = nullptr;
  check(VecGetArray(m.b, &a), "VecGetArray");
  std::copy(f.data(), f.data() + m.n, a);
  std::copy(g.data(), g.data() + k, a + m.n);
  check(VecRestoreArray(m.b, &a), "VecRestoreArray");
  check(VecSet(m.x, 0.0), "VecSet");
  KSP ksp = nullptr;
  check(KSPCreate(PETSC_COMM_SELF, &ksp), "KSPCreate");
  struct KspGuard {
    KSP& k;
    ~KspGuard() { KSPDestroy(&k); }
  } guard{ksp};
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
  const PetscScalar* c = nullptr;
  check(VecGetArrayRead(m.x, &c), "VecGetArrayRead");
  du = CVec(c, m.n);
  dq = CVec(c + m.n, k);
  check(VecRestoreArrayRead(m.x, &c), "VecRestoreArrayRead");
  res.solve_seconds = seconds_since(t0);
  return res;
}

#endif

}  // namespace ltl
