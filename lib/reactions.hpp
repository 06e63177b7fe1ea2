// The reaction forces of the supports, per Dirichlet condition ([[fixed]], [[symmetry]],
// [[displacement]]), and the mean displacement of each condition's nodes: what a
// load-displacement curve plots. Written with every step (/steps/N/reactions, support_u;
// experiments/README.md, "Results files").
//
// The reaction of a support is the force it exerts on the body: at a fixed degree of freedom the
// residual of the discrete equilibrium (equilibrium_residual, measures.hpp: the (4.5) equation
// at a fixed point of (4.1)-(4.3)), internal force minus dead load minus contact force. Summed
// over the conditions it balances the dead loads and the contact force [LTL87 (1.2)]:
//   sum_conditions R + sum_nodes f_ext + contact force = 0   (global equilibrium),
// since the internal forces of a translation-invariant energy sum to zero. A degree of freedom
// listed by two conditions (a corner on a fixed part and a symmetry plane) counts towards the
// first one in the configuration's order, so the sum over the conditions is the total reaction.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "discretization.hpp"
#include "state.hpp"

namespace ltl {

struct IterateRows;  // measures.hpp: where a distributed solver's state holds u

struct SupportReactions {
  /// One label per Dirichlet condition, in the problem's order: "<key>:<group>", e.g.
  /// "fixed[0]:left", "symmetry[1]:bottom" (the configuration key without ".group").
  std::vector<std::string> labels;
  /// #conditions x dim: the force each support exerts on the body (N/m in plane strain, N in
  /// 3-D), zero in the components the condition leaves free.
  Eigen::MatrixXd force;
  /// #conditions x dim: the mean displacement of the condition's nodes (m): the prescribed one
  /// in the components it fixes (load factor x value), the computed one in the others.
  Eigen::MatrixXd u;
};

/// [LTL87 (1.2), (4.5)] The reactions and support displacements at a converged state under the
/// discretization's dead loads times load_scale (the step's load factor). On a rank's cells
/// (Discretization::partial(), collective) each rank sums the reactions of its block of the
/// nodes (equilibrium_residual_rows) and the sums are added over the ranks: no array of every
/// node's residual. With `at` (IterateRows, measures.hpp) u is on the rank's layer rows (a
/// distributed solver's state between steps): the conditions' nodes' rows come from the ranks
/// that hold them, the same rows summed in the same order as on one process.
SupportReactions support_reactions(const Discretization& d, const State& s, double load_scale = 1,
                                   const IterateRows* at = nullptr);

/// The labels joined by "; " (the attribute `conditions` of the datasets).
std::string joined_labels(const SupportReactions& r);

}  // namespace ltl
