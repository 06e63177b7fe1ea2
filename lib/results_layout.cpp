// The layout of a results file (results_layout.hpp), driven by the field table.
#include "results_layout.hpp"

#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <tuple>

#include "error.hpp"
#include "fe.hpp"
#include "results_commit.hpp"

namespace ltl::layout {

using namespace h5;

namespace {

// ---------------------------------------------------------------------------------------------
// Layout conversions (Eigen is column-major, the file is row-major)

std::vector<double> rows_of(const Eigen::MatrixXd& m) {
  std::vector<double> out(m.size());
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out[r * m.cols() + c] = m(r, c);
  return out;
}

std::vector<int> rows_of(const Eigen::MatrixXi& m) {
  std::vector<int> out(m.size());
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) out[r * m.cols() + c] = m(r, c);
  return out;
}

Eigen::MatrixXd from_rows(const std::vector<double>& a, int rows, int cols) {
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m(r, c) = a[r * cols + c];
  return m;
}

/// Transposed-block field ((dim*#cells) x dim, block c = T_c^T) -> [c][i][j] = T_c(i, j),
/// padded with zeros to pad x pad per cell.
std::vector<double> tensors_of(const Eigen::MatrixXd& field, int dim, int pad) {
  const int nc = static_cast<int>(field.rows()) / dim;
  std::vector<double> out(static_cast<std::size_t>(nc) * pad * pad, 0.0);
  for (int c = 0; c < nc; ++c)
    for (int i = 0; i < dim; ++i)
      for (int j = 0; j < dim; ++j) out[(c * pad + i) * pad + j] = field(dim * c + j, i);
  return out;
}

Eigen::MatrixXd tensors_from(const std::vector<double>& a, int nc, int dim) {
  Eigen::MatrixXd field(dim * nc, dim);
  for (int c = 0; c < nc; ++c)
    for (int i = 0; i < dim; ++i)
      for (int j = 0; j < dim; ++j) field(dim * c + j, i) = a[(c * dim + i) * dim + j];
  return field;
}

std::vector<double> vec(const Eigen::VectorXd& v) {
  return {v.data(), v.data() + v.size()};
}

void set_state_field(State& s, const std::string& name, const Eigen::MatrixXd& v) {
  if (name == "u") s.u = v;
  if (name == "E") s.E = v;
  if (name == "lambda") s.lambda = v;
  if (name == "beta") s.beta = v.col(0);
  if (name == "e") s.e = v;
  if (name == "lambda_c") s.lambda_c = v;
}

/// The expected rows x cols of a field in the layout of StepData::fields, n entities.
std::pair<Eigen::Index, Eigen::Index> layout_size(const Field& f, int n, int dim) {
  switch (f.shape) {
    case Shape::Scalar:
      return {n, 1};
    case Shape::Vector:
      return {n, dim};
    case Shape::Vector3:
      return {n, 3};
    case Shape::Tensor3:
      return {n, 9};
    default:
      return {static_cast<Eigen::Index>(dim) * n, dim};
  }
}

/// A field in the file's layout (row-major, (n), (n, dim) or (n, dim, dim)) padded to `pad`
/// components (dim or 3), and its shape.
std::vector<double> file_data(const Field& f, const Eigen::MatrixXd& v, int dim, int pad) {
  switch (f.shape) {
    case Shape::Scalar:
      return {v.data(), v.data() + v.size()};
    case Shape::Vector: {
      Eigen::MatrixXd w = Eigen::MatrixXd::Zero(v.rows(), pad);
      w.leftCols(dim) = v;
      return rows_of(w);
    }
    case Shape::Vector3:
    case Shape::Tensor3:
      return rows_of(v);
    default:
      return tensors_of(v, dim, pad);
  }
}

std::vector<hsize_t> file_shape(const Field& f, int n, int pad) {
  const hsize_t h = static_cast<hsize_t>(n), d = static_cast<hsize_t>(pad);
  switch (f.shape) {
    case Shape::Scalar:
      return {h};
    case Shape::Vector:
      return {h, d};
    case Shape::Vector3:
      return {h, 3};
    case Shape::Tensor3:
      return {h, 3, 3};
    default:
      return {h, d, d};
  }
}

/// Writes a dataset with the "unit" and "description" of its row of the field table (by the
/// last component of `path`); a ParaView copy (under /xdmf/) says so in its description.
void describe(hid_t f, const std::string& path, int dim, const std::string& file) {
  const Field& row = field(path.substr(path.rfind('/') + 1), file);
  const bool xdmf = path.find("/xdmf/") != std::string::npos;
  fault_point();
  Handle set = checked(H5Dopen2(f, path.c_str(), H5P_DEFAULT), H5Dclose, file,
                       cat("cannot open dataset ", path));
  write_string_attr(set.get(), "unit", dim == 2 ? row.unit_2d : row.unit_3d, file, path);
  write_string_attr(
      set.get(), "description",
      (xdmf ? "ParaView copy (3 components, 3x3 tensors): " : "") + std::string(row.description),
      file, path);
}

void write_described(hid_t f, const std::string& path, hid_t mem_type, hid_t file_type,
                     const std::vector<hsize_t>& dims, const void* data, int dim,
                     const std::string& file) {
  write_array(f, path, mem_type, file_type, dims, data, file);
  describe(f, path, dim, file);
}

/// Entities of a step field converted to the file's layout at a time (write_field).
constexpr hsize_t kEntitiesPerBlock = 16384;

/// A step field being written: given in StepData::fields, asked of the step's source, or the
/// state's. Its whole size is known at once; its rows are read a block at a time, so that from
/// a source the writer never holds the whole field (the source makes and releases it: open in
/// the constructor, close in the destructor).
class OpenField {
 public:
  OpenField(const StepData& step, const Field& f) : name_(f.name) {
    const auto it = step.fields.find(name_);
    if (it != step.fields.end()) {
      whole_ = &it->second;
    } else if (step.source) {
      source_ = step.source;
      std::tie(rows_, cols_) = source_->open(name_);
      return;
    } else if (f.source == Source::State) {
      whole_ = &state_field(*step.state, name_, buffer_);
    }
    if (whole_) rows_ = whole_->rows(), cols_ = whole_->cols();
  }
  ~OpenField() {
    if (source_) source_->close(name_);
  }
  OpenField(const OpenField&) = delete;
  OpenField& operator=(const OpenField&) = delete;

