// Newton's method on the discrete problem that ALG2 solves (the second phase of a time step
// with algorithm.solver = "newton"; paper_notes/newton.md).
//
// At a fixed point of ALG2 (4.1)-(4.3) the local variables equal what the constraints B say they
// are (E_e = I + Gbar_e u, e_s = ubar_s), so the fixed points are the solutions of a problem in
// u alone, with one pressure per cell for incompressibility and one force per contact point:
//
//   Pi(u) = sum_e |O_e| W(Fbar_e) + C1 (||grad u||^2 - sum_e |O_e| |Gbar_e u|^2) - F . u   (2.2)
//   G_e(u) = integral_e det F - |O_e| = 0   (mean-det, (2.7); det-mean: |O_e| (det Fbar_e - 1))
//   N . ubar_s - g_s <= 0,  mu_s >= 0,  mu_s (N . ubar_s - g_s) = 0      (1.1), frictionless
//
// with W the law as split (2.5)-(2.6), Fbar_e = I + Gbar_e u. The KKT conditions are
//   R_u = grad Pi - sum_e p_e grad G_e + sum_s mu_s N (x) mean_s = 0,   G = 0,
//   C_s = mu_s - max(0, mu_s + c_s (N . ubar_s - g_s)) = 0   (the min-NCP function),
// solved by a semismooth Newton method (primal-dual active set for the contact, Hintermueller,
// Ito and Kunisch 2002) with a backtracking line search on the norm of the scaled residual. The
// linear systems are the KKT systems (u free dofs, p, active contact forces), symmetric and
// indefinite, solved through the augmented Lagrangian of the linear system: one CHOLMOD
// factorization of the tangent plus 1e4 times the constraints' projections, and a few sweeps of
// multiplier updates. When that factorization fails (the tangent is not positive on the
// constraints' kernel: a saddle, e.g. a compressed block under a dead load) the KKT system itself
// is solved by UMFPACK's sparse LU.
//
// The glue adds a variable beta_s in [0, 1] per contact point and, to Pi, the adhesion part of
// the time-discrete functional (2.2) at e_s = ubar_s:
//   sum_s |G_s| [(kappa/2) beta_s^2 |ubar_s|^2 - w beta_s]
//   + (1/(2 dt)) sum_s sum_s' |G_s| k_ss' (beta_s - beta_prev_s)(beta_s' - beta_prev_s'),
// whose beta-derivative over |G_s| is g_s (glue_gradient); the box 0 <= beta_s <= 1 is a second
// min-NCP, beta_s = clamp(beta_s - g_s / a_s, 0, 1), treated by the same active-set Newton. The
// glued KKT system (u, p, mu, beta) is not symmetric positive on a kernel, so it is solved by LU
// (newton_kkt.cpp).
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "discretization.hpp"
#include "mpi_comm.hpp"
#include "obstacles.hpp"
#include "problem.hpp"
#include "state.hpp"

namespace ltl {

class Newton {
 public:
  /// The per-cell data (nodes, mean gradients, the points of the incompressibility constraint)
  /// and the constant part of the tangent. disc must outlive the object. krylov: the linear
  /// systems by GMRES with an AMG V-cycle (newton_krylov.hpp) instead of CHOLMOD's factor, for a
  /// run whose global step is CG + AMG (the Solver sets it; in a distributed Solver the
  /// distributed CG + GAMG, and then the Krylov solves are over the ranks too, each rank adding
  /// its cells' terms and holding their constraint rows); then the factor's pattern is not
  /// built.
  ///
  /// cells: for the Newton phase of a distributed Solver (Ranks::All), the Solver's partition of
  /// the cells (the Solver sets it; null: not distributed). Its linear systems are then solved
  /// over the ranks (mpi_newton.hpp), unless the PETSc option -ltl_mpi_newton_replicated keeps
  /// them replicated. On more than one rank the per-cell data (mean gradients, constraint points,
  /// the cells' positions in the tangent's values) is built for the rank's cells of the partition
  /// only (ALG2's cells), so that it takes 1/P of the memory, and the distributed systems' rows
  /// are those of its nodes (node_ranks of the partition, the global step's rows);
  /// the cell loops of the residual, of the augmented tangent and of the det F check run on those
  /// cells and are summed over the ranks, so that every rank holds the same whole residual and
  /// matrix. The LU step's system (and tangent(), constraint_gradient()) gathers the ranks' cell
  /// terms: it is whole on every rank.
  explicit Newton(const Discretization& disc, bool krylov = false,
                  const mpi::Partition* cells = nullptr);

