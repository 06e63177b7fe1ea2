// The linear systems of the Newton phase (newton.hpp, newton_kkt.cpp) as distributed PETSc
// factorizations over the MPI ranks (lib/mpi_comm.hpp), for a Solver built with Ranks::All:
//
//   - the augmented tangent K + kappa (B^T W B + C^T W_c C) of the Newton step (the KKT
//     conditions of (2.2) with (2.7), (1.1); CHOLMOD's LL' in the serial solver) by MUMPS's
//     symmetric factorization (KSPPREONLY + PCCHOLESKY on an MPIAIJ matrix, analyzed once per
//     Newton phase, factorized numerically at each step). MUMPS runs its symmetric indefinite
//     LDL' (SYM = 2) and the inertia says whether the matrix is positive definite, the answer
//     CHOLMOD's failure gives in the serial solver (then the step falls back to the LU);
//   - the full KKT system (u, p, the active mu, with glue every beta; UMFPACK's LU in the serial
//     solver) by MUMPS's LU (KSPPREONLY + PCLU), analyzed again only when its pattern changes.
//
// The rows are split like the distributed global step's (mpi_global.hpp): a node's free dofs on
// the rank of node_ranks, the smallest rank among its cells' (the cells are the Solver's
// partition, PT-Scotch's parts of the dual graph); the KKT system's other rows (p, mu, beta) in
// blocks of their index. Each rank computes the tangent's terms of its cells, the same cells as
// ALG2's, and adds them into PETSc's matrix (a term in another rank's rows travels at the end of
// the assembly); the right-hand side is whole on every rank and the solution is gathered to every
// rank (mpi::gather), so that the rest of Newton stays identical on every rank. The LU's full KKT
// system is still assembled whole on every rank.
//
// With the global step on the distributed CG + GAMG (algorithm.global_solver = "cg-amg") the
// augmented tangent is not factorized: its system goes to GMRES + GAMG over the same rows
// (newton_krylov.hpp), and only a glued or indefinite step's LU is MUMPS's.
//
// Without LTL_WITH_MPI the solvers are not compiled (their constructors throw) and
// distributed_newton_solves() is false: the serial Newton is unchanged.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <memory>
#include <vector>

