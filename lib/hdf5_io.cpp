// The HDF5 layer of the results files (hdf5_io.hpp): checked calls, errors naming the file.
#include "hdf5_io.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <thread>

#include "error.hpp"

namespace ltl::h5 {

void quiet() {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}

void fail(const std::string& file, const std::string& what) {
  throw Error(cat(file, ": ", what));
}

Handle checked(hid_t id, CloseFn close, const std::string& file, const std::string& what) {
  if (id < 0) fail(file, what);
  return Handle(id, close);
}

void ok(herr_t status, const std::string& file, const std::string& what) {
  if (status < 0) fail(file, what);
}

/// File access in memory (HDF5's core driver, no backing store): the working copy of the results
/// file is an image in memory, which the commit (lib/results_commit.cpp) writes with checked
/// write(2) calls. HDF5 1.10 writing to disk itself reports a full disk late or not at all (a
/// dataset's sieve buffer flushed in H5Dclose), and a failed H5Fclose leaves a freed file behind
/// that crashes the program at exit (H5F__close_cb in H5_term_library); in memory neither can
/// happen.
Handle memory_access(const std::string& file) {
  Handle fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "cannot create an access list");
  ok(H5Pset_fapl_core(fapl.get(), 1 << 20, false), file, "cannot select HDF5's core driver");
  return fapl;
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

namespace {
/// A new dataset `path` of shape `dims` and its dataspace in the file.
struct NewDataset {
  Handle space, set;
};
NewDataset create_dataset(hid_t file_id, const std::string& path, hid_t file_type,
                          const std::vector<hsize_t>& dims, const std::string& file) {
  NewDataset d;
  d.space = checked(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), H5Sclose,
                    file, cat("cannot create the dataspace of dataset ", path));
  d.set = checked(H5Dcreate2(file_id, path.c_str(), file_type, d.space.get(), H5P_DEFAULT,
                             H5P_DEFAULT, H5P_DEFAULT),
                  H5Dclose, file, cat("cannot create dataset ", path));
  return d;
}
}  // namespace

/// Writes a dataset `path` (absolute) of the given shape from row-major `data`.
void write_array(hid_t file_id, const std::string& path, hid_t mem_type, hid_t file_type,
                 const std::vector<hsize_t>& dims, const void* data, const std::string& file) {
  const NewDataset d = create_dataset(file_id, path, file_type, dims, file);
  hsize_t total = 1;
  for (hsize_t n : dims) total *= n;
  errno = 0;
  if (total > 0 && H5Dwrite(d.set.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    fail(file,
         cat("cannot write dataset ", path, errno ? ": " + std::string(std::strerror(errno)) : ""));
}

void write_rows(hid_t file_id, const std::string& path, hid_t file_type,
                const std::vector<hsize_t>& dims, hsize_t rows_per_block,
                const std::function<void(hsize_t, hsize_t, std::vector<double>&)>& rows,
                const std::string& file) {
  const NewDataset d = create_dataset(file_id, path, file_type, dims, file);
  hsize_t per_row = 1;
  for (std::size_t k = 1; k < dims.size(); ++k) per_row *= dims[k];
  std::vector<hsize_t> start(dims.size(), 0), count = dims;
  std::vector<double> data;
  for (hsize_t first = 0; first < dims[0] && per_row > 0; first += rows_per_block) {
    start[0] = first;
    count[0] = std::min(rows_per_block, dims[0] - first);
    data.clear();
    rows(first, count[0], data);
    const hsize_t n = count[0] * per_row;
    if (data.size() != n)
      fail(file, cat("internal: ", data.size(), " values for ", n, " of dataset ", path));
    Handle memory = checked(H5Screate_simple(1, &n, nullptr), H5Sclose, file,
                            cat("cannot create a dataspace for dataset ", path));
    errno = 0;
    if (H5Sselect_hyperslab(d.space.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(),
                            nullptr) < 0 ||
        H5Dwrite(d.set.get(), H5T_NATIVE_DOUBLE, memory.get(), d.space.get(), H5P_DEFAULT,
                 data.data()) < 0)
      fail(file, cat("cannot write dataset ", path,
                     errno ? ": " + std::string(std::strerror(errno)) : ""));
  }
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

namespace {
/// Whether another process holds an exclusive lock on `path` (a writer committing in place).
bool locked_by_writer(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return false;
  const bool locked = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return locked;
}
}  // namespace

Handle open_for_reading(const std::string& path) {
  quiet();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) fail(path, "no such file");
  if (std::filesystem::is_directory(path, ec)) fail(path, "is a directory, not a results file");
  // A writer holds the file exclusively only while it updates it in place: wait for it.
  for (int attempt = 0; attempt < 1000 && locked_by_writer(path); ++attempt)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const htri_t is_hdf5 = H5Fis_hdf5(path.c_str());
  if (is_hdf5 <= 0) fail(path, "not an HDF5 file (or not readable)");
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  for (int attempt = 0; f < 0 && attempt < 100 && locked_by_writer(path); ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  }
  if (f < 0) {  // a file system without locks, or a lock held for ever
    Handle fapl = checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, path, "cannot open the file");
#if (H5_VERS_MAJOR == 1 && H5_VERS_MINOR == 10 && H5_VERS_RELEASE >= 7) || H5_VERSION_GE(1, 12, 1)
    ok(H5Pset_file_locking(fapl.get(), false, true), path, "cannot open the file");
#endif
    f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl.get());
  }
  return checked(f, H5Fclose, path, "cannot open the file (damaged HDF5 file?)");
}

std::vector<std::string> link_names(hid_t file_id, const std::string& path,
                                    const std::string& file) {
  Handle g = open_group(file_id, path, file);
  H5G_info_t info;
  ok(H5Gget_info(g.get(), &info), file, cat("cannot read group ", path));
  std::vector<std::string> names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t n =
        H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (n < 0) fail(file, cat("cannot list group ", path));
    std::string name(static_cast<std::size_t>(n) + 1, '\0');
    if (H5Lget_name_by_idx(g.get(), ".", H5_INDEX_NAME, H5_ITER_INC, i, name.data(), name.size(),
                           H5P_DEFAULT) < 0)
      fail(file, cat("cannot list group ", path));
    name.resize(static_cast<std::size_t>(n));
    names.push_back(name);
  }
  return names;
}

}  // namespace ltl::h5
