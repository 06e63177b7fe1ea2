// ALG2, the augmented-Lagrangian local/global iteration (4.1)-(4.4) of the paper, and its
// Bermudez-Moreno variant (7.7)-(7.10), for one time step (2.1) of the adhesion problem.
//
// Unknowns (our reading, section3-4.md): u (P2 / H8 nodal displacement), E and lambda (P0 per
// cell), e, beta, lambda_c (per contact point). One iteration reads as three phases:
//
//   (4.1) global step:
//           K u = f + g + GbarT [ R q (E - I) + lambda - 2 C1 I ] + MT [ R q_c e + lambda_c ]
//   (4.2) local steps:
//           E per cell (4.6, sec. 5), {e, beta} per point (4.7, sec. 6)
//   (4.3) update:
//           lambda -= rho R q (I + Gbar u - E),  lambda_c -= rho R q_c (ubar - e)
//
// Stopping [LTL87 (4.4)]: r_G + r_B < tol, with both parts scaled by ||I||_q (see residuals());
// the loop (acceleration, safeguard, NaN, blow-up, cap, history) is the driver's (fixed_point.hpp),
// shared with the Signorini solver.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adaptive_r.hpp"
#include "discretization.hpp"
#include "fe.hpp"
#include "global_step.hpp"
#include "mpi_global.hpp"
#include "newton.hpp"
#include "obstacles.hpp"
#include "problem.hpp"
#include "state.hpp"
#include "strain_step.hpp"

namespace ltl {

struct IterateRows;  // measures.hpp

namespace mpi {
struct Partition;
}

/// The ranks a Solver runs on: this process alone (the serial package), or every MPI rank of
/// an MPI build (lib/alg2_mpi.cpp, paper_notes/mpi.md).
enum class Ranks { One, All };

/// What this process holds, in bytes (Solver::holdings; the breakdown of paper_notes/mpi.md).
struct Holdings {
  int cells_with_operators = 0;  ///< cells whose rows of Gbar are not empty
  double mesh = 0;  ///< the mesh in the discretization's problem (X, cells, boundary facets), the
                    ///< rank's part of it (Discretization::part()) and its layer's X
  double operators = 0;    ///< Gbar, GbarT_vol, the Laplacian, vol, the columns' nodes
  double cell_arrays = 0;  ///< dense per-cell arrays: the work arrays, the cell lists
  /// Dense per-node arrays (dead loads, rhs), the ghost layer's node lists and the Dirichlet
  /// values (12 B per fixed dof).
  double node_arrays = 0;
  /// The rows of the global step's right-hand side: #nodes, or on several ranks with a ghost
  /// layer the rank's cells' and points' nodes (alg2_mpi.cpp)
  int rhs_rows = 0;
  /// The rows of u in a distributed ALG2's iterate while a phase runs (asked from a progress
  /// callback): with a ghost layer the layer's (rhs_rows), else #nodes; 0 outside a phase and
  /// in a serial solver (Ranks::One)
  int iterate_u_rows = 0;
  double contact = 0;  ///< the contact points' operators and arrays
  /// With the Newton phase (newton.hpp): its cells (the rank's on several ranks), their
  /// data, their positions in the tangent's pattern, and the whole-mesh data it keeps.
  int newton_cells = 0;
  double newton_cell_data = 0, newton_positions = 0, newton_whole = 0;
};

/// What this rank holds and did in a distributed solver (Ranks::All; zeros otherwise).
struct RankShare {
  int cells = 0, points = 0;         ///< owned cells and contact points
  bool contact_replicated = false;   ///< the coupled Gauss-Seidel (d0 > 0) on every rank
  bool replicated_cholesky = false;  ///< -ltl_mpi_replicated: the serial factor on every rank
  bool mumps = false;                ///< the distributed solve is MUMPS's Cholesky
  /// The automatic choice's prediction (DistributedGlobalStep::predicted_factor_bytes; -1: no
  /// analysis), and MUMPS's factorizations' allocation (factor_bytes; 0 with CG + GAMG)
  double predicted_factor_bytes = -1, factor_bytes = 0;
  long ksp_iterations = 0, ksp_solves = 0, ghosts = 0;
  long rows = 0;          ///< the rank's rows of the distributed matrices, summed over the sets
  long layer_ghosts = 0;  ///< the ghost layer's rows of other ranks, summed over the sets
  /// The distributed step's Dirichlet sets on this rank (DistributedGlobalStep::set_shares)
  std::vector<DistributedGlobalStep::SetShare> sets;
  /// GAMG's coarse operators, and those still holding their products' data (none after setup)
  int coarse_operators = 0, coarse_products = 0;
  double ksp_seconds = 0, ksp_setup_seconds = 0;
};

class Solver {
 public:
  /// Discretizes the problem (discretization.hpp), then the precompute: assembles K with R q and
  /// factorizes it once [LTL87 (4.5)]. Ranks::All with the distributed KSP (plain ALG2 or with
  /// the Newton phase): each rank discretizes its own cells only, its part of a graph partition
  /// (cell_partition; Discretization of some cells: Gbar, the Laplacian and its part of K of
  /// its cells; paper_notes/mpi.md).
  /// With the replicated factor the whole discretization, on every rank.
  /// The problem is held by the discretization: pass it by std::move when the caller has no
  /// further use for it (ltl_run, bench_mpi), else it is copied (its mesh included).
  explicit Solver(Problem problem, Ranks ranks = Ranks::One);
  /// The same from a discretization built beforehand. Ranks::All (an MPI build, lib/mpi_comm.hpp)
  /// distributes the iterations over the MPI ranks (alg2_mpi.cpp): each rank computes its cells
  /// and its block of contact points on the rank's rows of E and lambda, and gathers the whole
  /// state at the end of each ALG2 phase (solve_step). A rank's cells are those of its
  /// discretization of some cells (the ranks' must add up to the mesh's: an Error otherwise),
  /// else cell_partition's.
  explicit Solver(Discretization discretization, Ranks ranks = Ranks::One);
  ~Solver();

