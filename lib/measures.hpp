// The numbers the figures report, each with one definition (computed here and nowhere else).
//
// Every measure takes the discretization (the problem and its contact points), the loads where it
// needs them and the state: nothing here reads the solver, so that the solver, the time loop, the
// drivers and the tests measure the same way.
//
// Contact measures are taken over the discretization's contact points (facets with
// discretization.contact = "facet-mean", nodes with "nodal"): p_i = -lambda_c_i . N is the
// nominal contact pressure (per reference length/area) at point i with weight w_i; a point is in
// contact where p_i > kContactThreshold * max_i p_i.
//
// Peel measures are taken over the same contact points where the glue is modelled (the adhesion
// intensity beta per point, [LTL87 (1.2)-(1.3)]): the opening of a point is -e . N (the contact
// displacement away from the support, > 0 once the bar has lifted off, (4.11)); a point is
// debonded where beta < kDebondedBeta and damaged where beta < kDamagedBeta; the debonding front
// is the largest reference coordinate (along `axis`) of a debonded point.
//
// Every measure of a step is written to the results file (stored_measures(), /steps/N/measures,
// experiments/README.md): the drivers print them, the regression compares them, the figure
// scripts plot them; none of them recomputes a definition or a threshold.
//
// The equilibrium measure is the residual of the discrete equilibrium of the reduced energy with
// the contact forces, the (4.5) equation at a fixed point of (4.1)-(4.3) written with the stress
// P = 2 C1 E - lambda: "converged" means the same thing for plain and accelerated iterations and
// for a Newton solver.
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "discretization.hpp"
#include "problem.hpp"
#include "state.hpp"
#include "stored_measure.hpp"