  /// The unknowns of the discrete problem: u (#nodes x dim), a pressure per cell (empty for the
  /// compressible law), a force per contact point (N in 3-D, N/m in plane strain), and with glue
  /// the adhesion intensity beta per contact point (else empty).
  struct Unknowns {
    Eigen::MatrixXd u;
    Eigen::VectorXd p, mu, beta;
  };
  /// The glue of this time step (kappa, w, dt, the kernel k_ss' of the local step (6.4)-(6.5))
  /// and beta at the previous step: to be set before unknowns(), residual() and solve() on a
  /// glued problem (the Solver does it at every step).
  /// Several obstacles: the glue of one only (Problem::validate refuses glued obstacles among
  /// several under solver = "newton").
  void set_glue(const ContactSteps& contact, const Eigen::VectorXd& beta_prev);
  /// What this Newton holds (bytes): the per-cell data of its cells (the rank's cells of the
  /// partition on several ranks: their nodes, mean gradients, fluctuation blocks, constraint
  /// points and weights), the cells' positions in the values of the tangent's pattern (none with
  /// the distributed solves: PETSc's matrix holds the pattern, each rank its rows), and the
  /// whole-mesh data every rank keeps (the free-dof numbering; the tangent's pattern and the
  /// positions of the diagonal unless the solves are distributed).
  struct Holdings {
    int cells = 0;
    double cell_data = 0, positions = 0, whole = 0;
  };
  Holdings holdings() const;
  /// This rank's cells (sorted; every cell on one rank), and with the distributed solves the
  /// rank of each node's rows (node_ranks of the cells' partition; else empty).
  const std::vector<int>& cells() const { return cells_; }
  const std::vector<int>& node_rank() const { return node_rank_; }
  /// [(2.2)] The beta-derivative of the discrete functional over |G_s|, at e_s = ubar_s:
  ///   g_s = kappa beta_s |ubar_s|^2 - w + (1/dt) sum_s' k_ss' (beta_s' - beta_prev_s'),
  /// the stationarity of the local step's point problem (6.1)-(6.5) in gamma. Empty without glue.
  Eigen::VectorXd glue_gradient(const Unknowns& x) const;
  /// From an ALG2 state: u; p_e from lambda_e = 2 C1 E_e - dW(E_e) + p_e cof E_e (least
  /// squares); mu_s = |G_s| max(0, -(lambda_c_s + kappa beta_s^2 e_s) . N); beta. On several
  /// ranks s's E and lambda may be whole or the rank's cells' rows (on_rows; the state between
  /// steps of a distributed Solver): p is made on the rank's cells and summed. Collective
  /// then.
  Unknowns unknowns(const State& s) const;
  /// The ALG2 state of the unknowns: E_e = Fbar_e, lambda_e = 2 C1 Fbar_e - dW(Fbar_e) +
  /// p_e cof Fbar_e, e_s = ubar_s, lambda_c_s = -(mu_s / |G_s|) N - kappa beta_s^2 ubar_s, beta
  /// (unchanged without glue). At a solution it is a fixed point of ALG2 (r_B = 0) for every R.
  /// E and lambda keep s's form: the rank's rows (on_rows), or whole (summed over the ranks).
  void to_state(const Unknowns& x, State& s) const;

  /// [(2.2), (2.7), (1.1)] R_u (dim * #nodes, interleaved, fixed dofs included) at x under the
  /// load F = load_factor x f (f: #nodes x dim; its entries scaled one by one, no F made), and
  /// G_e (#cells; empty for the compressible law). With glue, R_u holds the glue's force
  /// sum_s |G_s| kappa beta_s^2 ubar_s (x) mean_s.
  void residual(const Unknowns& x, const Eigen::MatrixXd& f, Eigen::VectorXd& Ru,
                Eigen::VectorXd& G, double load_factor = 1) const;
  /// The tangent dR_u/du at x (dim * #nodes square, all dofs): the Hessian of Pi minus
  /// sum_e p_e times the Hessian of G_e (plus the glue's |G_s| kappa beta_s^2 mean_s (x) mean_s).
  /// Its columns are the directional derivatives of residual() (tests: central differences).
  Eigen::SparseMatrix<double> tangent(const Unknowns& x) const;
  /// dG/du (#cells x dim * #nodes) at u.
  Eigen::SparseMatrix<double> constraint_gradient(const Eigen::MatrixXd& u) const;

