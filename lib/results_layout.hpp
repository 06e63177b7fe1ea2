// The layout of a results file: what the root, /mesh and a step's group hold, written and read
// through the field table (lib/results_fields.hpp) and the HDF5 layer (lib/hdf5_io.hpp). The
// layout is documented for users in experiments/README.md ("Results files") and in results.hpp.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "hdf5_io.hpp"
#include "results.hpp"
#include "results_fields.hpp"

namespace ltl::layout {

/// The sizes a file's datasets are checked against.
struct Sizes {
  int dim = 0, nodes = 0, cells = 0, points = 0;
  bool contact = false;  ///< the file has /mesh/contact_facets
  /// The number of entities at `at` (nodes, cells, contact points; 1 for a step).
  int count(Location at) const;
  /// The number of entities of field f given as `value`: count(f.at), or for the per-condition
  /// (support) fields the rows given, one per Dirichlet condition.
  int count(const Field& f, const Eigen::MatrixXd& value) const {
    return f.at == Location::Support ? static_cast<int>(value.rows()) : count(f.at);
  }
};

/// A field of the state (u, E, lambda, e, lambda_c, beta) in the layout of StepData::fields
/// (#entities x dim for a vector): the state's own matrix, not a copy; beta, a vector, copied
/// into `buffer` as one column.
const Eigen::MatrixXd& state_field(const State& s, const std::string& name,
                                   Eigen::MatrixXd& buffer);
/// The XDMF topology of a mesh cell, or null when it cannot be stored.
const char* cell_topology(int dim, int nodes_per_cell);
/// "NNNNNN", the group name of step p.
std::string step_name(int p);
/// Names of the complete steps in /steps (six digits), in increasing p.
std::vector<std::string> step_names(hid_t f, const std::string& file);
/// An Error unless the file holds /mesh/X, /mesh/cells and /steps.
void expect_results_file(hid_t f, const std::string& file);
/// The sizes of an open results file (read from its mesh).
Sizes sizes_of(hid_t f, const std::string& file);

/// Writes the root attributes, /mesh (with the contact surface of options.contact) and an empty
/// /steps; returns the sizes. Errors name `file` and what is inconsistent.
Sizes write_mesh(hid_t f, const Mesh& mesh, const RunInfo& info, const ResultsOptions& options,
                 const std::string& file);
/// Checks the sizes of a step's data (an Error naming the step and the field).
void check_step(const StepData& step, const Sizes& n, const std::string& file);
/// Writes the group `g` (absolute) of one step: attributes, fields, measures, history and, in
/// 2-D, the padded copies for ParaView (not for an unconverged iterate, which no XDMF grid shows).
void write_step(hid_t f, const std::string& g, const StepData& step, bool converged, const Sizes& n,
                const std::string& file);
/// The last complete step of an open results file (nullopt if it has none).
std::optional<StoredStep> read_last_step(hid_t f, const std::string& file);
/// The checkpoint of step p (/unconverged/NNNNNN with attribute checkpoint = 1, written by
/// ResultsFile::save_checkpoint): nullopt when the group is absent or holds a diverged step's
/// iterate.
std::optional<StoredStep> read_checkpoint(hid_t f, int p, const std::string& file);

/// The mesh of an open results file (ResultsFile::read_mesh).
StoredMesh read_mesh(hid_t f, const std::string& file);

}  // namespace ltl::layout
