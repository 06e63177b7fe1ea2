// A results file being changed, held as the pages written since it was opened over the committed
// file on disk. The writer's memory is then the bytes of one change (a step's data and a few pages
// of HDF5 metadata), not the whole file: HDF5 reads what it needs of the committed file when it
// needs it, and every write lands in a page of 4 KiB held here. lib/results_commit.cpp puts the
// pages that differ from the file on disk into the redo journal and then into the file.
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
class PageStore {
 public:
  static constexpr std::size_t kPage = 4096;
  /// A new, empty file (nothing on disk).
  PageStore() = default;
  /// Over the committed file open read-only on `fd` (owned: closed with the store), `size` bytes.
  PageStore(int fd, std::uint64_t size);
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
  /// The size of the committed file on disk when the store was opened over it (0: none).
  std::uint64_t disk_size() const { return disk_size_; }
  /// The committed file (-1: none).
  int disk() const { return disk_; }
  /// The bytes held in pages.
  std::size_t held_bytes() const { return pages_.size() * kPage; }

  struct Range {
    std::uint64_t offset = 0, length = 0;
  };
  /// The byte ranges in which the file differs from the committed file on disk, by pages of
  /// 4 KiB (adjacent pages merged, but none across the end of the file on disk; everything past
  /// that end). Only the pages written are compared, against the disk read page by page. False
  /// (errno set) on a read error.
  bool changed_ranges(std::vector<Range>& out) const;

 private:
  void add(std::vector<Range>& out, std::uint64_t at, std::uint64_t n) const;
  bool read_disk(std::uint64_t at, std::size_t n, char* out) const;
  int disk_ = -1;
  std::uint64_t disk_size_ = 0;
  /// Bytes of the committed file still part of this one (a truncation below it cuts them).
  std::uint64_t disk_end_ = 0;
  std::uint64_t size_ = 0;
  std::map<std::uint64_t, std::unique_ptr<char[]>> pages_;  ///< by page index
};

/// A file access property list whose files live in `store` (the name given to H5Fcreate or
/// H5Fopen is not used). Opening without H5F_ACC_CREAT needs a store over a file on disk.
h5::Handle page_access(const std::shared_ptr<PageStore>& store, const std::string& file);

}  // namespace ltl
