// CG preconditioned by PETSc's GAMG for the global step (4.5); see cg_amg.hpp.
#include "cg_amg.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <type_traits>
#include <vector>

#include "error.hpp"

#ifdef LTL_HAVE_PETSC
#include <petscksp.h>
#endif

namespace ltl {

bool CgAmg::available() {
#ifdef LTL_HAVE_PETSC
  return true;
#else
  return false;
#endif
}

#ifndef LTL_HAVE_PETSC

struct CgAmg::Impl {};

CgAmg::CgAmg(const SpMat& A, const Eigen::MatrixXd& X, const std::string& what)
    : CgAmg(SpMatR(A), X, what) {}
CgAmg::CgAmg(SpMatR&& A, const Eigen::MatrixXd&, const std::string& what)
    : n_(static_cast<int>(A.rows())) {
  throw Error(cat(what, ": algorithm.global_solver = \"cg-amg\" needs PETSc, and this build has ",
                  "none: install it (Debian: apt-get install petsc-dev, or `make test-petsc`) and ",
                  "rebuild, or use global_solver = \"cholesky\""));
}
CgAmg::~CgAmg() = default;
int CgAmg::solve(const double*, double*) {
  return 0;
}

#else

namespace {

void check(PetscErrorCode ierr, const std::string& what, const char* call) {
  if (ierr) throw Error(cat(what, ": PETSc's ", call, " failed (PETSc error ", ierr, ")"));
}

/// Nonzeros of a PETSc matrix.
double nonzeros(Mat M) {
  MatInfo info;
  if (MatGetInfo(M, MAT_LOCAL, &info)) return 0.0;
  return info.nz_used;
}

}  // namespace

/// PETSc (and MPI, a singleton process) initialized once, on the first CG + AMG step, without
/// PETSc's signal handlers (the drivers' own handling of interrupts stays in charge) and with
/// errors returned to us rather than printed; finalized at exit.
void initialize_petsc() {
  static const bool ready = [] {
    PetscBool up = PETSC_FALSE;
    PetscInitialized(&up);
    if (!up) {
      PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr);
      if (PetscInitializeNoArguments()) throw Error("PETSc could not be initialized (MPI?)");
      std::atexit([] { PetscFinalize(); });
    }
    PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);
    return true;
  }();
  (void)ready;
}

struct CgAmg::Impl {
  std::string what;
  SpMatR csr;                        ///< the matrix's arrays, PETSc's A in place
  std::vector<PetscInt> rows, cols;  ///< their indices as PetscInt, when it is not int
  Mat A = nullptr;
  KSP ksp = nullptr;
  Vec b = nullptr, x = nullptr, r = nullptr;
  ~Impl() {
    if (ksp) KSPDestroy(&ksp);
    if (A) MatDestroy(&A);
    if (b) VecDestroy(&b);
    if (x) VecDestroy(&x);
    if (r) VecDestroy(&r);
  }
};

CgAmg::CgAmg(const SpMat& K, const Eigen::MatrixXd& X, const std::string& what)
    : CgAmg(SpMatR(K), X, what) {}

