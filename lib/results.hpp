// Results in HDF5 (one file per run), with XDMF files beside it for ParaView.
//
// The layout, every group, dataset, attribute and unit, is documented for users in
// experiments/README.md ("Results files"); in short (format_version 2; arrays row-major, C order;
// tensors per cell are (#cells, dim, dim) with [c][i][j] the (i, j) entry of the cell's tensor;
// every dataset carries string attributes "unit" and "description"):
//   /                    attributes: format_version (int), name, config (the configuration text
//                        as given, with --set applied), config_resolved (TOML: every value in SI
//                        with every default filled in, resolved_configuration(), config.hpp),
//                        config_path, code_version, git_version, library versions, identity hashes,
//                        status
//   /mesh/X, cells, cell_volume (from the discretization, lib/fe), and with a contact surface
//   /mesh/contact_facets, contact_centre, contact_area, and with nodal contact contact_nodes,
//   contact_topology (the facets numbered by contact point)
//   /steps/NNNNNN        one group per completed time step p (6 digits): attributes p, t,
//                        iterations, status, converged, strain_failures and the equilibrium
//                        measure force_residual, det_error, penetration; the datasets of the
//                        field table (lib/results_fields.hpp): u, E, lambda, P, sigma, sigma33
//                        (2-D), pressure, and with contact beta, e, lambda_c, contact_pressure,
//                        gap; history (#iterations, 8)
//   /steps/NNNNNN/measures  the step's measures (lib/measures.hpp, stored_measures): one scalar
//                        dataset per measure (contact force, half-width, debonding front,
//                        opening, ...) and with contact in_contact (#points, 0/1)
//   /steps/NNNNNN/xdmf   2-D only: u, e, lambda_c padded to 3 components and E, P, sigma to 3x3
//                        with the true out-of-plane entries (E33 = 1, sigma33, P33 = det E
//                        sigma33), for ParaView. Not solver data.
//   /unconverged/NNNNNN  the last iterate and history of a step that did not converge (attribute
//                        unconverged = 1): NOT a result, for diagnosis; readers of results ignore
//                        it.
// Strings are variable-length UTF-8 scalars. A step is written as /steps/incomplete and renamed
// once complete, so a name of six digits always denotes a complete step.
//
// Layers: lib/hdf5_io.hpp (HDF5 handles and checked reads and writes), lib/results_commit.hpp
// (the crash-safe commit: the whole file replaced by a rename, or only what changed written in
// place after a redo journal), lib/results_fields.hpp (the one field table: every dataset's
// location, shape, unit and description), lib/results_layout.hpp (what the groups of the mesh and
// of a step hold), lib/results_xdmf.hpp (the XDMF files) and lib/results_info.hpp (library
// versions); the resolved configuration comes from the configuration layer (config.hpp). This class
// puts them together.
//
// XDMF (updated after every change): xdmf_path_of(path) (the body: u, pressure, sigma33, E, P,
// sigma) and, with a contact surface, contact_xdmf_path_of(path) (beta, contact_pressure, gap, e,
// lambda_c on the contact points, per contact node or per facet). They refer to the HDF5 file by
// its bare name, so keep the files side by side. Several steps: a temporal collection of uniform
// grids; one step: its uniform grid alone (what meshio.read() accepts).
// The readers wait while a writer updates the file in place (a few milliseconds per step) and
// apply a journal left by a killed writer in memory, so a running simulation can be inspected;
// a second writer is refused (lib/output_guard.hpp).
#pragma once

#include <Eigen/Dense>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "contact_points.hpp"
#include "mesh.hpp"
#include "problem.hpp"
#include "results_info.hpp"
#include "results_xdmf.hpp"
#include "state.hpp"
#include "stored_measure.hpp"