  bool empty() const { return rows_ * cols_ == 0; }
  Eigen::Index rows() const { return rows_; }
  Eigen::Index cols() const { return cols_; }
  /// Rows first .. first + count - 1 into `out`.
  void read(Eigen::Index first, Eigen::Index count, Eigen::MatrixXd& out) {
    if (source_)
      source_->read(name_, first, count, out);
    else
      out = whole_->middleRows(first, count);
  }

 private:
  std::string name_;
  FieldSource* source_ = nullptr;
  const Eigen::MatrixXd* whole_ = nullptr;
  Eigen::MatrixXd buffer_;
  Eigen::Index rows_ = 0, cols_ = 0;
};

/// Writes a step field `v` (the layout of StepData::fields, n entities) as dataset `path` in
/// the file's layout padded to `pad` components, kEntitiesPerBlock entities at a time: the writer
/// holds one block of it (read from `v`) and the block's copy in the file's layout, not the whole
/// field. `fix(first, count, data)` may change a block in the file's layout (the out-of-plane
/// entries of a padded copy).
void write_field(hid_t f, const std::string& path, const Field& row, OpenField& v, int n, int dim,
                 int pad, const std::string& file,
                 const std::function<void(int, int, std::vector<double>&)>& fix = {}) {
  const Eigen::Index per = row.shape == Shape::Tensor ? dim : 1;  // rows of v per entity
  Eigen::MatrixXd block;
  write_rows(
      f, path, H5T_IEEE_F64LE, file_shape(row, n, pad), kEntitiesPerBlock,
      [&](hsize_t first, hsize_t count, std::vector<double>& data) {
        v.read(per * static_cast<Eigen::Index>(first), per * static_cast<Eigen::Index>(count),
               block);
        data = file_data(row, block, dim, pad);
        if (fix) fix(static_cast<int>(first), static_cast<int>(count), data);
      },
      file);
  describe(f, path, dim, file);
}

void write_doubles(hid_t f, const std::string& path, const std::vector<hsize_t>& dims,
                   const std::vector<double>& data, int dim, const std::string& file) {
  write_described(f, path, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, dims, data.data(), dim, file);
}

void write_ints(hid_t f, const std::string& path, const std::vector<hsize_t>& dims,
                const std::vector<int>& data, int dim, const std::string& file) {
  write_described(f, path, H5T_NATIVE_INT, H5T_STD_I32LE, dims, data.data(), dim, file);
}

/// The rows of the field table written per step: node, cell, contact-point and support
/// (Dirichlet condition) fields.
bool per_step(const Field& f) {
  return f.source != Source::Other && (f.at == Location::Node || f.at == Location::Cell ||
                                       f.at == Location::Point || f.at == Location::Support);
}

bool is_step_name(const std::string& name) {
  if (name.size() != 6) return false;
  for (char c : name)
    if (c < '0' || c > '9') return false;
  return true;
}

}  // namespace

