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
//                        measure force_residual, det_error, penetration; datasets u, E, lambda,
//                        P, sigma, sigma33 (2-D), pressure, and with contact beta, e, lambda_c,
//                        contact_pressure, gap; history (#iterations, 8)
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
// Crash consistency: the file at `path` is only ever replaced whole. Every change (the mesh with
// the first step, each further step, a status) is made in memory (HDF5's core driver, loaded from
// a copy of `path` when it exists); its image is written to `path + ".partial"` with checked
// write(2) calls (a full disk is an Error naming ENOSPC), fsync'ed and renamed onto `path`
// (rename(2) is atomic), and the directory is fsync'ed. A process killed at any instant leaves
// either the previous complete file or the new one (and perhaps a stale .partial, removed by the
// next writer); a run killed in the middle keeps every step it completed, and can be resumed.
// The working file and the XDMF temporaries are created afresh (O_CREAT | O_EXCL | O_NOFOLLOW,
// a stale entry unlinked first, never followed), with the mode of the file they replace; an
// existing file is read into memory without following a link (open with O_NOFOLLOW).
// Cost: one copy of the file per committed change.
// Environment LTL_FAULT_AT_WRITE=k (tests only) kills the process at the k-th write event.
//
// XDMF (rewritten after every change): xdmf_path_of(path) (the body: u, pressure, sigma33, E, P,
// sigma) and, with a contact surface, contact_xdmf_path_of(path) (beta, contact_pressure, gap, e,
// lambda_c on the contact facets, per contact node or per facet). They refer to the HDF5 file by
// its bare name, so keep the files side by side. Several steps: a temporal collection of uniform
// grids; one step: its uniform grid alone (what meshio.read() accepts).
// The readers open files without HDF5 file locking when another process is writing them, so
// a running simulation can be inspected; a second writer is refused.
#pragma once

#include <Eigen/Dense>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "mesh.hpp"
#include "problem.hpp"
#include "state.hpp"
#include "stored_measure.hpp"

namespace ltl {

/// Version of the file layout (root attribute format_version; files without it are version 1:
/// no units, no sigma33, no equilibrium measure, no contact XDMF, no config_resolved).
inline constexpr int kFormatVersion = 2;

/// The XDMF file of the body beside a results file: path with .h5 replaced by suffix + ".xdmf"
/// (else path + suffix + ".xdmf").
std::string xdmf_path_of(const std::string& path, const std::string& suffix = "");
/// The XDMF file of the contact surface: <stem>_contact.xdmf.
std::string contact_xdmf_path_of(const std::string& path);
/// Whether `xdmf` is a regular file (not a link) that this code wrote for the results file
/// `path`: it opens with the comment naming path's file name (xdmf_text). The XDMF files beside a
/// results file are replaced only when they are (check_output_path).
bool is_xdmf_of(const std::string& xdmf, const std::string& path);

/// What is written once per run.
struct RunInfo {
  std::string name;
  std::string config_text;      ///< as given (with --set applied)
  std::string config_resolved;  ///< resolved_configuration(), config.hpp (may be empty)
  std::string config_path;
  std::map<std::string, std::string> attributes;  ///< extra string attributes (versions, ...)
};

/// Everything written for one completed time step.
struct StepData {
  int p = 0;
  double t = 0;
  const State* state = nullptr;
  const StepReport* report = nullptr;
  Eigen::MatrixXd P, sigma;               ///< transposed-block layout like State::E
  Eigen::VectorXd sigma33;                ///< #cells, plane strain only (Pa)
  Eigen::VectorXd pressure;               ///< #cells
  Eigen::VectorXd contact_pressure, gap;  ///< #facets (empty without contact)
  std::vector<StoredMeasure> measures;    ///< /steps/N/measures (none: no group)
  Eigen::VectorXi in_contact;             ///< #facets, 1 in the contact set (may be empty)
  /// Per Dirichlet condition (lib/reactions.hpp; none: not written): the support's reaction
  /// force and the mean displacement of its nodes (#conditions x dim), and their labels
  /// ("fixed[0]:left; symmetry[0]:bottom", the step's attribute `conditions`).
  Eigen::MatrixXd reactions, support_u;
  std::string conditions;
};

/// A step read back from a file (for resuming, and for tests).
struct StoredStep {
  int p = 0;
  double t = 0;
  State state;  ///< u, E, lambda, e, beta, lambda_c in the solver's layouts
  int iterations = 0;
  std::map<std::string, double> measures;  ///< /steps/N/measures (empty in older files)
};

class ResultsFile {
 public:
  /// Creates `path` (truncating it), writing the root attributes and the mesh. `contact_facets`
  /// is the contact boundary's facets (may be null) with the contact points' centres and areas
  /// (each may be null). The contact points are the facets, or with `contact_nodes` (nodal
  /// contact, written as /mesh/contact_nodes) those nodes, in that order. `contact_centre` is dim x
  /// #facets (the layout of FacetOperators::centre); #facets x dim is accepted too when the shape
  /// is not square. Supported cells: six-node P2 triangles (2-D), eight-node hexahedra and
  /// ten-node P2 tetrahedra (3-D).
  /// /mesh/cell_volume is `cell_volume` (the solver's CellOperators::vol), or when null
  /// cell_operators(mesh).vol: the discretization's, never a second copy of shape functions.
  /// With `commit` false, `path` is left as it is (an existing file stays) until the first
  /// append(): the mesh is committed together with the first step.
  static ResultsFile create(const std::string& path, const Mesh& mesh, const RunInfo& info,
                            const Mesh::Boundary* contact_facets = nullptr,
                            const Eigen::MatrixXd* contact_centre = nullptr,
                            const Eigen::VectorXd* contact_area = nullptr,
                            const std::vector<int>* contact_nodes = nullptr, bool commit = true,
                            const Eigen::VectorXd* cell_volume = nullptr);
  /// Opens an existing file to append further steps (resume).
  static ResultsFile open(const std::string& path);

