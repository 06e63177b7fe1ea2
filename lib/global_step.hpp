// The global step (4.1), i.e. the linear problem (4.5), with its matrix factorized once.
//
// [LTL87 (4.5)] The bilinear form is
//   a(u, v) = 2 C1 integral grad u : grad v + R q sum_e |O_e| Gbar_e(u) : Gbar_e(v)
//             + R q_c sum_s |G_s| ubar_s . vbar_s
// which is K (x) I_dim: one SCALAR matrix K repeated for each displacement component. It does not
// change during the run, so it is factorized once (CHOLMOD supernodal Cholesky) and every
// iteration of every time step is a triangular solve against the stored factor, with all the
// components that share a Dirichlet set solved in one call (multi-column right-hand side).
// Components with different Dirichlet sets (symmetry planes) get one factor per distinct set.
//
// The factorization and the sweeps are the Cholesky wrapper's (cholesky.hpp): the best of the
// AMD, METIS and nested-dissection orderings is computed once and induced on the other Dirichlet
// sets. Several factors (3-D with symmetry planes) are solved concurrently on the OpenMP threads
// when they are large (paper_notes/performance.md).
//
// Or iteratively (cg_amg.hpp): conjugate gradients preconditioned by AMG set up once per
// Dirichlet set, warm-started from the previous iterate, for meshes whose factor does not fit.
// algorithm.global_solver chooses; left out (GlobalSolver::Auto) CG + AMG is taken only when
// PETSc is built in, the matrix has more than kAutoMinRows rows, and the factor predicted by
// CHOLMOD's AMD analysis (one symbolic pass, before any factorization) needs more than
// kAutoFactorBytes: far beyond every test, figure and benchmark of the package, which all
// factorize as before. Over MPI ranks the same rule with MUMPS's analysis for CHOLMOD's
// (DistributedGlobalStep::Solver::Auto, mpi_global.hpp).
#pragma once

#include <Eigen/Sparse>
#include <memory>
#include <vector>

#include "cholesky.hpp"
#include "fe.hpp"

namespace ltl {

/// [LTL87 (1.1)] Per-component Dirichlet data, u = value on Gamma_1: fixed[i] lists the fixed
/// nodes of component i (sorted, unique) and value[i][k] is the prescribed value at fixed[i][k].
/// O(#fixed nodes), not a dense #nodes x dim array: every MPI rank holds it (paper_notes/mpi.md).
struct DirichletData {
  std::vector<std::vector<int>> fixed;
  std::vector<std::vector<double>> value;
  /// The prescribed value of component i at node a (a binary search in fixed[i]); 0 where the
  /// component is free.
  double value_at(int a, int i) const;
  /// Component i of u at every fixed node set to scale x its prescribed value.
  void impose(Eigen::MatrixXd& u, int i, double scale) const;
  /// The largest |prescribed value| (0 with none: no step is driven by a displacement).
  double max_abs_value() const;
  /// An Error unless every fixed[i] is sorted, without repeats, within 0 .. nodes - 1, and
  /// value[i] has one entry per fixed node (value_at's binary search relies on it).
  void check(int nodes) const;
};

/// The displacement components grouped by Dirichlet set, in order of first appearance: the
/// components of one group share K restricted to their free nodes, hence one factor (or one
/// AMG hierarchy, or one distributed KSP).
std::vector<std::vector<int>> components_by_dirichlet_set(const DirichletData& bc);

/// [LTL87 (4.5)] K = 2 C1 L + R q Gbar^T diag(|O|) Gbar + R q_c M^T diag(|G|) M, with L the
/// Laplacian, Gbar the mean gradient, M the facet mean (pass nullptr when there is no contact).
/// #nodes x #nodes in the mesh's numbering, also from the operators of some cells (on their
/// nodes' columns, CellOperators::node): then their part of K.
SpMat global_matrix(const CellOperators& cells, const ContactPoints* points, double C1, double Rq,
                    double Rqc);

class GlobalStep {
 public:
  /// Auto: CG + AMG above both (and only when CgAmg::available()).
  static constexpr int kAutoMinRows = 200000;
  static constexpr double kAutoFactorBytes = 4e9;
  /// Auto's thresholds (the defaults above; the tests that reach the choice lower them), and
  /// the rule, the serial one and the one over the ranks (mpi_global.hpp, with MUMPS's
  /// analysis): CG + AMG when the matrix has more than min_rows rows and the factors' predicted
  /// bytes exceed factor_bytes. `bytes()` is called above min_rows only (an analysis).
  struct AutoLimits {
    int min_rows = kAutoMinRows;
    double factor_bytes = kAutoFactorBytes;
    template <class Bytes>
    bool cg_amg(long rows, Bytes bytes) const {
      return rows > min_rows && bytes() > factor_bytes;
    }
  };
  /// Groups the components by Dirichlet set, and analyzes and factorizes K restricted to each
  /// set's free nodes once. Throws a clear Error if a restricted matrix is not positive
  /// definite (a rigid motion not removed by fixed parts, symmetry planes or contact).
  /// `solver`: Cholesky, CG + AMG (then X, the #nodes x dim reference coordinates, gives the
  /// AMG's near-null space and is required), or Auto (the rule above). newton_dim: with a
  /// Newton phase (solver = "newton") the dimension, whose tangent's factor Auto counts too
  /// (predicted_factor_nonzeros); 0 without. `limits`: Auto's thresholds (null: AutoLimits'
  /// defaults).
  GlobalStep(const SpMat& K, const DirichletData& bc, GlobalSolver solver = GlobalSolver::Cholesky,
             const Eigen::MatrixXd* X = nullptr, int newton_dim = 0,
             const AutoLimits* limits = nullptr);
  /// The same, K consumed: freed as soon as the restricted matrices are made (before the last
  /// factorization, before any AMG setup), so that it is not resident at the setup's peak.
  GlobalStep(SpMat&& K, const DirichletData& bc, GlobalSolver solver = GlobalSolver::Cholesky,
             const Eigen::MatrixXd* X = nullptr, int newton_dim = 0,
             const AutoLimits* limits = nullptr);
  ~GlobalStep();
  GlobalStep(const GlobalStep&) = delete;
  GlobalStep& operator=(const GlobalStep&) = delete;