const Eigen::MatrixXd& state_field(const State& s, const std::string& name,
                                   Eigen::MatrixXd& buffer) {
  if (name == "u") return s.u;
  if (name == "E") return s.E;
  if (name == "lambda") return s.lambda;
  if (name == "e") return s.e;
  if (name == "lambda_c") return s.lambda_c;
  if (name == "beta") return buffer = s.beta;
  throw Error(cat("internal: the state has no field ", name));
}

int Sizes::count(Location at) const {
  switch (at) {
    case Location::Node:
      return nodes;
    case Location::Cell:
      return cells;
    case Location::Point:
      return points;
    default:
      return 1;
  }
}

const char* cell_topology(int dim, int nodes_per_cell) {
  if (dim == 2 && nodes_per_cell == 6) return "Triangle_6";
  if (dim == 3 && nodes_per_cell == 8) return "Hexahedron";
  if (dim == 3 && nodes_per_cell == 10) return "Tetrahedron_10";  // VTK order, as Mesh::cells
  return nullptr;
}

std::string step_name(int p) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", p);
  return buf;
}

std::vector<std::string> step_names(hid_t f, const std::string& file) {
  std::vector<std::string> names;
  for (std::string& name : link_names(f, "/steps", file))
    if (is_step_name(name)) names.push_back(std::move(name));
  return names;  // zero-padded: name order is p order
}

void expect_results_file(hid_t f, const std::string& file) {
  for (const char* p : {"/mesh/X", "/mesh/cells", "/steps"})
    if (!exists(f, p, file)) fail(file, cat("not a results file of this code (no ", p, ")"));
}

Sizes sizes_of(hid_t f, const std::string& file) {
  const auto X = dataset_shape(f, "/mesh/X", file);
  const auto cells = dataset_shape(f, "/mesh/cells", file);
  if (X.size() != 2 || cells.size() != 2 ||
      !cell_topology(static_cast<int>(X[1]), static_cast<int>(cells[1])))
    fail(file,
         cat("bad mesh: /mesh/X has shape ", shape_text(X), ", /mesh/cells ", shape_text(cells)));
  Sizes n;
  n.dim = static_cast<int>(X[1]);
  n.nodes = static_cast<int>(X[0]);
  n.cells = static_cast<int>(cells[0]);
  n.contact = exists(f, "/mesh/contact_facets", file);
  if (n.contact) {
    // The contact points: the contact nodes (nodal contact) or the contact facets.
    if (exists(f, "/mesh/contact_nodes", file)) {
      const auto k = dataset_shape(f, "/mesh/contact_nodes", file);
      if (k.size() != 1) fail(file, "dataset /mesh/contact_nodes is not a vector");
      n.points = static_cast<int>(k[0]);
    } else {
      const auto F = dataset_shape(f, "/mesh/contact_facets", file);
      if (F.size() != 2) fail(file, "dataset /mesh/contact_facets is not a matrix");
      n.points = static_cast<int>(F[0]);
    }
  }
  return n;
}