  ResultsFile(ResultsFile&&) noexcept;
  ResultsFile& operator=(ResultsFile&&) noexcept;
  ~ResultsFile();  ///< closes the file and rewrites the XDMF file beside it

  /// Appends one step, flushes it to disk and rewrites the XDMF file. `state` is required;
  /// without `report` the step has no history and 0 iterations. P, sigma, pressure,
  /// contact_pressure, gap are written when non-empty (wrong sizes are an Error). Storing a p
  /// that is already in the file is an Error.
  /// With a non-empty `status`, the root attribute "status" is set in the same commit.
  void append(const StepData& step, const std::string& status = "");
  /// Saves the last iterate and the iteration history of step `step.p`, which did not converge,
  /// as /unconverged/NNNNNN (attribute unconverged = 1; replaced if present), never as a result:
  /// /steps and the XDMF files are unchanged. Sets the root "status" in the same commit.
  void save_unconverged(const StepData& step, const std::string& status);
  /// Sets the root attribute "status" (e.g. "running", "complete",
  /// "diverged at step 12: iteration cap reached") and flushes.
  void set_status(const std::string& status);
  const std::string& path() const { return path_; }

  /// The last completed step stored in `path` (nullopt if it has none). Errors name the file:
  /// missing file, not HDF5, not a results file (no /mesh or /steps group), bad datasets.
  /// Without a contact surface, e and lambda_c are dim x 0 and beta is empty.
  static std::optional<StoredStep> read_last_step(const std::string& path);
  /// Reads root attribute `name` (empty string if absent; an Error if the file cannot be read).
  static std::string read_attribute(const std::string& path, const std::string& name);

 private:
  ResultsFile() = default;
  std::string xdmf_text(bool contact) const;  ///< from the open working file ("" if none)
  void write_xdmf(const std::string& xdmf, const std::string& text) const;  ///< atomically
  void check_step(const StepData& step) const;
  void write_step(const std::string& group, const StepData& step, bool converged);
  void begin();             ///< opens the working file (a copy of path) if it is not open
  void commit();            ///< closes, syncs and renames the working file onto path
  void discard() noexcept;  ///< closes and removes an uncommitted working file
  void close() noexcept;    ///< discards uncommitted changes
  long long file_ = -1;     ///< hid_t of the working file while a change is being made
  std::string path_, work_;
  int dim_ = 0;
  int num_nodes_ = 0, num_cells_ = 0, num_facets_ = 0;
  bool contact_ = false;  ///< the file has /mesh/contact_facets
};

/// Versions of the libraries in use, as attributes: keys "eigen", "cholmod" (compile time),
/// "hdf5" (run time), "gmsh" (compile time), values like "3.4.0".
std::map<std::string, std::string> library_versions();

}  // namespace ltl
