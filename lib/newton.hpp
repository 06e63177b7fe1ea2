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
// is solved by UMFPACK's sparse LU. Not treated: the glue (w, kappa > 0), whose
// problems keep ALG2.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <functional>
#include <string>
#include <vector>

#include "discretization.hpp"
#include "problem.hpp"
#include "state.hpp"

namespace ltl {

class Newton {
 public:
  /// Why the Newton phase cannot treat this discrete problem (the glue), or empty.
  static std::string unsupported(const Problem& problem);

  /// The per-cell data (nodes, mean gradients, the points of the incompressibility constraint)
  /// and the constant part of the tangent. disc must outlive the object.
  explicit Newton(const Discretization& disc);

  /// The unknowns of the discrete problem: u (#nodes x dim), a pressure per cell (empty for the
  /// compressible law), a force per contact point (N in 3-D, N/m in plane strain).
  struct Unknowns {
    Eigen::MatrixXd u;
    Eigen::VectorXd p, mu;
  };
  /// From an ALG2 state: u; p_e from lambda_e = 2 C1 E_e - dW(E_e) + p_e cof E_e (least
  /// squares); mu_s = |G_s| max(0, -lambda_c_s . N).
  Unknowns unknowns(const State& s) const;
  /// The ALG2 state of the unknowns: E_e = Fbar_e, lambda_e = 2 C1 Fbar_e - dW(Fbar_e) +
  /// p_e cof Fbar_e, e_s = ubar_s, lambda_c_s = -(mu_s / |G_s|) N; beta unchanged. At a solution
  /// it is a fixed point of ALG2 (r_B = 0) for every R.
  void to_state(const Unknowns& x, State& s) const;

  /// [(2.2), (2.7), (1.1)] R_u (dim * #nodes, interleaved, fixed dofs included) at x under the
  /// load F (#nodes x dim), and G_e (#cells; empty for the compressible law).
  void residual(const Unknowns& x, const Eigen::MatrixXd& F, Eigen::VectorXd& Ru,
                Eigen::VectorXd& G) const;
  /// The tangent dR_u/du at x (dim * #nodes square, all dofs): the Hessian of Pi minus
  /// sum_e p_e times the Hessian of G_e. Its columns are the directional derivatives of
  /// residual() (tests: central differences).
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
  /// Semismooth Newton from s under load F, to force residual <= alg.force_tol (relative to the
  /// largest nodal load, or without loads to the largest nodal force at the start), constraints
  /// |G_e| / |O_e| <= 1e-10 and complementarity. Appends each iteration to report.history
  /// (n continuing; r_G = force residual, r_B = constraint residual) and calls progress. On
  /// success s is the converged state (to_state); otherwise s is unchanged.
  Result solve(State& s, const Eigen::MatrixXd& F, const AlgorithmParams& alg, StepReport& report,
               const std::function<void(const IterationRecord&)>& progress) const;

 private:
  /// Per cell: the residual and constraint into Ru and G, the tangent Ke and the constraint
  /// gradient be (local dof d a + i) as triplets into K and B, and/or handed to on_cell.
  using CellSink = std::function<void(int, const Eigen::MatrixXd&, const Eigen::VectorXd&)>;
  template <int d>
  void assemble(const Unknowns& x, Eigen::VectorXd* Ru, Eigen::VectorXd* G,
                std::vector<Eigen::Triplet<double>>* K, std::vector<Eigen::Triplet<double>>* B,
                const CellSink* on_cell = nullptr) const;
  /// The Newton step by the augmented Lagrangian of its KKT system (solve_kkt in newton.cpp),
  /// with the matrix scattered into the fixed pattern_ (no triplets). False when the augmented
  /// tangent is not positive definite.
  struct Scatter;
  bool augmented_step(const Unknowns& base, const Eigen::VectorXd& Ru, const Eigen::VectorXd& G,
                      const Eigen::VectorXd& gap, const std::vector<int>& active, double damping,
                      Scatter& work, Eigen::VectorXd& dx) const;
  /// Smallest det F over the constraint points (+inf without them) and over the cell means.
  template <int d>
  double min_det(const Eigen::MatrixXd& u) const;

  const Discretization& disc_;
  int dim_ = 0, npc_ = 0;
  bool incompressible_ = false;
  std::vector<int> nodes_;  ///< #cells x npc, the cells' nodes
  /// Mean gradients per cell (npc x dim, cell after cell) and the constraint points: per cell
  /// nq_ gradients (npc x dim) and weights (mean-det: the quadrature points; det-mean: the mean
  /// gradient with weight |O_e|).
  std::vector<Eigen::MatrixXd> gbar_, gq_;
  std::vector<double> wq_;
  int nq_ = 0;
  Eigen::SparseMatrix<double> fluct_;  ///< 2 C1 (L - GbarT_vol Gbar) (x) I_dim, dof numbering
  std::vector<int> free_;              ///< per dof, its free index or -1
  int nfree_ = 0;
  Eigen::VectorXd c_;  ///< per contact point, the NCP parameter 0.02 C1 |G_s| / h
  /// The pattern of the augmented tangent (free dofs, lower triangle) and where each entry of a
  /// cell matrix (cell_pos_, (d npc)^2 per cell, -1: fixed dof or upper triangle), of the
  /// fluctuation term (fluct_pos_), of the diagonal (diag_pos_) and of a contact point's pairs
  /// (point_dofs_, point_coef_: its free dofs and their coefficients in N . ubar_s;
  /// point_pos_: their pairs) lands in its values.
  Eigen::SparseMatrix<double> pattern_;
  std::vector<int> cell_pos_, diag_pos_;
  std::vector<std::pair<int, double>> fluct_pos_;
  std::vector<std::vector<int>> point_dofs_, point_pos_;
  std::vector<std::vector<double>> point_coef_;
};

}  // namespace ltl