Sizes write_mesh(hid_t f, const Mesh& mesh, const RunInfo& info, const ResultsOptions& options,
                 const std::string& path) {
  const int dim = mesh.dim, nn = mesh.num_nodes(), nc = mesh.num_cells();
  const int npc = mesh.nodes_per_cell();
  if (!cell_topology(dim, npc))
    fail(path, cat("cannot store a mesh of ", npc, "-node cells in ", dim,
                   "-D (six-node triangles in 2-D, eight-node hexahedra and ten-node tetrahedra in "
                   "3-D are supported)"));
  if (mesh.X.cols() != dim) fail(path, cat("mesh X has ", mesh.X.cols(), " columns, dim is ", dim));
  if (nc > 0 && (mesh.cells.minCoeff() < 0 || mesh.cells.maxCoeff() >= nn))
    fail(path, "mesh cells refer to nodes that do not exist");
  // Contact fields live on the contact points: the facets, or the nodes of a nodal contact.
  const ContactOutput& contact = options.contact;
  const std::vector<int>& nodes = contact.nodes;
  const int n_points = !contact.facets  ? 0
                       : !nodes.empty() ? static_cast<int>(nodes.size())
                                        : static_cast<int>(contact.facets->facets.rows());
  if (!nodes.empty() && !contact.facets) fail(path, "contact nodes given without contact facets");
  Eigen::MatrixXd centre;  // #points x dim
  if (!nodes.empty() && contact.centre.size() == 0) centre.resize(n_points, dim);
  if (contact.facets) {
    const auto& F = contact.facets->facets;
    if (F.cols() != mesh.nodes_per_facet())
      fail(path,
           cat("contact facets have ", F.cols(), " nodes, expected ", mesh.nodes_per_facet()));
    if (n_points > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= nn))
      fail(path, "contact facets refer to nodes that do not exist");
    const Eigen::MatrixXd& c = contact.centre;
    if (c.size()) {
      if (c.rows() == dim && c.cols() == n_points)
        centre = c.transpose();
      else if (c.rows() == n_points && c.cols() == dim)
        centre = c;
      else
        fail(path, cat("contact centres are ", c.rows(), " x ", c.cols(), ", expected ", dim, " x ",
                       n_points));
    }
    if (contact.area.size() && contact.area.size() != n_points)
      fail(path, cat("contact areas have ", contact.area.size(), " entries, expected ", n_points));
  }

  {
    Handle root = open_group(f, "/", path);
    for (const auto& [key, value] : info.attributes)
      write_string_attr(root.get(), key, value, path, "/");
    write_string_attr(root.get(), "name", info.name, path, "/");
    write_string_attr(root.get(), "config", info.config_text, path, "/");
    write_string_attr(root.get(), "config_path", info.config_path, path, "/");
    if (!info.config_resolved.empty())
      write_string_attr(root.get(), "config_resolved", info.config_resolved, path, "/");
    write_scalar_attr<int>(root.get(), "format_version", kFormatVersion, path, "/");
    write_string_attr(root.get(), "status", "running", path, "/");
  }
  {
    Handle g = create_group(f, "/mesh", path);
    write_string_attr(g.get(), "cell_type", cell_topology(dim, npc), path, "/mesh");
    write_string_attr(g.get(), "source", mesh.source, path, "/mesh");
  }
  const auto un = [](Eigen::Index n) { return static_cast<hsize_t>(n); };
  write_doubles(f, "/mesh/X", {un(nn), un(dim)}, rows_of(mesh.X), dim, path);
  write_ints(f, "/mesh/cells", {un(nc), un(npc)}, rows_of(mesh.cells), dim, path);
  // Cell volumes from the discretization (one definition of the shape functions, lib/fe).
  const Eigen::VectorXd volume =
      options.cell_volume.size() ? options.cell_volume : cell_volumes(mesh);
  if (volume.size() != nc)
    fail(path, cat("cell volumes have ", volume.size(), " entries, expected ", nc));
  write_doubles(f, "/mesh/cell_volume", {un(nc)}, vec(volume), dim, path);
  if (contact.facets) {
    const auto& F = contact.facets->facets;
    write_ints(f, "/mesh/contact_facets", {un(F.rows()), un(F.cols())}, rows_of(F), dim, path);
    if (!nodes.empty()) {
      write_ints(f, "/mesh/contact_nodes", {un(n_points)}, nodes, dim, path);
      // The facets in the numbering of the contact points: the contact grid of the XDMF files.
      // Several obstacles: each obstacle's facets in the numbering of its own points (a node of
      // two groups is one point of each).
      const bool several = contact.offset.size() > 2;
      const std::vector<int> po = several ? contact.offset : std::vector<int>{0, n_points};
      const std::vector<int> fo =
          several ? contact.facet_offset : std::vector<int>{0, static_cast<int>(F.rows())};
      if (fo.size() != po.size() || fo.back() != F.rows() || po.back() != n_points)
        fail(path, "contact offsets do not match the contact points and facets");
      std::vector<int> local(F.size(), -1), index(nn, -1);
      for (std::size_t o = 0; o + 1 < po.size(); ++o) {
        std::fill(index.begin(), index.end(), -1);
        for (int k = po[o]; k < po[o + 1]; ++k) {
          const int node = nodes[k];
          if (node < 0 || node >= nn) fail(path, cat("contact node ", node, " does not exist"));
          index[node] = k;
        }
        for (Eigen::Index i = fo[o]; i < fo[o + 1]; ++i)
          for (Eigen::Index j = 0; j < F.cols(); ++j) {
            local[i * F.cols() + j] = index[F(i, j)];
            if (local[i * F.cols() + j] < 0)
              fail(path, cat("node ", F(i, j), " of contact facet ", i, " is not a contact node"));
          }
      }
      write_ints(f, "/mesh/contact_topology", {un(F.rows()), un(F.cols())}, local, dim, path);
      if (contact.centre.size() == 0)  // the contact points' positions: the contact grid's geometry
        for (int k = 0; k < n_points; ++k) centre.row(k) = mesh.X.row(nodes[k]);
    }
    Handle set = checked(H5Dopen2(f, "/mesh/contact_facets", H5P_DEFAULT), H5Dclose, path,
                         "cannot open dataset /mesh/contact_facets");
    write_string_attr(set.get(), "boundary", contact.facets->name, path, "/mesh/contact_facets");
    if (centre.rows() == n_points && n_points > 0)
      write_doubles(f, "/mesh/contact_centre", {un(n_points), un(dim)}, rows_of(centre), dim, path);
    if (contact.area.size())
      write_doubles(f, "/mesh/contact_area", {un(n_points)}, vec(contact.area), dim, path);
    if (contact.offset.size() > 2) {  // several obstacles: the obstacle of each contact point
      std::vector<int> obstacle(n_points, 0);
      for (std::size_t o = 0; o + 1 < contact.offset.size(); ++o)
        for (int k = contact.offset[o]; k < contact.offset[o + 1] && k < n_points; ++k)
          obstacle[k] = static_cast<int>(o);
      write_ints(f, "/mesh/contact_obstacle", {un(n_points)}, obstacle, dim, path);
    }
  }
  create_group(f, "/steps", path);
  return {dim, nn, nc, n_points, contact.facets != nullptr};
}