  /// E = I, lambda = 2 C1 I (zero first Piola-Kirchhoff stress P = 2 C1 E - lambda), u = the
  /// prescribed values, e = 0, beta = beta_0, lambda_c = 0. In the form of the state between
  /// steps (below), or with `whole` every cell's E and lambda (as a results file stores them).
  ///
  /// The state between steps. A distributed solver on a discretization of the rank's cells
  /// (Ranks::All, the default distributed KSP) keeps a state's E and lambda on the rank's rows
  /// only, the rows of discretization().held_cells() in their order (Discretization::cell_row):
  /// initial_state, solve_step, kept_copy / restore and the measures of lib/measures.hpp and
  /// lib/admissibility.hpp (collective) take and give that form. With a ghost layer (the default
  /// distributed KSP) u is on its rows too, the rank's cells' and contact points' nodes (since
  /// 2026-12-05; state_rows says where); else whole on every rank. The contact fields are whole
  /// on every rank. whole_state(), cells_to_writer() and nodes_to_writer() gather it. On one
  /// process, and with the replicated factor, the state is whole, and this is the same thing.
  State initial_state(bool whole = false) const;
  /// Where a state between steps, and an ALG2 phase's iterate, hold u (IterateRows,
  /// measures.hpp: the ghost layer's nodes, the cell operators' columns' rows, the rank's points
  /// and its owned nodes' rows), for the measures, the reactions, the admissibility check and
  /// the stopping test: `at` filled and returned when u is on the layer's rows, null when it is
  /// whole.
  const IterateRows* state_rows(IterateRows& at) const;
  /// The reference positions X on the rows of u that state_rows gives (IterateRows::X, which
  /// sets it once the mesh's X is released after the set-up), the writer reading them by the
  /// nodes each rank owns (nodes_to_writer); null when u is not on a ghost layer's rows.
  const Eigen::MatrixXd* reference_rows() const;
  /// u of a state between steps made whole on every rank (collective when it is on the layer's
  /// rows; else nothing): what the Newton phase takes.
  void whole_u(Eigen::MatrixXd& u) const;
  /// The nodes first .. first + count - 1 (count < 0: to the last) of u of a state between steps,
  /// on rank 0 alone, the results writer, in `block` (collective when u is on the layer's rows:
  /// each node's row from the rank that owns it); on the other ranks `block` is left empty.
  void nodes_to_writer(const Eigen::MatrixXd& u, Eigen::MatrixXd& block, int first = 0,
                       int count = -1) const;
  /// Does a state between steps hold E and lambda on the rank's rows (above)?
  bool rows_between_steps() const;
  /// The whole state from a state between steps, on every rank (collective; a copy when it is
  /// whole already).
  State whole_state(const State& s) const;
  /// The cells first_cell .. first_cell + count - 1 (count < 0: to the last) of a per-cell field
  /// of a state between steps (rows_per_cell rows per cell: every cell's, or the rank's held
  /// cells' in their order), on rank 0 alone, the results writer, in `block` (collective when
  /// rows_between_steps(); else a copy of those rows): on the other ranks `block` is left empty.
  /// E, lambda, and the fields computed from them (lib/step_fields.hpp) are gathered so, a block
  /// of cells at a time: no rank holds a whole field.
  void cells_to_writer(const Eigen::MatrixXd& rows, Eigen::MatrixXd& block, int rows_per_cell,
                       int first_cell = 0, int count = -1) const;
  /// A whole state (a results file's, --resume, --init) made the state between steps: E and
  /// lambda cut to the rank's rows and u to the layer's (nothing when they are whole between
  /// steps).
  void hold_rows(State& s) const;

