// Is a converged state a physical one? The iteration (4.1)-(4.4) and the equilibrium check of
// the time loop (lib/simulation.cpp) only say that a state is a fixed point in equilibrium; the
// discrete problem has other fixed points than the physical one (paper_notes/admissibility.md):
// a body turned through the obstacle under a dead load (only the contact surface is constrained
// by (1.1)), a cell inverted inside, a cell on the branch of the local strain step (4.6) rotated
// by pi. check_admissibility() looks for each of them after convergence and before writing:
//
//   - obstacle: every node of the body (not only the contact surface) on the admissible side of
//     the plane, (x - p0) . N <= kInsideTolerance h, h the mean cell size (on the contact surface:
//     its contact points, up to the constraint residual ubar - e of the iterate);
//   - orientation: det F > 0 at every quadrature point of every cell (F = I + grad u; the in-plane
//     block in plane strain) and det E_e > 0 for the stored cell strain;
//   - rotated branch: the polar rotation of no cell's E_e differs by more than
//     kRotationJumpDegrees from the polar rotations of the majority of the cells sharing a node
//     with it;
//   - contact: the contact pressure p = -lambda_c . N >= -kPressureTolerance p_ref where there is
//     no glue (kappa = 0, or beta = 0 at the point), and 0 <= beta <= 1.
//
// A state that fails is not a result: the time loop reports it like a divergence (what failed,
// where, what to try), saves it apart in /unconverged and ends with an error.
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <string>
#include <vector>

#include "discretization.hpp"
#include "state.hpp"
#include "stored_measure.hpp"

namespace ltl {

struct IterateRows;  // measures.hpp: where a distributed solver's state holds u

/// A node is inside the obstacle when (x - p0) . N > kInsideTolerance h, h = (|Omega| /
/// #cells)^(1/dim) the mean cell size; a contact point is allowed its constraint residual on
/// top of it (AdmissibilityReport::max_inside).
inline constexpr double kInsideTolerance = 1e-6;
/// A cell is on the rotated branch when its polar rotation differs by more than this angle
/// (degrees) from the polar rotations of more than half of the cells sharing a node with it.
inline constexpr double kRotationJumpDegrees = 90;
/// Without glue, a contact pressure below -kPressureTolerance p_ref is a tension the contact
/// cannot carry; p_ref = max(peak contact pressure, largest nodal load / smallest contact
/// weight, 1e-3 C1).
inline constexpr double kPressureTolerance = 1e-3;
/// beta may leave [0, 1] by this much (round-off of the projection, Anderson's extrapolation).
inline constexpr double kBetaTolerance = 1e-9;

/// What check_admissibility found. Indices are 0-based (nodes and cells of the mesh, contact
/// points of Discretization::points()); -1 where there is nothing to report.
struct AdmissibilityReport {
  double h = 0;  ///< mean cell size (m), the length scale of the obstacle tolerance

  // Obstacle: max over every node of the body of (x - p0) . N (m; > 0: inside; -inf without
  // contact) and where (a measure: under facet-mean contact the P2 nodes of the contact surface
  // may legitimately zig-zag about the plane). The check: every node off the contact surface
  // with (x - p0) . N <= inside_tol, and every contact point (node, or facet mean with
  // facet-mean contact) with (xbar - p0) . N <= inside_tol + |(ubar - e) . N|, the constraint
  // residual of the iterate there; nodes_inside counts the points that fail.
  double max_inside = -std::numeric_limits<double>::infinity();
  int inside_node = -1;
  int nodes_inside = 0;
  double inside_tol = 0;  ///< m: kInsideTolerance h

  // Orientation: the smallest det F over the quadrature points (and its cell), the number of
  // cells with det F <= 0 somewhere, the smallest det E_e (and its cell).
  double det_F_min = std::numeric_limits<double>::infinity();
  int det_F_cell = -1;
  int cells_inverted = 0;
  double det_E_min = std::numeric_limits<double>::infinity();
  int det_E_cell = -1;

  // Rotated branch: per cell, the angle (degrees) between its polar rotation and its
  // neighbours' that more than half of them exceed (the "lower median"); its max over cells and
  // where; the cells above kRotationJumpDegrees.
  double rotation_jump = 0;
  int rotation_cell = -1;
  int cells_rotated = 0;

  // Contact: the smallest pressure over the points without glue (+inf if none), where, the
  // tolerance (Pa); the range of beta and the point out of [0, 1] (or -1).
  double pressure_min = std::numeric_limits<double>::infinity();
  int pressure_point = -1;
  double pressure_tol = 0;
  double beta_min = 0, beta_max = 0;
  int beta_point = -1;

  std::vector<std::string> failures;  ///< what failed and where, one sentence each
  std::vector<std::string> remedies;  ///< what to try, one per failure kind
  bool admissible() const { return failures.empty(); }
  /// "the state is not admissible: <failures>. What to try: <remedies>" (empty if admissible).
  std::string message() const;
};

/// The admissibility of state s (paper_notes/admissibility.md). Never throws on a bad state; the
/// report says what is wrong. Costs one pass over the quadrature points and one polar
/// decomposition per cell. A discretization of some cells (a rank's, under mpirun) checks its
/// cells and reduces the counts and the worst cells over the ranks (collective): every rank
/// gets the report of one process.
/// With `at`, s is a distributed solver's state between steps, u on the rank's layer rows
/// (IterateRows, measures.hpp): each rank checks the nodes it owns and its cells, and every
/// rank gets the same report (collective).
AdmissibilityReport check_admissibility(const Discretization& d, const State& s,
                                        const IterateRows* at = nullptr);

/// The smallest det F = det(I + grad u) over the quadrature points of every cell (in plane
/// strain the in-plane block, F33 = 1), and its cell in `cell` if not null. Under mean-det
/// incompressibility det F varies inside a cell (only its cell mean is 1): this is the measure
/// of local inversion, det_error (lib/measures.hpp) the measure of the constraint. Over the
/// discretization's cells; a rank's, then the smallest over the ranks (collective).
/// With `u_nodes` (sorted), u's rows are those nodes' (a rank's ghost layer, IterateRows), which
/// hold the discretization's cells' nodes.
double min_det_F(const Discretization& d, const Eigen::MatrixXd& u, int* cell = nullptr,
                 int* cells_inverted = nullptr, const std::vector<int>* u_nodes = nullptr);

/// The measures of the report as written to the results file (/steps/N/measures).
std::vector<StoredMeasure> stored_measures(const AdmissibilityReport& r);

}  // namespace ltl