namespace ltl {

struct IterateRows;  // below: where a distributed solver's state holds u

/// A contact point is in contact where its pressure exceeds this fraction of the peak pressure.
inline constexpr double kContactThreshold = 1e-6;

/// A contact point's glue is broken ("debonded") where beta < kDebondedBeta: fewer than half of
/// its adhesive links survive. Defines the debonding front and the broken count (Figs 3-4).
inline constexpr double kDebondedBeta = 0.5;
/// A contact point's glue is damaged where beta < kDamagedBeta: it has lost more than a tenth of
/// its links. The front of the damage runs ahead of the debonding front and moves before any
/// link breaks; the regression compares it (key front_beta_below_0.9) on runs that stop before
/// the peel runs away, where nothing is debonded yet.
inline constexpr double kDamagedBeta = 0.9;

/// The contact set of the nominal contact pressures p (Discretization::contact_pressure): 1 at the
/// points with p_i > kContactThreshold * max_i p_i, else 0.
Eigen::VectorXi contact_set(const Eigen::VectorXd& p);

struct ContactMeasures {
  int points = 0;          ///< contact points (facets or nodes)
  int in_contact = 0;      ///< points with p_i > kContactThreshold * p_max
  double p_max = 0;        ///< peak nominal contact pressure (Pa)
  double force = 0;        ///< sum_i w_i p_i (N/m in plane strain, N in 3-D)
  double area = 0;         ///< sum of w_i over the points in contact (reference measure)
  double a_edge = 0;       ///< largest deformed coordinate along `axis` of a node that carries
                           ///< a point in contact (a facet's nodes, or the node itself)
  double a_moment = 0;     ///< 2 sqrt(M2 / M0), M0 = sum w_i p_i, M2 = sum w_i p_i x_i^2, x_i
                           ///< the deformed coordinate along `axis` of point i (smooth in h)
  double penetration = 0;  ///< max over the contact surface's nodes of (x - p0) . N (> 0: inside)
  /// sum_i w_i lambda_c_i: the force of the obstacle on the body (N/m in plane strain, N;
  /// lambda_c is the support's traction, section6.md); its component along -N is `force` without
  /// glue. The balance of forces of several obstacles: their resultants and the loads sum to 0.
  Eigen::Vector3d resultant = Eigen::Vector3d::Zero();
};

/// [LTL87 (1.1), (4.11)] The contact measures at a state over the discretization's contact
/// points (none without a contact surface); `axis` is the coordinate along which the contact
/// zone's half-width is measured (x1 for Figs 5-6).
/// Several obstacles (paper_notes/obstacles.md): those of obstacle k, over its own points.
/// With `at`, s is a distributed solver's state between steps, u on a rank's layer rows
/// (IterateRows; collective).
ContactMeasures contact_measures(const Discretization& d, const State& s, int axis = 0, int k = 0,
                                 const IterateRows* at = nullptr);

/// [LTL87 (4.11)] The opening of each contact point, -e_i . N (m): the contact displacement
/// away from the support (e . N <= 0 is the non-penetration of (1.1); > 0: lifted off).
Eigen::VectorXd opening(const Problem& problem, const State& s);

struct PeelMeasures {
  int points = 0;  ///< contact points (facets or nodes)
  int broken = 0;  ///< points with beta < kDebondedBeta
  /// Debonding front: the largest reference coordinate along `axis` (facet centre or node) of a
  /// point with beta < kDebondedBeta; NaN when no point is debonded.
  double front = std::numeric_limits<double>::quiet_NaN();
  /// Damage front: the same with beta < kDamagedBeta; NaN when no point is damaged.
  double damage_front = std::numeric_limits<double>::quiet_NaN();
  double beta_min = 0, beta_max = 0;
  double beta_l2 = 0;        ///< sqrt(sum_i w_i beta_i^2 / sum_i w_i), the mean-square beta
  double max_opening = 0;    ///< max_i opening_i (m), opening() (may be < 0 when pressed)
  int max_opening_at = -1;   ///< the point where it is reached (the first one on ties)
  double max_opening_x = 0;  ///< its reference coordinate along `axis` (m)
};

/// [LTL87 (1.2)-(1.3), (4.11)] The peel measures at a state over the contact points `points`
/// (which carry s.beta); `axis` is the coordinate along which the front is measured (x1).
PeelMeasures peel_measures(const Problem& problem, const ContactPoints& points, const State& s,
                           int axis = 0);

/// Every measure of a step: contact measures when the problem has a contact surface, peel
/// measures when it is glued (kappa = 1/eps > 0, the state carrying beta per point), and the
/// largest nodal displacement.
struct StepMeasures {
  std::optional<ContactMeasures> contact;  ///< of obstacle 0 (the one obstacle of the paper)
  std::vector<ContactMeasures> obstacles;  ///< of obstacles 1, 2, ... (stored suffixed "_k")
  std::optional<PeelMeasures> peel;
  Eigen::VectorXi in_contact;   ///< contact_set() per contact point (empty without contact)
  double max_displacement = 0;  ///< max over nodes of |u| (m)
};
/// With `at`, u on a rank's layer rows (contact_measures; collective).
StepMeasures step_measures(const Discretization& d, const State& s, int axis = 0,
                           const IterateRows* at = nullptr);

/// The measures as written to results files (/steps/N/measures): name, value, unit,
/// description; one list, so that the file and this header cannot disagree. `dim` selects the
/// units of forces and areas (plane strain: per metre of depth).
std::vector<StoredMeasure> stored_measures(const StepMeasures& m, int dim);

/// The node at reference position X (within 1e-9 m): its index; a clear error if there is none.
/// (Fig 5's "drop of the top" is -u2 at the node (0, 1).)
int node_at(const Mesh& mesh, const Eigen::VectorXd& X);

/// The applied load along the contact plane's normal N: sum over nodes of f_ext . N (what the
/// plane carries when nothing else holds the body), f_ext the assembled loads (#nodes x dim,
/// Solver::external_load). 0 without contact.
double load_along_normal(const Problem& problem, const Eigen::MatrixXd& f_ext);

/// max |load_scale f_ext|, the largest nodal load, without making the array: |load_scale| max
/// |f_ext|, which is max |fl(load_scale f_ext)| exactly (rounding is monotonic).
double largest_load(const Eigen::MatrixXd& f_ext, double load_scale = 1);
/// The same for the discretization's dead loads (Discretization::dead_load), read on the loaded
/// nodes: no #nodes x dim array.
double largest_load(const Discretization& d, double load_scale);

/// Residual of the discrete equilibrium, #nodes x dim:
///   r = GbarT_vol P + 2 C1 (L u - GbarT_vol Gbar u) - f_ext - meanT_area lambda_c^T
///       - Discretization::fluctuation_force (mean-det incompressibility only),
///   P = 2 C1 E - lambda (C1 of Discretization::split()), f_ext the assembled loads (#nodes x
///   dim, Solver::external_load).
/// Zero on every free degree of freedom at a fixed point of (4.1)-(4.3); on a fixed one it is the
/// reaction of the support.
/// The loads are load_scale x f_ext: a caller holding the dead loads and a load factor
/// (Solver) passes them so, with no #nodes x dim copy.
Eigen::MatrixXd equilibrium_residual(const Discretization& d, const Eigen::MatrixXd& f_ext,
                                     const State& s, double load_scale = 1);

/// [(4.5)] The rows first .. first + r.rows() - 1 of equilibrium_residual: every row (first 0)
/// on a discretization of every cell. On a rank's cells (Discretization::partial()) the rank's
/// block of the nodes (mpi::blocks(#nodes, ranks)): each rank's cells' part on their nodes
/// (Discretization::held_cell_forces_on_columns), summed by the blocks' ranks
/// (mpi::sum_rows_to_blocks), less the block's loads and contact term (by point). No rank makes
/// an array of every node, and the sum moves the rank's nodes, not every node (collective). With
/// f_ext null, the loads are the discretization's dead loads (read on the loaded nodes).
struct ResidualRows {
  Eigen::MatrixXd r;
  int first = 0;
};
/// Where a rank's ALG2 iterate holds u and the contact multipliers (a phase on a ghost layer,
/// alg2_mpi.cpp: Solver::state_rows): u's rows are the nodes `nodes` (sorted), column j of the
/// cell operators at u's row column_row[j], and lambda_c current at the points `points` alone
/// (the rank's, each point on one rank; null: every point current on every rank).
/// Between steps a distributed solver's state holds u on the same rows (Solver::state_rows), and
/// `owned` lists the rows (positions in `nodes`) of the nodes that the rank owns, each node of the
/// mesh owned by one rank (node_ranks, mpi_global.hpp): what counts a node once over the ranks.
/// A node's row is the same on every rank whose layer holds it.
/// X: the reference positions on the same rows, held by a rank that has released the mesh's
/// (Mesh::release_X, after the set-up: paper_notes/mpi.md, "The mesh's positions on the rank's
/// nodes"); null while the mesh's X is whole, which is then read.
struct IterateRows {
  const std::vector<int>* nodes = nullptr;
  const int* column_row = nullptr;
  const std::vector<int>* points = nullptr;
  const std::vector<int>* owned = nullptr;
  const Eigen::MatrixXd* X = nullptr;
};
/// u's rows at the nodes `nodes` (any order), on every rank: s.u's rows when u is whole (at
/// null), else from the ranks whose layer holds them (collective: every node is on some rank's
/// layer; the largest over the ranks of the rows, -inf where a rank has none, is the row).
Eigen::MatrixXd u_at_nodes(const State& s, const std::vector<int>& nodes, const IterateRows* at);
/// The reference positions X of the nodes `nodes` (any order), on every rank: the mesh's rows,
/// or with `at` holding them (IterateRows::X) from the ranks whose layer holds them, as
/// u_at_nodes (collective then).
Eigen::MatrixXd X_at_nodes(const Mesh& mesh, const std::vector<int>& nodes, const IterateRows* at);
/// X(n, c) of node n at u's row `row` (u_row_of): the mesh's, or the rank's row with
/// IterateRows::X.
inline double X_at(const Mesh& mesh, const IterateRows* at, int n, Eigen::Index row, int c) {
  return at && at->X ? (*at->X)(row, c) : mesh.X(n, c);
}
/// [(3.2)] mean * X of the contact points (#points x dim: their reference positions as the
/// constraint reads them), with the mesh's X whole (at null or without IterateRows::X: the
/// product), else summed term by term on the rows of each rank's points, as point_means
/// (collective).
Eigen::MatrixXd point_reference(const ContactPoints& pts, const Mesh& mesh, const IterateRows* at);
/// [(3.2)] mean * u of the contact points (#points x dim: ubar, of the constraint ubar = e), with
/// u whole (at null) or on a rank's layer rows (collective): each rank the rows of its points
/// (every point when `at->points` is null), summed term by term as the row-major product does.
/// Their deformed positions are point_reference + point_means.
Eigen::MatrixXd point_means(const ContactPoints& pts, const State& s, const IterateRows* at);
/// With `at` (a rank's discretization only), s is in that form: the rank's points' contact terms
/// are added at their nodes with its cells' forces, before the sum on the blocks.
ResidualRows equilibrium_residual_rows(const Discretization& d, const Eigen::MatrixXd* f_ext,
                                       const State& s, double load_scale = 1,
                                       const IterateRows* at = nullptr);

struct EquilibriumMeasure {
  double force_residual = 0;  ///< max |r| over free dofs / max |f_ext| (largest nodal load)
  /// max over cells of |det E + c_e - 1|, the incompressibility constraint as discretized
  /// (c_e = 0 for det-mean, Discretization::fluctuation_det for mean-det); 0 for a compressible
  /// law. It is NOT the pointwise det F: under mean-det only the cell mean of det F is 1 and det F
  /// varies inside a cell legitimately (and so does det E_e = 1 - c_e); see det_min.
  double det_error = 0;
  double penetration = 0;  ///< ContactMeasures::penetration (0 without contact)
  /// min over the quadrature points of every cell of det F = det(I + grad u) (in-plane block in
  /// plane strain), lib/admissibility.hpp min_det_F: > 0 unless a cell is inverted. With
  /// det_error ~ 0 it tells how far the pointwise det F strays from 1 under mean-det.
  double det_min = 0;
};

/// The equilibrium measure of a state under the loads f_ext (reported with every converged step).
EquilibriumMeasure equilibrium_measure(const Discretization& d, const Eigen::MatrixXd& f_ext,
                                       const State& s, double load_scale = 1);
/// The same under the discretization's dead loads times load_scale, without making them whole
/// (the solver's step; on a rank's cells on the blocks of the nodes, equilibrium_residual_rows).
/// With `at`, u on a rank's layer rows (IterateRows: the state between steps of a distributed
/// solver; collective).
EquilibriumMeasure equilibrium_measure(const Discretization& d, const State& s, double load_scale,
                                       const IterateRows* at = nullptr);

/// Max over the obstacles and their contact groups' nodes of (x - x_0) . N, the deformed node's
/// distance behind the obstacle plane (m; > 0: penetration); -inf without contact. With `at`, u
/// on a rank's layer rows (collective: the largest over the ranks' layers); on ranks that have
/// released the mesh's X (Mesh::release_X) collective too, u whole read at their parts' nodes.
double max_penetration(const Discretization& d, const State& s, const IterateRows* at = nullptr);
/// The same for obstacle k alone: max over its group's nodes of (x - p0_k) . N_k. A node behind
/// ANY obstacle is inadmissible: max_penetration is the max over the obstacles.
double penetration_of(const Discretization& d, const State& s, int k,
                      const IterateRows* at = nullptr);

/// The stopping test of `algorithm.stopping = "equilibrium"` (4.5): the largest of
/// - the force residual on the free dofs (equilibrium_residual) relative to a force scale: the
///   largest nodal load, else (a problem driven by prescribed displacements) the largest reaction,
///   else C1 h^(d-1) (a problem at rest);
/// - the strains' compatibility with u, max |E_e - (I + Gbar_e u)| (B = 0 of (3.2)), and for an
///   incompressible law the constraint on u itself, max |det(I + Gbar_e u) + c_e(u) - 1|;
/// - the penetration (max_penetration, when positive) relative to the body's size |Omega|^(1/d).
/// A step is converged when this is at most `algorithm.force_tol`, whatever the iteration.
double equilibrium_error(const Discretization& d, const Eigen::MatrixXd& f_ext, const State& s,
                         double load_scale = 1);
/// The same under the discretization's dead loads times load_scale (equilibrium_measure above).
double equilibrium_error(const Discretization& d, const State& s, double load_scale);
/// The same at a rank's ALG2 iterate on its ghost layer's rows (IterateRows; a discretization of
/// the rank's cells, collective): the residual on the blocks of the nodes from the rank's cells
/// and points, the compatibility and det terms on its cells, the penetration at its layer's
/// nodes, the largest over the ranks. The stopping test then makes no whole u or lambda_c.
double equilibrium_error(const Discretization& d, const State& s, double load_scale,
                         const IterateRows& at);

}  // namespace ltl
