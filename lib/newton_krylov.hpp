// The linear system of a Newton step (newton.hpp) by a Krylov method, for the meshes whose
// factorization does not fit: the Newton phase of a run whose global step is CG + AMG
// (algorithm.global_solver = "cg-amg", chosen or taken by the automatic choice, cg_amg.hpp).
//
// The system is the KKT system of the step, augmented and scaled (Newton::krylov_step):
//
//   [ A  G^T ] [du]   [f]        A = K + G^T Gamma G  (the tangent of (2.2) augmented by the
//   [ G   0  ] [dq] = [g],       constraints of (2.7) and the active contact rows of (1.1)),
//
// G the constraint rows scaled so that every row of the system is a force and every unknown a
// length. It is solved by GMRES, right-preconditioned by the block upper-triangular
//
//   P = [ A  G^T ]     with    S_hat^{-1} = -(Gamma + S0^{-1}),  S0 = G K^{-1} G^T approximated
//       [ 0  S_hat ]           by a diagonal (the pressure mass over the shear modulus; Jacobi),
//
// which is the augmented-Lagrangian preconditioner of Benzi and Olshanskii (2006): the identity
// (G A^{-1} G^T)^{-1} = (G K^{-1} G^T)^{-1} + Gamma is exact, so S_hat errs only in S0, by less the
// larger Gamma is. A^{-1} in P is one V-cycle of PETSc's smoothed-aggregation GAMG on A, set up at
// every Newton step (A changes), with the rigid-body modes as near-null space; A holds every dof
// (a prescribed one as a row and column of its diagonal only) so that GAMG sees nodes of `dim`
// dofs. PETSc's options with the prefix -ltl_newton_ tune the outer Krylov method
// (-ltl_newton_ksp_type, ..._ksp_gmres_restart) and -ltl_newton_amg_ the V-cycle.
//
// PETSc is optional at build time: without it available() is false and the constructor throws.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <memory>
#include <string>
#include <vector>

#include "fe.hpp"

namespace ltl {

class NewtonKrylov {
 public:
  /// GMRES's restart (PETSc's option -ltl_newton_ksp_gmres_restart overrides it) and iteration
  /// cap (-ltl_newton_ksp_max_it).
  static constexpr int kRestart = 60, kMaxIterations = 3000;
  static bool available();
  /// The real PETSc option `name` (e.g. "-ltl_newton_penalty"), else `fallback`; the fallback
  /// without PETSc.
  static double option(const char* name, double fallback);

  /// The matrix A's pattern: dim dofs per node (#nodes = X.rows(), interleaved: dim a + i), the
  /// cells' nodes (#cells x npc, cell after cell), prescribed dofs: fixed[dim a + i] true. X: the
  /// coordinates, for the rigid-body modes.
  NewtonKrylov(int dim, const Eigen::MatrixXd& X, const std::vector<int>& cell_nodes, int npc,
               const std::vector<char>& fixed);
  ~NewtonKrylov();
  NewtonKrylov(const NewtonKrylov&) = delete;
  NewtonKrylov& operator=(const NewtonKrylov&) = delete;

  /// Starts assembling A: every value 0.
  void zero();
  /// Adds the symmetric block v (n x n) at the dofs (-1: a prescribed dof, left out).
  void add(int n, const int* dofs, const double* v);
  /// Adds v[k] at (row, cols[k]) (-1 columns left out).
  void add_row(int row, int n, const int* cols, const double* v);
  /// Ends the assembly: the prescribed dofs' diagonal set to `fixed_diagonal`.
  void finish(double fixed_diagonal);

  struct Result {
    bool converged = false;
    int iterations = 0;
    double residual = 0;  ///< ||rhs - M x|| / ||rhs|| at the end
    double setup_seconds = 0, solve_seconds = 0;
    std::string reason;  ///< PETSc's, when not converged
  };
  /// [A, G^T; G, 0] (du, dq) = (f, g) to a relative residual rtol. G: the constraint rows over
  /// the dofs (zero in the prescribed columns); schur_inv: S_hat^{-1}, one per row of G
  /// (negative); f: dim * #nodes (zero at prescribed dofs). du, dq: the solution.
  Result solve(const SpMatR& G, const Eigen::VectorXd& schur_inv, const Eigen::VectorXd& f,
               const Eigen::VectorXd& g, double rtol, Eigen::VectorXd& du, Eigen::VectorXd& dq);

  /// Nonzeros of A.
  double matrix_nonzeros() const;

  struct Impl;  ///< PETSc's objects (declared here for PETSc's callbacks)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ltl