void check_step(const StepData& step, const Sizes& n, const std::string& file) {
  if (!step.state) fail(file, cat("step ", step.p, ": no state to write"));
  if (step.p < 0 || step.p > 999999) fail(file, cat("step number ", step.p, " out of 0..999999"));
  const State& s = *step.state;
  const int dim = n.dim, nc = n.cells, n_points = n.points;
  auto expect = [&](const std::string& what, Eigen::Index rows, Eigen::Index cols, Eigen::Index r,
                    Eigen::Index c) {
    if (rows != r || cols != c)
      fail(file,
           cat("step ", step.p, ": ", what, " is ", rows, " x ", cols, ", expected ", r, " x ", c));
  };
  // u too may be on a rank's rows in the state (a ghost layer's), from the source then.
  if (!step.source) expect("u", s.u.rows(), s.u.cols(), n.nodes, dim);
  // E and lambda may both be empty for a problem without cell unknowns (the Signorini problem of
  // section 7), beta for a contact problem without adhesion intensity; they are then not written.
  // With a source they come from it (on a rank's rows in the state), checked when written.
  if (!step.source && (s.E.size() || s.lambda.size())) {
    expect("E", s.E.rows(), s.E.cols(), dim * nc, dim);
    expect("lambda", s.lambda.rows(), s.lambda.cols(), dim * nc, dim);
  }
  if (n.contact) {
    expect("e", s.e.rows(), s.e.cols(), n_points, dim);
    expect("lambda_c", s.lambda_c.rows(), s.lambda_c.cols(), n_points, dim);
    if (s.beta.size()) expect("beta", s.beta.size(), 1, n_points, 1);
  }
  for (const auto& [name, value] : step.fields) {
    const Field& f = field(name, file);
    if (f.source != Source::Derived || !per_step(f))
      fail(file, cat("step ", step.p, ": ", name, " is not a computed field of a step"));
    if (f.at == Location::Point && !n.contact)
      fail(file, cat("step ", step.p, ": ", name, " given without a contact surface"));
    if (name == "sigma33" && dim != 2)
      fail(file, cat("step ", step.p, ": sigma33 is for plane strain (2-D) only"));
    // Support fields: one row per Dirichlet condition, as many as given.
    const int count = n.count(f, value);
    const auto [r, c] = layout_size(f, count, dim);
    if (value.size()) expect(name, value.rows(), value.cols(), r, c);
  }
}