namespace ltl {

class CommittedFile;

/// Version of the file layout (root attribute format_version; files without it are version 1:
/// no units, no sigma33, no equilibrium measure, no contact XDMF, no config_resolved).
inline constexpr int kFormatVersion = 2;

/// What is written once per run.
struct RunInfo {
  std::string name;
  std::string config_text;      ///< as given (with --set applied)
  std::string config_resolved;  ///< resolved_configuration(), config.hpp (may be empty)
  std::string config_path;
  std::map<std::string, std::string> attributes;  ///< extra string attributes (versions, ...)
};

/// The fields of a step made when the writer asks for them, one at a time, and read by blocks of
/// rows (the simulation's StepFields, lib/step_fields.hpp): the writer then holds one block of
/// one field at a time, not every field of the step at once, nor one whole field.
class FieldSource {
 public:
  virtual ~FieldSource() = default;
  /// Makes the field `name` of the field table (a per-step row: the state's or a computed one)
  /// ready to be read; returns its whole size (rows, columns) in the layout of StepData::fields,
  /// {0, 0} when the step has none.
  virtual std::pair<Eigen::Index, Eigen::Index> open(const std::string& name) = 0;
  /// Rows first .. first + count - 1 of the field opened as `name` (whole rows of its entities:
  /// a tensor's dim rows each) into `rows`.
  virtual void read(const std::string& name, Eigen::Index first, Eigen::Index count,
                    Eigen::MatrixXd& rows) = 0;
  /// Done with the field opened as `name`: what was made for it is released. Never throws.
  virtual void close(const std::string& name) noexcept = 0;
  /// The whole field `name` in `buffer` (open, read every row, close), or null when the step has
  /// none.
  const Eigen::MatrixXd* whole(const std::string& name, Eigen::MatrixXd& buffer);
};

/// Everything written for one completed time step.
struct StepData {
  int p = 0;
  double t = 0;
  const State* state = nullptr;
  const StepReport* report = nullptr;
  /// The computed fields (rows of lib/results_fields.hpp with Source::Derived: P, sigma, sigma33,
  /// pressure, contact_pressure, gap, ...) by name, in the solver's layouts: a scalar a column
  /// (#entities), a vector #entities x dim, a tensor dim x dim blocks stacked like State::E.
  /// Each one given is written (wrong sizes and names not in the table are an Error).
  std::map<std::string, Eigen::MatrixXd> fields;
  /// The other fields, the state's among them, asked for one at a time and read by blocks (null:
  /// the state's from `state`, the computed ones from `fields` alone). `state` is then the step's
  /// state in the solver's form (under mpirun E and lambda on each rank's rows): only its u, e,
  /// lambda_c and beta are read directly, and every field asked for is checked against its shape.
  FieldSource* source = nullptr;
  std::vector<StoredMeasure> measures;  ///< /steps/N/measures (none: no group)
  Eigen::VectorXi in_contact;           ///< #points, 1 in the contact set (may be empty)
  /// The Dirichlet conditions of the support fields (reactions, support_u) in their row order,
  /// e.g. "fixed[0]:left; symmetry[0]:bottom": the step's attribute `conditions`.
  std::string conditions;
};

/// What a results file stores of the contact surface, beside the mesh.
struct ContactOutput {
  const Mesh::Boundary* facets = nullptr;  ///< the contact boundary (null: no contact surface)
  /// The contact points: the facets, or with `nodes` (nodal contact, /mesh/contact_nodes) those
  /// mesh nodes, in that order.
  std::vector<int> nodes;
  /// Reference position of each contact point, dim x #points (the layout of
  /// ContactPoints::centre; #points x dim is accepted when not square). Empty: with nodes, the
  /// nodes' positions; without, not written.
  Eigen::MatrixXd centre;
  Eigen::VectorXd area;  ///< weight of each contact point (empty: not written)
  /// Several obstacles (paper_notes/obstacles.md): the points of obstacle k are offset[k] ..
  /// offset[k + 1] - 1 and its facets facet_offset[k] .. facet_offset[k + 1] - 1 (`facets` holds
  /// every obstacle's, one after the other); written as /mesh/contact_obstacle (the obstacle of
  /// each point). Empty, or one obstacle: the layout of one contact surface.
  std::vector<int> offset, facet_offset;
};

/// The contact output of the obstacles `groups` of `mesh` with their contact points (null: none):
/// one group's boundary, or with several their facets one after the other in `storage` (which
/// must outlive the output).
ContactOutput contact_output(const Mesh& mesh, const std::vector<std::string>& groups,
                             const ContactPoints* points, Mesh::Boundary& storage);

/// How ResultsFile::create starts a file.
struct ResultsOptions {
  ContactOutput contact;
  /// /mesh/cell_volume: the solver's CellOperators::vol, or when empty cell_volumes(mesh) (the
  /// discretization's quadrature, never a second copy of shape functions; a rank's
  /// discretization holds its cells' volumes alone).
  Eigen::VectorXd cell_volume;
  /// false: `path` is left as it is (an existing file stays) until the first append(); the mesh
  /// is committed together with the first step.
  bool commit = true;
};

/// A step read back from a file (for resuming, and for tests).
struct StoredStep {
  int p = 0;
  double t = 0;
  State state;  ///< u, E, lambda, e, beta, lambda_c in the solver's layouts
  int iterations = 0;
  std::map<std::string, double> measures;  ///< /steps/N/measures (empty in older files)
  double load_factor = 1;  ///< a checkpoint's (read_checkpoint): the load factor it iterated at
};

/// The mesh of a results file (for a start from another mesh, lib/nested_start.hpp): /mesh/X,
/// /mesh/cells (mesh.source = the file, no boundary parts) and, with a contact surface, the
/// reference position of each contact point (#points x dim, /mesh/contact_centre; empty when
/// the file has none) and its obstacle (/mesh/contact_obstacle; empty: one obstacle).
struct StoredMesh {
  Mesh mesh;
  Eigen::MatrixXd contact_centre;
  Eigen::VectorXi contact_obstacle;
};

class ResultsFile {
 public:
  /// Creates `path` (replacing it), writing the root attributes, the mesh and, with
  /// options.contact.facets, the contact surface. Supported cells: six-node P2 triangles (2-D),
  /// eight-node hexahedra and ten-node P2 tetrahedra (3-D).
  static ResultsFile create(const std::string& path, const Mesh& mesh, const RunInfo& info,
                            const ResultsOptions& options = {});
  /// Opens an existing file to append further steps (resume).
  static ResultsFile open(const std::string& path);

