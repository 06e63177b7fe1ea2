// The fields of a step for the results file, made one at a time when the writer asks for them
// and read by blocks of rows (FieldSource, lib/results.hpp): the state's (u, E, lambda, e,
// lambda_c, beta) and those computed from it, the Derived rows of lib/results_fields.hpp: the
// stresses, one definition each (Discretization::stresses: P, sigma, sigma33 and the pressure of
// (1.5)), the strain's derived fields (lib/derived_fields.hpp: det F of (2.7), the principal
// stretches, von Mises, the nodal stress), the contact pressure and gap. The writer then holds
// one block of one field at a time.
//
// Under mpirun, with a solver whose state between steps holds E and lambda on each rank's rows
// (Solver::rows_between_steps), each rank makes a cell field on its own cells when it is opened,
// and rank 0, the writer, gathers the rows of each block it reads (Solver::cells_to_writer); the
// nodal stress of a block of nodes is summed over the ranks' cells (mpi::sum_to_writer), and u,
// on the ranks' ghost layers' rows, by the nodes each rank owns (Solver::nodes_to_writer). Opening
// and reading are then collective: rank 0 sends each request to the other ranks, which serve it,
// until the write is done (written()). paper_notes/mpi.md, "The writer holds one block".
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <map>
#include <string>
#include <utility>

#include "alg2.hpp"
#include "results.hpp"

namespace ltl {

class StepFields final : public FieldSource {
 public:
  /// Which fields it makes: every one of the table, or the state's alone (u, E, lambda, e,
  /// lambda_c, beta: a checkpoint's iterate; the others then open empty).
  enum class Fields { All, State };
  /// Not a field of the table: the mesh's connectivity, #cells x nodes per cell (the mesh's node
  /// numbers, as doubles), made on each rank from its part (Discretization::part()) and read by
  /// blocks of cells like a cell field, for the writer to write the mesh once the ranks have
  /// released it (Discretization::release_mesh_cells). Made whatever `fields` says.
  static constexpr const char* kMeshCells = "mesh_cells";
  /// Not a field of the table either: the mesh's reference positions X, #nodes x dim, read by
  /// blocks of nodes from those each rank owns on its ghost layer's rows (Solver::reference_rows)
  /// like u, for the writer to write the mesh once the ranks have released its X
  /// (Discretization::release_mesh_X). Made whatever `fields` says.
  static constexpr const char* kMeshX = "mesh_X";
  /// The fields of `state` (the solver's state between steps, or an iterate in that form:
  /// Solver::iterate_to_writer), which must outlive this.
  StepFields(const Solver& solver, const State& state, Fields fields = Fields::All);

  /// Makes the field `name` on this rank (its cells' part): its whole size, {0, 0} when the step
  /// has none (e.g. sigma33 in 3-D, the contact fields without contact, every field of the cells
  /// of a problem without E). Under mpirun, on rank 0 inside written() only (collective).
  std::pair<Eigen::Index, Eigen::Index> open(const std::string& name) override;
  /// Rows first .. first + count - 1 of the open field `name`, on rank 0: under mpirun the ranks'
  /// rows of those cells gathered, or the nodal sums of those nodes added up (collective).
  void read(const std::string& name, Eigen::Index first, Eigen::Index count,
            Eigen::MatrixXd& rows) override;
  /// Releases the field `name` on this rank; under mpirun, on the others with the next request.
  void close(const std::string& name) noexcept override;

  /// Runs `write` on rank 0, the writer (on one process: the process), which may open and read
  /// fields; meanwhile every other rank serves the requests. Returns the message of the error
  /// `write` threw (empty: none), on every rank. Every field left open is released.
  std::string written(const std::function<void()>& write);

  /// Fields opened so far (by rank 0) or served (by the other ranks).
  int fields_made() const { return made_; }
  /// Blocks read so far (by rank 0) or served (by the other ranks), of the fields made here.
  int blocks_read() const { return reads_; }

 private:
  /// A field made on this rank.
  struct Part {
    /// Where its rows are read: whole on this rank (the contact points' fields, u when it is
    /// whole, every field on one process), the ranks' cells' rows gathered, the nodal sums of
    /// the ranks' cells added up, or u's rows of the nodes each rank owns (u on the ranks' ghost
    /// layers, Solver::nodes_to_writer).
    enum class Kind { Here, Cells, Nodes, NodeRows } kind = Kind::Here;
    const Eigen::MatrixXd* state = nullptr;  ///< its rows in the state (null: in `own`)
    Eigen::MatrixXd own;      ///< what was made for it (Nodes: sigma of the rank's cells)
    Eigen::VectorXd sigma33;  ///< Nodes in plane strain: sigma33 of the rank's cells
    /// Nodes of a whole state on a rank's discretization (which holds its cells' volumes alone):
    /// every cell's volume (cell_volumes), made once when opened; else empty
    Eigen::VectorXd volume;
    int m = 1;                        ///< Cells: rows per cell
    bool von_mises = false;           ///< Nodes: von_mises_node, else sigma_node
    Eigen::Index rows = 0, cols = 0;  ///< the whole field's size
    const Eigen::MatrixXd& data() const { return state ? *state : own; }
  };
  /// Carries out a request of rank 0 (every rank alike): lines "close NAME", "open NAME",
  /// "read NAME FIRST COUNT". A read's rows land in `rows` on rank 0.
  std::pair<Eigen::Index, Eigen::Index> serve(const std::string& request, Eigen::MatrixXd& rows);
  /// Makes the part of field `name` on this rank (no part: the step has none).
  void make(const std::string& name);
  /// Sends `request`, after the fields closed since the last one, to the other ranks (under
  /// mpirun), then serves it here.
  std::pair<Eigen::Index, Eigen::Index> ask(const std::string& request, Eigen::MatrixXd& rows);

  const Solver& solver_;
  const State& state_;
  bool rows_;             ///< E and lambda on each rank's rows: asking is collective
  bool state_only_;       ///< Fields::State
  bool writing_ = false;  ///< rank 0 inside written()
  int made_ = 0, reads_ = 0;
  std::map<std::string, Part> open_;
  std::string closed_;  ///< "close NAME" lines not yet sent to the other ranks
};

}  // namespace ltl