  struct Result {
    bool converged = false;
    std::string status;          ///< what happened, for the report
    int iterations = 0;          ///< Newton iterations done
    double force_residual = 0;   ///< max |R_u| over free dofs / load scale, at the end
    std::vector<double> forces;  ///< the force residual after each iteration (the rate)
  };
  /// Semismooth Newton from s under the load F = load_factor x f (f: #nodes x dim, the assembled
  /// dead loads; the Solver passes its discretization's and the step's factor, so that no whole
  /// F is made), to force residual <= alg.force_tol (relative to the largest nodal load, or
  /// without loads to the largest nodal force at the start), constraints |G_e| / |O_e| <= 1e-10
  /// and complementarity. Appends each iteration to report.history (n continuing; r_G = force
  /// residual, r_B = constraint residual) and calls progress. On success s is the converged
  /// state (to_state); otherwise s is unchanged.
  Result solve(State& s, const Eigen::MatrixXd& f, double load_factor, const AlgorithmParams& alg,
               StepReport& report,
               const std::function<void(const IterationRecord&)>& progress) const;
  /// [(2.2)] From solve's progress callback: the current Newton iterate as a state (to_state),
  /// for a checkpoint, in the form of `form` (the state given to solve: E and lambda on the
  /// rank's rows, or whole, then collective on several ranks); null outside a solve. (Until
  /// 2026-12-03 a checkpoint of the Newton phase saved ALG2's last iterate, and --resume did the
  /// whole phase again.)
  std::optional<State> current_state(const State& form) const;

 private:
  /// Per cell: the residual and constraint into Ru and G, the tangent Ke and the constraint
  /// gradient be (local dof d a + i) as triplets into K and B, and/or handed to on_cell.
  using CellSink = std::function<void(int, const Eigen::MatrixXd&, const Eigen::VectorXd&)>;
  /// own: the rank's cells only (on several ranks the only ones it can assemble), else every
  /// cell.
  template <int d>
  void assemble(const Unknowns& x, Eigen::VectorXd* Ru, Eigen::VectorXd* G,
                std::vector<Eigen::Triplet<double>>* K, std::vector<Eigen::Triplet<double>>* B,
                const CellSink* on_cell = nullptr, bool own = false) const;
  /// The Newton step by the augmented Lagrangian of its KKT system (solve_kkt in newton.cpp),
  /// with the matrix scattered into the fixed pattern_ (no triplets). False when the augmented
  /// tangent is not positive definite.
  struct Scatter;
  struct ScatterDeleter {
    void operator()(Scatter* w) const;
  };
  using ScatterPtr = std::unique_ptr<Scatter, ScatterDeleter>;
  /// The work of a Newton phase; for a distributed Solver's Newton (the constructor's distributed)
  /// with MUMPS's factorizations over the MPI ranks (mpi_newton.hpp).
  ScatterPtr new_scatter() const;
  /// rtol: the relative residual asked of a Krylov solve (inexact Newton).
  bool augmented_step(const Unknowns& base, const Eigen::VectorXd& Ru, const Eigen::VectorXd& G,
                      const Eigen::VectorXd& gap, const std::vector<int>& active, double damping,
                      double rtol, Scatter& work, Eigen::VectorXd& dx) const;
  /// [(2.2), (2.7), (1.1)] The same system by GMRES (newton_krylov.hpp): the tangent, augmented
  /// by a moderate multiple of the constraints' projections, assembled into PETSc's matrix;
  /// false when GMRES fails.
  bool krylov_step(const Unknowns& base, const Eigen::VectorXd& Ru, const Eigen::VectorXd& G,
                   const Eigen::VectorXd& gap, const std::vector<int>& active, double damping,
                   double rtol, Scatter& work, Eigen::VectorXd& dx) const;
  /// The KKT system of a Newton step assembled in full (u free dofs, p, the active contact
  /// forces, and with glue every beta; bstate: -1/+1 beta at its bound 0/1, 0 free) and solved by
  /// UMFPACK's LU (newton_kkt.cpp; MUMPS's with work.mumps_lu): the glued step, and the
  /// fall-back of augmented_step. dx in the same layout, beta last. False when singular.
  bool lu_step(const Unknowns& base, const Eigen::VectorXd& Ru, const Eigen::VectorXd& G,
               const Eigen::VectorXd& gap, const std::vector<int>& active,
               const std::vector<int>& bstate, double damping, Scatter& work,
               Eigen::VectorXd& dx) const;
  /// The glue's terms of the KKT system (newton_kkt.cpp): the u-u block, the u-beta coupling,
  /// the beta rows (ob: the first beta row), their right-hand side -|G_s| g_s.
  void add_glue_kkt(const Unknowns& x, const std::vector<int>& bstate, int ob,
                    std::vector<Eigen::Triplet<double>>& kkt, Eigen::VectorXd& rhs) const;
  /// The glue's force into R_u and its u-u block (dof numbering) into t; nothing without glue.
  void add_glue_force(const Unknowns& x, Eigen::VectorXd& Ru) const;
  void add_glue_tangent(const Unknowns& x, std::vector<Eigen::Triplet<double>>& t) const;
  /// Smallest det F over the constraint points (+inf without them) and over the cell means.
  template <int d>
  double min_det(const Eigen::MatrixXd& u) const;
  /// On several ranks: every rank's triplets (its cells' terms) on every rank; else nothing.
  void gather_triplets(std::vector<Eigen::Triplet<double>>& t) const;

