// The Signorini problem of section 7 [LTL87 (7.1)-(7.4)] and its augmented-Lagrangian solution by
// ALG2 (4.1)-(4.3) or by the Bermudez-Moreno variant (7.7)-(7.10).
//
// A linearly elastic body (isotropic; plane strain in 2-D) rests without friction on a rigid
// plane with unit normal N pointing INTO the obstacle. With the contact surface Gamma_c split into
// facets s (P2 edges in 2-D, quadrilaterals in 3-D), the discrete problem reads
//
//   min  G(v) = 1/2 a(v, v) - f.v - g.v                                    (7.1)
//   over v = u_D on the Dirichlet parts, with  H_s = vbar_s . N <= g_s     (7.3)-(7.4)
//
// where vbar_s is the facet mean of v (fe.hpp) and g_s >= 0 the initial gap at the facet centre
// along N (the convention e.N <= g of contact_step.hpp). The augmented Lagrangian (3.2) with
// H = {H_s} (P0 per facet), B(v, H) = vbar.N - H (7.4), F = indicator of {H <= g} (7.3), and
// weights |G_s| q_c (3.3) gives the three phases of one iteration:
//
//   (4.1)/(7.7) global:  (A + R q_c M_N^T W M_N) u = f + g + M_N^T W (R q_c H + lambda_c)
//   (4.2)/(7.9) local:   H_s = min(g_s, vbar_s.N - lambda_c_s / (R q_c))   (a projection)
//   (4.3)        update: lambda_c -= rho R q_c B(u, H)
//   (7.8),(7.10) Bermudez-Moreno: lambda_c^{n-1/2} = lambda_c^{n-1} - R q_c B(u^n, H^{n-1}),
//                local step with lambda_c^{n-1/2}, then
//                lambda_c^n = lambda_c^{n-1/2} - (2 rho - 1) R q_c B(u^n, H^n)
//
// with A the linear-elasticity stiffness (components coupled), M_N = N^T (x) M the facet mean of
// the normal component, W = diag(|G_s|). The matrix is assembled and factorized ONCE (CHOLMOD
// supernodal Cholesky on the free degrees of freedom). At the fixed point H = vbar.N, A u = f + g
// + M_N^T W lambda_c: lambda_c_s is the normal traction on the body along N, and the contact
// pressure is p_s = -lambda_c_s >= 0, with p_s (g_s - H_s) = 0. The fixed point is the minimizer
// of G under the facet-mean constraints: it does not depend on R, q_c or rho.
//
// Stopping [LTL87 (4.4)]: r_G + r_B < tol with (the weights q_c cancel)
//   r_B = ||vbar.N - H||_{Gamma_c} / U,   r_G = ||H^n - H^{n-1}||_{Gamma_c} / U,
//   ||x||_{Gamma_c} = sqrt(sum_s |G_s| x_s^2 / |Gamma_c|)  (root mean square over Gamma_c),
//   U = max over the nodes of |u^n| (the size of the current displacement),
// so that tol is a relative accuracy of the contact displacement on every problem.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cholesky.hpp"
#include "fe.hpp"
#include "mesh.hpp"
#include "problem.hpp"
#include "state.hpp"

namespace ltl {

/// The Signorini problem [LTL87 (7.1)-(7.4)] as the user states it. SI units.
struct SignoriniProblem {
  Mesh mesh;
  double E = 0;   ///< Young's modulus (Pa), > 0
  double nu = 0;  ///< Poisson's ratio, in (-1, 1/2); 2-D is plane strain
  /// Fixed parts (all components, zero field), symmetry planes (one component, zero field) or
  /// prescribed displacements (any affine field): eliminated from the linear system.
  std::vector<DirichletCondition> dirichlet;
  std::vector<Traction> tractions;                         ///< dead tractions g on Gamma_2 (Pa)
  Eigen::Vector3d body_force = Eigen::Vector3d::Zero();    ///< f (N/m^3)
  std::string contact_group;                               ///< Gamma_c, a boundary group
  Eigen::Vector3d plane_point = Eigen::Vector3d::Zero();   ///< a point of the rigid plane (m)
  Eigen::Vector3d plane_normal = Eigen::Vector3d::Zero();  ///< unit, pointing into the obstacle
  /// R, q_c (Pa/m), rho, update, tol, max_iter, blowup, acceleration and depth (Anderson, with
  /// ALG2's safeguard) are read; q, sweeps, contact_sweeps are not (there is no strain variable and
  /// one block relaxation per iteration). Only R q_c enters; about 1.5 E* / sqrt(h L) (E* = E / (1
  /// - nu^2), h: contact facet size, L: body size) was the fastest on the Hertz problem
  /// (paper_notes/section7.md); the answer does not depend on it.
  AlgorithmParams algorithm;

