// Results in HDF5 through the HDF5 C API, with an XDMF file beside it for ParaView.
// See results.hpp for the file layout. Every HDF5 call is checked; HDF5's own error stack printing
// is switched off and failures become ltl::Error naming the file and the object.
#include "results.hpp"

#include <cholmod.h>
#include <fcntl.h>
#include <gmsh.h>
#include <hdf5.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <type_traits>
#include <utility>
#include <vector>

#include "error.hpp"
#include "fe.hpp"

namespace ltl {
namespace {

// ---------------------------------------------------------------------------------------------
// HDF5 plumbing

void quiet_hdf5() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

using CloseFn = herr_t (*)(hid_t);

/// Owns an HDF5 identifier and closes it.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, CloseFn close) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(std::exchange(o.id_, -1)), close_(o.close_) {}
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, -1);
      close_ = o.close_;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  void reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = -1;
  }
  hid_t get() const { return id_; }

 private:
  hid_t id_ = -1;
  CloseFn close_ = nullptr;
};

[[noreturn]] void fail(const std::string& file, const std::string& what) {
  throw Error(cat(file, ": ", what));
}

// Test hook for the kill test: LTL_FAULT_AT_WRITE=k kills the process (SIGKILL, no cleanup) at
// the k-th write event (each dataset written, and each stage of a commit: before the flush,
// before the rename, after the rename).
void fault_point() {
  static const long at = [] {
    const char* v = std::getenv("LTL_FAULT_AT_WRITE");
    return v ? std::atol(v) : 0L;
  }();
  static long count = 0;
  if (at > 0 && ++count == at) {
    std::fflush(nullptr);
    raise(SIGKILL);
  }
}

// errno as text, with ENOSPC spelled out.
std::string errno_text(int e) {
  return e == ENOSPC ? "no space left on the device (ENOSPC)" : std::strerror(e);
}

/// Forces `path` (a file or a directory) to the disk.
void sync_path(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) fail(path, cat("cannot open to sync: ", errno_text(errno)));
  const int rc = ::fsync(fd);
  const int e = errno;
  ::close(fd);
  if (rc != 0 && !directory) fail(path, cat("cannot sync to disk: ", errno_text(e)));
}

Handle checked(hid_t id, CloseFn close, const std::string& file, const std::string& what) {
  if (id < 0) fail(file, what);
  return Handle(id, close);
}

void ok(herr_t status, const std::string& file, const std::string& what) {
  if (status < 0) fail(file, what);
}

/// File access in memory (HDF5's core driver, no backing store): the working copy of the results
/// file is an image in memory, which commit() writes with checked write(2) calls. HDF5 1.10 writing
/// to disk itself reports a full disk late or not at all (a dataset's sieve buffer flushed in
/// H5Dclose), and a failed H5Fclose leaves a freed file behind that crashes the program at exit
/// (H5F__close_cb in H5_term_library); in memory neither can happen.
Handle memory_access(const std::string& file) {
  Handle fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "cannot create an access list");
  ok(H5Pset_fapl_core(fapl.get(), 1 << 20, false), file, "cannot select HDF5's core driver");
  return fapl;
}

/// Creates `path` afresh for writing: a name this code owns beside the results file (the
/// `.partial` working file, an XDMF file's `.tmp`), written only while the writer holds the lock,
/// so whatever is there is stale and is removed first. unlink(2) removes a symbolic link or a
/// hard link without touching what it points to, and the file is then created with
/// O_CREAT | O_EXCL | O_NOFOLLOW: a link made there meanwhile is an error, never followed. With
/// `mode` >= 0 the file gets exactly that mode (the permissions of the file it will replace).
int create_fresh(const std::string& path, int mode, const std::string& file) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode))
      fail(file, cat("cannot create the working file ", path, ": a directory is in the way"));
    if (::unlink(path.c_str()) != 0)
      fail(file, cat("cannot remove the stale working file ", path, ": ", errno_text(errno)));
  }
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0)
    fail(file, cat("cannot create the working file ", path, ": ",
                   errno == EEXIST ? std::string("another process created it meanwhile")
                                   : errno_text(errno)));
  if (mode >= 0 && ::fchmod(fd, static_cast<mode_t>(mode)) != 0) {
    const int e = errno;
    ::close(fd);
    ::unlink(path.c_str());
    fail(file, cat("cannot set the mode of ", path, ": ", errno_text(e)));
  }
  return fd;
}

/// The permission bits of the regular file at `path`, or -1 (no file).
int mode_of(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return -1;
  return static_cast<int>(st.st_mode & 07777);
}

/// Writes `image` to `work` (created afresh, create_fresh) and forces it to the disk; a failure
/// (ENOSPC) removes `work` and names `file`. `work` gets the mode of `file` when it exists. The
/// fault point in the middle is the kill test's "inside the flush".
void write_image(const std::string& work, const std::vector<char>& image, const std::string& file) {
  const int fd = create_fresh(work, mode_of(file), file);
  const auto failed = [&](const char* what) {
    const int e = errno;
    ::close(fd);
    ::unlink(work.c_str());
    fail(file, cat(what, work, ": ", errno_text(e)));
  };
  const std::size_t half = image.size() / 2;
  for (std::size_t done = 0; done < image.size();) {
    const std::size_t end = done < half ? half : image.size();
    const ssize_t n = ::write(fd, image.data() + done, end - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) failed("cannot write the file: ");
    done += static_cast<std::size_t>(n);
    if (done == half) fault_point();
  }
  if (::fsync(fd) != 0) failed("cannot sync to disk: ");
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(work.c_str());
    fail(file, cat("cannot close ", work, ": ", errno_text(e)));
  }
}

