// The iterative global step [LTL87 (4.1), (4.5)] for meshes whose Cholesky factor does not fit:
// conjugate gradients preconditioned by algebraic multigrid (PETSc's smoothed-aggregation GAMG),
// the hierarchy set up once per matrix, like the factor it replaces (global_step.hpp).
//
// The matrix is the SCALAR K of (4.5) restricted to one Dirichlet set's free nodes (the global
// matrix is K (x) I_dim: the displacement components are decoupled), so the hierarchy is built
// once and serves every component of the set, one CG solve per component. Its near-null space is
// what the rigid-body modes of the vector problem are, component by component: the constants and
// the coordinates x, y (, z) (a rotation W x has linear components), orthonormalized.
//
// Each solve is warm-started from the previous iterate (ALG2 calls it once per iteration with
// a right-hand side that changes less and less) and is INEXACT, with a tolerance that tightens as
// ALG2 converges: it stops when
//     ||b - K x|| <= max(kEta ||b - K x0||, kFloor ||b||),
// x0 the warm start. At a fixed point of ALG2 the warm start solves the system already, so the
// inexactness vanishes there: the converged state is the one of the exact (Cholesky) step, which
// the PETSc tests check (tests/test_cg_amg.cpp).
//
// PETSc is optional at build time (CMake defines LTL_HAVE_PETSC when pkg-config finds it):
// without it available() is false and the constructor throws a clear Error.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <string>

#include "fe.hpp"

namespace ltl {

/// PETSc (and MPI, a singleton process) initialized once, on first use, without PETSc's signal
/// handlers and with errors returned rather than printed; finalized at exit. Defined only in a
/// build with PETSc (LTL_HAVE_PETSC).
void initialize_petsc();

class CgAmg {
 public:
  /// Relative reduction of the warm start's residual asked of each solve (the inexactness); the
  /// PETSc option -ltl_cg_eta sets another. Measured with ALG2 + Anderson on the gutter levels 3
  /// and 4 to a force residual of 1e-6 (paper_notes/performance.md): 1e-2 takes 19-36 % less time
  /// than 1e-3 for -10 to +5 % iterations; 1e-1 saves a little more time for up to 24 % more
  /// iterations.
  static constexpr double kEta = 1e-2;
  /// The floor: residual at most kFloor ||b|| whatever the warm start.
  static constexpr double kFloor = 1e-12;
  /// CG iterations per solve before the solve is an Error (a preconditioner that fails).
  static constexpr int kMaxIterations = 2000;

  /// Built with PETSc?
  static bool available();
  /// kEta, or the PETSc option -ltl_cg_eta when it is in (0, 1). PETSc must be initialized.
  static double eta_option();
  /// A solve's residual target from its warm start's residual r0 = ||b - A x0|| and ||b||:
  /// max(eta r0, kFloor ||b||) (the rule above; the distributed CG + GAMG's too, mpi_global.hpp).
  static double target(double eta, double r0, double b_norm) {
    return eta * r0 > kFloor * b_norm ? eta * r0 : kFloor * b_norm;
  }

  /// Sets up the AMG hierarchy of the symmetric positive definite A (both triangles stored) with
  /// the near-null space of the coordinates X (#rows x dim; the rows' nodes). `what` names the
  /// matrix in errors. Throws Error without PETSc or when PETSc fails.
  CgAmg(const SpMat& A, const Eigen::MatrixXd& X, const std::string& what);
  /// The same from A in compressed rows, consumed: PETSc's matrix is A's own arrays
  /// (MatCreateSeqAIJWithArrays, no copy), held until destruction.
  CgAmg(SpMatR&& A, const Eigen::MatrixXd& X, const std::string& what);
  ~CgAmg();
  CgAmg(const CgAmg&) = delete;
  CgAmg& operator=(const CgAmg&) = delete;

  /// [LTL87 (4.5)] A x = b, x in: the warm start, out: the solution to the tolerance above.
  /// Returns the CG iterations taken (0 when the warm start already meets it).
  int solve(const double* b, double* x);

  int rows() const { return n_; }
  double setup_seconds() const { return setup_seconds_; }
  /// Nonzeros of the hierarchy (every level's operator and interpolation, the finest operator
  /// included) and their bytes as stored (AIJ: a double and an index per nonzero, an index per
  /// row).
  double hierarchy_nonzeros() const { return hierarchy_nnz_; }
  double hierarchy_bytes() const { return hierarchy_bytes_; }
  int levels() const { return levels_; }
  long iterations() const { return iterations_; }  ///< CG iterations since construction
  long solves() const { return solves_; }

 private:
  struct Impl;  // PETSc's objects
  std::unique_ptr<Impl> impl_;
  int n_ = 0, levels_ = 0;
  double eta_ = kEta;  ///< kEta, or the option -ltl_cg_eta
  double setup_seconds_ = 0, hierarchy_nnz_ = 0, hierarchy_bytes_ = 0;
  long iterations_ = 0, solves_ = 0;
};

}  // namespace ltl
