// The HDF5 layer of the results files: identifiers owned by RAII handles, and checked reads and
// writes of datasets and attributes. Every call is checked; HDF5's own error stack printing is
// switched off and a failure becomes an ltl::Error naming the file and the object. Nothing here
// knows the layout of a results file (lib/results_layout.hpp) nor how it is committed to disk
// (lib/results_commit.hpp).
#pragma once

#include <hdf5.h>

#include <functional>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace ltl::h5 {

/// Switches off HDF5's printing of its error stack (our errors say what failed).
void quiet();

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
  /// Gives up ownership.
  hid_t release() { return std::exchange(id_, -1); }

 private:
  hid_t id_ = -1;
  CloseFn close_ = nullptr;
};

/// Throws Error("<file>: <what>").
[[noreturn]] void fail(const std::string& file, const std::string& what);
/// `id` owned by a Handle, or an Error naming `file` and `what` when id < 0.
Handle checked(hid_t id, CloseFn close, const std::string& file, const std::string& what);
/// An Error naming `file` and `what` when status < 0.
void ok(herr_t status, const std::string& file, const std::string& what);

/// File access in memory (HDF5's core driver, no backing store).
Handle memory_access(const std::string& file);
/// Opens an existing file read-only, with clear errors for a missing or non-HDF5 file. HDF5
/// holds a shared lock on the file while it is open; when a writer holds the file exclusively
/// (the few milliseconds of an in-place commit, lib/results_commit.hpp) the open is retried, and
/// after about ten seconds done without locking.
Handle open_for_reading(const std::string& path);

/// Whether the object at absolute `path` ("/a/b/c") exists (every component is checked, as
/// H5Lexists requires).
bool exists(hid_t file_id, const std::string& path, const std::string& file);
Handle open_group(hid_t file_id, const std::string& path, const std::string& file);
Handle create_group(hid_t file_id, const std::string& path, const std::string& file);
/// The names of the links in group `path`, in name order.
std::vector<std::string> link_names(hid_t file_id, const std::string& path,
                                    const std::string& file);

/// "(3, 2)", "(4,)": a shape as numpy prints it.
std::string shape_text(const std::vector<hsize_t>& dims);
/// Writes a dataset `path` (absolute) of the given shape from row-major `data`.
void write_array(hid_t file_id, const std::string& path, hid_t mem_type, hid_t file_type,
                 const std::vector<hsize_t>& dims, const void* data, const std::string& file);
/// The same from native doubles made a block of rows at a time: `rows(first, count, data)` fills
/// `data` with rows first .. first + count - 1 of the array, row-major; at most rows_per_block
/// rows each. The writer holds one block in the file's layout, not the whole array.
void write_rows(hid_t file_id, const std::string& path, hid_t file_type,
                const std::vector<hsize_t>& dims, hsize_t rows_per_block,
                const std::function<void(hsize_t, hsize_t, std::vector<double>&)>& rows,
                const std::string& file);
/// The shape of dataset `path` (which must exist).
std::vector<hsize_t> dataset_shape(hid_t file_id, const std::string& path, const std::string& file);

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
  if (!exists(file_id, path, file)) fail(file, "missing dataset " + path);
  Handle set = checked(H5Dopen2(file_id, path.c_str(), H5P_DEFAULT), H5Dclose, file,
                       "cannot open dataset " + path);
  Handle type = checked(H5Dget_type(set.get()), H5Tclose, file, "bad type of " + path);
  const H5T_class_t cls = H5Tget_class(type.get());
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) fail(file, "dataset " + path + " is not numeric");
  Array<T> a;
  a.dims = dataset_shape(file_id, path, file);
  hsize_t total = 1;
  for (hsize_t d : a.dims) total *= d;
  a.data.resize(total);
  const hid_t mem = std::is_same_v<T, int> ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  if (total > 0)
    ok(H5Dread(set.get(), mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.data.data()), file,
       "cannot read dataset " + path);
  return a;
}

template <class T>
void expect_shape(const Array<T>& a, const std::vector<hsize_t>& dims, const std::string& path,
                  const std::string& file) {
  if (a.dims != dims)
    fail(file,
         "dataset " + path + " has shape " + shape_text(a.dims) + ", expected " + shape_text(dims));
}

void delete_attribute_if_any(hid_t obj, const std::string& name, const std::string& file,
                             const std::string& where);
/// Writes (or replaces) a variable-length UTF-8 string attribute.
void write_string_attr(hid_t obj, const std::string& name, const std::string& value,
                       const std::string& file, const std::string& where);
/// Opens attribute `name` of `obj` checking it holds one value; an empty Handle if absent.
Handle open_scalar_attr(hid_t obj, const std::string& name, const std::string& file,
                        const std::string& where);
/// A string attribute (fixed or variable length); nullopt if absent.
std::optional<std::string> read_string_attr(hid_t obj, const std::string& name,
                                            const std::string& file, const std::string& where);

/// Writes (or replaces) a scalar attribute, int (32-bit) or double.
template <class T>
void write_scalar_attr(hid_t obj, const std::string& name, T value, const std::string& file,
                       const std::string& where) {
  const std::string what = "cannot write attribute " + name + " of " + where;
  const hid_t mem = std::is_same_v<T, int> ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  const hid_t ftype = std::is_same_v<T, int> ? H5T_STD_I32LE : H5T_IEEE_F64LE;
  delete_attribute_if_any(obj, name, file, where);
  Handle space = checked(H5Screate(H5S_SCALAR), H5Sclose, file, what);
  Handle attr = checked(H5Acreate2(obj, name.c_str(), ftype, space.get(), H5P_DEFAULT, H5P_DEFAULT),
                        H5Aclose, file, what);
  ok(H5Awrite(attr.get(), mem, &value), file, what);
}

/// A scalar attribute (an Error if absent).
template <class T>
T read_scalar_attr(hid_t obj, const std::string& name, const std::string& file,
                   const std::string& where) {
  Handle attr = open_scalar_attr(obj, name, file, where);
  if (attr.get() < 0) fail(file, "missing attribute " + name + " of " + where);
  T value{};
  const hid_t mem = std::is_same_v<T, int> ? H5T_NATIVE_INT : H5T_NATIVE_DOUBLE;
  ok(H5Aread(attr.get(), mem, &value), file, "cannot read attribute " + name + " of " + where);
  return value;
}

}  // namespace ltl::h5