  /// [LTL87 (2.1), (4.1)-(4.4) / (7.7)-(7.10)] Iterates from `state` (warm start) to
  /// convergence; beta_prev is beta at the previous time step. `progress` (may be null) is
  /// called after every iteration. Never throws on divergence: the report says what happened.
  StepReport solve_step(State& state, const Eigen::VectorXd& beta_prev,
                        const std::function<void(const IterationRecord&)>& progress = {});

  /// The discrete problem: operators, contact points, Dirichlet data, loads, outputs.
  const Discretization& discretization() const { return disc_; }
  /// The Newton phase (algorithm.solver = "newton"; else null).
  const Newton* newton() const { return newton_.get(); }
  const Problem& problem() const { return disc_.problem(); }
  int dim() const { return disc_.dim(); }
  /// With a Newton phase (algorithm.solver = "newton") the dimension, else 0: the automatic
  /// choice of the global solver counts the Newton tangent's factor too (global_step.hpp).
  int newton_dim() const { return alg().solver == NonlinearSolver::Newton ? dim() : 0; }
  /// Discretization::energy_gradient at the current load.
  Eigen::MatrixXd energy_gradient(const Eigen::MatrixXd& u) const {
    return disc_.energy_gradient(u, external_load());
  }

  /// [LTL87 (2.2)] The discrete functional J_p at a state, with beta_prev = beta_{p-1}:
  ///   sum_e |O_e| W(E_e) + C1 (||grad u||^2 - sum_e |O_e| |Gbar_e u|^2) - f.u - g.u
  ///   + sum_s |G_s| [(kappa/2) beta_s^2 |e_s|^2 - w beta_s] + dissipation(beta - beta_prev).
  /// (At a converged state E = I + Gbar u and e = ubar up to the tolerance.)
  double energy(const State& s, const Eigen::VectorXd& beta_prev) const;

