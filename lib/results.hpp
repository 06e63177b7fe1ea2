// Results in HDF5 (one file per run), with an XDMF file beside it for ParaView.
//
// Layout (all arrays row-major, C order; tensors per cell are (#cells, dim, dim) with [c][i][j]
// the (i, j) entry of the cell's tensor):
//   /                    attributes: name, config (the resolved configuration text),
//                        config_path, code_version, git_version, library versions, status
//   /mesh/X              (#nodes, dim) reference positions
//   /mesh/cells          (#cells, nodes_per_cell) int, gmsh node order (= VTK/XDMF order)
//   /mesh/cell_volume    (#cells)
//   /mesh/contact_facets (#facets, nodes_per_facet) int  (only with a contact surface)
//   /mesh/contact_centre (#facets, dim), /mesh/contact_area (#facets)
//   /steps/NNNNNN        one group per completed time step p (6 digits), attributes p, t,
//                        iterations, status; datasets u (#nodes, dim), E, lambda, P, sigma
//                        (#cells, dim, dim), pressure (#cells), and with contact: beta (#facets),
//                        e, lambda_c (#facets, dim), contact_pressure, gap (#facets);
//                        history (#iterations, 8): n, r_G, r_B, t_global, t_strain, t_contact,
//                        t_update, wall (column names in its attribute "columns").
//                        Further step attributes: converged (int 0/1), strain_failures (int).
//   /steps/NNNNNN/xdmf   2-D only: copies of u padded to (#nodes, 3) and of P, sigma padded to
//                        (#cells, 3, 3) with zeros, for ParaView (XDMF wants 3-vectors and 3x3
//                        tensors). Not solver data; readers of the solver data ignore it.
//   /mesh attributes:    cell_type ("Triangle_6" or "Hexahedron", the XDMF topology), source;
//                        /mesh/contact_facets has the string attribute "boundary" (its name).
// Strings are variable-length UTF-8 scalars. A step is written as /steps/incomplete and renamed
// once complete, so a name of six digits always denotes a complete step.
//
// Crash consistency: the file at `path` is only ever replaced whole. Every change (the mesh with
// the first step, each further step, a status) is made in memory (HDF5's core driver, loaded from
// a copy of `path` when it exists); its image is written to `path + ".partial"` with checked
// write(2) calls (a full disk is an Error naming ENOSPC), fsync'ed and renamed onto `path`
// (rename(2) is atomic), and the directory is fsync'ed. A process killed at any instant leaves
// either the previous complete file or the new one (and perhaps a stale .partial, overwritten by
// the next writer); a run killed in the middle keeps every step it completed, and can be resumed.
// Cost: one copy of the file per committed change.
// Environment LTL_FAULT_AT_WRITE=k (tests only) kills the process at the k-th write event.
//
// XDMF (path with .h5 replaced by .xdmf, else path + ".xdmf"; rewritten after every append and on
// close; it refers to the HDF5 file by its bare name, so keep the two side by side): a temporal
// collection with one grid per step, topology Triangle_6 or Hexahedron on /mesh/cells, geometry
// XY or XYZ on /mesh/X, attributes u (Vector, nodes), pressure (Scalar, cells), P and sigma
// (Tensor, cells, 3x3). In 2-D these point at the padded copies in /steps/NNNNNN/xdmf.
// The readers open files without HDF5 file locking when another process is writing them, so
// a running simulation can be inspected; a second writer is refused.
#pragma once

#include <Eigen/Dense>
#include <map>
#include <optional>
#include <string>

#include "mesh.hpp"
#include "state.hpp"

namespace ltl {

/// What is written once per run.
struct RunInfo {
  std::string name;
  std::string config_text;
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
  Eigen::VectorXd pressure;               ///< #cells
  Eigen::VectorXd contact_pressure, gap;  ///< #facets (empty without contact)
};

/// A step read back from a file (for resuming, and for tests).
struct StoredStep {
  int p = 0;
  double t = 0;
  State state;  ///< u, E, lambda, e, beta, lambda_c in the solver's layouts
  int iterations = 0;
};

class ResultsFile {
 public:
  /// Creates `path` (truncating it), writing the root attributes and the mesh. `contact_facets`
  /// is the contact boundary's facets (may be null) with the contact points' centres and areas
  /// (each may be null). The contact points are the facets, or with `contact_nodes` (nodal
  /// contact, written as /mesh/contact_nodes) those nodes, in that order. `contact_centre` is dim x
  /// #facets (the layout of FacetOperators::centre); #facets x dim is accepted too when the shape
  /// is not square. Supported cells: six-node P2 triangles (2-D) and eight-node hexahedra (3-D);
  /// /mesh/cell_volume is computed here by exact quadrature.
  /// With `commit` false, `path` is left as it is (an existing file stays) until the first
  /// append(): the mesh is committed together with the first step.
  static ResultsFile create(const std::string& path, const Mesh& mesh, const RunInfo& info,
                            const Mesh::Boundary* contact_facets = nullptr,
                            const Eigen::MatrixXd* contact_centre = nullptr,
                            const Eigen::VectorXd* contact_area = nullptr,
                            const std::vector<int>* contact_nodes = nullptr, bool commit = true);
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
  std::string xdmf_text() const;                   ///< from the open working file
  void write_xdmf(const std::string& text) const;  ///< beside path, atomically
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
