// The nested start (grid sequencing): a run starts from the last step of a results file computed
// on another mesh of the same body, typically a coarser one (`ltl_run --init COARSE.h5`;
// paper_notes/nested.md). The state is rebuilt on this problem's mesh so that it is consistent
// in the sense of the Newton phase's to_state (lib/newton.hpp): at a converged source it is close
// to a fixed point of ALG2 (4.1)-(4.3) on the new mesh, and ALG2 or Newton start next to it.
//
//   u        the source's finite-element field evaluated at the nodes (lib/mesh_transfer.hpp),
//            the prescribed values kept where this problem prescribes them;
//   E_e      Fbar_e = I + Gbar_e u, the cell mean gradient of (2.7), (3.3);
//   lambda_e 2 C1 Fbar_e - dW(Fbar_e) + p_e cof Fbar_e: the multiplier at which the local strain
//            step (4.6) returns Fbar_e, with p_e the pressure of the source cell containing the
//            cell's centroid (from the source's E and lambda, as Newton::unknowns reads it);
//   e_s      ubar_s (4.7) projected onto the admissible set N . e_s <= g_s of (4.11);
//   lambda_c -(pc_s) N - kappa beta_s^2 e_s: the contact pressure pc_s (>= 0) and beta_s of the
//            nearest source contact point (reference positions), as in Newton::to_state.
//
// Time: the run computes this problem's own steps 1..P from that state (the load factor of its
// step 1, not the source's), so that a one-step problem (the figures) is solved at full load
// from the coarse solution, as the Newton peer's "nested" start does.
#pragma once

#include <string>

#include "alg2.hpp"
#include "state.hpp"

namespace ltl {

/// How a nested start went, for the console and the tests.
struct NestedStart {
  State state;         ///< the state between steps of the solver (Solver::initial_state)
  std::string source;  ///< the results file
  int source_step = 0, source_cells = 0;
  double source_load_factor = 1;  ///< the source step's load factor (1 if the file has none)
  /// Target nodes (and cell centroids) inside no source cell, given the closest cell's value at
  /// the clamped reference point, and the largest distance outside (m), also relative to the
  /// size of the cell it was clamped to.
  int clamped_nodes = 0, clamped_centroids = 0;
  double max_outside = 0, max_outside_relative = 0;
  double seconds = 0;
  /// One line for the console: the source, its step and size, the clamped nodes.
  std::string summary() const;
};

/// A node farther outside the source mesh than this fraction of the closest source cell's size
/// is refused (the meshes are not of the same body, or not in the same coordinates).
constexpr double kMaxOutside = 0.1;

/// The nested start of `solver`'s problem from the last step of the results file `path`. An
/// Error naming the file and `key` (the option that named it) when the file cannot be read, has
/// no completed step, is of another dimension, or when a node lies farther outside the source
/// mesh than kMaxOutside. Collective when the solver's discretization holds some of the cells
/// only (Discretization::partial: several MPI ranks): each rank computes E and lambda on its
/// cells, then every rank gets them whole; u is whole (Solver::hold_rows cuts the state to the
/// state between steps). A source without contact fields
/// leaves lambda_c = 0 and beta = beta_0 (the solver's initial state); a problem without contact
/// ignores the source's.
NestedStart nested_start(const Solver& solver, const std::string& path,
                         const std::string& key = "--init");

}  // namespace ltl