  /// [(4.1)-(4.4), (2.2)] The current iterate, for a checkpoint, from solve_step's `progress`
  /// callback (`s` the state solve_step was given), in the form of the state between steps, which
  /// ResultsWriter::checkpoint writes. In a Newton phase, Newton's iterate
  /// (Newton::current_state; `s` holds ALG2's last one: until 2026-12-03 a checkpoint saved
  /// that, and --resume did the Newton phase again); with glue ALG2's last one still (a glued
  /// Newton state is kept only if the local contact step holds there). A distributed solver
  /// iterates on the rank's rows of E and lambda and releases the caller's E and lambda until the
  /// ALG2 phase ends; inside that phase this makes the iterate into the state between steps, as
  /// the phase's end does (between_steps; collective: every rank calls it at the same
  /// iteration): E and lambda the rank's rows, which the writer gathers a block of cells at a
  /// time (StepFields; whole on every rank with the replicated factor), u on the ghost layer's
  /// rows, which the writer reads a block of nodes at a time (nodes_to_writer; whole without a
  /// ghost layer), and the contact fields from the ranks' points (whole on every rank). Only
  /// then: an iteration
  /// without a save gathers
  /// nothing (until 2026-12-03 a run with --checkpoint gathered E and lambda to every rank at every
  /// iteration, and until the fifth session of that day a save gathered them whole on rank 0).
  /// Null when `s` is the iterate: ALG2's phase of a serial solver (Ranks::One), or `s` between
  /// ALG2's phases without a Newton iterate.
  std::optional<State> iterate_to_writer(const State& s) const;
  /// [(4.5)] The equilibrium stopping test (measures.hpp: equilibrium_error) at the iterate of
  /// the ALG2 phase under way on the ranks, as the phase evaluates it when it is due: on a
  /// ghost layer at the iterate's rows (no whole u or contact field made: state_rows), else on
  /// the state between steps made from it. Null outside such a phase (collective: from a
  /// progress callback, every rank).
  std::optional<double> iterate_equilibrium_error() const;

  /// A copy of the state s to go back to (load subdivision, lib/simulation.cpp): in a
  /// distributed solver its E and lambda are the rank's rows only (as own_rows) and u the ghost
  /// layer's rows (u_on_layer; without a layer the rank's block of the nodes, mpi::blocks), the
  /// contact fields whole; on one process a plain copy. restore() makes s that state again, in
  /// the form of the state between steps (collective when u is kept by blocks: u gathered); s's
  /// own fields are released first, so that one whole state exists at a time.
  State kept_copy(const State& s) const;
  void restore(const State& kept, State& s) const;

  /// The serial global step (an Error in a distributed solver with the distributed KSP).
  const GlobalStep& global_step() const;
  /// The global step's solver, in the words of the run's first line: "2 factor(s)" (CHOLMOD's,
  /// one per Dirichlet set), "CG + AMG on 2 Dirichlet set(s)", or over the ranks "MUMPS's
  /// Cholesky over 2 ranks, ..." or "CG + GAMG over 2 ranks, ...", with the prediction that
  /// made the automatic choice when MUMPS's analysis made it (mpi_global.hpp).
  std::string global_step_summary() const;
  /// Over the ranks: the distributed step is CG + GAMG (chosen, or the automatic choice); the
  /// Newton phase then solves by GMRES + GAMG (newton_krylov.hpp).
  bool distributed_cg_gamg() const;
  bool distributed() const { return dist_ != nullptr; }
  RankShare rank_share() const;
  /// The ranks' cells (cell_partition) of a distributed solver (Ranks::All); else null. Its rows of
  /// a per-cell array gather with mpi::gather_rows. Its order (every cell's rank) is released after
  /// the set-up on a rank's cells without the Newton phase (release_after_setup): then only its
  /// offsets are left, and a rank's cells are own_cells().
  const mpi::Partition* cell_partition() const;
  /// The ranks' contact points (point_partition) of a distributed solver with contact; else null.
  const mpi::Partition* contact_point_partition() const;
  /// The bytes this process holds in the discretization and the solver's arrays (not PETSc's
  /// or the factor's).
  Holdings holdings() const;
  /// load_factor() x the assembled dead loads f, g (#nodes x dim; made on each call: the Solver
  /// keeps the dead loads once, in the discretization, and the factor).
  Eigen::MatrixXd external_load() const { return load_factor_ * disc_.dead_load(); }
  /// max |external_load()|, the largest nodal load, without making the array (measures.hpp).
  double largest_load() const;
  /// The load factor of the current step (LoadRamp, set by the time loop before each step):
  /// external_load() = factor x the assembled dead loads f, g, and the prescribed displacements
  /// at factor x their values (set_displacement_factor(factor)). K is unchanged.
  void set_load_factor(double factor);
  /// The prescribed displacements alone at `factor` x their values (1 by default). K is
  /// unchanged.
  void set_displacement_factor(double factor);
  double load_factor() const { return load_factor_; }
  /// The augmentation parameter R in use (the configuration's, or the last one chosen by the
  /// adaptive rule, AlgorithmParams::adaptive_R), and how many times K was factorized.
  double R() const { return R_; }
  /// Wall-clock seconds of the setup: the discretization, then the precompute (assembly and
  /// factorization of K) and the rest of the constructor.
  double setup_seconds() const { return setup_seconds_; }
  int factorizations() const { return factorizations_; }

