// A results file being changed, held as the pages written since it was opened over the committed
// file on disk, or written straight into the file past its end. The writer's memory is then the
// pages of HDF5's metadata of one change, not the whole file nor the step's data: HDF5 reads what
// it needs of the committed file when it needs it; a write before the file's end lands in a page
// of 4 KiB held here, and a write past it goes into the file there, where no reader looks.
// lib/results_commit.cpp puts the held pages that differ from the file on disk into the redo
// journal and then into the file.
//
// HDF5 reaches the pages through a file driver of ours (a virtual file driver, HDF5's interface
// for where the bytes of a file live), registered once and selected by page_access().
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "hdf5_io.hpp"

namespace ltl {

/// The bytes of a file: those of the committed file on disk (read when asked, never kept) under
/// the pages written since (kept). Reads past the end of what was written read zeros, as a file.
///
/// Direct (a store over a file open for writing): what is written past the end of the
/// committed file goes straight into the file there (the committed file is the bytes before its
/// end; a reader never looks past them), and only the writes before that end are kept as pages.
/// A failed write there is not HDF5's error: it is kept (deferred_error()) and the writes go on
/// into pages, so that the change stays consistent until the commit refuses it.
class PageStore {
 public:
  static constexpr std::size_t kPage = 4096;
  /// Over the committed file open on `fd` (owned: closed with the store), `size` bytes; direct
  /// when `fd` is open for writing and `direct` is set.
  PageStore(int fd, std::uint64_t size, bool direct = false);
  PageStore(const PageStore&) = delete;
  PageStore& operator=(const PageStore&) = delete;
  ~PageStore();

  /// Copies [at, at + n) into `out`; false (errno set) when the file on disk cannot be read.
  bool read(std::uint64_t at, std::size_t n, char* out) const;
  /// Writes [at, at + n) from `in`; the file grows to at + n if it is shorter. False (errno set)
  /// when the file on disk cannot be read for a page written in part.
  bool write(std::uint64_t at, std::size_t n, const char* in);
  /// Cuts or extends the file to `n` bytes (extended with zeros).
  void truncate(std::uint64_t n);

  /// The file's size now.
  std::uint64_t size() const { return size_; }
  /// The size of the committed file on disk when the store was opened over it.
  std::uint64_t disk_size() const { return disk_size_; }
  /// The committed file (or, for a new file, the working file it is written into).
  int disk() const { return disk_; }
  bool direct() const { return split_ == disk_size_; }
  /// errno of the first failed write (or cut) past the end of the committed file (0: none).
  int deferred_error() const { return deferred_error_; }
  /// Bytes written into the file directly.
  std::uint64_t direct_bytes() const { return direct_bytes_; }
  /// The bytes held in pages.
  std::size_t held_bytes() const { return (below_.size() + past_.size()) * kPage; }

  struct Range {
    std::uint64_t offset = 0, length = 0;
  };
  /// The byte ranges in which the file differs from the committed file on disk, by pages of
  /// 4 KiB (adjacent pages merged, but none across the end of the file on disk; everything past
  /// that end, unless direct: that part is in the file already). Only the pages written are
  /// compared, against the disk read page by page. False (errno set) on a read error.
  bool changed_ranges(std::vector<Range>& out) const;

 private:
  using Pages = std::map<std::uint64_t, std::unique_ptr<char[]>>;  ///< by page index
  /// The bytes under the pages of `pages`: the committed file's before `split_`, the file's past
  /// it (direct), zeros past what either holds.
  bool backing(const Pages& pages, std::uint64_t at, std::size_t n, char* out) const;
  bool read_layer(const Pages& pages, std::uint64_t at, std::size_t n, char* out) const;
  bool write_layer(Pages& pages, std::uint64_t at, std::size_t n, const char* in);
  bool write_direct(std::uint64_t at, std::size_t n, const char* in);
  void add(std::vector<Range>& out, std::uint64_t at, std::uint64_t n) const;
  int disk_ = -1;
  std::uint64_t disk_size_ = 0;
  /// Bytes of the committed file still part of this one (a truncation below it cuts them).
  std::uint64_t disk_end_ = 0;
  std::uint64_t size_ = 0;
  /// Where the pages of `below_` end and the file's own bytes begin (direct: the committed
  /// file's end; otherwise never).
  std::uint64_t split_ = UINT64_MAX;
  std::uint64_t direct_end_ = 0;  ///< the end of the file's bytes past split_ (direct)
  int deferred_error_ = 0;
  std::uint64_t direct_bytes_ = 0;
  Pages below_;  ///< pages written before split_
  Pages past_;   ///< pages written past split_ after a failed direct write
};

/// A file access property list whose files live in `store` (the name given to H5Fcreate or
/// H5Fopen is not used).
h5::Handle page_access(const std::shared_ptr<PageStore>& store, const std::string& file);

}  // namespace ltl