CgAmg::CgAmg(SpMatR&& K, const Eigen::MatrixXd& X, const std::string& what)
    : impl_(std::make_unique<Impl>()), n_(static_cast<int>(K.rows())) {
  const auto t0 = std::chrono::steady_clock::now();
  initialize_petsc();
  Impl& m = *impl_;
  m.what = what;
  eta_ = eta_option();
  if (X.rows() != n_) throw Error(cat(what, ": ", X.rows(), " coordinates for ", n_, " rows"));
  {  // the matrix: PETSc's AIJ on K's own compressed rows (kept in m.csr), no copy of the values
    static_assert(std::is_same<PetscScalar, double>::value, "a real PETSc build is needed");
    m.csr.swap(K);
    m.csr.makeCompressed();
    PetscInt *rows = nullptr, *cols = nullptr;
    if constexpr (std::is_same<PetscInt, SpMatR::StorageIndex>::value) {
      rows = m.csr.outerIndexPtr();
      cols = m.csr.innerIndexPtr();
    } else {
      m.rows.assign(m.csr.outerIndexPtr(), m.csr.outerIndexPtr() + n_ + 1);
      m.cols.assign(m.csr.innerIndexPtr(), m.csr.innerIndexPtr() + m.csr.nonZeros());
      rows = m.rows.data();
      cols = m.cols.data();
    }
    check(MatCreateSeqAIJWithArrays(PETSC_COMM_SELF, n_, n_, rows, cols, m.csr.valuePtr(), &m.A),
          what, "MatCreateSeqAIJWithArrays");
    check(MatSetOption(m.A, MAT_SPD, PETSC_TRUE), what, "MatSetOption");
  }
  {  // the near-null space: the constants and the centred coordinates, orthonormalized (the
     // PETSc option -ltl_amg_constants keeps the constants alone, GAMG's scalar default)
    PetscBool constants_only = PETSC_FALSE;
    PetscOptionsHasName(nullptr, nullptr, "-ltl_amg_constants", &constants_only);
    std::vector<Eigen::VectorXd> basis;
    for (int k = 0; k < (constants_only ? 0 : X.cols()); ++k) {
      Eigen::VectorXd v = X.col(k).array() - X.col(k).mean();
      for (int pass = 0; pass < 2; ++pass)
        for (const Eigen::VectorXd& q : basis) v -= q.dot(v) * q;
      const double nv = v.norm();
      if (nv > 1e-10 * std::sqrt(static_cast<double>(n_)) * (X.cwiseAbs().maxCoeff() + 1e-300))
        basis.push_back(v / nv);
    }
    std::vector<Vec> vecs(basis.size());
    for (std::size_t k = 0; k < basis.size(); ++k) {
      check(VecCreateSeq(PETSC_COMM_SELF, n_, &vecs[k]), what, "VecCreateSeq");
      PetscScalar* a = nullptr;
      check(VecGetArray(vecs[k], &a), what, "VecGetArray");
      std::copy(basis[k].data(), basis[k].data() + n_, a);
      check(VecRestoreArray(vecs[k], &a), what, "VecRestoreArray");
    }
    MatNullSpace nsp = nullptr;
    check(MatNullSpaceCreate(PETSC_COMM_SELF, PETSC_TRUE, static_cast<PetscInt>(vecs.size()),
                             vecs.data(), &nsp),
          what, "MatNullSpaceCreate");
    check(MatSetNearNullSpace(m.A, nsp), what, "MatSetNearNullSpace");
    MatNullSpaceDestroy(&nsp);
    for (Vec& v : vecs) VecDestroy(&v);
  }
  check(KSPCreate(PETSC_COMM_SELF, &m.ksp), what, "KSPCreate");
  check(KSPSetOperators(m.ksp, m.A, m.A), what, "KSPSetOperators");
  check(KSPSetType(m.ksp, KSPCG), what, "KSPSetType");
  // The true residual ||b - K x|| (CG updates it anyway): the stopping test of cg_amg.hpp.
  check(KSPSetNormType(m.ksp, KSP_NORM_UNPRECONDITIONED), what, "KSPSetNormType");
  check(KSPSetInitialGuessNonzero(m.ksp, PETSC_TRUE), what, "KSPSetInitialGuessNonzero");
  PC pc;
  check(KSPGetPC(m.ksp, &pc), what, "KSPGetPC");
  check(PCSetType(pc, PCGAMG), what, "PCSetType");
  check(PCGAMGSetType(pc, PCGAMGAGG), what, "PCGAMGSetType");
  // PETSc's options (PETSC_OPTIONS in the environment, e.g. -log_view, -pc_gamg_threshold) can
  // tune the defaults above.
  check(KSPSetFromOptions(m.ksp), what, "KSPSetFromOptions");
  check(KSPSetUp(m.ksp), what, "KSPSetUp (the AMG hierarchy)");
  check(MatCreateVecs(m.A, &m.x, &m.b), what, "MatCreateVecs");
  check(VecDuplicate(m.b, &m.r), what, "VecDuplicate");
  // The hierarchy's size: every level's operator, and the interpolations.
  PetscInt nlev = 0;
  check(PCMGGetLevels(pc, &nlev), what, "PCMGGetLevels");
  levels_ = static_cast<int>(nlev);
  for (PetscInt l = 0; l < nlev; ++l) {
    KSP smoother;
    Mat Al = nullptr, Pl = nullptr;
    check(PCMGGetSmoother(pc, l, &smoother), what, "PCMGGetSmoother");
    check(KSPGetOperators(smoother, &Al, nullptr), what, "KSPGetOperators");
    PetscInt rows = 0, cols = 0;
    MatGetSize(Al, &rows, &cols);
    hierarchy_nnz_ += nonzeros(Al);
    hierarchy_bytes_ += nonzeros(Al) * (sizeof(double) + sizeof(PetscInt)) +
                        static_cast<double>(rows + 1) * sizeof(PetscInt);
    if (l > 0 && !PCMGGetInterpolation(pc, l, &Pl) && Pl) {
      MatGetSize(Pl, &rows, &cols);
      hierarchy_nnz_ += nonzeros(Pl);
      hierarchy_bytes_ += nonzeros(Pl) * (sizeof(double) + sizeof(PetscInt)) +
                          static_cast<double>(rows + 1) * sizeof(PetscInt);
    }
  }
  setup_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

CgAmg::~CgAmg() = default;

double CgAmg::eta_option() {
  PetscReal eta = kEta;
  PetscBool set = PETSC_FALSE;
  if (!PetscOptionsGetReal(nullptr, nullptr, "-ltl_cg_eta", &eta, &set) && set && eta > 0 &&
      eta < 1)
    return eta;
  return kEta;
}

int CgAmg::solve(const double* b, double* x) {
  Impl& m = *impl_;
  PetscScalar* a = nullptr;
  check(VecGetArray(m.b, &a), m.what, "VecGetArray");
  std::copy(b, b + n_, a);
  check(VecRestoreArray(m.b, &a), m.what, "VecRestoreArray");
  check(VecGetArray(m.x, &a), m.what, "VecGetArray");
  std::copy(x, x + n_, a);
  check(VecRestoreArray(m.x, &a), m.what, "VecRestoreArray");
  // r0 = b - K x0: the warm start's residual, which sets this solve's tolerance.
  PetscReal r0 = 0, bn = 0;
  check(MatMult(m.A, m.x, m.r), m.what, "MatMult");
  check(VecAYPX(m.r, -1.0, m.b), m.what, "VecAYPX");
  check(VecNorm(m.r, NORM_2, &r0), m.what, "VecNorm");
  check(VecNorm(m.b, NORM_2, &bn), m.what, "VecNorm");
  ++solves_;
  const double target = CgAmg::target(eta_, r0, bn);
  if (r0 <= target) return 0;
  check(KSPSetTolerances(m.ksp, 0.0, target, PETSC_DEFAULT, kMaxIterations), m.what,
        "KSPSetTolerances");
  check(KSPSolve(m.ksp, m.b, m.x), m.what, "KSPSolve");
  KSPConvergedReason reason;
  PetscInt its = 0;
  KSPGetConvergedReason(m.ksp, &reason);
  KSPGetIterationNumber(m.ksp, &its);
  if (reason < 0)
    throw Error(cat(m.what, ": CG + AMG did not converge (", KSPConvergedReasons[reason], ", ", its,
                    " iterations, residual asked ", target,
                    "): the matrix is not positive definite or the preconditioner failed; "
                    "use algorithm.global_solver = \"cholesky\""));
  const PetscScalar* c = nullptr;
  check(VecGetArrayRead(m.x, &c), m.what, "VecGetArrayRead");
  std::copy(c, c + n_, x);
  check(VecRestoreArrayRead(m.x, &c), m.what, "VecRestoreArrayRead");
  iterations_ += its;
  return static_cast<int>(its);
}

#endif

}  // namespace ltl