  ResultsFile(ResultsFile&&) noexcept;
  ResultsFile& operator=(ResultsFile&&) noexcept;
  ~ResultsFile();  ///< drops a change not committed (an error in the middle of a step)

  /// Appends one step, commits it to disk and rewrites the XDMF files. `state` is required;
  /// without `report` the step has no history and 0 iterations. Storing a p that is already in
  /// the file is an Error. Costs about the step's bytes on disk, once (lib/results_commit.hpp).
  /// With a non-empty `status`, the root attribute "status" is set in the same commit.
  void append(const StepData& step, const std::string& status = "");
  /// Saves the last iterate and the iteration history of step `step.p`, which did not converge,
  /// as /unconverged/NNNNNN (attribute unconverged = 1; replaced if present), never as a result:
  /// /steps and the XDMF files are unchanged. Sets the root "status" in the same commit.
  void save_unconverged(const StepData& step, const std::string& status);
  /// Saves the iterate of step `step.p`, still iterating at the load factor `load_factor`
  /// (--checkpoint), as /unconverged/NNNNNN with attributes checkpoint = 1 and load_factor
  /// (replacing what is there), never as a result: /steps and the XDMF files are unchanged. Sets
  /// the root "status" in the same commit. --resume continues the step from it; the step's result
  /// supersedes it (append deletes it), a divergence replaces it (save_unconverged).
  void save_checkpoint(const StepData& step, double load_factor, const std::string& status);
  /// Sets the root attribute "status" (e.g. "running", "complete",
  /// "diverged at step 12: iteration cap reached") and flushes.
  void set_status(const std::string& status);
  const std::string& path() const { return path_; }

  /// The last completed step stored in `path` (nullopt if it has none). Errors name the file:
  /// missing file, not HDF5, not a results file (no /mesh or /steps group), bad datasets.
  /// Without a contact surface, e and lambda_c are dim x 0 and beta is empty.
  static std::optional<StoredStep> read_last_step(const std::string& path);
  /// The checkpoint of step p in `path` (save_checkpoint), with its load factor and iterations;
  /// nullopt when there is none (no /unconverged/NNNNNN, or a diverged step's iterate there).
  static std::optional<StoredStep> read_checkpoint(const std::string& path, int p);
  /// The mesh stored in `path` (errors name the file, as read_last_step's).
  static StoredMesh read_mesh(const std::string& path);
  /// Reads root attribute `name` (empty string if absent; an Error if the file cannot be read).
  static std::string read_attribute(const std::string& path, const std::string& name);

 private:
  ResultsFile() = default;
  void commit();  ///< commits the change and rewrites the XDMF files
  /// save_unconverged and save_checkpoint (checkpoint_factor: null for a diverged step).
  void save_iterate(const StepData& step, const std::string& status,
                    const double* checkpoint_factor);
  std::string path_;
  std::unique_ptr<CommittedFile> file_;
  std::string xdmf_, contact_xdmf_;  ///< the XDMF texts written last
  int dim_ = 0;
  int num_nodes_ = 0, num_cells_ = 0, num_points_ = 0;
  bool contact_ = false;  ///< the file has /mesh/contact_facets
};

}  // namespace ltl