  /// Checks ranges and that every named group exists; throws a clear Error naming the field.
  void validate() const;
};

/// The converged (or last) iterate and its record.
struct SignoriniSolution {
  Eigen::MatrixXd u;         ///< #nodes x dim, displacement
  Eigen::VectorXd H;         ///< #points, normal displacement of Gamma_c (P0), H <= g
  Eigen::VectorXd lambda_c;  ///< #points, multiplier of vbar.N = H: normal traction along N
  Eigen::VectorXd p;         ///< #points, contact pressure p_s = -lambda_c_s (>= 0)
  Eigen::VectorXd uN;        ///< #points, vbar_s . N of u (equals H at convergence)
  Eigen::VectorXd gap;       ///< #points, deformed gap g_s - vbar_s . N (>= 0 when admissible)
  StepReport report;         ///< history of r_G, r_B, times; status
};

/// [LTL87 (7.9), (4.2)] The local step, facet by facet: the minimizer over H_s <= g_s of
///   (R q_c / 2) (uN_s - H_s)^2 + lambda_c_s H_s,  i.e.  H_s = min(g_s, uN_s - lambda_c_s / Rqc).
/// It lands on the constraint set and is idempotent (H = min(g, H) when lambda_c = 0).
Eigen::VectorXd signorini_projection(const Eigen::VectorXd& uN, const Eigen::VectorXd& lambda_c,
                                     double Rqc, const Eigen::VectorXd& g);

/// [LTL87 (7.1)] The linear-elasticity stiffness A, (dim * #nodes)^2, degrees of freedom
/// interleaved (dof dim * a + i is component i of node a): A = integral sigma(phi) : eps(phi) with
/// sigma = lambda_L tr(eps) I + 2 mu eps, plane strain in 2-D. P2 triangles (6-point rule) or
/// H8 (2x2x2 Gauss), isoparametric like fe.hpp.
SpMat elasticity_matrix(const Mesh& mesh, double E, double nu);

class SignoriniSolver {
 public:
  /// Validates, assembles A + R q_c M_N^T W M_N and the loads, eliminates the Dirichlet degrees
  /// of freedom, and factorizes the restricted matrix once (CHOLMOD supernodal). Throws a clear
  /// Error for bad input or when the matrix is singular (a rigid motion left free).
  explicit SignoriniSolver(const SignoriniProblem& problem);
  ~SignoriniSolver();
  SignoriniSolver(const SignoriniSolver&) = delete;
  SignoriniSolver& operator=(const SignoriniSolver&) = delete;

  /// [LTL87 (4.1)-(4.3) or (7.7)-(7.10)] Iterates from H = min(g, 0), lambda_c = 0 until
  /// r_G + r_B < tol. `progress` (may be null) is called after every iteration. Never throws on
  /// divergence: report.status says what happened.
  SignoriniSolution solve(const std::function<void(const IterationRecord&)>& progress = {});
  /// The same from a given start (H, lambda_c: #points each).
  SignoriniSolution solve(const Eigen::VectorXd& H0, const Eigen::VectorXd& lambda_c0,
                          const std::function<void(const IterationRecord&)>& progress = {});