/// The bytes of the regular file `path` (opened without following a symbolic link).
std::vector<char> read_image(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) fail(path, cat("cannot open the results file: ", errno_text(errno)));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    fail(path, "is not a regular file");
  }
  std::vector<char> image(static_cast<std::size_t>(st.st_size));
  for (std::size_t done = 0; done < image.size();) {
    const ssize_t n = ::read(fd, image.data() + done, image.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = n < 0 ? errno : 0;
      ::close(fd);
      fail(path, cat("cannot read the results file: ", e ? errno_text(e) : "it shrank"));
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return image;
}

/// Whether the object at absolute `path` ("/a/b/c") exists (every component is checked, as
/// H5Lexists requires).
bool exists(hid_t file_id, const std::string& path, const std::string& file) {
  std::string prefix;
  std::size_t start = 1;
  while (start <= path.size()) {
    std::size_t end = path.find('/', start);
    if (end == std::string::npos) end = path.size();
    prefix = path.substr(0, end);
    const htri_t e = H5Lexists(file_id, prefix.c_str(), H5P_DEFAULT);
    if (e < 0) fail(file, cat("cannot look up ", prefix));
    if (e == 0) return false;
    start = end + 1;
  }
  return true;
}

Handle open_group(hid_t file_id, const std::string& path, const std::string& file) {
  return checked(H5Gopen2(file_id, path.c_str(), H5P_DEFAULT), H5Gclose, file,
                 cat("cannot open group ", path));
}

Handle create_group(hid_t file_id, const std::string& path, const std::string& file) {
  return checked(H5Gcreate2(file_id, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                 file, cat("cannot create group ", path));
}

std::string shape_text(const std::vector<hsize_t>& dims) {
  std::ostringstream s;
  s << '(';
  for (std::size_t i = 0; i < dims.size(); ++i) s << (i ? ", " : "") << dims[i];
  s << (dims.size() == 1 ? ",)" : ")");
  return s.str();
}

/// Writes a dataset `path` (absolute) of the given shape from row-major `data`.
void write_array(hid_t file_id, const std::string& path, hid_t mem_type, hid_t file_type,
                 const std::vector<hsize_t>& dims, const void* data, const std::string& file) {
  Handle space = checked(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr),
                         H5Sclose, file, cat("cannot create the dataspace of dataset ", path));
  Handle set = checked(H5Dcreate2(file_id, path.c_str(), file_type, space.get(), H5P_DEFAULT,
                                  H5P_DEFAULT, H5P_DEFAULT),
                       H5Dclose, file, cat("cannot create dataset ", path));
  hsize_t total = 1;
  for (hsize_t d : dims) total *= d;
  errno = 0;
  if (total > 0 && H5Dwrite(set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(file, cat("cannot write dataset ", path, errno ? ": " + errno_text(errno) : ""));
  fault_point();
}

/// A dense array read from a dataset (row-major) with its shape.
template <class T>
struct Array {
  std::vector<hsize_t> dims;
  std::vector<T> data;
};

/// Reads dataset `path` converting to T (double or int); a clear Error if it is missing or is not
/// numeric.
template <class T>
Array<T> read_array(hid_t file_id, const std::string& path, const std::string& file) {
  if (!exists(file_id, path, file)) fail(file, cat("missing dataset ", path));
  Handle set = checked(H5Dopen2(file_id, path.c_str(), H5P_DEFAULT), H5Dclose, file,
                       cat("cannot open dataset ", path));
  Handle type = checked(H5Dget_type(set.get()), H5Tclose, file, cat("bad type of ", path));
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) fail(file, cat("dataset ", path, " is not numeric"));
  Handle space = checked(H5Dget_space(set.get()), H5Sclose, file, cat("bad dataspace of ", path));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail(file, cat("bad dataspace of ", path));
  Array<T> a;
  a.dims.resize(rank);
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), a.dims.data(), nullptr) < 0)
    fail(file, cat("bad dataspace of ", path));
  hsize_t total = 1;
  for (hsize_t d : a.dims) total *= d;
  a.data.resize(total);
  const hid_t mem = std::is_same_v<T, int> ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  if (total > 0)
    ok(H5Dread(set.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.data.data()), file,
       cat("cannot read dataset ", path));
  return a;
}

template <class T>
void expect_shape(const Array<T>& a, const std::vector<hsize_t>& dims, const std::string& path,
                  const std::string& file) {
  if (a.dims != dims)
    fail(file,
         cat("dataset ", path, " has shape ", shape_text(a.dims), ", expected ", shape_text(dims)));
}

/// The shape of dataset `path` (which must exist).
std::vector<hsize_t> dataset_shape(hid_t file_id, const std::string& path,
                                   const std::string& file) {
  Handle set = checked(H5Dopen2(file_id, path.c_str(), H5P_DEFAULT), H5Dclose, file,
                       cat("cannot open dataset ", path));
  Handle space = checked(H5Dget_space(set.get()), H5Sclose, file, cat("bad dataspace of ", path));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail(file, cat("bad dataspace of ", path));
  std::vector<hsize_t> dims(rank);
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
    fail(file, cat("bad dataspace of ", path));
  return dims;
}

void delete_attribute_if_any(hid_t obj, const std::string& name, const std::string& file,
                             const std::string& where) {
  const htri_t e = H5Aexists(obj, name.c_str());
  if (e < 0) fail(file, cat("cannot look up attribute ", name, " of ", where));
  if (e > 0)
    ok(H5Adelete(obj, name.c_str()), file, cat("cannot replace attribute ", name, " of ", where));
}

/// Writes (or replaces) a variable-length UTF-8 string attribute.
void write_string_attr(hid_t obj, const std::string& name, const std::string& value,
                       const std::string& file, const std::string& where) {
  const std::string what = cat("cannot write attribute ", name, " of ", where);
  Handle type = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, what);
  ok(H5Tset_size(type.get(), H5T_VARIABLE), file, what);
  ok(H5Tset_cset(type.get(), H5T_CSET_UTF8), file, what);
  delete_attribute_if_any(obj, name, file, where);
  Handle space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, what);
  Handle attr =
      checked(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
              H5Aclose, file, what);
  const char* s = value.c_str();
  ok(H5Awrite(attr.get(), type.get(), &s), file, what);
}

template <class T>
void write_scalar_attr(hid_t obj, const std::string& name, T value, const std::string& file,
                       const std::string& where) {
  const std::string what = cat("cannot write attribute ", name, " of ", where);
  const hid_t mem = std::is_same_v<T, int> ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  const hid_t ftype = std::is_same_v<T, int> ? H5T_STD_I32LE : H5T_IEEE_F64LE;
  delete_attribute_if_any(obj, name, file, where);
  Handle space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, what);
  Handle attr = checked(H5Acreate2(obj, name.c_str(), ftype, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                        H5Aclose, file, what);
  ok(H5Awrite(attr.get(), mem, &value), file, what);
}

/// The unit and description of a dataset of the layout, by its path (/mesh/X, /steps/N/u,
/// /steps/N/xdmf/u, /unconverged/N/u, ...); every dataset written gets both as string
/// attributes "unit" and "description". Unknown names are an Error (nothing is written without
/// them).
std::pair<std::string, std::string> dataset_meta(const std::string& path, int dim,
                                                 const std::string& file) {
  struct Meta {
    const char *unit_2d, *unit_3d, *text;
  };
  static const std::map<std::string, Meta> table = {
      {"X", {"m", "m", "reference positions of the nodes (#nodes, dim)"}},
      {"cells", {"1", "1", "node indices of each cell, gmsh order (= XDMF order)"}},
      {"cell_volume",
       {"m^2", "m^3",
        "reference volume of each cell (plane strain: area, per metre of depth), from the "
        "discretization's cell operators (lib/fe: CellOperators::vol)"}},
      {"contact_facets", {"1", "1", "node indices of each facet of the contact surface"}},
      {"contact_nodes", {"1", "1", "mesh node of each contact point (nodal contact)"}},
      {"contact_centre", {"m", "m", "reference position of each contact point (#points, dim)"}},
      {"contact_area",
       {"m", "m^2",
        "weight of each contact point: facet measure, or integral of the node's shape function "
        "over the contact surface (plane strain: per metre of depth)"}},
      {"contact_topology",
       {"1", "1",
        "the contact facets as indices into the contact points (nodal contact): the topology of "
        "the contact-surface XDMF grid"}},
      {"u", {"m", "m", "displacement of the nodes (#nodes, dim)"}},
      {"E", {"1", "1", "strain E of each cell (the paper's F, (2.7)); [c][i][j] = E_c(i, j)"}},
      {"lambda",
       {"Pa", "Pa", "multiplier of I + grad u = E of each cell (a first Piola-Kirchhoff stress)"}},
      {"P", {"Pa", "Pa", "first Piola-Kirchhoff stress of each cell, P = 2 C1 E - lambda"}},
      {"sigma", {"Pa", "Pa", "Cauchy stress of each cell, sigma = P E^T / det E"}},
      {"sigma33",
       {"Pa", "Pa",
        "plane strain: out-of-plane Cauchy stress of each cell, from the law with F33 = 1 and "
        "the pressure (Material::plane_strain_sigma33, (1.5))"}},
      {"pressure",
       {"Pa", "Pa", "mean stress of each cell, -trace(sigma) / 3 (with sigma33 in plane strain)"}},
      {"beta", {"1", "1", "adhesion intensity of each contact point, in [0, 1]"}},
      {"e", {"m", "m", "contact displacement of each contact point (the paper's h)"}},
      {"lambda_c",
       {"Pa", "Pa",
        "multiplier of u = e at each contact point: a traction per reference area (#points, "
        "dim)"}},
      {"contact_pressure",
       {"Pa", "Pa", "contact pressure of each contact point, -lambda_c . N (> 0: pressed)"}},
      {"gap", {"m", "m", "gap of each contact point to the obstacle plane, g - e . N"}},
      {"reactions",
       {"N/m", "N",
        "force each Dirichlet condition's support exerts on the body (#conditions, dim; plane "
        "strain: per metre of depth), in the order of the step's attribute `conditions` "
        "(lib/reactions.hpp)"}},
      {"support_u",
       {"m", "m", "mean displacement of the nodes of each Dirichlet condition (#conditions, dim)"}},
      {"in_contact",
       {"1", "1",
        "1 at the contact points in the contact set, p > kContactThreshold * max p "
        "(lib/measures.hpp), else 0"}},
      {"history",
       {"1 1 1 s s s s s", "1 1 1 s s s s s",
        "one row per iteration: n, r_G, r_B (scaled residuals, (3.3)), seconds in the global, "
        "strain, contact and update phases, wall seconds since the step began"}},
  };
  const std::string name = path.substr(path.rfind('/') + 1);
  const auto it = table.find(name);
  if (it == table.end()) fail(file, cat("internal: no unit and description for dataset ", path));
  const Meta& m = it->second;
  const bool xdmf = path.find("/xdmf/") != std::string::npos;
  return {dim == 2 ? m.unit_2d : m.unit_3d,
          (xdmf ? "ParaView copy (3 components, 3x3 tensors): " : "") + std::string(m.text)};
}