void write_step(hid_t f, const std::string& g, const StepData& step, bool converged, const Sizes& n,
                const std::string& file) {
  const int dim = n.dim;
  {
    Handle group = create_group(f, g, file);
    const StepReport* rep = step.report;
    write_scalar_attr<int>(group.get(), "p", step.p, file, g);
    write_scalar_attr<double>(group.get(), "t", step.t, file, g);
    write_scalar_attr<int>(group.get(), "iterations", rep ? rep->iterations : 0, file, g);
    // (algorithm.solver = "newton") the Newton iterations among them; 0 for ALG2 alone.
    write_scalar_attr<int>(group.get(), "newton_iterations", rep ? rep->newton_iterations : 0, file,
                           g);
    write_string_attr(group.get(), "status", rep ? rep->status : "", file, g);
    write_scalar_attr<int>(group.get(), "converged", rep && rep->converged ? 1 : 0, file, g);
    write_scalar_attr<int>(group.get(), "strain_failures", rep ? rep->strain_failures : 0, file, g);
    // The equilibrium measure of the stored iterate (lib/measures.hpp).
    write_scalar_attr<double>(group.get(), "force_residual", rep ? rep->force_residual : 0, file,
                              g);
    write_scalar_attr<double>(group.get(), "det_error", rep ? rep->det_error : 0, file, g);
    write_scalar_attr<double>(group.get(), "penetration", rep ? rep->penetration : 0, file, g);
    write_scalar_attr<double>(group.get(), "det_min",
                              rep ? rep->det_min : std::numeric_limits<double>::quiet_NaN(), file,
                              g);
    write_string_attr(group.get(), "units",
                      "t: s; force_residual: 1 (max nodal force residual / max nodal load); "
                      "det_error: 1 (max over cells of |det E + c_e - 1|, the incompressibility "
                      "as discretized); penetration: m (max over the contact surface's nodes); "
                      "det_min: 1 (min of det F over the quadrature points, > 0: no cell "
                      "inverted)",
                      file, g);
    if (!step.conditions.empty())
      write_string_attr(group.get(), "conditions", step.conditions, file, g);
    if (!converged) {
      write_scalar_attr<int>(group.get(), "unconverged", 1, file, g);
      write_string_attr(group.get(), "note",
                        "NOT A RESULT: the last iterate of a time step that did not converge, "
                        "kept with its iteration history to diagnose why",
                        file, g);
    }
  }
  const auto un = [](Eigen::Index k) { return static_cast<hsize_t>(k); };
  // The fields of the table: the state's and the computed ones given, each where it lives.
  // In 2-D, the ones shown by ParaView also as 3-vectors and 3x3 tensors (not for an unconverged
  // iterate): plane strain E33 = F33 = 1, sigma33 the true out-of-plane stress (0 when not
  // given), P33 = det E sigma33 (sigma = P F^T / det F).
  const bool padded = dim == 2 && converged;
  if (padded) create_group(f, g + "/xdmf", file);
  // One field open at a time (a source makes each when asked), read a block at a time; the
  // padding's E and sigma33 are opened beside the field whose padded copy needs them.
  for (const Field& row : kFields) {
    if (!per_step(row) || (row.at == Location::Point && !n.contact)) continue;
    OpenField v(step, row);
    if (v.empty()) continue;
    const int count = row.at == Location::Support ? static_cast<int>(v.rows()) : n.count(row.at);
    const auto [r, c] = layout_size(row, count, dim);
    if (v.rows() != r || v.cols() != c)
      fail(file, cat("step ", step.p, ": ", row.name, " is ", v.rows(), " x ", v.cols(),
                     ", expected ", r, " x ", c));
    write_field(f, g + "/" + row.name, row, v, count, dim, dim, file);
    if (!padded || row.xdmf == Pad33::None || shown_as_stored(row)) continue;
    std::function<void(int, int, std::vector<double>&)> fix;
    std::optional<OpenField> E, s33;
    Eigen::MatrixXd E_block, s33_block;
    if (row.shape == Shape::Tensor) {
      if (row.xdmf == Pad33::DetESigma33) E.emplace(step, field("E", file));
      if (row.xdmf == Pad33::Sigma33 || row.xdmf == Pad33::DetESigma33)
        s33.emplace(step, field("sigma33", file));
      fix = [&](int first, int n_block, std::vector<double>& data) {
        const bool has_E = E && !E->empty(), has_s33 = s33 && !s33->empty();
        if (has_E) E->read(2 * first, 2 * n_block, E_block);
        if (has_s33) s33->read(first, n_block, s33_block);
        for (int b = 0; b < n_block; ++b) {
          const double sigma33 = has_s33 ? s33_block(b, 0) : 0.0;
          const double detE = has_E ? E_block.block<2, 2>(2 * b, 0).determinant() : 1.0;
          data[9 * b + 8] = row.xdmf == Pad33::One           ? 1.0
                            : row.xdmf == Pad33::Sigma33     ? sigma33
                            : row.xdmf == Pad33::DetESigma33 ? detE * sigma33
                                                             : 0.0;
        }
      };
    }
    write_field(f, g + "/xdmf/" + row.name, row, v, count, dim, 3, file, fix);
  }
  if (!step.measures.empty() || step.in_contact.size()) {
    // The step's measures (lib/measures.hpp): scalar datasets with the unit and description
    // given by the measures module, and the contact set per contact point.
    const std::string mg = g + "/measures";
    create_group(f, mg, file);
    for (const StoredMeasure& m : step.measures) {
      const std::string path = mg + "/" + m.name;
      Handle space = checked(H5Screate(H5S_SCALAR), H5Sclose, file,
                             cat("cannot create the dataspace of dataset ", path));
      Handle set = checked(H5Dcreate2(f, path.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
                                      H5P_DEFAULT, H5P_DEFAULT),
                           H5Dclose, file, cat("cannot create dataset ", path));
      ok(H5Dwrite(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, &m.value), file,
         cat("cannot write dataset ", path));
      write_string_attr(set.get(), "unit", m.unit, file, path);
      write_string_attr(set.get(), "description", m.description, file, path);
    }
    if (step.in_contact.size()) {
      const std::vector<int> mask(step.in_contact.data(),
                                  step.in_contact.data() + step.in_contact.size());
      write_ints(f, mg + "/in_contact", {un(n.points)}, mask, dim, file);
    }
  }
  const std::size_t ni = step.report ? step.report->history.size() : 0;
  std::vector<double> h(8 * ni);
  for (std::size_t i = 0; i < ni; ++i) {
    const IterationRecord& r = step.report->history[i];
    const double row[8] = {static_cast<double>(r.n),
                           r.r_G,
                           r.r_B,
                           r.t_global,
                           r.t_strain,
                           r.t_contact,
                           r.t_update,
                           r.wall};
    std::copy(row, row + 8, h.begin() + 8 * i);
  }
  write_doubles(f, g + "/history", {un(ni), 8}, h, dim, file);
  Handle set = checked(H5Dopen2(f, (g + "/history").c_str(), H5P_DEFAULT), H5Dclose, file,
                       cat("cannot open dataset ", g, "/history"));
  write_string_attr(set.get(), "columns", "n r_G r_B t_global t_strain t_contact t_update wall",
                    file, g + "/history");
}

