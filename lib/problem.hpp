// A problem as the user states it: mesh, material, boundary conditions, loads, contact/adhesion,
// algorithm parameters and time stepping. Built from a configuration file (config.hpp) or in
// code (tests). Nothing here is discretized or solved yet: the solver (alg2.hpp) builds the
// discrete operators from it.
#pragma once

#include <Eigen/Dense>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "adhesion.hpp"
#include "cholesky.hpp"  // GlobalSolver
#include "fe.hpp"
#include "material.hpp"
#include "mesh.hpp"

namespace ltl {

/// Dirichlet condition on a boundary part, u_i(x) = field_i(x) for the listed components.
/// Gamma_1 of the paper (fixed part, u = 0) has all components and a zero field; a symmetry
/// plane fixes one component to zero.
struct DirichletCondition {
  std::string group;
  std::vector<int> components;  ///< 0-based
  AffineField field;            ///< prescribed displacement (zero for fixed parts and symmetry)
  std::string origin;           ///< where it came from (configuration key), for messages
};

/// Dead surface traction on Gamma_2, g(x) affine in the reference position (Pa) [LTL87 (1.2)].
struct Traction {
  std::string group;
  AffineField g;
  std::string origin;
};

/// One rigid obstacle: the contact surface Gamma_c of the body with a rigid plane, and its glue
/// [LTL87 (1.1)-(1.3), (4.11)]. A problem has a list of them (`[[contact]]`, or one `[contact]`
/// table; paper_notes/obstacles.md): the paper's one plane is the list of one.
struct ContactCondition {
  std::string group;
  Eigen::Vector3d plane_point = Eigen::Vector3d::Zero();   ///< a point of the obstacle plane (m)
  Eigen::Vector3d plane_normal = Eigen::Vector3d::Zero();  ///< unit, pointing into the obstacle
  Adhesion adhesion;   ///< w, kappa = 1/eps, d0, kernel rule (dt is set from the time step)
  double beta0 = 1.0;  ///< initial adhesion intensity beta_0 in [0, 1]
  /// The key of its table in messages: "contact" (one `[contact]` table) or "contact[k]".
  std::string origin = "contact";
  /// The key of one of its entries, e.g. key("group") = "contact.group" or "contact[1].group".
  std::string key(const std::string& name) const { return origin + "." + name; }
};

/// Multiplier update of the iteration.
enum class Update {
  Uzawa,           ///< ALG2 (4.1)-(4.4): lambda -= rho R q B(u^n, G^n)
  BermudezMoreno,  ///< section 7, (7.7)-(7.10): half-step update before the local step
};

/// Acceleration of the ALG2 fixed-point map (4.1)-(4.3) (paper_notes/performance.md).
enum class Acceleration {
  None,      ///< the paper's plain iteration
  Anderson,  ///< safeguarded Anderson acceleration of depth `depth`
};
/// Which part of the iterate (E, e, beta, lambda, lambda_c) Anderson extrapolates; the rest is
/// taken from the plain iteration.
enum class Accelerated {
  Multipliers,         ///< lambda, lambda_c
  StrainsMultipliers,  ///< E, e, lambda, lambda_c
  All,                 ///< E, e, beta, lambda, lambda_c
};

/// How a time step is solved: the paper's ALG2 alone, or ALG2 from the previous step's state into
/// the basin of Newton's method on the same discrete problem (newton.hpp).
enum class NonlinearSolver { Alg2, Newton };

/// When a step of ALG2 is converged: "paper", r_G + r_B < tol (4.4), the paper's test on the
/// changes of the iterate; "equilibrium", the equilibrium error (measures.hpp, equilibrium_error:
/// the force residual of (4.5) relative to the load, and the penetration) at most force_tol.
enum class Stopping { Paper, Equilibrium };

/// Parameters of ALG2 [LTL87 sec. 3-4, 7].
struct AlgorithmParams {
  double R = 1.0;    ///< augmentation parameter (dimensionless), R > 0
  double q = 1.0;    ///< weight of the strain constraint (Pa), q > 0   (3.3)
  double q_c = 1.0;  ///< weight of the contact constraint (Pa/m), q_c > 0   (3.3)
  double rho = 1.0;  ///< Uzawa: step factor in (0, 2); Bermudez-Moreno: in (1/2, 1]
                     ///< (configurations default to 0.75 for Bermudez-Moreno)
  Update update = Update::Uzawa;
  int sweeps = 1;          ///< block-relaxation sweeps (4.1)-(4.2) per multiplier update
  int contact_sweeps = 1;  ///< Gauss-Seidel sweeps over the facets in one local contact step
  double tol = 1e-8;       ///< stopping = Paper: stop when r_G + r_B < tol (scaled, alg2.hpp)
  /// Configurations default to Equilibrium (the figure configurations state "paper"); a Problem
  /// built in code keeps the paper's test.
  Stopping stopping = Stopping::Paper;
  int max_iter = 5000;  ///< iteration cap: reaching it is reported as non-convergence
  double blowup = 1e8;  ///< residual above blowup * (first residual) is divergence
  Acceleration acceleration = Acceleration::None;
  int depth = 5;  ///< Anderson history (number of differences kept), 1 ... 16
  Accelerated accelerate = Accelerated::All;
  /// Adaptive R by residual balancing (paper_notes/performance.md, "Adaptive R"): every
  /// `adapt_every` iterations, R is doubled when r_B > 10 R r_G and halved when R r_G > 10 r_B,
  /// never below R_min, K re-factorized at most `max_refactorizations` times per run. Off by
  /// default: the paper's ALG2 keeps its R.
  bool adaptive_R = false;
  int adapt_every = 20;
  int max_refactorizations = 4;
  /// The floor of adaptive R: R_min q = 6 (C1 + C2) in 2-D, 8 (C1 + C2) in 3-D, the default
  /// rule's R q (below about 4 C1 the local strain step jumps to a rotated branch,
  /// paper_notes/section3-4.md), unless the configuration gives it; 0 until derived.
  double R_min = 0;
  /// A step whose equilibrium measure (StepReport::force_residual: max nodal force residual /
  /// max nodal load) exceeds this is not converged, whatever r_G and r_B say: with a huge R the
  /// iterate residuals are small after one iteration far from equilibrium. The figures' steps
  /// are at 1e-7..2e-3; a step stopped by a loose tol = 1e-4 on a coarse mesh at ~2e-2.
  double max_force_residual = 0.1;
  /// Which of R, q, q_c the configuration left out and were derived by derive_algorithm_defaults
  /// (the rule is written there), and the mesh length h of the q_c rule (m; 0: q_c was given).
  bool R_derived = false, q_derived = false, q_c_derived = false;
  double h = 0;
  NonlinearSolver solver = NonlinearSolver::Alg2;
  GlobalSolver global_solver = GlobalSolver::Auto;  ///< "cholesky" | "cg-amg" (global_step.hpp)
  /// Newton: ALG2 runs until r_G + r_B < newton_switch, then Newton; a Newton phase that fails
  /// returns to ALG2's iterate, which goes on to a switch 10 times smaller (at most 3 starts).
  double newton_switch = 1e-2;
  /// Newton's stopping test: force residual (max nodal force / max nodal load) and
  /// complementarity at most force_tol, |G_e| / |O_e| at most 1e-10; with stopping =
  /// Equilibrium, ALG2's too (measures.hpp, equilibrium_error).
  double force_tol = 1e-8;
  /// Stagnation: a step whose best r_G + r_B has not decreased by 1 % over max(this, half of
  /// its iterations so far) iterations ends "stagnated" (ALG2 alone: a divergence; solver =
  /// "newton": Newton starts from there). Not a configuration key: 20000 (the literal readings of
  /// Figs 3-4 plateau for thousands of iterations while the peel runs away, then converge), 100
  /// for the first phase of solver = "newton".
  int stagnation_window = 20000;
  int newton_max_iter = 100;  ///< Newton iterations per start (rejected ones included)
};

/// Discrete choices where the paper's own (P2/H8 with everything on cell and facet means) does not
/// converge under refinement (paper_notes/discretization.md). The defaults converge; the paper's
/// choices stay one key away.
struct DiscretizationChoice {
  /// Plane-strain incompressible Mooney-Rivlin: on det F = 1, |adj F|^2 = |F|^2 + 1 exactly, so the
  /// C2 term is a second |F|^2 term. true (default, "pointwise"): it joins C1 in the global
  /// quadratic, evaluated on the full gradient (the local step sees C2 = 0). false ("cell-mean",
  /// the paper's split (2.5)-(2.6)): it stays in the local step, on cell-mean gradients.
  bool c2_pointwise = true;
  /// true (default, "nodal"): the contact unknowns e, beta, lambda_c live at the nodes of the
  /// contact surface, weighted by integral phi_a (non-penetration at every node). false
  /// ("facet-mean", the paper's): P0 per facet, constraint on facet means.
  bool nodal_contact = true;
  /// Incompressible law whose local step sees a purely quadratic energy (plane strain with
  /// c2_pointwise, or C2 = 0 in 3-D): true (default, "mean-det") imposes the cell mean of det F,
  /// (1/|O_e|) integral det F = 1, which converges under refinement; false ("det-mean", the
  /// paper's) imposes det of the cell-mean gradient, det(Gbar_e u + I) = 1, which loses area in
  /// the intra-cell fluctuation of grad u and converges to another answer in 2-D, and locks in
  /// bending with H8 (paper_notes/discretization.md). Ignored (det-mean) when a C2 term remains
  /// in the local step (c2 = "cell-mean", or C2 != 0 in 3-D).
  bool mean_det = true;
};

/// A load factor per time step multiplying the body force, the tractions and the prescribed
/// displacements (Solver::set_load_factor): constant 1 (the paper's dead loads, applied in full
/// at the first step), a linear ramp factor(t_p) = min(t_p / ramp_time, 1), or a table factor(p) =
/// table[p - 1], the last entry holding beyond the table. The factor of a step depends on the step
/// only (not on time.steps), so a run extended to a later horizon repeats the shorter run's steps.
struct LoadRamp {
  enum class Kind { Constant, Linear, Table } kind = Kind::Constant;
  double ramp_time = 0;       ///< Linear: the time (s) at which the factor reaches 1
  std::vector<double> table;  ///< Table: the factor of steps 1, 2, ...
  double factor(int p, double dt) const;
};

struct TimeStepping {
  double dt = 1.0;  ///< t_p - t_{p-1} (s), > 0
  int steps = 1;    ///< P; a single step is a static contact problem
};

struct Problem {
  std::string name;  ///< experiment name (for messages and outputs)
  Mesh mesh;
  std::map<std::string, double> mesh_parameters;  ///< [mesh] parameters: ONELAB numbers of the .geo
  Material material;
  std::vector<DirichletCondition> dirichlet;
  std::vector<Traction> tractions;
  Eigen::Vector3d body_force = Eigen::Vector3d::Zero();  ///< f (N/m^3)
  LoadRamp ramp;  ///< the load factor of each time step (multiplies f and g)
  /// The rigid obstacles, each a plane with its contact group and glue (empty: no contact).
  std::vector<ContactCondition> contacts;
  AlgorithmParams algorithm;
  DiscretizationChoice discretization;
  TimeStepping time;
  std::string config_text;  ///< the resolved configuration (written into the results)
  std::string config_path;
  /// The resolved configuration without time.steps: a resumed run may extend the horizon, and
  /// nothing else (compared through its fingerprint, hash.hpp).
  std::string config_identity;
  std::string output_file;  ///< [output] file (relative to the configuration's folder), or empty