/// Writes a dataset with its "unit" and "description" attributes (dataset_meta).
void write_described(hid_t f, const std::string& path, hid_t mem_type, hid_t file_type,
                     const std::vector<hsize_t>& dims, const void* data, int dim,
                     const std::string& file) {
  const auto [unit, text] = dataset_meta(path, dim, file);
  write_array(f, path, mem_type, file_type, dims, data, file);
  Handle set = checked(H5Dopen2(f, path.c_str(), H5P_DEFAULT), H5Dclose, file,
                       cat("cannot open dataset ", path));
  write_string_attr(set.get(), "unit", unit, file, path);
  write_string_attr(set.get(), "description", text, file, path);
}

void write_doubles(hid_t f, const std::string& path, const std::vector<hsize_t>& dims,
                   const std::vector<double>& data, int dim, const std::string& file) {
  write_described(f, path, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, dims, data.data(), dim, file);
}

void write_ints(hid_t f, const std::string& path, const std::vector<hsize_t>& dims,
                const std::vector<int>& data, int dim, const std::string& file) {
  write_described(f, path, H5T_NATIVE_INT, H5T_STD_I32LE, dims, data.data(), dim, file);
}

/// Opens attribute `name` of `obj` checking it holds one value; an empty Handle if absent.
Handle open_scalar_attr(hid_t obj, const std::string& name, const std::string& file,
                        const std::string& where) {
  const htri_t e = H5Aexists(obj, name.c_str());
  if (e < 0) fail(file, cat("cannot look up attribute ", name, " of ", where));
  if (e == 0) return Handle();
  Handle attr = checked(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose, file,
                        cat("cannot open attribute ", name, " of ", where));
  Handle space =
      checked(H5Aget_space(attr.get()), H5Sclose, file, cat("bad attribute ", name, " of ", where));
  if (H5Sget_simple_extent_npoints(space.get()) != 1)
    fail(file, cat("attribute ", name, " of ", where, " is not a single value"));
  return attr;
}

/// A string attribute (fixed or variable length); nullopt if absent.
std::optional<std::string> read_string_attr(hid_t obj, const std::string& name,
                                            const std::string& file, const std::string& where) {
  Handle attr = open_scalar_attr(obj, name, file, where);
  if (attr.get() < 0) return std::nullopt;
  const std::string what = cat("cannot read attribute ", name, " of ", where);
  Handle ftype = checked(H5Aget_type(attr.get()), H5Tclose, file, what);
  if (H5Tget_class(ftype.get()) != H5T_STRING)
    fail(file, cat("attribute ", name, " of ", where, " is not a string"));
  const htri_t variable = H5Tis_variable_str(ftype.get());
  if (variable < 0) fail(file, what);
  if (variable > 0) {
    Handle mtype = checked(H5Tcopy(H5T_C_S1), H5Tclose, file, what);
    ok(H5Tset_size(mtype.get(), H5T_VARIABLE), file, what);
    ok(H5Tset_cset(mtype.get(), H5Tget_cset(ftype.get())), file, what);
    char* s = nullptr;
    ok(H5Aread(attr.get(), mtype.get(), &s), file, what);
    std::string out = s ? s : "";
    H5free_memory(s);
    return out;
  }
  const std::size_t n = H5Tget_size(ftype.get());
  if (n == 0) fail(file, what);
  std::vector<char> buf(n, '\0');
  ok(H5Aread(attr.get(), ftype.get(), buf.data()), file, what);
  std::string out(buf.data(), strnlen(buf.data(), n));
  while (!out.empty() && out.back() == ' ') out.pop_back();  // space-padded strings
  return out;
}

template <class T>
T read_scalar_attr(hid_t obj, const std::string& name, const std::string& file,
                   const std::string& where) {
  Handle attr = open_scalar_attr(obj, name, file, where);
  if (attr.get() < 0) fail(file, cat("missing attribute ", name, " of ", where));
  T value{};
  const hid_t mem = std::is_same_v<T, int> ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  ok(H5Aread(attr.get(), mem, &value), file, cat("cannot read attribute ", name, " of ", where));
  return value;
}

/// Opens an existing file read-only, with clear errors for a missing or non-HDF5 file. When
/// another process is writing the file (and holds its lock), the file is opened without locking,
/// so that a running simulation can be inspected.
Handle open_for_reading(const std::string& path) {
  quiet_hdf5();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, "no such file");
  if (std::filesystem::is_directory(path, ec)) fail(path, "is a directory, not a results file");
  const htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
  if (is_hdf5 <= 0) fail(path, "not an HDF5 file (or not readable)");
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    Handle fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, path, "cannot open the file");
#if (H5_VERS_MAJOR == 1 && H5_VERS_MINOR == 10 && H5_VERS_RELEASE >= 7) || H5_VERSION_GE(1, 12, 1)
    ok(H5Pset_file_locking(fapl.get(), false, true), path, "cannot open the file");
#endif
    f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get());
  }
  return checked(f, H5Fclose, path, "cannot open the file (damaged HDF5 file?)");
}

/// Checks that the file holds /mesh/X, /mesh/cells and /steps.
void expect_results_file(hid_t f, const std::string& file) {
  for (const char* p : {"/mesh/X", "/mesh/cells", "/steps"})
    if (!exists(f, p, file)) fail(file, cat("not a results file of this code (no ", p, ")"));
}