namespace {
/// The attributes p, t, iterations and the state of the step group g (a result or a checkpoint).
StoredStep read_step_group(hid_t f, const std::string& g, const std::string& path) {
  const Sizes n = sizes_of(f, path);
  StoredStep out;
  {
    Handle group = open_group(f, g, path);
    out.p = read_scalar_attr<int>(group.get(), "p", path, g);
    out.t = read_scalar_attr<double>(group.get(), "t", path, g);
    out.iterations = read_scalar_attr<int>(group.get(), "iterations", path, g);
  }
  if (g.substr(g.rfind('/') + 1) != step_name(out.p))
    fail(path, cat("group ", g, " has attribute p = ", out.p));
  if (exists(f, g + "/measures", path))
    for (const std::string& name : link_names(f, g + "/measures", path)) {
      const Array<double> a = read_array<double>(f, g + "/measures/" + name, path);
      if (a.dims.empty() && a.data.size() == 1) out.measures[name] = a.data[0];
    }
  // The state: the State rows of the field table, back in the solver's layouts.
  State& s = out.state;
  s.e = Eigen::MatrixXd::Zero(0, n.dim);
  s.lambda_c = Eigen::MatrixXd::Zero(0, n.dim);
  s.beta = Eigen::VectorXd::Zero(0);
  for (const Field& row : kFields) {
    if (row.source != Source::State || (row.at == Location::Point && !n.contact)) continue;
    const std::string full = g + "/" + row.name;
    const int count = n.count(row.at);
    const Array<double> a = read_array<double>(f, full, path);
    expect_shape(a, file_shape(row, count, n.dim), full, path);
    Eigen::MatrixXd v;
    if (row.shape == Shape::Scalar)
      v = Eigen::Map<const Eigen::VectorXd>(a.data.data(), count);
    else if (row.shape == Shape::Vector)
      v = from_rows(a.data, count, n.dim);
    else
      v = tensors_from(a.data, count, n.dim);
    set_state_field(s, row.name, v);
  }
  return out;
}
}  // namespace