  /// [LTL87 (4.1), (4.5)] Solves K u = b (b: #nodes x dim) with u = value on the fixed nodes.
  /// One multi-column triangular solve per distinct Dirichlet set; the factor is reused.
  /// Allocation-free after the first call.
  void solve(const Eigen::MatrixXd& b, Eigen::MatrixXd& u);

  /// The prescribed values are value_scale x DirichletData::value (1 unless set: a substep of
  /// the increment of prescribed displacements, lib/simulation.cpp). The factors do not change.
  void set_value_scale(double s) { scale_ = s; }
  double value_scale() const { return scale_; }

  int num_factors() const { return static_cast<int>(groups_.size()); }
  /// The solver in use: Cholesky or CgAmg (never Auto).
  GlobalSolver solver() const { return solver_; }
  /// CG + AMG: CG iterations and solves (one per component and call) since construction, AMG
  /// setup seconds and the hierarchies' nonzeros and bytes (0 with Cholesky).
  long cg_iterations() const;
  long cg_solves() const;
  double amg_setup_seconds() const;
  double amg_nonzeros() const;
  double amg_bytes() const;
  /// The factors' nnz(L) predicted from CHOLMOD's symbolic analysis alone (AMD ordering, no
  /// factorization): #distinct Dirichlet sets x the count of the largest set's matrix; the
  /// constructor's best-of-three ordering gives about as much or less. With newton_dim = d > 0
  /// (a Newton phase, whose factor is held with these) plus d^2 x that count: the augmented
  /// tangent couples the same nodes as K with d x d blocks, so its factor is K's with each
  /// entry a d x d block (measured: 9.0 and 8.7 times the largest set's nnz(L) on 800- and
  /// 4 800-cell gutters; paper_notes/mpi.md, "The automatic choice over the ranks").
  static double predicted_factor_nonzeros(const SpMat& K, const DirichletData& bc,
                                          int newton_dim = 0);
  double analyze_seconds() const { return analyze_seconds_; }
  double factorize_seconds() const { return factorize_seconds_; }
  double factor_nonzeros() const { return factor_nnz_; }  ///< sum over the factors of nnz(L)
  double min_rcond() const { return min_rcond_; }         ///< smallest CHOLMOD condition estimate
  /// Factor k: number of rows (free nodes), of right-hand-side columns, and the factor itself.
  int factor_rows(int k) const;
  int factor_columns(int k) const;
  const Cholesky& factor(int k) const;  ///< Cholesky only (an Error with CG + AMG)
  /// Wall time spent in solve() since construction, and the number of calls (benchmarks).
  double solve_seconds() const { return solve_seconds_; }
  long solve_calls() const { return solve_calls_; }

  /// Several factors are solved concurrently (OpenMP) when their total nnz(L) is above this.
  static constexpr double kParallelMinNnz = 200000;

 private:
  struct Group;  // one distinct Dirichlet set: its factor (or CG + AMG) and its rows
  void iterate(Group& g, const Eigen::MatrixXd& b, Eigen::MatrixXd& u) const;
  template <class F>
  double amg_sum(const F& f) const;  ///< sum of f(CgAmg) over the CG + AMG groups
  std::vector<std::unique_ptr<Group>> groups_;
  const DirichletData bc_;
  GlobalSolver solver_ = GlobalSolver::Cholesky;
  double analyze_seconds_ = 0, factorize_seconds_ = 0, factor_nnz_ = 0, min_rcond_ = 1;
  double solve_seconds_ = 0;
  long solve_calls_ = 0;
  double scale_ = 1;  ///< see set_value_scale
};

}  // namespace ltl