bool is_step_name(const std::string& name) {
  if (name.size() != 6) return false;
  for (char c : name)
    if (c < '0' || c > '9') return false;
  return true;
}

std::string step_name(int p) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", p);
  return buf;
}

/// Names of the complete steps in /steps, in increasing p.
std::vector<std::string> step_names(hid_t f, const std::string& file) {
  Handle g = open_group(f, "/steps", file);
  H5G_info_t info;
  ok(H5Gget_info(g.get(), &info), file, "cannot read group /steps");
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t n =
        H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (n < 0) fail(file, "cannot list group /steps");
    std::string name(static_cast<std::size_t>(n) + 1, '\0');
    if (H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(),
                           H5P_DEFAULT) < 0)
      fail(file, "cannot list group /steps");
    name.resize(static_cast<std::size_t>(n));
    if (is_step_name(name)) names.push_back(name);
  }
  return names;  // zero-padded: name order is p order
}

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

/// dim x #facets -> (#facets, dim).
std::vector<double> columns_of(const Eigen::MatrixXd& m) {
  return rows_of(Eigen::MatrixXd(m.transpose()));
}

Eigen::MatrixXd columns_from(const std::vector<double>& a, int n, int dim) {
  return from_rows(a, n, dim).transpose();
}

std::vector<double> vec(const Eigen::VectorXd& v) {
  return {v.data(), v.data() + v.size()};
}

// ---------------------------------------------------------------------------------------------
// Cells

const char* topology(int dim, int nodes_per_cell) {
  if (dim == 2 && nodes_per_cell == 6) return "Triangle_6";
  if (dim == 3 && nodes_per_cell == 8) return "Hexahedron";
  if (dim == 3 && nodes_per_cell == 10) return "Tetrahedron_10";  // VTK order, as Mesh::cells
  return nullptr;
}

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// Shortest of %.15g, %.16g, %.17g that reads back as x.
std::string number(double x) {
  char buf[40];
  for (int precision : {15, 16, 17}) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

/// The comment that opens every XDMF file this code writes for the results file `path`: how
/// is_xdmf_of() recognizes its own files.
std::string xdmf_marker(const std::string& path) {
  return "<!-- Written by ltl::ResultsFile: the time steps of " +
         xml_escape(std::filesystem::path(path).filename().string());
}

std::string work_path_of(const std::string& path) {
  return path + ".partial";
}

}  // namespace

std::string xdmf_path_of(const std::string& path, const std::string& suffix) {
  const std::string ext = ".h5";
  if (path.size() > ext.size() && path.compare(path.size() - ext.size(), ext.size(), ext) == 0)
    return path.substr(0, path.size() - ext.size()) + suffix + ".xdmf";
  return path + suffix + ".xdmf";
}

std::string contact_xdmf_path_of(const std::string& path) {
  return xdmf_path_of(path, "_contact");
}

bool is_xdmf_of(const std::string& xdmf, const std::string& path) {
  const int fd = ::open(xdmf.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st {};
  std::string head(512, '\0');
  ssize_t n = -1;
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode)) n = ::read(fd, head.data(), head.size());
  ::close(fd);
  if (n <= 0) return false;
  head.resize(static_cast<std::size_t>(n));
  const std::string first = "<?xml version=\"1.0\"?>\n" + xdmf_marker(path) + " for ParaView";
  return head.compare(0, first.size(), first) == 0;
}

// ---------------------------------------------------------------------------------------------

namespace {
/// Number of contact points of a file: its contact nodes (nodal contact) or its contact facets.
int contact_points(hid_t f, const std::string& path) {
  if (exists(f, "/mesh/contact_nodes", path)) {
    const auto n = dataset_shape(f, "/mesh/contact_nodes", path);
    if (n.size() != 1) fail(path, "dataset /mesh/contact_nodes is not a vector");
    return static_cast<int>(n[0]);
  }
  const auto F = dataset_shape(f, "/mesh/contact_facets", path);
  if (F.size() != 2) fail(path, "dataset /mesh/contact_facets is not a matrix");
  return static_cast<int>(F[0]);
}
}  // namespace

ResultsFile ResultsFile::create(const std::string& path, const Mesh& mesh, const RunInfo& info,
                                const Mesh::Boundary* contact_facets,
                                const Eigen::MatrixXd* contact_centre,
                                const Eigen::VectorXd* contact_area,
                                const std::vector<int>* contact_nodes, bool commit,
                                const Eigen::VectorXd* cell_volume) {
  quiet_hdf5();
  const int dim = mesh.dim, nn = mesh.num_nodes(), nc = mesh.num_cells();
  const int npc = mesh.nodes_per_cell();
  if (!topology(dim, npc))
    fail(path, cat("cannot store a mesh of ", npc, "-node cells in ", dim,
                   "-D (six-node triangles in 2-D, eight-node hexahedra and ten-node tetrahedra in "
                   "3-D are supported)"));
  if (mesh.X.cols() != dim) fail(path, cat("mesh X has ", mesh.X.cols(), " columns, dim is ", dim));
  if (nc > 0 && (mesh.cells.minCoeff() < 0 || mesh.cells.maxCoeff() >= nn))
    fail(path, "mesh cells refer to nodes that do not exist");
  // Contact fields live on the contact points: the facets, or the nodes of a nodal contact.
  const int nf = !contact_facets ? 0
                 : contact_nodes ? static_cast<int>(contact_nodes->size())
                                 : static_cast<int>(contact_facets->facets.rows());
  if (contact_nodes && !contact_facets) fail(path, "contact nodes given without contact facets");
  Eigen::MatrixXd centre;  // #facets x dim
  if (contact_nodes && !contact_centre) centre.resize(nf, dim);
  if (contact_facets) {
    const auto& F = contact_facets->facets;
    if (F.cols() != mesh.nodes_per_facet())
      fail(path,
           cat("contact facets have ", F.cols(), " nodes, expected ", mesh.nodes_per_facet()));
    if (nf > 0 && (F.minCoeff() < 0 || F.maxCoeff() >= nn))
      fail(path, "contact facets refer to nodes that do not exist");
    if (contact_centre) {
      if (contact_centre->rows() == dim && contact_centre->cols() == nf)
        centre = contact_centre->transpose();
      else if (contact_centre->rows() == nf && contact_centre->cols() == dim)
        centre = *contact_centre;
      else
        fail(path, cat("contact centres are ", contact_centre->rows(), " x ",
                       contact_centre->cols(), ", expected ", dim, " x ", nf));
    }
    if (contact_area && contact_area->size() != nf)
      fail(path, cat("contact areas have ", contact_area->size(), " entries, expected ", nf));
  }

  ResultsFile r;
  r.path_ = path;
  r.work_ = work_path_of(path);
  r.dim_ = dim;
  r.num_nodes_ = nn;
  r.num_cells_ = nc;
  r.num_facets_ = nf;
  r.contact_ = contact_facets != nullptr;
  r.file_ = H5Fcreate(r.work_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, memory_access(path).get());
  if (r.file_ < 0)
    fail(path,
         "cannot create the file (does its directory exist, is it writable, is the file "
         "open elsewhere?)");
  const hid_t f = r.file_;

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
    write_string_attr(g.get(), "cell_type", topology(dim, npc), path, "/mesh");
    write_string_attr(g.get(), "source", mesh.source, path, "/mesh");
  }
  const auto un = [](int n) { return static_cast<hsize_t>(n); };
  write_doubles(f, "/mesh/X", {un(nn), un(dim)}, rows_of(mesh.X), dim, path);
  write_ints(f, "/mesh/cells", {un(nc), un(npc)}, rows_of(mesh.cells), dim, path);
  // Cell volumes from the discretization (one definition of the shape functions, lib/fe).
  const Eigen::VectorXd volume = cell_volume ? *cell_volume : cell_operators(mesh).vol;
  if (volume.size() != nc)
    fail(path, cat("cell volumes have ", volume.size(), " entries, expected ", nc));
  write_doubles(f, "/mesh/cell_volume", {un(nc)}, vec(volume), dim, path);
  if (contact_facets) {
    const auto& F = contact_facets->facets;
    write_ints(f, "/mesh/contact_facets",
               {un(static_cast<int>(F.rows())), un(static_cast<int>(F.cols()))}, rows_of(F), dim,
               path);
    if (contact_nodes) {
      write_ints(f, "/mesh/contact_nodes", {un(nf)}, *contact_nodes, dim, path);
      // The facets in the numbering of the contact points: the contact grid of the XDMF files.
      std::vector<int> local(F.size(), -1), index(nn, -1);
      for (int k = 0; k < nf; ++k) {
        const int node = (*contact_nodes)[k];
        if (node < 0 || node >= nn) fail(path, cat("contact node ", node, " does not exist"));
        index[node] = k;
      }
      for (Eigen::Index i = 0; i < F.rows(); ++i)
        for (Eigen::Index j = 0; j < F.cols(); ++j) {
          local[i * F.cols() + j] = index[F(i, j)];
          if (local[i * F.cols() + j] < 0)
            fail(path, cat("node ", F(i, j), " of contact facet ", i, " is not a contact node"));
        }
      write_ints(f, "/mesh/contact_topology",
                 {un(static_cast<int>(F.rows())), un(static_cast<int>(F.cols()))}, local, dim,
                 path);
      if (!contact_centre)  // the contact points' positions: the contact grid's geometry
        for (int k = 0; k < nf; ++k) centre.row(k) = mesh.X.row((*contact_nodes)[k]);
    }
    Handle set = checked(H5Dopen2(f, "/mesh/contact_facets", H5P_DEFAULT), H5Dclose, path,
                         "cannot open dataset /mesh/contact_facets");
    write_string_attr(set.get(), "boundary", contact_facets->name, path, "/mesh/contact_facets");
    if (centre.rows() == nf && nf > 0)
      write_doubles(f, "/mesh/contact_centre", {un(nf), un(dim)}, rows_of(centre), dim, path);
    if (contact_area)
      write_doubles(f, "/mesh/contact_area", {un(nf)}, vec(*contact_area), dim, path);
  }
  create_group(f, "/steps", path);
  if (commit) r.commit();
  return r;
}

