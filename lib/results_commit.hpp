// The crash-safe commit of a results file. Every change (the mesh with the first step, each further
// step, a status) is made through HDF5 over the file on disk (lib/results_pages.hpp): HDF5 reads
// the committed file where it needs to; what it writes before the file's end (HDF5's metadata)
// is held in pages, and what it writes past the end (the new step's data) goes into the file
// there, where no reader looks (a reader reads up to the end the committed metadata gives).
// commit() then makes the change so that a process killed at any instant, a full disk or a reader
// opening the file meanwhile never sees half of it:
//
//  - A new file is written into `<file>.partial` (created afresh) as it is made; its commit
//    fsyncs it and renames it onto `<file>` (rename(2) is atomic), and fsyncs the directory.
//  - A commit while a reader has the file open REPLACES the file whole: the file as changed is
//    copied into `<file>.partial` with checked write(2) calls, fsync'ed and renamed onto
//    `<file>`; the bytes the change wrote past the old end are cut from the old file. An open
//    reader keeps the previous file.
//  - Any other commit UPDATES the file IN PLACE under an exclusive flock(2) (HDF5 readers hold a
//    shared one while the file is open, so none is open meanwhile; one that tries waits,
//    lib/hdf5_io.hpp): the file is set to its new size and fsync'ed (the new data past the old
//    end on the disk), the pages that changed before the old end are written to the redo journal
//    `<file>.journal` (header, ranges, a checksum, a trailer) and fsync'ed, then written into the
//    file, which is fsync'ed, and the journal removed. A process killed in the middle leaves the
//    previous file (perhaps with bytes past its end, which nothing reads) and no journal or an
//    incomplete one (ignored and removed), or the file and a complete journal, which the next
//    writer applies (recover()) and which a reader applies in memory (open_committed()).
//  - A full disk during the change is kept as the change's error (HDF5 never sees it): the
//    commit refuses, cuts the file back to its committed end (or removes `<file>.partial`), and
//    the previous file is intact.
//
// Cost: about the bytes that changed, once (the metadata pages twice), instead of the whole file
// per commit. No image of the file is held: the writer's memory is the metadata pages of one
// change.
//
// Working files (`.partial`, `.journal`, an XDMF file's `.tmp`) are created afresh
// (O_CREAT | O_EXCL | O_NOFOLLOW, a stale entry unlinked first, never followed), with the mode of
// the file they replace; the committed file is read without following a link (O_NOFOLLOW).
// Environment LTL_FAULT_AT_WRITE=k (tests only) kills the process at the k-th write event.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "hdf5_io.hpp"
#include "results_pages.hpp"

namespace ltl {

/// Test hook of the kill test: with LTL_FAULT_AT_WRITE=k the process is killed (SIGKILL, no
/// cleanup) at the k-th call (each dataset written, each stage of a commit).
void fault_point();
/// errno as text, with ENOSPC spelled out.
std::string errno_text(int e);
/// Creates `path` afresh for reading and writing (see above); with `mode` >= 0 it gets exactly
/// that mode.
/// Returns the file descriptor; errors name `file`.
int create_fresh(const std::string& path, int mode, const std::string& file);
/// Writes `text` to `path` atomically: to `path + ".tmp"` (create_fresh), then renamed.
void write_replacing(const std::string& path, const std::string& text);
/// Makes the file `path` hold `text`, given that it holds `on_disk` (what this process wrote there
/// last; empty: unknown). When `text` only changes the last 256 bytes of `on_disk` and extends it
/// (a step added to an XDMF file), and the file is still that text, the file is updated in place
/// by one write of what changed; otherwise it is replaced (write_replacing). Then on_disk = text.
/// For files derived from the results file (XDMF), which a kill in the middle of that one write
/// may leave incomplete until the next run or --resume rewrites them.
void write_appending(const std::string& path, const std::string& text, std::string& on_disk);

/// Bytes this process has written to results files, journals and XDMF files (all commits).
std::uint64_t bytes_committed();

/// The journal beside a results file.
std::string journal_path_of(const std::string& path);
/// Applies a complete journal left beside `path` by a killed writer and removes it; removes an
/// incomplete one (the file was not touched). Nothing to do without a journal.
void recover(const std::string& path);
/// Opens `path` for reading (h5::open_for_reading); when a complete journal lies beside it (a
/// writer was killed in the middle of an in-place commit), the file with the journal applied, in
/// memory: what recover() will write.
h5::Handle open_committed(const std::string& path);

/// An HDF5 file changed in memory and committed to `path` as described above.
class CommittedFile {
 public:
  CommittedFile() = default;
  explicit CommittedFile(std::string path) : path_(std::move(path)) {}
  CommittedFile(CommittedFile&& o) noexcept;
  CommittedFile& operator=(CommittedFile&& o) noexcept;
  CommittedFile(const CommittedFile&) = delete;
  CommittedFile& operator=(const CommittedFile&) = delete;
  ~CommittedFile() { discard(); }

  /// Starts a new, empty file in memory; its first commit replaces `path` whole.
  hid_t create();
  /// Opens the committed file for a change in memory (recovering a journal first); returns the
  /// open file when a change is already under way.
  hid_t begin();
  /// The file in memory (-1 when no change is under way).
  hid_t id() const { return static_cast<hid_t>(file_); }
  /// Closes the file in memory and puts the change on disk.
  void commit();
  /// Drops the change under way (nothing on disk changes).
  void discard() noexcept;
  const std::string& path() const { return path_; }
  /// The bytes the change under way holds in memory (0 when none is under way).
  std::size_t held_bytes() const { return store_ ? store_->held_bytes() : 0; }

 private:
  void commit_fresh(const PageStore& s);
  void replace_whole(const PageStore& s);
  bool update_in_place(const PageStore& s);
  std::string path_;
  long long file_ = -1;  ///< hid_t of the file in memory while a change is under way
  /// The pages of the change under way, over the file on disk it was opened over (a new file:
  /// over `<file>.partial`, of size 0 when opened; begin() refuses an empty file).
  std::shared_ptr<PageStore> store_;
};

}  // namespace ltl
