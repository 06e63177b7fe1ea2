// ALG2, the augmented-Lagrangian local/global iteration (4.1)-(4.4) of the paper, and its
// Bermudez-Moreno variant (7.7)-(7.10), for one time step (2.1) of the adhesion problem.
//
// Unknowns (our reading, section3-4.md): u (P2 / H8 nodal displacement), E and lambda (P0 per
// cell), e, beta, lambda_c (P0 per contact facet). One iteration reads as three phases:
//
//   (4.1) global step:
//           K u = f + g + GbarT [ R q (E - I) + lambda - 2 C1 I ] + MT [ R q_c e + lambda_c ]
//   (4.2) local steps:
//           E per cell (4.6, sec. 5), {e, beta} per facet (4.7, sec. 6)
//   (4.3) update:
//           lambda -= rho R q (I + Gbar u - E),  lambda_c -= rho R q_c (ubar - e)
//
// Stopping [LTL87 (4.4)]: r_G + r_B < tol, with both parts scaled by ||I||_q (see residuals());
// the policy (NaN, blow-up, cap, history) is iteration.hpp's, shared with the Signorini solver.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "anderson.hpp"
#include "contact_step.hpp"
#include "fe.hpp"
#include "global_step.hpp"
#include "problem.hpp"
#include "state.hpp"
#include "strain_step.hpp"

namespace ltl {

class Solver {
 public:
  /// Discretizes the problem, assembles K and factorizes it once [LTL87 (4.5)].
  explicit Solver(const Problem& problem);

  /// E = I, lambda = 2 C1 I (zero first Piola-Kirchhoff stress P = 2 C1 E - lambda), u = the
  /// prescribed values, e = 0, beta = beta_0, lambda_c = 0.
  State initial_state() const;

  /// [LTL87 (2.1), (4.1)-(4.4) / (7.7)-(7.10)] Iterates from `state` (warm start) to
  /// convergence; beta_prev is beta at the previous time step. `progress` (may be null) is
  /// called after every iteration. Never throws on divergence: the report says what happened.
  StepReport solve_step(State& state, const Eigen::VectorXd& beta_prev,
                        const std::function<void(const IterationRecord&)>& progress = {});

  // Outputs at a converged state, per cell (transposed-block layout like E) or per facet.
  /// First Piola-Kirchhoff stress P = 2 C1 E - lambda (in-plane block in plane strain).
  Eigen::MatrixXd piola(const State& s) const;
  /// Cauchy stress sigma = P E^T / det E (in-plane block in plane strain).
  Eigen::MatrixXd cauchy(const State& s) const;
  /// Pressure per cell, -tr(sigma)/dim (in plane strain the mean in-plane stress).
  Eigen::VectorXd pressure(const State& s) const;
  /// Contact pressure per facet, p_c = -lambda_c . N >= 0 where the body presses the plane.
  Eigen::VectorXd contact_pressure(const State& s) const;
  /// Gap to the plane after deformation per facet: g_s - e_s . N (>= 0 when admissible).
  Eigen::VectorXd contact_gap(const State& s) const;

  /// Gradient (#nodes x dim, zero on fixed components) of the reduced discrete energy
  ///   Pi(u) = sum_e |O_e| W(I + Gbar_e u) + C1 (||grad u||^2 - sum_e |O_e| |Gbar_e u|^2)
  ///           - f.u - g.u
  /// for the compressible law without contact: zero at the discrete equilibrium.
  Eigen::MatrixXd energy_gradient(const Eigen::MatrixXd& u) const;

  /// [LTL87 (2.2)] The discrete functional J_p at a state, with beta_prev = beta_{p-1}:
  ///   sum_e |O_e| W(E_e) + C1 (||grad u||^2 - sum_e |O_e| |Gbar_e u|^2) - f.u - g.u
  ///   + sum_s |G_s| [(kappa/2) beta_s^2 |e_s|^2 - w beta_s] + dissipation(beta - beta_prev).
  /// (At a converged state E = I + Gbar u and e = ubar up to the tolerance.)
  double energy(const State& s, const Eigen::VectorXd& beta_prev) const;

  const Problem& problem() const { return problem_; }
  /// The material as split between the global and the local steps: problem().material, except
  /// that in plane strain with DiscretizationChoice::c2_pointwise the incompressible C2 term is
  /// moved into C1 (C1 + C2, C2 = 0), an identity on det F = 1. P = 2 split().C1 E - lambda.
  const Material& split() const { return split_; }
  const CellOperators& cells() const { return cells_; }
  /// The contact points: facets (discretization.contact = "facet-mean") or the nodes of the
  /// contact surface ("nodal"), with their weights (area), positions (centre) and the map from
  /// nodal values (mean).
  const FacetOperators* facets() const { return facets_ ? facets_.get() : nullptr; }
  const GlobalStep& global_step() const { return *global_; }
  const Eigen::MatrixXd& external_load() const { return F_ext_; }
  /// The load factor of the current step (LoadRamp, set by the time loop before each step):
  /// external_load() = factor x the assembled dead loads f, g. K is unchanged.
  void set_load_factor(double factor);
  double load_factor() const { return load_factor_; }
  /// Per component, the sorted nodes whose displacement is prescribed (Dirichlet, symmetry).
  const std::vector<std::vector<int>>& fixed_nodes() const { return bc_.fixed; }
  int dim() const { return problem_.mesh.dim; }