ResultsFile ResultsFile::open(const std::string& path) {
  {
    Handle check = open_for_reading(path);  // clear errors for missing / non-HDF5 files
    expect_results_file(check.get(), path);
  }
  ResultsFile r;
  r.path_ = path;
  r.work_ = work_path_of(path);
  Handle fh = open_for_reading(path);
  const hid_t f = fh.get();
  const auto X = dataset_shape(f, "/mesh/X", path);
  const auto cells = dataset_shape(f, "/mesh/cells", path);
  if (X.size() != 2 || cells.size() != 2 ||
      !topology(static_cast<int>(X[1]), static_cast<int>(cells[1])))
    fail(path,
         cat("bad mesh: /mesh/X has shape ", shape_text(X), ", /mesh/cells ", shape_text(cells)));
  r.dim_ = static_cast<int>(X[1]);
  r.num_nodes_ = static_cast<int>(X[0]);
  r.num_cells_ = static_cast<int>(cells[0]);
  r.contact_ = exists(f, "/mesh/contact_facets", path);
  if (r.contact_) {
    r.num_facets_ = contact_points(f, path);
  }
  // Left by a process killed while writing a step (before files were written atomically).
  const bool incomplete = exists(f, "/steps/incomplete", path);
  fh.reset();
  if (incomplete) {
    r.begin();
    r.commit();
  }
  return r;
}

void ResultsFile::begin() {
  if (file_ >= 0) return;
  quiet_hdf5();
  // The file is read into memory and opened from that image (HDF5's core driver without a
  // backing store writes nothing to disk); the name given to H5Fopen must not exist, so a stale
  // working file is removed first (without following a link there).
  const std::vector<char> image = read_image(path_);
  if (image.empty()) fail(path_, "is empty, not a results file");
  struct stat st {};
  if (::lstat(work_.c_str(), &st) == 0 && !S_ISDIR(st.st_mode)) ::unlink(work_.c_str());
  Handle fapl = memory_access(path_);
  ok(H5Pset_file_image(fapl.get(), const_cast<char*>(image.data()), image.size()), path_,
     "cannot load the file into memory");
  file_ = H5Fopen(work_.c_str(), H5F_ACC_RDWR, fapl.get());
  if (file_ < 0)
    fail(path_, cat("cannot open the results file in memory for writing (a damaged file, or ",
                    work_, " is in the way?)"));
  if (exists(file_, "/steps/incomplete", path_))
    ok(H5Ldelete(file_, "/steps/incomplete", H5P_DEFAULT), path_,
       "cannot delete /steps/incomplete");
}

