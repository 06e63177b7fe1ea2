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
// Over the MPI ranks (a distributed Solver's Newton phase, given node_rank): A, G and the
// vectors are PETSc's distributed objects on PETSC_COMM_WORLD. A node's dofs are rows of the rank
// of node_rank (the global step's and the distributed factorization's rows, mpi_newton.hpp),
// nodes in their index order within a rank's block; each rank adds its cells' terms into A (a term
// in another rank's rows travels at the assembly), holds its cells' rows of G (and, on the rank
// that adds them, the contact rows), and GMRES's vectors and GAMG's hierarchy are split the same
// way: nothing of the solve is whole on a rank but the solution du, gathered to every rank (the
// rest of the Newton phase holds the whole state).
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
  /// cells' nodes (#cells x nodes per cell: the mesh's cells), prescribed dofs: fixed[dim a + i]
  /// true. X: the coordinates, for the rigid-body modes. Over the ranks (collective; node_rank
  /// non-null on more than one process): node_rank (#nodes) the rank whose rows hold each node's
  /// dofs. A is preallocated for its rows from every cell of the mesh, whichever rank adds the
  /// cell's block.
  NewtonKrylov(int dim, const Eigen::MatrixXd& X, const Eigen::MatrixXi& cells,
               const std::vector<char>& fixed, const std::vector<int>* node_rank = nullptr);
  ~NewtonKrylov();
  NewtonKrylov(const NewtonKrylov&) = delete;
  NewtonKrylov& operator=(const NewtonKrylov&) = delete;

  /// Starts assembling A: every value 0.
  void zero();
  /// Adds the symmetric block v (n x n) at the dofs (-1: a prescribed dof, left out).
  void add(int n, const int* dofs, const double* v);
  /// Adds v[k] at (row, cols[k]) (-1 columns left out).
  void add_row(int row, int n, const int* cols, const double* v);
  /// Ends the assembly: the prescribed dofs' diagonal set to `fixed_diagonal`. Collective.
  void finish(double fixed_diagonal);
  /// Is dof k one of this rank's rows (every dof on one process)? A term that every rank knows
  /// (the residual, the damping) is added by the rank that owns its row only.
  bool owns(int k) const;

  struct Result {
    bool converged = false;
    int iterations = 0;
    double residual = 0;  ///< ||rhs - M x|| / ||rhs|| at the end
    double setup_seconds = 0, solve_seconds = 0;
    std::string reason;  ///< PETSc's, when not converged
  };
  /// [A, G^T; G, 0] (du, dq) = (f, g) to a relative residual rtol. G: the constraint rows over
  /// the dofs (zero in the prescribed columns); schur_inv: S_hat^{-1}, one per row of G
  /// (negative); f: dim * #nodes (zero at prescribed dofs). du, dq: the solution. Over the ranks
  /// (collective): G, schur_inv, g and dq are this rank's rows of the constraints (the rows of
  /// all ranks in turn are the system's), f is this rank's part (the parts of the ranks add up to
  /// the right-hand side), and du is whole on every rank. f is taken by value (pass it with
  /// std::move) and released once its entries are in PETSc's vector, before the AMG set-up; GMRES's
  /// basis is released before du is gathered: whole-size arrays do not add to the solve's peak.
  Result solve(const SpMatR& G, const Eigen::VectorXd& schur_inv, Eigen::VectorXd f,
               const Eigen::VectorXd& g, double rtol, Eigen::VectorXd& du, Eigen::VectorXd& dq);

  /// Nonzeros of A (this rank's rows).
  double matrix_nonzeros() const;
  /// This rank's rows of A (every dof on one process).
  int rows() const;

  struct Impl;  ///< PETSc's objects (declared here for PETSc's callbacks)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ltl