  const SignoriniProblem& problem() const { return problem_; }
  const ContactPoints& points() const { return points_; }
  const Eigen::VectorXd& initial_gap() const { return g_; }        ///< g_s, #points
  const Eigen::VectorXd& normal() const { return N_; }             ///< N, dim entries
  const SpMat& stiffness() const { return A_; }                    ///< A, without the contact term
  const Eigen::MatrixXd& external_load() const { return F_ext_; }  ///< #nodes x dim, f + g
  /// Facet means of the normal component, vbar_s . N (#points), of u (#nodes x dim).
  Eigen::VectorXd normal_mean(const Eigen::MatrixXd& u) const;
  int dim() const { return problem_.mesh.dim; }
  int num_free_dofs() const { return static_cast<int>(free_.size()); }
  double factorize_seconds() const { return factorize_seconds_; }
  double rcond() const { return rcond_; }  ///< CHOLMOD reciprocal condition estimate

 private:
  void global_solve(const Eigen::VectorXd& H, const Eigen::VectorXd& lambda_c,
                    Eigen::MatrixXd& u);  // (4.1) / (7.7)
  /// The iteration as a fixed-point map of the driver (fixed_point.hpp), in signorini.cpp.
  class Map;

  SignoriniProblem problem_;
  ContactPoints points_;
  SpMat A_;       ///< elasticity stiffness, all dofs
  SpMatR MN_;     ///< #points x (dim * #nodes), row s: N . vbar_s
  SpMatR MNT_W_;  ///< (dim * #nodes) x #points, M_N^T W
  Eigen::VectorXd N_, g_;
  Eigen::MatrixXd F_ext_;
  std::vector<int> free_;    ///< free dofs
  std::vector<int> dof_;     ///< #free, the dof of each row of the factor's permuted system
  Eigen::VectorXd u_fixed_;  ///< dim * #nodes, prescribed values (zero on free dofs)
  Eigen::VectorXd shift_;    ///< #free, K_fd u_d in the factor's order
  std::unique_ptr<Cholesky> llt_;
  double area_c_ = 0, factorize_seconds_ = 0, rcond_ = 1;
  Eigen::VectorXd f_flat_;        ///< dim * #nodes, f + g interleaved
  Eigen::VectorXd rhs_full_, U_;  // work buffers
};

/// The contact zone of a symmetric half model measured from the P0 pressure and gap along a
/// coordinate s >= 0 of the contact facets (e.g. x1, with s = 0 on the symmetry plane), for a
/// frictionless contact of smooth bodies: the pressure vanishes like sqrt(a - s) at the edge and
/// the gap grows like (s - a)^{3/2} beyond it [Johnson, Contact Mechanics, 1985].
struct ContactZone {
  int active = 0;                ///< facets with p > rel_threshold * max p
  double half_width = 0;         ///< a_h, edge interpolated from the gaps (see contact_zone())
  double half_width_last = 0;    ///< outer end of the last active facet (O(h) bound)
  double half_width_moment = 0;  ///< sqrt(4 int p s^2 / int p): equals a for Hertz's ellipse
  double peak = 0;               ///< p0_h: pressure extrapolated to s = 0
  double peak_max = 0;           ///< largest facet pressure
  double force = 0;              ///< sum_s |G_s| p_s, the normal contact force
};

/// Measures the contact zone. Facets are sorted by centre; the active ones have
/// p > rel_threshold * max p (the free ones carry round-off). The edge a_h is where the facet
/// means of g = D (s - a)_+^{3/2} have the ratio of the gaps of the first two free facets (so the
/// edge is interpolated from displacements, which converge faster than the P0 pressures),
/// bracketed by [start of the last active facet, end of the first free one]; without two free
/// facets a_h is the end of the last active facet. The peak is the value at s = 0 of the
/// parabola p^2 = p0^2 - c s^2 through the first two facet centres (exact for Hertz's ellipse).
/// s_lo, s_hi: #points, the facet's extent in s (s_lo < s_hi); p, gap, area: #points.
ContactZone contact_zone(const Eigen::VectorXd& s_lo, const Eigen::VectorXd& s_hi,
                         const Eigen::VectorXd& p, const Eigen::VectorXd& gap,
                         const Eigen::VectorXd& area, double rel_threshold = 1e-6);

}  // namespace ltl