namespace ltl {

/// Newton's linear solves in this process since the start (or the last reset): the serial ones
/// (CHOLMOD, UMFPACK, the Krylov ones) and the distributed ones (MUMPS), with their seconds.
/// Analysis = symbolic factorization; the LU's are counted with its factorizations (UMFPACK does
/// both at once).
struct NewtonSolveStats {
  long cholmod_analyses = 0, cholmod_factorizations = 0, cholmod_solves = 0;
  long umfpack_factorizations = 0;
  long mumps_analyses = 0, mumps_factorizations = 0, mumps_solves = 0;
  long mumps_lu_analyses = 0, mumps_lu_factorizations = 0;
  /// Factorizations analyzed and made again because MUMPS found its workspace short (its
  /// estimate plus 20 %, then twice the estimate; mpi_newton.cpp).
  long mumps_workspace_retries = 0;
  /// The augmented tangent's entries this rank added into other ranks' rows (PETSc's stash, sent
  /// at the assembly), summed over the assemblies.
  long mumps_offrank_entries = 0;
  /// The augmented tangent's last factor: CHOLMOD's nnz(L) at its analysis (serially), MUMPS's
  /// bytes allocated by its factorization on its most loaded rank (INFOG(18), over the ranks).
  double cholmod_factor_nonzeros = 0, mumps_factor_bytes = 0;
  double cholmod_analysis_s = 0, cholmod_factor_s = 0, cholmod_solve_s = 0, umfpack_s = 0;
  double mumps_analysis_s = 0, mumps_factor_s = 0, mumps_solve_s = 0, mumps_lu_s = 0;
  /// The Krylov solves (newton_krylov.hpp): solves, GMRES iterations, the most in one solve,
  /// the AMG set-ups' and the iterations' seconds, failures (not converged).
  long krylov_solves = 0, krylov_iterations = 0, krylov_max_iterations = 0, krylov_failures = 0;
  double krylov_setup_s = 0, krylov_solve_s = 0;
  /// This rank's rows of the Krylov solves' matrix A and of their constraint rows G, and the
  /// entries A stores in its rows, in the last solve (every dof and every row on one process;
  /// over the ranks, its block of each).
  long krylov_rows = 0, krylov_constraint_rows = 0;
  double krylov_nonzeros = 0;
};
NewtonSolveStats& newton_solve_stats();

/// Are the distributed solves available to a distributed Solver's Newton phase
/// (Newton's constructor, distributed)? In an MPI build, unless the PETSc option
/// -ltl_mpi_newton_replicated keeps them replicated.
bool distributed_newton_solves();

/// The rows of the distributed Newton systems: the free dofs (dim * #nodes, interleaved; -1:
/// fixed) of the nodes of rank r (node_rank[a] == r: node_ranks of the ranks' cells,
/// mpi_global.hpp, the rows of the global step) in their index order, rank after rank; `extra`
/// further rows in blocks of their index. perm[k]: the global PETSc row of system row k (free dofs
/// first, then the extra rows); offset: the ranks' blocks of PETSc rows.
struct NewtonRows {
  std::vector<int> perm, offset;
  NewtonRows(const std::vector<int>& free_of_dof, int dim, const std::vector<int>& node_rank,
             int extra);
};

/// The augmented tangent on the free dofs by MUMPS over every rank, assembled in place: each rank
/// adds the terms it computes (its cells', and any other) into PETSc's matrix (ADD_VALUES; a term
/// in another rank's rows travels at the end of the assembly), so that no rank holds the whole
/// matrix. Its pattern is that of the cells' free dofs (every pair of free dofs of a cell), built
/// for the owned rows only from the mesh. Collective (except add).
class DistributedCholesky {
 public:
  /// rows: the PETSc rows of the free dofs; dim dofs per node; cells: the mesh's cells' nodes
  /// (#cells x nodes per cell); free_of_dof[dim a + i]: the free index of dof i of node a, or -1.
  /// Analyzes at the first factorize.
  DistributedCholesky(NewtonRows rows, int dim, const Eigen::MatrixXi& cells,
                      const std::vector<int>& free_of_dof);
  ~DistributedCholesky();
  DistributedCholesky(const DistributedCholesky&) = delete;
  DistributedCholesky& operator=(const DistributedCholesky&) = delete;
  /// Starts an assembly: every value 0.
  void zero();
  /// Adds the symmetric block v (n x n) at the free indices `free` (-1: left out), both triangles.
  /// Not collective.
  void add(int n, const int* free, const double* v);
  /// Adds v at (row, col) (free indices). Not collective.
  void add_entry(int row, int col, double v);
  /// Is free index k one of this rank's rows?
  bool owns(int k) const;
  /// Ends the assembly and factorizes. False when the matrix is not positive definite (a
  /// negative or zero pivot, or MUMPS failed): the same on every rank.
  bool factorize();
  /// x = A^{-1} b, b whole on every rank, x whole on every rank.
  void solve(const Eigen::VectorXd& b, Eigen::VectorXd& x);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The full KKT system by MUMPS's LU over every rank, analyzed again when its pattern changes.
class DistributedLU {
 public:
  DistributedLU();
  ~DistributedLU();
  DistributedLU(const DistributedLU&) = delete;
  DistributedLU& operator=(const DistributedLU&) = delete;
  /// A x = b, A (compressed, whole on every rank) with the rows `rows`; x whole on every rank.
  /// False when A is singular (MUMPS failed): the same on every rank.
  bool solve(const Eigen::SparseMatrix<double>& A, const NewtonRows& rows, const Eigen::VectorXd& b,
             Eigen::VectorXd& x);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ltl
