// The iterate of ALG2 and the record of its iterations (plain data, no dependencies).
#pragma once

#include <Eigen/Dense>
#include <limits>
#include <string>
#include <vector>

namespace ltl {

/// n identity blocks d x d stacked, (d n) x d: E and lambda / 2 C1 at rest in the layout of
/// State (an expression, not stored).
inline auto identity_rows(int d, int n) {
  return Eigen::MatrixXd::Identity(d, d).replicate(n, 1);
}

/// The iterate. Cell tensors are stored as (dim * #cells) x dim matrices whose block of rows
/// dim*c .. dim*c+dim-1 is the TRANSPOSE of the cell's tensor (the layout of Gbar * u, so that
/// every cell-wise linear operation is one whole-array operation); use cell_tensor() to read one.
struct State {
  Eigen::MatrixXd u;         ///< #nodes x dim
  Eigen::MatrixXd E;         ///< (dim*#cells) x dim, strain (the paper's F), transposed blocks
  Eigen::MatrixXd lambda;    ///< (dim*#cells) x dim, multiplier of I + grad u = E, transposed
  Eigen::MatrixXd e;         ///< #points x dim like u, contact displacement (the paper's h)
  Eigen::VectorXd beta;      ///< #points, adhesion intensity
  Eigen::MatrixXd lambda_c;  ///< #points x dim, multiplier of u = e on Gamma_c (a traction)
};

/// Do two states have fields of the same shapes (the same mesh and contact surface)?
inline bool same_shapes(const State& a, const State& b) {
  const auto same = [](const Eigen::MatrixXd& x, const Eigen::MatrixXd& y) {
    return x.rows() == y.rows() && x.cols() == y.cols();
  };
  return same(a.u, b.u) && same(a.E, b.E) && same(a.lambda, b.lambda) && same(a.e, b.e) &&
         same(a.lambda_c, b.lambda_c) && a.beta.size() == b.beta.size();
}

/// The tensor of cell c (dim x dim) from a transposed-block field.
inline Eigen::MatrixXd cell_tensor(const Eigen::MatrixXd& field, int c) {
  const auto d = field.cols();
  return field.block(d * c, 0, d, d).transpose();
}

/// One row of the iteration history.
struct IterationRecord {
  int n = 0;
  double r_G = 0;  ///< ||G^n - G^{n-1}|| / ||I||_q (+ RMS change of beta)
  double r_B = 0;  ///< ||B(u^n, G^n)|| / ||I||_q, weights of (3.3)
  double t_global = 0, t_strain = 0, t_contact = 0, t_update = 0;  ///< seconds in each phase
  double wall = 0;  ///< seconds since the start of the time step
  /// Anderson acceleration: 0 the iterate this record measures was a plain one; +1 it was an
  /// accelerated one, kept (its merit r_G + r_B did not exceed the previous record's); -1 it was
  /// an accelerated one, rejected (the next iterate is the plain one and the history restarts).
  int accelerated = 0;
};

struct StepReport {
  bool converged = false;
  std::string status;  ///< "converged", "iteration cap reached", "NaN", "residual blow-up"
  int iterations = 0;
  std::vector<IterationRecord> history;
  int strain_failures = 0;  ///< local strain problems whose Newton iteration did not converge
  int accepted = 0;  ///< accelerated iterates kept by the safeguard (history: accelerated = +1)
  int rejected = 0;  ///< accelerated iterates rejected by the safeguard (accelerated = -1)
  /// The equilibrium measure at the last iterate (lib/measures.hpp): max nodal force residual /
  /// max nodal load, max |det E - 1|, max penetration of a contact-surface node (m).
  double force_residual = 0, det_error = 0, penetration = 0;
  double R = 0;       ///< the augmentation parameter at the end of the step
  int R_changes = 0;  ///< how many times adaptive R changed R (and re-factorized K) in the step
  /// algorithm.solver = "newton": the Newton iterations among `iterations` (the last rows of the
  /// history: r_G = force residual, r_B = constraint residual), and how many times the Newton
  /// phase was started (each failed start falls back to more ALG2 iterations).
  int newton_iterations = 0, newton_attempts = 0;
  /// The smallest det F = det(I + grad u) over the quadrature points (lib/admissibility.hpp,
  /// min_det_F): > 0 unless a cell is inverted. Under mean-det det F varies inside a cell (its
  /// cell mean is 1); det_error measures the constraint, this the orientation. NaN: not measured
  /// (a non-finite iterate).
  double det_min = std::numeric_limits<double>::quiet_NaN();
};

}  // namespace ltl