  const Discretization& disc_;
  mutable const Unknowns* current_ = nullptr;  ///< solve's iterate while it runs (current_state)
  int dim_ = 0, npc_ = 0;
  bool incompressible_ = false;
  /// The nodes of this rank's cells (cells_, npc each, in that order): a rank holds its cells'
  /// rows, not the mesh's whole table.
  std::vector<int> nodes_;
  /// The nodes of cell e, one of this rank's cells.
  const int* cell_nodes(int e) const { return &nodes_[static_cast<std::size_t>(slot_[e]) * npc_]; }
  /// Mean gradients per cell (npc x dim, cell after cell) and the constraint points: per cell
  /// nq_ gradients (npc x dim) and weights (mean-det: the quadrature points; det-mean: the mean
  /// gradient with weight |O_e|). This rank's cells (cells_) only: cell e at slot_[e].
  std::vector<Eigen::MatrixXd> gbar_, gq_;
  std::vector<double> wq_;
  int nq_ = 0;
  /// [(2.5), (3.3)] Per cell of cells_ (at slot_[e]), npc x npc column-major: the intra-cell
  /// fluctuation of C1 |grad u|^2, 2 C1 (L_e - |O_e| gbar_e gbar_e^T), on each component (the
  /// cell's part of 2 C1 (L - GbarT_vol Gbar) of the discretization), added into the cell's
  /// residual and tangent (assemble).
  std::vector<double> lf_;
  std::vector<int> free_;  ///< per dof, its free index or -1
  /// Distributed solves: per node the rank of its rows (node_ranks of the cells' partition).
  std::vector<int> node_rank_;
  int nfree_ = 0;
  Eigen::VectorXd c_;  ///< per contact point, the NCP parameter 0.02 C1 |G_s| / h
  /// The pattern of the augmented tangent (free dofs, lower triangle) and where each entry of a
  /// cell matrix (cell_pos_, (d npc)^2 per cell of cells_, -1: fixed dof or upper triangle), of
  /// the diagonal (diag_pos_) and of a contact point's pairs (point_dofs_, point_coef_: its free
  /// dofs and their coefficients in N . ubar_s; point_pos_: their pairs) lands in its values.
  Eigen::SparseMatrix<double> pattern_;
  std::vector<int> cell_pos_, diag_pos_;
  std::vector<std::vector<int>> point_dofs_, point_pos_;
  std::vector<std::vector<double>> point_coef_;
  /// The glue (set_glue): kappa, w, dt, the kernel k_ss', beta_prev, and the scale a_s of the
  /// box NCP (w + k_ss / dt, or a small multiple of kappa h^2 without them).
  struct Glue {
    double kappa = 0, w = 0, dt = 1;
    Eigen::SparseMatrix<double> k;
    Eigen::VectorXd beta_prev, a;
  };
  bool glued_ = false;
  bool distributed_ = false;  ///< a partition of the cells given: a distributed Solver's
  /// distributed on more than one rank: the per-cell data and the cell loops on this rank's
  /// cells, summed over the ranks.
  bool split_ = false;
  /// This rank's cells, ascending (all of them on one rank), and per cell its index in cells_
  /// (-1: another rank's).
  std::vector<int> cells_, slot_;
  /// |O_e| of every cell: the discretization's, or on a discretization of some cells (a rank's,
  /// which holds its cells' alone) this copy, made by cell_volumes (the constraint's measure
  /// reads every cell's, as it reads the pressures of every cell).
  Eigen::VectorXd whole_vol_;
  const Eigen::VectorXd& volumes() const {
    return disc_.partial() ? whole_vol_ : disc_.cells().vol;
  }
  /// Are s's E and lambda the rank's cells' rows (split_; cells_ in order), not whole?
  bool on_rows(const State& s) const;
  bool krylov_ = false;           ///< the constructor's krylov
  std::vector<int> dof_of_free_;  ///< per free index its dof (krylov_ only)
  Glue glue_;
};

}  // namespace ltl