 private:
  /// [LTL87 (4.5)] The precompute, the only place where R meets the operators: K with R q and
  /// R q_c, factorized; the local steps with R q and R q_c.
  void precompute(double R);

  /// What the global step (4.1) hands to the local steps (4.2) and the update (4.3): the cell
  /// mean gradients Gbar u, the means ubar of u at the contact points, and the mean-det targets
  /// det E_e = J_e = 1 - c_e(u). Allocated once.
  struct GlobalOutput {
    /// Gbar u of the cells own_cells() in their order: (dim #own cells) x dim, the k-th cell's
    /// block at rows dim k (every cell in the cell order on one process), like the iterate's E.
    Eigen::MatrixXd GU;
    Eigen::MatrixXd ubar;  ///< #points x dim, like u
    Eigen::VectorXd J;     ///< #own cells
  };
  /// The multipliers the local steps see: lambda^{n-1} (Uzawa) or the half step (7.8).
  struct Multipliers {
    Eigen::MatrixXd lambda, lambda_c;
  };

  /// [LTL87 (4.1)-(4.3) / (7.7)-(7.10)] One iteration: s = (u, E, e, beta, lambda, lambda_c)
  /// -> its successor. Returns r_G and r_B of the iteration (timings filled, n and wall not).
  IterationRecord iterate(State& s, const Eigen::VectorXd& beta_prev, int& strain_failures);
  /// Phase 1, (4.1): u from the right-hand side built on s; fills g.
  void global_phase(State& s, GlobalOutput& g);
  /// Phase 2, (4.2) = (4.6) + (4.7): E per cell and {e, beta} per contact point, given the
  /// multipliers lambda, lambda_c; returns the number of local strain problems that failed.
  int local_phase(const GlobalOutput& g, const Eigen::MatrixXd& lambda,
                  const Eigen::MatrixXd& lambda_c, const Eigen::VectorXd& beta_prev, State& s,
                  IterationRecord& rec);
  /// Phase 3, (4.3) / (7.10): the multiplier update from the constraint residual
  /// B = (I + Gbar u - E, ubar - e); Bermudez-Moreno starts from the half step m.
  void update_phase(const GlobalOutput& g, const Multipliers* half, State& s) const;
  /// [LTL87 (7.8)] Bermudez-Moreno's half step: lambda - R q B(u^n, G^{n-1}).
  void half_step(const GlobalOutput& g, const State& s, Multipliers& m) const;
  /// [LTL87 (4.4)] r_G (change of the local variables since `prev`) and r_B (the constraint
  /// residual), both with the weights of (3.3) and divided by ||I||_q; and whether u is finite
  /// on every rank (distributed, the ranks' u differ off their ghost layers: summed with the
  /// residual's parts).
  void residuals(const GlobalOutput& g, const State& s, const State& prev, IterationRecord& rec,
                 bool& finite) const;