// The working file is complete and closed before it replaces the results file in one rename(2):
// a reader, or a process killed at any instant, sees the previous complete file or this one.
void ResultsFile::commit() {
  if (file_ < 0) fail(path_, "commit without changes");
  fault_point();
  if (H5Fflush(file_, H5F_SCOPE_LOCAL) < 0) {
    discard();
    fail(path_, "cannot flush the file to its image in memory");
  }
  const ssize_t size = H5Fget_file_image(file_, nullptr, 0);
  std::vector<char> image(size > 0 ? static_cast<std::size_t>(size) : 0);
  if (size <= 0 || H5Fget_file_image(file_, image.data(), image.size()) != size) {
    discard();
    fail(path_, "cannot get the image of the file in memory");
  }
  const std::string xdmf = xdmf_text(false), contact_xdmf = contact_ ? xdmf_text(true) : "";
  const herr_t closed = H5Fclose(file_);  // in memory: writes nothing
  file_ = -1;
  if (closed < 0) fail(path_, "cannot close the file in memory");
  write_image(work_, image, path_);
  fault_point();
  if (std::rename(work_.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    fail(path_, cat("cannot move ", work_, " into place: ", errno_text(e)));
  }
  const auto dir = std::filesystem::path(path_).parent_path();
  sync_path(dir.empty() ? "." : dir.string(), true);
  fault_point();
  write_xdmf(xdmf_path_of(path_), xdmf);
  if (!contact_xdmf.empty()) write_xdmf(contact_xdmf_path_of(path_), contact_xdmf);
}

void ResultsFile::discard() noexcept {
  if (file_ < 0) return;
  H5Fclose(file_);
  file_ = -1;
  std::error_code ec;
  std::filesystem::remove(work_, ec);
}

ResultsFile::ResultsFile(ResultsFile&& o) noexcept
    : file_(std::exchange(o.file_, -1)),
      path_(std::move(o.path_)),
      work_(std::move(o.work_)),
      dim_(o.dim_),
      num_nodes_(o.num_nodes_),
      num_cells_(o.num_cells_),
      num_facets_(o.num_facets_),
      contact_(o.contact_) {}

ResultsFile& ResultsFile::operator=(ResultsFile&& o) noexcept {
  if (this != &o) {
    close();
    file_ = std::exchange(o.file_, -1);
    path_ = std::move(o.path_);
    work_ = std::move(o.work_);
    dim_ = o.dim_;
    num_nodes_ = o.num_nodes_;
    num_cells_ = o.num_cells_;
    num_facets_ = o.num_facets_;
    contact_ = o.contact_;
  }
  return *this;
}

ResultsFile::~ResultsFile() {
  close();
}

void ResultsFile::close() noexcept {
  discard();  // changes not committed (an error in the middle of a step) are dropped
}

// Checks the sizes of a step's data (an Error naming the step and the field).
void ResultsFile::check_step(const StepData& step) const {
  const std::string& file = path_;
  if (path_.empty()) fail(file, "append to a closed results file");
  if (!step.state) fail(file, cat("step ", step.p, ": no state to write"));
  if (step.p < 0 || step.p > 999999) fail(file, cat("step number ", step.p, " out of 0..999999"));
  const State& s = *step.state;
  const int dim = dim_, nn = num_nodes_, nc = num_cells_, nf = num_facets_;
  auto expect = [&](const char* what, Eigen::Index rows, Eigen::Index cols, Eigen::Index r,
                    Eigen::Index c) {
    if (rows != r || cols != c)
      fail(file,
           cat("step ", step.p, ": ", what, " is ", rows, " x ", cols, ", expected ", r, " x ", c));
  };
  expect("u", s.u.rows(), s.u.cols(), nn, dim);
  // E and lambda may both be empty for a problem without cell unknowns (the Signorini problem of
  // section 7), beta for a contact problem without adhesion intensity; they are then not written.
  if (s.E.size() || s.lambda.size()) {
    expect("E", s.E.rows(), s.E.cols(), dim * nc, dim);
    expect("lambda", s.lambda.rows(), s.lambda.cols(), dim * nc, dim);
  }
  if (contact_) {
    expect("e", s.e.rows(), s.e.cols(), dim, nf);
    expect("lambda_c", s.lambda_c.rows(), s.lambda_c.cols(), dim, nf);
    if (s.beta.size()) expect("beta", s.beta.size(), 1, nf, 1);
  }
  if (step.P.size()) expect("P", step.P.rows(), step.P.cols(), dim * nc, dim);
  if (step.sigma.size()) expect("sigma", step.sigma.rows(), step.sigma.cols(), dim * nc, dim);
  if (step.sigma33.size()) {
    if (dim != 2) fail(file, cat("step ", step.p, ": sigma33 is for plane strain (2-D) only"));
    expect("sigma33", step.sigma33.size(), 1, nc, 1);
  }
  if (step.pressure.size()) expect("pressure", step.pressure.size(), 1, nc, 1);
  if (step.contact_pressure.size())
    expect("contact_pressure", step.contact_pressure.size(), 1, nf, 1);
  if (step.gap.size()) expect("gap", step.gap.size(), 1, nf, 1);
}

// Writes the group `g` (absolute) of one step: attributes, fields, history and, in 2-D, the
// padded copies for ParaView (not for an unconverged iterate, which no XDMF grid shows).
void ResultsFile::write_step(const std::string& g, const StepData& step, bool converged) {
  const std::string& file = path_;
  const State& s = *step.state;
  const int dim = dim_, nn = num_nodes_, nc = num_cells_;
  {
    Handle group = create_group(file_, g, file);
    const StepReport* rep = step.report;
    write_scalar_attr<int>(group.get(), "p", step.p, file, g);
    write_scalar_attr<double>(group.get(), "t", step.t, file, g);
    write_scalar_attr<int>(group.get(), "iterations", rep ? rep->iterations : 0, file, g);
    write_string_attr(group.get(), "status", rep ? rep->status : "", file, g);
    write_scalar_attr<int>(group.get(), "converged", rep && rep->converged ? 1 : 0, file, g);
    write_scalar_attr<int>(group.get(), "strain_failures", rep ? rep->strain_failures : 0, file, g);
    // [10.3] The equilibrium measure of the stored iterate (lib/measures.hpp).
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
  const auto un = [](Eigen::Index n) { return static_cast<hsize_t>(n); };
  const auto put = [&](const std::string& ds, const std::vector<hsize_t>& dims,
                       const std::vector<double>& data) {
    write_doubles(file_, g + "/" + ds, dims, data, dim, file);
  };
  const int nf = num_facets_;
  const bool cells = s.E.size() || s.lambda.size();
  put("u", {un(nn), un(dim)}, rows_of(s.u));
  if (cells) {
    put("E", {un(nc), un(dim), un(dim)}, tensors_of(s.E, dim, dim));
    put("lambda", {un(nc), un(dim), un(dim)}, tensors_of(s.lambda, dim, dim));
  }
  if (step.P.size()) put("P", {un(nc), un(dim), un(dim)}, tensors_of(step.P, dim, dim));
  if (step.sigma.size()) put("sigma", {un(nc), un(dim), un(dim)}, tensors_of(step.sigma, dim, dim));
  if (step.sigma33.size()) put("sigma33", {un(nc)}, vec(step.sigma33));
  if (step.pressure.size()) put("pressure", {un(nc)}, vec(step.pressure));
  if (contact_) {
    if (s.beta.size()) put("beta", {un(nf)}, vec(s.beta));
    put("e", {un(nf), un(dim)}, columns_of(s.e));
    put("lambda_c", {un(nf), un(dim)}, columns_of(s.lambda_c));
  }
  if (step.contact_pressure.size()) put("contact_pressure", {un(nf)}, vec(step.contact_pressure));
  if (step.gap.size()) put("gap", {un(nf)}, vec(step.gap));
  if (step.reactions.size()) {  // per Dirichlet condition (lib/reactions.hpp)
    put("reactions", {un(step.reactions.rows()), un(dim)}, rows_of(step.reactions));
    put("support_u", {un(step.support_u.rows()), un(dim)}, rows_of(step.support_u));
  }
  if (!step.measures.empty() || step.in_contact.size()) {
    // The step's measures (lib/measures.hpp): scalar datasets with the unit and description
    // given by the measures module, and the contact set per contact point.
    const std::string mg = g + "/measures";
    create_group(file_, mg, file);
    for (const StoredMeasure& m : step.measures) {
      const std::string path = mg + "/" + m.name;
      Handle space = checked(H5Screate(H5S_SCALAR), H5Sclose, file,
                             cat("cannot create the dataspace of dataset ", path));
      Handle set = checked(H5Dcreate2(file_, path.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT,
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
      write_ints(file_, mg + "/in_contact", {un(nf)}, mask, dim, file);
    }
  }
  {
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
    put("history", {un(ni), 8}, h);
    Handle set = checked(H5Dopen2(file_, (g + "/history").c_str(), H5P_DEFAULT), H5Dclose, file,
                         cat("cannot open dataset ", g, "/history"));
    write_string_attr(set.get(), "columns", "n r_G r_B t_global t_strain t_contact t_update wall",
                      file, g + "/history");
  }
  if (dim == 2 && converged) {
    // 3-vectors and 3x3 tensors for ParaView. Plane strain: E33 = F33 = 1, sigma33 the true
    // out-of-plane stress (0 when not given), P33 = det E sigma33 (sigma = P F^T / det F).
    create_group(file_, g + "/xdmf", file);
    Eigen::MatrixXd u3 = Eigen::MatrixXd::Zero(nn, 3);
    u3.leftCols(2) = s.u;
    put("xdmf/u", {un(nn), 3}, rows_of(u3));
    const auto padded = [&](const Eigen::MatrixXd& T, const std::function<double(int)>& t33) {
      std::vector<double> out = tensors_of(T, dim, 3);
      for (int c = 0; c < nc; ++c) out[9 * c + 8] = t33(c);
      return out;
    };
    const auto detE = [&](int c) { return s.E.block<2, 2>(2 * c, 0).determinant(); };
    const auto s33 = [&](int c) { return step.sigma33.size() ? step.sigma33(c) : 0.0; };
    if (cells) put("xdmf/E", {un(nc), 3, 3}, padded(s.E, [](int) { return 1.0; }));
    if (step.P.size())
      put("xdmf/P", {un(nc), 3, 3},
          padded(step.P, [&](int c) { return cells ? detE(c) * s33(c) : s33(c); }));
    if (step.sigma.size()) put("xdmf/sigma", {un(nc), 3, 3}, padded(step.sigma, s33));
    if (contact_) {
      Eigen::MatrixXd v = Eigen::MatrixXd::Zero(3, nf);
      v.topRows(2) = s.e;
      put("xdmf/e", {un(nf), 3}, columns_of(v));
      v.topRows(2) = s.lambda_c;
      put("xdmf/lambda_c", {un(nf), 3}, columns_of(v));
    }
  }
}

void ResultsFile::append(const StepData& step, const std::string& status) {
  check_step(step);
  const std::string& file = path_;
  const std::string name = step_name(step.p), g = "/steps/" + name;
  begin();
  if (exists(file_, g, file)) {
    discard();
    fail(file, cat("step ", step.p, " is already stored (", g, ")"));
  }
  // Written under a temporary name and renamed when complete.
  const std::string tmp = "/steps/incomplete";
  if (exists(file_, tmp, file))
    ok(H5Ldelete(file_, tmp.c_str(), H5P_DEFAULT), file, cat("cannot delete ", tmp));
  write_step(tmp, step, true);
  ok(H5Lmove(file_, tmp.c_str(), file_, g.c_str(), H5P_DEFAULT, H5P_DEFAULT), file,
     cat("cannot rename ", tmp, " to ", g));
  // An unconverged iterate of this step saved by an earlier run is superseded by the result.
  const std::string stale = "/unconverged/" + name;
  if (exists(file_, stale, file))
    ok(H5Ldelete(file_, stale.c_str(), H5P_DEFAULT), file, cat("cannot delete ", stale));
  if (!status.empty()) {
    Handle root = open_group(file_, "/", path_);
    write_string_attr(root.get(), "status", status, path_, "/");
  }
  commit();
}

void ResultsFile::save_unconverged(const StepData& step, const std::string& status) {
  check_step(step);
  const std::string& file = path_;
  const std::string g = "/unconverged/" + step_name(step.p);
  begin();
  if (!exists(file_, "/unconverged", file)) {
    Handle group = create_group(file_, "/unconverged", file);
    write_string_attr(group.get(), "note",
                      "NOT RESULTS: the last iterate and iteration history of time steps that "
                      "did not converge (one group per step, named like /steps), for diagnosis; "
                      "readers of results use /steps only",
                      file, "/unconverged");
  }
  if (exists(file_, g, file))
    ok(H5Ldelete(file_, g.c_str(), H5P_DEFAULT), file, cat("cannot replace ", g));
  write_step(g, step, false);
  if (!status.empty()) {
    Handle root = open_group(file_, "/", path_);
    write_string_attr(root.get(), "status", status, path_, "/");
  }
  commit();
}

void ResultsFile::set_status(const std::string& status) {
  if (path_.empty()) fail(path_, "set_status on a closed results file");
  begin();
  {
    Handle root = open_group(file_, "/", path_);
    write_string_attr(root.get(), "status", status, path_, "/");
  }
  commit();
}

// XDMF: the body (xdmf_path_of) and, with a contact surface, the contact surface
// (contact_xdmf_path_of), both referring to the datasets of the HDF5 file by its file name (the
// files are meant to stay side by side). One uniform grid per step in a temporal collection; a
// file with one step is that step's uniform grid alone (no collection, no Time element), which
// meshio.read() reads as well as ParaView; a file with no step is the bare mesh.
std::string ResultsFile::xdmf_text(bool contact) const {
  const std::string& file = path_;
  const std::string h5 = xml_escape(std::filesystem::path(path_).filename().string());
  const int dim = dim_, nn = num_nodes_, nc = num_cells_, nf = num_facets_;
  const auto npc = dataset_shape(file_, "/mesh/cells", file).at(1);
  const bool nodal = exists(file_, "/mesh/contact_nodes", file);
  // The grid: cells of the body, or facets of the contact surface.
  std::string topo, cells_ds, geometry_ds, centre;
  hsize_t elements = nc, per = npc, points = nn;
  if (!contact) {
    topo = topology(dim, static_cast<int>(npc));
    cells_ds = "/mesh/cells";
    geometry_ds = "/mesh/X";
  } else {
    const auto F = dataset_shape(file_, "/mesh/contact_facets", file);
    elements = F.at(0), per = F.at(1);
    topo = dim == 2 && per == 3   ? "Edge_3"
           : dim == 2 && per == 2 ? "Polyline"
           : dim == 3 && per == 4 ? "Quadrilateral"
           : dim == 3 && per == 6 ? "Triangle_6"
           : dim == 3 && per == 3 ? "Triangle"
                                  : "";
    if (topo.empty()) fail(file, cat("no XDMF topology for ", per, "-node contact facets"));
    cells_ds = nodal ? "/mesh/contact_topology" : "/mesh/contact_facets";
    geometry_ds = nodal ? "/mesh/contact_centre" : "/mesh/X";
    points = nodal ? nf : nn;
    if (!exists(file_, geometry_ds, file) || !exists(file_, cells_ds, file)) return "";
  }
  const char* at = contact && !nodal ? "Cell" : "Node";  // where the contact fields live

  std::ostringstream o;
  auto item = [&](const std::string& indent, const std::string& dims, bool integer,
                  const std::string& dataset) {
    o << indent << "<DataItem Dimensions=\"" << dims << "\" NumberType=\""
      << (integer ? "Int" : "Float") << "\" Precision=\"" << (integer ? 4 : 8)
      << "\" Format=\"HDF\">" << h5 << ":" << dataset << "</DataItem>\n";
  };
  auto attribute = [&](const std::string& name, const char* type, const char* centre,
                       const std::string& dims, const std::string& dataset) {
    o << "        <Attribute Name=\"" << name << "\" AttributeType=\"" << type << "\" Center=\""
      << centre << "\">\n";
    item("          ", dims, false, dataset);
    o << "        </Attribute>\n";
  };
  auto grid = [&](const std::string& name, const std::string* time) {
    o << "      <Grid Name=\"" << name << "\" GridType=\"Uniform\">\n";
    if (time) o << "        <Time Value=\"" << *time << "\"/>\n";
    o << "        <Topology TopologyType=\"" << topo << "\" NumberOfElements=\"" << elements
      << "\">\n";
    item("          ", cat(elements, ' ', per), true, cells_ds);
    o << "        </Topology>\n"
      << "        <Geometry GeometryType=\"" << (dim == 2 ? "XY" : "XYZ") << "\">\n";
    item("          ", cat(points, ' ', dim), false, geometry_ds);
    o << "        </Geometry>\n";
  };
  const std::vector<std::string> names = step_names(file_, file);
  o << "<?xml version=\"1.0\"?>\n"
    << xdmf_marker(path_) << " for ParaView" << (contact ? ", on the contact surface" : "")
    << " (layout: experiments/README.md). -->\n"
    << "<Xdmf Version=\"3.0\">\n  <Domain>\n";
  const bool series = names.size() > 1;
  if (series)
    o << "    <Grid Name=\"" << (contact ? "contact" : "steps")
      << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  if (names.empty()) {
    grid(contact ? "contact_surface" : "mesh", nullptr);
    o << "      </Grid>\n";
  }
  for (const std::string& name : names) {
    const std::string g = "/steps/" + name;
    double t = 0;
    {
      Handle group = open_group(file_, g, file);
      t = read_scalar_attr<double>(group.get(), "t", file, g);
    }
    const std::string time = number(t);
    grid("step_" + name, series ? &time : nullptr);
    const std::string v = dim == 2 ? g + "/xdmf" : g;  // 3-vectors and 3x3 tensors
    const auto has = [&](const std::string& ds) { return exists(file_, ds, file); };
    if (!contact) {
      attribute("u", "Vector", "Node", cat(nn, " 3"), v + "/u");
      for (const char* S : {"pressure", "sigma33"})
        if (has(g + "/" + S)) attribute(S, "Scalar", "Cell", cat(nc), g + "/" + S);
      for (const char* T : {"E", "P", "sigma"})
        if (has(v + "/" + T)) attribute(T, "Tensor", "Cell", cat(nc, " 3 3"), v + "/" + T);
    } else {
      for (const char* S : {"beta", "contact_pressure", "gap"})
        if (has(g + "/" + S)) attribute(S, "Scalar", at, cat(nf), g + "/" + S);
      for (const char* V : {"e", "lambda_c"})
        if (has(v + "/" + V)) attribute(V, "Vector", at, cat(nf, " 3"), v + "/" + V);
    }
    o << "      </Grid>\n";
  }
  if (series) o << "    </Grid>\n";
  o << "  </Domain>\n</Xdmf>\n";
  return o.str();
}

void ResultsFile::write_xdmf(const std::string& xdmf, const std::string& text) const {
  // Written beside and renamed, so that a reader never sees half a file.
  // The temporary is created afresh (create_fresh: never through a link).
  const std::string tmp = xdmf + ".tmp";
  const int fd = create_fresh(tmp, -1, xdmf);
  for (std::size_t done = 0; done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int e = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      fail(xdmf, cat("cannot write the XDMF file: ", errno_text(e)));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0 || std::rename(tmp.c_str(), xdmf.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    fail(xdmf, cat("cannot write the XDMF file: ", errno_text(e)));
  }
}

std::optional<StoredStep> ResultsFile::read_last_step(const std::string& path) {
  Handle fh = open_for_reading(path);
  const hid_t f = fh.get();
  expect_results_file(f, path);
  const std::vector<std::string> names = step_names(f, path);
  if (names.empty()) return std::nullopt;

  const auto X = dataset_shape(f, "/mesh/X", path);
  const auto cells = dataset_shape(f, "/mesh/cells", path);
  if (X.size() != 2 || cells.size() != 2 || (X[1] != 2 && X[1] != 3))
    fail(path,
         cat("bad mesh: /mesh/X has shape ", shape_text(X), ", /mesh/cells ", shape_text(cells)));
  const int dim = static_cast<int>(X[1]), nn = static_cast<int>(X[0]);
  const int nc = static_cast<int>(cells[0]);
  const hsize_t d = dim;

  const std::string g = "/steps/" + names.back();
  StoredStep out;
  {
    Handle group = open_group(f, g, path);
    out.p = read_scalar_attr<int>(group.get(), "p", path, g);
    out.t = read_scalar_attr<double>(group.get(), "t", path, g);
    out.iterations = read_scalar_attr<int>(group.get(), "iterations", path, g);
  }
  if (step_name(out.p) != names.back()) fail(path, cat("group ", g, " has attribute p = ", out.p));
  const auto get = [&](const std::string& ds, const std::vector<hsize_t>& dims) {
    const std::string full = g + "/" + ds;
    Array<double> a = read_array<double>(f, full, path);
    expect_shape(a, dims, full, path);
    return a.data;
  };
  if (exists(f, g + "/measures", path)) {
    Handle mg = open_group(f, g + "/measures", path);
    H5G_info_t info;
    ok(H5Gget_info(mg.get(), &info), path, cat("cannot read group ", g, "/measures"));
    for (hsize_t i = 0; i < info.nlinks; ++i) {
      char name[256];
      if (H5Lget_name_by_idx(mg.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, name, sizeof name,
                             H5P_DEFAULT) < 0)
        fail(path, cat("cannot list group ", g, "/measures"));
      const std::string full = g + "/measures/" + name;
      const Array<double> a = read_array<double>(f, full, path);
      if (a.dims.empty() && a.data.size() == 1) out.measures[name] = a.data[0];
    }
  }
  State& s = out.state;
  s.u = from_rows(get("u", {X[0], d}), nn, dim);
  s.E = tensors_from(get("E", {cells[0], d, d}), nc, dim);
  s.lambda = tensors_from(get("lambda", {cells[0], d, d}), nc, dim);
  if (exists(f, "/mesh/contact_facets", path)) {
    const int nf = contact_points(f, path);
    const hsize_t hf = static_cast<hsize_t>(nf);
    s.e = columns_from(get("e", {hf, d}), nf, dim);
    s.lambda_c = columns_from(get("lambda_c", {hf, d}), nf, dim);
    const auto beta = get("beta", {hf});
    s.beta = Eigen::Map<const Eigen::VectorXd>(beta.data(), nf);
  } else {
    s.e = Eigen::MatrixXd::Zero(dim, 0);
    s.lambda_c = Eigen::MatrixXd::Zero(dim, 0);
    s.beta = Eigen::VectorXd::Zero(0);
  }
  return out;
}

std::string ResultsFile::read_attribute(const std::string& path, const std::string& name) {
  Handle f = open_for_reading(path);
  Handle root = open_group(f.get(), "/", path);
  return read_string_attr(root.get(), name, path, "/").value_or("");
}

std::map<std::string, std::string> library_versions() {
  unsigned major = 0, minor = 0, release = 0;
  const bool hdf5 = H5get_libversion(&major, &minor, &release) >= 0;
  return {
      {"eigen", cat(EIGEN_WORLD_VERSION, '.', EIGEN_MAJOR_VERSION, '.', EIGEN_MINOR_VERSION)},
      {"cholmod", cat(CHOLMOD_MAIN_VERSION, '.', CHOLMOD_SUB_VERSION, '.', CHOLMOD_SUBSUB_VERSION)},
      {"hdf5", hdf5 ? cat(major, '.', minor, '.', release) : std::string(H5_VERSION)},
      {"gmsh", GMSH_API_VERSION},
  };
}

}  // namespace ltl