  /// Checks ranges and consistency (groups exist, contact group is on the boundary and not
  /// fixed, ...); throws a clear Error naming the key.
  void validate() const;
  /// Refuses a body free to slide along a frictionless contact plane (or, in 3-D, to turn about
  /// its normal): a rigid motion the Dirichlet data do not remove; names the free direction.
  void check_sliding() const;
  /// check_sliding() with several obstacles: the rigid motions tangent to every frictionless
  /// plane at its group's nodes (and free at the glued ones' nodes) that no Dirichlet datum holds.
  void check_sliding_obstacles() const;
  /// Two obstacles whose contact groups share a contact point (a node with nodal contact, a facet
  /// with facet-mean): refused when either is glued (paper_notes/obstacles.md: the paper's glue
  /// has one beta per point and one plane); names both obstacles and the point.
  void check_shared_glue() const;
};

/// The default ALG2 parameters, derived from the material and the mesh for those of R, q, q_c the
/// configuration leaves out (experiments/README.md, "Choosing R, q, q_c"):
///   q   = 2 (C1 + C2)                     (Pa; C2 = 0 for the compressible law)
///   R q = 6 (C1 + C2) in 2-D, 8 (C1 + C2) in 3-D   (R = 3, 4 with the default q)
///   q_c = q / h in 2-D, q / (3 h) in 3-D  (Pa/m), h the mean size of the contact facets
/// (length in 2-D, square root of the area in 3-D; without contact the mesh's cell size).
/// R q >= 4 C1 in 3-D and >= 2.6 C1 in plane strain keeps the local strain step on the
/// physical branch (paper_notes/section3-4.md); q_c = q / h makes the contact term of the
/// global matrix (4.5) as stiff as the elastic term on one cell. Sets the *_derived flags and h.
void derive_algorithm_defaults(Problem& p, bool has_R, bool has_q, bool has_q_c);
/// The default rule's R q (Pa): 6 (C1 + C2) in 2-D, 8 (C1 + C2) in 3-D (C2 = 0 compressible).
double default_Rq(const Problem& p);

/// One line: "R = 2 (derived), q = 5e+05 Pa (derived: 2 (C1 + C2)), q_c = ..." for the start of
/// a run and for messages.
std::string describe_algorithm(const AlgorithmParams& a);

}  // namespace ltl