  /// The accelerated part of the iterate as one vector, scaled so that its Euclidean norm is
  /// the norm of r_G + r_B (weights of (3.3), multipliers divided by R q and R q_c).
  void pack(const State& s, Eigen::VectorXd& z) const;
  void unpack(const Eigen::VectorXd& z, State& s) const;
  /// The blocks of the packed vector in their order, one definition for pack and unpack:
  /// cells(A, c) and points(A, c, first, n) for the cell and point fields with their scale c
  /// (the points first .. first + n - 1: each run of own_points()), beta(b, w) for each of
  /// those points' beta_s with its weight, u(A) for the displacement (mean-det).
  template <class S, class Cells, class Points, class Beta, class U>
  void for_each_packed(S& s, Cells&& cells, Points&& points, Beta&& beta, U&& u) const;
  /// Adaptive R at the check after iteration rec (every adapt_every iterations): the R that
  /// adaptive_R_ (adaptive_r.hpp) asks for; true when it changed (K re-factorized; s may have
  /// been restored to the best iterate since a lowering that stalled).
  bool adapt_R(const IterationRecord& rec, State& s);

  /// [LTL87 (4.7), (6.1)-(6.8)] Is s (a converged Newton state, e = ubar) a fixed point of the
  /// local contact step: does each point's global minimizer over (e, gamma) give back s's e and
  /// beta? No when Newton met the first-order conditions on another branch of the glue (a
  /// stationary point the local step would leave, of higher energy).
  bool local_contact_step_holds(const State& s, const Eigen::VectorXd& beta_prev) const;

  const AlgorithmParams& alg() const { return disc_.problem().algorithm; }

  // The distribution over the MPI ranks (Ranks::All), in alg2_mpi.cpp: the owned blocks, the
  // owned parts of the operators and the distributed KSP.
  struct Distribution;
  struct DropDistribution {  // defined where Distribution is (alg2_mpi.cpp)
    void operator()(Distribution* d) const;
  };
  void distribute();
  /// After the set-up, on the ranks of a distributed run without the Newton phase (which reads
  /// them: newton.hpp), what the ranks no longer read whole: the mesh's connectivity and, with u
  /// on the ghost layer's rows, its positions (the writer reads them back from the ranks), and
  /// the order of the cells' partition (the writer gathers the cells' rows by their numbers).
  void release_after_setup();
  /// [(1.2)] f . u of the dead loads at factor 1 over the nodes each rank owns, summed over the
  /// ranks (collective), u whole: on ranks that kept their own nodes' loads (keep_loads).
  double owned_load_work(const Eigen::MatrixXd& u) const;
  /// The discretization a Solver on `ranks` builds (a rank's cells, or every cell).
  static Discretization discretize(Problem problem, Ranks ranks);
  /// The contact points whose term R q_c M^T |G| M goes into this rank's part of K: all of them
  /// unless the discretization is partial, then on rank 0 alone.
  const ContactPoints* points_in_K() const;
  /// The cells, and the contact points, whose local steps and updates this rank computes (sorted;
  /// all of them unless distributed; all points when the contact step is replicated).
  const std::vector<int>& own_cells() const;
  const std::vector<int>& own_points() const;
  /// The contact points whose residual and right-hand side this rank sums (sorted; its own
  /// points of the partition when distributed, point_partition in mpi_global.hpp).
  const std::vector<int>& residual_points() const;
  /// The distributed KSP in place of the factor, K moved into it (released once in PETSc's
  /// matrices); false with the replicated Cholesky, K untouched.
  bool distributed_global_step(SpMat& K, double scale);
  double distributed_value_scale() const;
  void set_distributed_value_scale(double scale);
  /// Phase 1 when distributed: the right-hand side's owned parts summed over the ranks, the
  /// distributed solve, then the owned rows of Gbar u, ubar and J.
  void global_phase_distributed(State& s, GlobalOutput& g);
  /// Sums over the ranks (residual parts, failures); nothing unless distributed.
  void sum_over_ranks(double* x, int n) const;
  /// Does each rank compute its own contact points (point_partition: the contact step
  /// distributed, not replicated)? Its iterate's e, lambda_c and beta are then current on those
  /// points only, until gather_points.
  bool points_distributed() const;
  /// The stopping test at the phase's iterate `own` (iterate_equilibrium_error).
  double equilibrium_error_of(const State& own) const;
  /// The owned points' rows of e, lambda_c and beta gathered (collective): at the end of an ALG2
  /// phase and wherever a whole state is made from the iterate (whole(), between_steps()), not
  /// after each iteration.
  void gather_points(State& s) const;
  /// The rank's rows of a per-cell field (the k-th of own_cells() at rows dim k), cut from a
  /// whole field or copied from those rows.
  Eigen::MatrixXd rank_rows(const Eigen::MatrixXd& A) const;
  /// Distributed: the iterate of the iterations from a state s, whose E, lambda and u are
  /// released: the rank's rows of E and lambda (the k-th of own_cells() at rows dim k; cut from
  /// a whole s, moved from a state between steps on the rank's rows), u on the ghost layer's
  /// rows (cut; whole and moved without a ghost layer), the contact fields whole (moved).
  State own_rows(State& s) const;
  /// The whole state from such an iterate (collective: E, lambda and the points' blocks
  /// gathered from the ranks).
  State whole(const State& own) const;
  /// The state between steps from such an iterate (collective): the points' blocks gathered,
  /// E and lambda kept on the rank's rows and u on the ghost layer's when rows_between_steps(),
  /// else all gathered (whole()).
  State between_steps(State own) const;
  /// Is u of the state between steps on the rank's ghost layer's rows (a distributed solver of
  /// the rank's cells with a ghost layer: state_rows)?
  bool u_on_layer() const;
  /// u cut to the ghost layer's rows when u_on_layer() and it is whole; else left as it is.
  void layer_rows(Eigen::MatrixXd& u) const;
  /// E and lambda gathered from the rank's rows (collective), the contact fields copied; no u.
  State whole_cells(const State& rows) const;