std::optional<StoredStep> read_last_step(hid_t f, const std::string& path) {
  expect_results_file(f, path);
  const std::vector<std::string> names = step_names(f, path);
  if (names.empty()) return std::nullopt;
  return read_step_group(f, "/steps/" + names.back(), path);
}

std::optional<StoredStep> read_checkpoint(hid_t f, int p, const std::string& path) {
  expect_results_file(f, path);
  const std::string g = "/unconverged/" + step_name(p);
  if (!exists(f, g, path)) return std::nullopt;
  double factor = 1;
  {
    Handle group = open_group(f, g, path);
    if (open_scalar_attr(group.get(), "checkpoint", path, g).get() < 0 ||
        read_scalar_attr<int>(group.get(), "checkpoint", path, g) != 1)
      return std::nullopt;  // a diverged step's iterate: never continued from
    factor = read_scalar_attr<double>(group.get(), "load_factor", path, g);
  }
  StoredStep out = read_step_group(f, g, path);
  out.load_factor = factor;
  return out;
}

StoredMesh read_mesh(hid_t f, const std::string& path) {
  expect_results_file(f, path);
  const Sizes n = sizes_of(f, path);
  StoredMesh out;
  Mesh& m = out.mesh;
  m.dim = n.dim;
  m.source = path;
  m.X = from_rows(read_array<double>(f, "/mesh/X", path).data, n.nodes, n.dim);
  const Array<int> cells = read_array<int>(f, "/mesh/cells", path);
  const int npc = static_cast<int>(cells.dims[1]);
  m.cells.resize(n.cells, npc);
  for (int c = 0; c < n.cells; ++c)
    for (int a = 0; a < npc; ++a) m.cells(c, a) = cells.data[static_cast<std::size_t>(c) * npc + a];
  if (n.cells > 0 && (m.cells.minCoeff() < 0 || m.cells.maxCoeff() >= n.nodes))
    fail(path, "bad mesh: /mesh/cells refers to nodes that do not exist");
  if (n.contact && exists(f, "/mesh/contact_centre", path)) {
    const Array<double> c = read_array<double>(f, "/mesh/contact_centre", path);
    expect_shape(c, {static_cast<hsize_t>(n.points), static_cast<hsize_t>(n.dim)},
                 "/mesh/contact_centre", path);
    out.contact_centre = from_rows(c.data, n.points, n.dim);
  }
  if (n.contact && exists(f, "/mesh/contact_obstacle", path)) {
    const Array<int> k = read_array<int>(f, "/mesh/contact_obstacle", path);
    expect_shape(k, {static_cast<hsize_t>(n.points)}, "/mesh/contact_obstacle", path);
    out.contact_obstacle = Eigen::Map<const Eigen::VectorXi>(k.data.data(), n.points);
  }
  return out;
}

}  // namespace ltl::layout