  /// True when incompressibility is imposed on the cell mean of det F
  /// (DiscretizationChoice::mean_det: incompressible with no C2 term left in the local step,
  /// i.e. plane strain with the pointwise C2 split, or C2 = 0 in 3-D).
  bool mean_det() const { return mean_det_; }
  /// [(2.7), discretization.md] Mean-det incompressibility: with delta = grad u - Gbar_e u the
  /// intra-cell fluctuation, (1/|O_e|) integral det F = det(Fbar_e) + c_e(u) with
  ///   c_e = (1/|O_e|) integral det F - det(Fbar_e)   (= the mean of det(delta) in 2-D),
  /// and the pressure p_e of the constraint does the extra work
  /// p_e integral (cof F - cof Fbar) : grad v (= p_e integral cof(delta) : grad v in 2-D).
  /// Returns c_e per cell (zero vector when !mean_det()).
  Eigen::VectorXd fluctuation_det(const Eigen::MatrixXd& u) const;
  /// The force sum_e p_e integral_e (cof F - cof Fbar) : grad v (#nodes x dim) with p_e read
  /// from the multiplier, p_e = lambda_e : E_e / (d det E_e) (lambda = p cof E at a fixed point,
  /// cof E : E = d det E); zero
  /// when !mean_det(). ALG2 adds it, lagged, to the right-hand side of (4.1).
  Eigen::MatrixXd fluctuation_force(const State& s) const;

 private:
  /// [LTL87 (4.1)-(4.3) / (7.7)-(7.10)] One iteration: global step, local steps, multiplier
  /// update; returns r_G and r_B of the iteration (timings filled, n and wall not).
  IterationRecord iterate(State& s, const Eigen::VectorXd& beta_prev, int& strain_failures);
  void update_multipliers(State& s);  // (4.3) / (7.10)
  /// The accelerated part of the iterate as one vector, scaled so that its Euclidean norm is
  /// the norm of r_G + r_B (weights of (3.3), multipliers divided by R q and R q_c).
  void pack(const State& s, Eigen::VectorXd& z) const;
  void unpack(const Eigen::VectorXd& z, State& s) const;
  /// The blocks of the packed vector in their order, one definition for pack and unpack:
  /// cells(A, c) and facets(A, c) for the cell and facet fields with their scale c, beta(b, w)
  /// for each beta_s with its weight, u(A) for the displacement (mean-det).
  template <class S, class Cells, class Facets, class Beta, class U>
  void for_each_packed(S& s, Cells&& cells, Facets&& facets, Beta&& beta, U&& u) const;
  void residuals(const State& s, IterationRecord& rec) const;  // (4.4)
  void global_solve(State& s);                                 // (4.1)
  int strain_solve(const Eigen::MatrixXd& lambda, State& s);   // (4.6)
  void contact_solve(const Eigen::MatrixXd& lambda_c, const Eigen::VectorXd& beta_prev,
                     State& s);  // (4.7)

  Problem problem_;
  Material split_;  ///< see split()
  CellOperators cells_;
  std::unique_ptr<FacetOperators> facets_;
  std::unique_ptr<GlobalStep> global_;
  std::unique_ptr<StrainStep> strain_;
  std::unique_ptr<ContactStep> contact_;
  DirichletData bc_;
  Eigen::MatrixXd F_ext_;  ///< #nodes x dim, consistent dead loads f, g
  Eigen::MatrixXd Id_;     ///< identity blocks, (dim*#cells) x dim
  double norm_I_ = 1;      ///< ||I||_q = sqrt(q |Omega| dim)
  double area_c_ = 0;      ///< |Gamma_c|
  // The load ramp: F_ext_ = load_factor_ x F_dead_ (F_dead_ the loads at factor 1).
  Eigen::MatrixXd F_dead_;
  double load_factor_ = 1;
  // Work buffers (allocated once).
  Eigen::MatrixXd rhs_, GU_, T_, ubar_rows_, ubar_, c_rows_, E_prev_, e_prev_, lambda_half_,
      lambda_c_half_;
  Eigen::VectorXd vol_rows_, beta_prev_iter_;
  // Mean-det incompressibility (mean_det()): point gradients at the cell quadrature points
  // (rows dim*(nq*e + k) + j, like Gbar), their weighted transpose, and work buffers.
  bool mean_det_ = false;
  int nq_ = 0;
  SpMatR Gq_, GqT_w_;
  Eigen::VectorXd wq_, Jtarget_;
  mutable Eigen::MatrixXd GQ_, Sq_;
  double gamma_ = 0;             ///< proximal stiffness on the fluctuations, 2 R q
  SpMat fluctuation_laplacian_;  ///< L - GbarT_vol Gbar (#nodes x #nodes)
  void fluctuation(const Eigen::MatrixXd& u, const Eigen::MatrixXd* lambda,
                   const Eigen::MatrixXd* E, Eigen::VectorXd* c, Eigen::MatrixXd* force) const;
  // Anderson acceleration (allocated once): history, packed iterates, weights, the plain iterate.
  std::unique_ptr<Anderson> anderson_;
  Eigen::VectorXd x_, g_, w_cell_, w_facet_;
  double w_u_ = 0;  ///< weight of u in the accelerated vector (mean-det only)
  State plain_;
};

}  // namespace ltl
