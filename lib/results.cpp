// Results files: the layers (results.hpp) put together. A change is made to the file in memory
// (lib/results_commit.hpp), laid out by lib/results_layout.hpp, committed, and the XDMF files
// rewritten from it.
#include "results.hpp"

#include <utility>

#include "error.hpp"
#include "results_commit.hpp"
#include "results_layout.hpp"

namespace ltl {

using namespace h5;

namespace {
/// Opens the file for a change, dropping a /steps/incomplete left by an older writer.
hid_t begin_change(CommittedFile& file, const std::string& path) {
  const hid_t f = file.begin();
  if (exists(f, "/steps/incomplete", path))
    ok(H5Ldelete(f, "/steps/incomplete", H5P_DEFAULT), path, "cannot delete /steps/incomplete");
  return f;
}

void write_status(hid_t f, const std::string& status, const std::string& path) {
  Handle root = open_group(f, "/", path);
  write_string_attr(root.get(), "status", status, path, "/");
}
}  // namespace

const Eigen::MatrixXd* FieldSource::whole(const std::string& name, Eigen::MatrixXd& buffer) {
  const auto [rows, cols] = open(name);
  if (rows * cols == 0) {
    close(name);
    return nullptr;
  }
  read(name, 0, rows, buffer);
  close(name);
  return &buffer;
}

ResultsFile::ResultsFile(ResultsFile&&) noexcept = default;
ResultsFile& ResultsFile::operator=(ResultsFile&&) noexcept = default;
ResultsFile::~ResultsFile() = default;

ResultsFile ResultsFile::create(const std::string& path, const Mesh& mesh, const RunInfo& info,
                                const ResultsOptions& options) {
  ResultsFile r;
  r.path_ = path;
  r.file_ = std::make_unique<CommittedFile>(path);
  const layout::Sizes n = layout::write_mesh(r.file_->create(), mesh, info, options, path);
  r.dim_ = n.dim;
  r.num_nodes_ = n.nodes;
  r.num_cells_ = n.cells;
  r.num_points_ = n.points;
  r.contact_ = n.contact;
  if (options.commit) r.commit();
  return r;
}

ResultsFile ResultsFile::open(const std::string& path) {
  ResultsFile r;
  r.path_ = path;
  r.file_ = std::make_unique<CommittedFile>(path);
  bool incomplete = false;
  {
    Handle f = open_committed(path);  // clear errors for missing / non-HDF5 files
    layout::expect_results_file(f.get(), path);
    const layout::Sizes n = layout::sizes_of(f.get(), path);
    r.dim_ = n.dim;
    r.num_nodes_ = n.nodes;
    r.num_cells_ = n.cells;
    r.num_points_ = n.points;
    r.contact_ = n.contact;
    // Left by a process killed while writing a step (before files were written atomically).
    incomplete = exists(f.get(), "/steps/incomplete", path);
  }
  if (incomplete) {
    begin_change(*r.file_, path);
    r.commit();
  }
  return r;
}

void ResultsFile::commit() {
  // The XDMF texts are made from the file in memory, and written once it is on disk.
  const hid_t f = file_->id();
  const std::string xdmf = xdmf_text(f, path_, false);
  const std::string contact_xdmf = contact_ ? xdmf_text(f, path_, true) : "";
  file_->commit();
  write_appending(xdmf_path_of(path_), xdmf, xdmf_);
  if (!contact_xdmf.empty())
    write_appending(contact_xdmf_path_of(path_), contact_xdmf, contact_xdmf_);
}

void ResultsFile::append(const StepData& step, const std::string& status) {
  if (!file_) fail(path_, "append to a closed results file");
  const layout::Sizes n{dim_, num_nodes_, num_cells_, num_points_, contact_};
  layout::check_step(step, n, path_);
  const std::string name = layout::step_name(step.p), g = "/steps/" + name;
  const hid_t f = begin_change(*file_, path_);
  if (exists(f, g, path_)) {
    file_->discard();
    fail(path_, cat("step ", step.p, " is already stored (", g, ")"));
  }
  // Written under a temporary name and renamed when complete.
  const std::string tmp = "/steps/incomplete";
  layout::write_step(f, tmp, step, true, n, path_);
  ok(H5Lmove(f, tmp.c_str(), f, g.c_str(), H5P_DEFAULT, H5P_DEFAULT), path_,
     cat("cannot rename ", tmp, " to ", g));
  // An unconverged iterate of this step saved by an earlier run is superseded by the result.
  const std::string stale = "/unconverged/" + name;
  if (exists(f, stale, path_))
    ok(H5Ldelete(f, stale.c_str(), H5P_DEFAULT), path_, cat("cannot delete ", stale));
  if (!status.empty()) write_status(f, status, path_);
  commit();
}

void ResultsFile::save_unconverged(const StepData& step, const std::string& status) {
  save_iterate(step, status, nullptr);
}

void ResultsFile::save_checkpoint(const StepData& step, double load_factor,
                                  const std::string& status) {
  save_iterate(step, status, &load_factor);
}

void ResultsFile::save_iterate(const StepData& step, const std::string& status,
                               const double* checkpoint_factor) {
  if (!file_) fail(path_, "saving an iterate to a closed results file");
  const layout::Sizes n{dim_, num_nodes_, num_cells_, num_points_, contact_};
  layout::check_step(step, n, path_);
  const std::string g = "/unconverged/" + layout::step_name(step.p);
  const hid_t f = begin_change(*file_, path_);
  if (!exists(f, "/unconverged", path_)) {
    Handle group = create_group(f, "/unconverged", path_);
    write_string_attr(group.get(), "note",
                      "NOT RESULTS: the last iterate and iteration history of time steps that "
                      "did not converge (one group per step, named like /steps), for diagnosis; "
                      "readers of results use /steps only",
                      path_, "/unconverged");
  }
  if (exists(f, g, path_))
    ok(H5Ldelete(f, g.c_str(), H5P_DEFAULT), path_, cat("cannot replace ", g));
  layout::write_step(f, g, step, false, n, path_);
  if (checkpoint_factor) {
    Handle group = open_group(f, g, path_);
    write_scalar_attr<int>(group.get(), "checkpoint", 1, path_, g);
    write_scalar_attr<double>(group.get(), "load_factor", *checkpoint_factor, path_, g);
    write_string_attr(group.get(), "note",
                      "NOT A RESULT: the iterate of a time step still iterating when it was saved "
                      "(a checkpoint, ltl_run --checkpoint); --resume continues the step from it",
                      path_, g);
  }
  if (!status.empty()) write_status(f, status, path_);
  commit();
}

void ResultsFile::set_status(const std::string& status) {
  if (!file_) fail(path_, "set_status on a closed results file");
  write_status(begin_change(*file_, path_), status, path_);
  commit();
}

std::optional<StoredStep> ResultsFile::read_last_step(const std::string& path) {
  Handle f = open_committed(path);
  return layout::read_last_step(f.get(), path);
}

std::optional<StoredStep> ResultsFile::read_checkpoint(const std::string& path, int p) {
  Handle f = open_committed(path);
  return layout::read_checkpoint(f.get(), p, path);
}

StoredMesh ResultsFile::read_mesh(const std::string& path) {
  Handle f = open_committed(path);
  return layout::read_mesh(f.get(), path);
}

std::string ResultsFile::read_attribute(const std::string& path, const std::string& name) {
  Handle f = open_committed(path);
  Handle root = open_group(f.get(), "/", path);
  return read_string_attr(root.get(), name, path, "/").value_or("");
}

ContactOutput contact_output(const Mesh& mesh, const std::vector<std::string>& groups,
                             const ContactPoints* points, Mesh::Boundary& storage) {
  ContactOutput out;
  if (groups.empty()) return out;
  if (groups.size() == 1) {
    out.facets = &mesh.boundary(groups.front());
  } else {  // the facets of every obstacle's group, one after the other
    storage.name.clear();
    out.facet_offset = {0};
    Eigen::Index rows = 0;
    for (const std::string& g : groups) rows += mesh.boundary(g).facets.rows();
    storage.facets.resize(rows, mesh.nodes_per_facet());
    for (const std::string& g : groups) {
      const Eigen::MatrixXi& F = mesh.boundary(g).facets;
      storage.facets.middleRows(out.facet_offset.back(), F.rows()) = F;
      out.facet_offset.push_back(out.facet_offset.back() + static_cast<int>(F.rows()));
      storage.name += (storage.name.empty() ? "" : ",") + g;
    }
    out.facets = &storage;
  }
  if (points) {
    out.centre = points->centre;
    out.area = points->area;
    out.nodes = points->nodes;
    if (groups.size() > 1) out.offset = points->offset;
  }
  return out;
}

}  // namespace ltl
