// The fields of a step for the results file, made one at a time when the writer asks for them
// (FieldSource, lib/results.hpp): the state's (u, E, lambda, e, lambda_c, beta) and those computed
// from it, the Derived rows of lib/results_fields.hpp: the stresses, one definition each
// (Discretization::stresses: P, sigma, sigma33 and the pressure of (1.5)), the strain's derived
// fields (lib/derived_fields.hpp: det F of (2.7), the principal stretches, von Mises, the nodal
// stress), the contact pressure and gap. The writer then holds one whole field at a time, not
// every field of the step at once.
//
// Under mpirun, with a solver whose state between steps holds E and lambda on each rank's rows
// (Solver::rows_between_steps), each rank computes a cell field on its own cells and rank 0, the
// writer, gathers it (Solver::cells_to_writer); the nodal stress is summed over the ranks' cells
// (mpi::sum_to_writer). Asking is then collective: rank 0 sends each name it asks for to the
// other ranks, which serve it, until the write is done (written()). paper_notes/mpi.md,
// "The writer holds one field at a time".
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <string>

#include "alg2.hpp"
#include "results.hpp"

namespace ltl {

class StepFields final : public FieldSource {
 public:
  /// The fields of `state` (the solver's state between steps), which must outlive this.
  StepFields(const Solver& solver, const State& state);

  /// The whole field `name` on rank 0, or null when the step has none (e.g. sigma33 in 3-D, the
  /// contact fields without contact, every field of the cells of a problem without E). Under
  /// mpirun, on rank 0 inside written() only (collective).
  const Eigen::MatrixXd* field(const std::string& name, Eigen::MatrixXd& buffer) override;

  /// Runs `write` on rank 0, the writer (on one process: the process), which may ask for fields
  /// (field()); meanwhile every other rank serves the fields asked for. Returns the message of
  /// the error `write` threw (empty: none), on every rank.
  std::string written(const std::function<void()>& write);

  /// Fields asked for so far (by rank 0) or served (by the other ranks).
  int fields_made() const { return made_; }

 private:
  /// The field `name` made on this rank: on rank 0 the whole field (null: none), elsewhere its
  /// part of the collective (the result null).
  const Eigen::MatrixXd* make(const std::string& name, Eigen::MatrixXd& buffer);
  /// A per-cell field of the state's cells (rows_per_cell rows each) made whole on rank 0.
  const Eigen::MatrixXd* cells(Eigen::MatrixXd&& own, Eigen::MatrixXd& buffer,
                               int rows_per_cell) const;

  const Solver& solver_;
  const State& state_;
  bool rows_;             ///< E and lambda on each rank's rows: asking is collective
  bool writing_ = false;  ///< rank 0 inside written()
  int made_ = 0;
};

}  // namespace ltl