  Discretization disc_;
  double R_ = 1;  ///< R in use (see R())
  int factorizations_ = 0;
  double setup_seconds_ = 0;
  AdaptiveR adaptive_R_{alg()};  ///< algorithm.adaptive_R (adaptive_r.hpp)
  std::unique_ptr<GlobalStep> global_;
  std::unique_ptr<StrainStep> strain_;
  std::vector<int> all_points_;            ///< 0 .. #points - 1 (own_points() unless distributed)
  std::unique_ptr<ContactSteps> contact_;  ///< one local contact step (4.7) per obstacle
  std::unique_ptr<Newton> newton_;         ///< algorithm.solver = "newton" (newton.hpp)
  double gamma_ = 0;  ///< mean-det's proximal stiffness on the fluctuations, 2 R q
  double load_factor_ = 1;
  const State* alg2_rows_ = nullptr;  ///< the rank's rows during an ALG2 phase (solve_step)
  bool iterate_finite_ = true;        ///< u of the last iteration finite on every rank
  double norm_I_ = 1;                 ///< ||I||_q = sqrt(q |Omega| dim)
  // Work buffers of the ALG2 iterations (allocated once per ALG2 phase, not per iteration): the
  // global step's right-hand side and output, the multipliers of the local steps
  // (Bermudez-Moreno), the previous iterate of the residual r_G. Sized by make_work (the
  // constructor, and each ALG2 phase of solve_step after a Newton phase); release_work frees them
  // for a Newton phase, which does not use them. rhs_ is #nodes x dim, on the rank's ghost layer
  // (alg2_mpi.cpp) #layer x dim: rhs_rows().
  void make_work();
  void release_work();
  int rhs_rows() const;
  Eigen::MatrixXd rhs_, T_;
  GlobalOutput global_out_;
  Multipliers half_;
  State prev_;  ///< E: the own cells' rows in their order, like GlobalOutput::GU
  // The packed iterate of Anderson acceleration: its length and weights.
  Eigen::Index packed_size_ = 0, packed_distributed_ = 0;
  Eigen::VectorXd w_cell_, w_point_;
  double w_u_ = 0;  ///< weight of u in the accelerated vector (mean-det only)
  // Ranks::All: the owned blocks, the owned parts of the operators, the distributed KSP
  // (alg2_mpi.cpp); null on one rank.
  std::unique_ptr<Distribution, DropDistribution> dist_;
  /// ALG2 as the fixed-point map of the driver (fixed_point.hpp), in alg2.cpp.
  class Alg2Map;
};

}  // namespace ltl
