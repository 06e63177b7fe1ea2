// The crash-safe commit of a results file (results_commit.hpp): the whole-file replacement, the
// in-place update with its redo journal, and the recovery of a journal left by a killed writer.
#include "results_commit.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>
#include <utility>

#include "error.hpp"

namespace ltl {

using h5::fail;

namespace {

std::atomic<std::uint64_t> written{0};

/// Forces the directory of `path` to the disk (a rename or unlink in it made durable).
void sync_directory_of(const std::string& path) {
  const auto parent = std::filesystem::path(path).parent_path();
  const std::string dir = parent.empty() ? "." : parent.string();
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail(dir, cat("cannot open to sync: ", errno_text(errno)));
  ::fsync(fd);
  ::close(fd);
}

/// Writes all of [data, data + n) at `offset` (or at the current position when offset < 0);
/// errno is set on failure. The fault point in the middle of a long write is the kill test's
/// "inside the write".
bool write_all(int fd, const char* data, std::size_t n, long long offset) {
  const std::size_t half = n / 2;
  for (std::size_t done = 0; done < n;) {
    const std::size_t end = done < half ? half : n;
    const ssize_t k =
        offset < 0 ? ::write(fd, data + done, end - done)
                   : ::pwrite(fd, data + done, end - done, static_cast<off_t>(offset + done));
    if (k < 0 && errno == EINTR) continue;
    if (k < 0) return false;
    written += static_cast<std::uint64_t>(k);
    done += static_cast<std::size_t>(k);
    if (done == half && n > 4096) fault_point();
  }
  return true;
}

/// The permission bits of the regular file at `path`, or -1 (no file).
int mode_of(const std::string& path) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return -1;
  return static_cast<int>(st.st_mode & 07777);
}

/// Creates `work` afresh (with the mode of `file` when it exists), fills it by `fill(fd)` (false:
/// failed, errno set) and forces it to the disk; a failure (ENOSPC) removes `work` and names
/// `file`.
template <class Fill>
void write_new(const std::string& work, const std::string& file, Fill fill) {
  const int fd = create_fresh(work, mode_of(file), file);
  if (!fill(fd) || ::fsync(fd) != 0) {
    const int e = errno;
    ::close(fd);
    ::unlink(work.c_str());
    fail(file, cat("cannot write the file: ", work, ": ", errno_text(e)));
  }
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(work.c_str());
    fail(file, cat("cannot close ", work, ": ", errno_text(e)));
  }
}

/// The bytes of the regular file `path` (opened without following a symbolic link); nullopt
/// when there is no such file and `missing_ok`.
std::optional<std::vector<char>> read_file(const std::string& path, bool missing_ok) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0 && missing_ok && errno == ENOENT) return std::nullopt;
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
      fail(path, cat("cannot read the file: ", e ? errno_text(e) : "it shrank"));
    }
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return image;
}

// ---------------------------------------------------------------------------------------------
// The redo journal: "LTLJRNL1", old size, new size, number of ranges, then per range its offset,
// length and bytes (padded to 8), then the checksum (s1, s2) of everything before it read as
// little-endian 64-bit words w_i (s1 = sum w_i, s2 = sum (i + 1) w_i, modulo 2^64), then
// "LTLJEND1". figures/ltl_results.py reads the same format.

constexpr char kJournalHead[9] = "LTLJRNL1", kJournalTail[9] = "LTLJEND1";

using Range = PageStore::Range;

struct Journal {
  std::uint64_t old_size = 0, new_size = 0;
  std::vector<std::pair<Range, const char*>> ranges;  ///< into the journal's bytes
};

std::uint64_t get_u64(const char* p) {
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

/// Adds the words of [data, data + n) (n a multiple of 8), the first being word `first` of the
/// journal, to its checksum (s1, s2).
void add_checksum(const char* data, std::size_t n, std::uint64_t first, std::uint64_t& s1,
                  std::uint64_t& s2) {
  for (std::size_t i = 0; i < n / 8; ++i) {
    const std::uint64_t w = get_u64(data + 8 * i);
    s1 += w;
    s2 += (first + i + 1) * w;
  }
}

/// Writes bytes to `fd` in chunks of 1 MiB, whole 64-bit words at a time, summing the journal's
/// checksum of what it writes.
class JournalOut {
 public:
  explicit JournalOut(int fd) : fd_(fd) {}
  bool put(const char* data, std::size_t n) {
    buf_.insert(buf_.end(), data, data + n);
    return buf_.size() < kChunk || flush();
  }
  bool put_u64(std::uint64_t v) {
    char b[8];
    std::memcpy(b, &v, 8);
    return put(b, 8);
  }
  /// Zeros up to the next multiple of 8 bytes.
  bool pad() {
    static const char zeros[8] = {};
    return put(zeros, (8 - (count_ + buf_.size()) % 8) % 8);
  }
  /// The checksum and the trailer after everything put so far (a multiple of 8 bytes).
  bool finish() {
    if (!flush()) return false;
    const std::uint64_t s1 = s1_, s2 = s2_;
    return put_u64(s1) && put_u64(s2) && put(kJournalTail, 8) && flush();
  }

 private:
  static constexpr std::size_t kChunk = std::size_t{1} << 20;
  bool flush() {
    const std::size_t n = buf_.size() / 8 * 8;
    add_checksum(buf_.data(), n, count_ / 8, s1_, s2_);
    if (!write_all(fd_, buf_.data(), n, -1)) return false;
    count_ += n;
    buf_.erase(buf_.begin(), buf_.begin() + static_cast<std::ptrdiff_t>(n));
    return true;
  }
  int fd_;
  std::vector<char> buf_;
  std::uint64_t count_ = 0, s1_ = 0, s2_ = 0;  ///< bytes written, checksum of them
};

/// Calls `out(data, n)` on the bytes [r.offset, r.offset + r.length) of `s`, 1 MiB at a time;
/// false (errno set) when `s` cannot be read or `out` fails.
template <class Out>
bool stream_range(const PageStore& s, Range r, Out out) {
  std::vector<char> chunk(std::min<std::uint64_t>(r.length, std::uint64_t{1} << 20));
  for (std::uint64_t done = 0; done < r.length;) {
    const std::size_t n = std::min<std::uint64_t>(chunk.size(), r.length - done);
    if (!s.read(r.offset + done, n, chunk.data()) || !out(chunk.data(), n, r.offset + done))
      return false;
    done += n;
  }
  return true;
}

/// Writes the journal of the change from the file on disk to `s` (its `ranges`) to `fd`.
bool write_journal(int fd, const PageStore& s, const std::vector<Range>& ranges) {
  JournalOut j(fd);
  bool ok = j.put(kJournalHead, 8) && j.put_u64(s.disk_size()) && j.put_u64(s.size()) &&
            j.put_u64(ranges.size());
  for (std::size_t k = 0; ok && k < ranges.size(); ++k)
    ok = j.put_u64(ranges[k].offset) && j.put_u64(ranges[k].length) &&
         stream_range(s, ranges[k],
                      [&](const char* d, std::size_t n, std::uint64_t) { return j.put(d, n); }) &&
         j.pad();
  return ok && j.finish();
}

/// The journal in `bytes`, or nullopt when it is incomplete or damaged.
std::optional<Journal> parse_journal(const std::vector<char>& bytes) {
  const std::size_t n = bytes.size();
  if (n < 56 || n % 8 || std::memcmp(bytes.data(), kJournalHead, 8) != 0 ||
      std::memcmp(bytes.data() + n - 8, kJournalTail, 8) != 0)
    return std::nullopt;
  std::uint64_t s1 = 0, s2 = 0;
  add_checksum(bytes.data(), n - 24, 0, s1, s2);
  if (get_u64(bytes.data() + n - 24) != s1 || get_u64(bytes.data() + n - 16) != s2)
    return std::nullopt;
  Journal j;
  j.old_size = get_u64(bytes.data() + 8);
  j.new_size = get_u64(bytes.data() + 16);
  const std::uint64_t count = get_u64(bytes.data() + 24);
  std::size_t at = 32;
  for (std::uint64_t k = 0; k < count; ++k) {
    if (at + 16 > n - 24) return std::nullopt;
    const Range r{get_u64(bytes.data() + at), get_u64(bytes.data() + at + 8)};
    at += 16;
    if (r.length > n - 24 - at || r.offset + r.length > j.new_size) return std::nullopt;
    j.ranges.push_back({r, bytes.data() + at});
    at += r.length + (8 - r.length % 8) % 8;
  }
  if (at != n - 24) return std::nullopt;
  return j;
}

/// Whether a file of `size` bytes can be the file of journal `j` in the middle of its commit: it
/// had j.old_size bytes when the journal was written, and grows (or shrinks) to j.new_size.
bool written_by(const Journal& j, std::uint64_t size) {
  return std::min(j.old_size, j.new_size) <= size && size <= std::max(j.old_size, j.new_size);
}

/// How applying a journal to a file ended.
enum class Applied { Done, FailedPastEnd, FailedInPlace };

/// Writes the ranges of `j` into the open file `fd`, the ones past `j.old_size` first (a full
/// disk fails there, before a byte of the old file is touched), sets its size to j.new_size and
/// syncs it; errno tells why it failed.
Applied apply_journal(int fd, const Journal& j) {
  for (bool past_end : {true, false}) {
    for (const auto& [r, data] : j.ranges)
      if ((r.offset >= j.old_size) == past_end &&
          !write_all(fd, data, r.length, static_cast<long long>(r.offset)))
        return past_end ? Applied::FailedPastEnd : Applied::FailedInPlace;
    if (past_end) fault_point();  // the new data written, the file's metadata not yet
  }
  if (::ftruncate(fd, static_cast<off_t>(j.new_size)) != 0 || ::fsync(fd) != 0)
    return Applied::FailedInPlace;
  return Applied::Done;
}

/// Writes the ranges of the journal of `s` (write_journal, all before the end of the file on
/// disk: what lies past it is in the file already) into the file `fd` from `s`, sets its size
/// and syncs it; errno tells why it failed.
bool apply_change(int fd, const PageStore& s, const std::vector<Range>& ranges) {
  const auto to_file = [fd](const char* d, std::size_t n, std::uint64_t at) {
    return write_all(fd, d, n, static_cast<long long>(at));
  };
  for (const Range& r : ranges)
    if (!stream_range(s, r, to_file)) return false;
  return ::ftruncate(fd, static_cast<off_t>(s.size())) == 0 && ::fsync(fd) == 0;
}

}  // namespace

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

std::string errno_text(int e) {
  return e == ENOSPC ? "no space left on the device (ENOSPC)" : std::strerror(e);
}

std::uint64_t bytes_committed() {
  return written.load();
}

std::string journal_path_of(const std::string& path) {
  return path + ".journal";
}

// A name this code owns beside the results file, written only while the writer holds the lock,
// so whatever is there is stale and is removed first. unlink(2) removes a symbolic link or a hard
// link without touching what it points to, and the file is then created with
// O_CREAT | O_EXCL | O_NOFOLLOW: a link made there meanwhile is an error, never followed.
int create_fresh(const std::string& path, int mode, const std::string& file) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode))
      fail(file, cat("cannot create the working file ", path, ": a directory is in the way"));
    if (::unlink(path.c_str()) != 0)
      fail(file, cat("cannot remove the stale working file ", path, ": ", errno_text(errno)));
  }
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
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

void write_replacing(const std::string& path, const std::string& text) {
  // Written beside and renamed, so that a reader never sees half a file.
  const std::string tmp = path + ".tmp";
  const int fd = create_fresh(tmp, -1, path);
  if (!write_all(fd, text.data(), text.size(), -1) || ::close(fd) != 0 ||
      std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    fail(path, cat("cannot write the file: ", errno_text(e)));
  }
}

void write_appending(const std::string& path, const std::string& text, std::string& on_disk) {
  std::size_t common = 0;
  const std::size_t n = std::min(text.size(), on_disk.size());
  while (common < n && text[common] == on_disk[common]) ++common;
  bool done = false;
  if (!on_disk.empty() && text.size() >= on_disk.size() && common + 256 >= on_disk.size()) {
    const int fd = ::open(path.c_str(), O_WRONLY | O_NOFOLLOW | O_CLOEXEC);
    struct stat st {};
    if (fd >= 0 && ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_nlink == 1 &&
        static_cast<std::size_t>(st.st_size) == on_disk.size())
      done =
          write_all(fd, text.data() + common, text.size() - common, static_cast<long long>(common));
    if (fd >= 0 && ::close(fd) != 0) done = false;
  }
  if (!done) write_replacing(path, text);
  on_disk = text;
}

void recover(const std::string& path) {
  const std::string jp = journal_path_of(path);
  const auto bytes = read_file(jp, true);
  if (!bytes) return;
  const std::optional<Journal> j = parse_journal(*bytes);
  if (j) {
    const int fd = ::open(path.c_str(), O_RDWR | O_NOFOLLOW | O_CLOEXEC);
    struct stat st {};
    const bool ours = fd >= 0 && ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) &&
                      written_by(*j, static_cast<std::uint64_t>(st.st_size));
    if (ours && (::flock(fd, LOCK_EX) != 0 || apply_journal(fd, *j) != Applied::Done)) {
      const int e = errno;
      ::close(fd);
      fail(path,
           cat("cannot complete the interrupted commit recorded in ", jp, ": ", errno_text(e)));
    }
    if (fd >= 0) ::close(fd);
  }
  if (::unlink(jp.c_str()) != 0 && errno != ENOENT)
    fail(path, cat("cannot remove the journal ", jp, ": ", errno_text(errno)));
  sync_directory_of(path);
}

h5::Handle open_committed(const std::string& path) {
  const auto bytes = read_file(journal_path_of(path), true);
  const std::optional<Journal> j = bytes ? parse_journal(*bytes) : std::nullopt;
  if (!j) return h5::open_for_reading(path);
  std::vector<char> image = *read_file(path, false);
  if (!written_by(*j, image.size())) return h5::open_for_reading(path);  // not this file's
  image.resize(j->new_size);
  for (const auto& [r, data] : j->ranges) std::memcpy(image.data() + r.offset, data, r.length);
  h5::quiet();
  h5::Handle fapl = h5::memory_access(path);
  h5::ok(H5Pset_file_image(fapl.get(), image.data(), image.size()), path,
         "cannot load the file into memory");
  // The core driver reads the image, not the name (which must not exist).
  const std::string name = journal_path_of(path) + ".view";
  return h5::checked(H5Fopen(name.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose, path,
                     "cannot open the file with its journal applied (damaged HDF5 file?)");
}

// ---------------------------------------------------------------------------------------------

CommittedFile::CommittedFile(CommittedFile&& o) noexcept
    : path_(std::move(o.path_)), file_(std::exchange(o.file_, -1)), store_(std::move(o.store_)) {}

CommittedFile& CommittedFile::operator=(CommittedFile&& o) noexcept {
  if (this != &o) {
    discard();
    path_ = std::move(o.path_);
    file_ = std::exchange(o.file_, -1);
    store_ = std::move(o.store_);
  }
  return *this;
}

hid_t CommittedFile::create() {
  discard();
  h5::quiet();
  // Written straight into the working file `<file>.partial` (results_pages.hpp, direct), renamed
  // onto the file by the commit.
  const std::string work = path_ + ".partial";
  store_ = std::make_shared<PageStore>(create_fresh(work, mode_of(path_), path_), 0, true);
  file_ = H5Fcreate(path_.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, page_access(store_, path_).get());
  if (file_ < 0) {
    discard();
    fail(path_, "cannot create the file");
  }
  return static_cast<hid_t>(file_);
}

hid_t CommittedFile::begin() {
  if (file_ >= 0) return static_cast<hid_t>(file_);
  h5::quiet();
  struct stat st {};
  if (::lstat(journal_path_of(path_).c_str(), &st) == 0) recover(path_);
  // Opened over the file on disk (results_pages.hpp): HDF5 reads the committed file where it
  // needs to; what it writes before the file's end is held in pages until the commit, and what
  // it writes past the end goes into the file there (direct), where no reader looks. A file that
  // cannot be opened for writing is changed in pages alone and replaced whole.
  const int flags = O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC;
  int fd = ::open(path_.c_str(), O_RDWR | flags);
  const bool direct = fd >= 0;
  if (fd < 0) fd = ::open(path_.c_str(), O_RDONLY | flags);
  if (fd < 0) fail(path_, cat("cannot open the results file: ", errno_text(errno)));
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    fail(path_, "is not a regular file");
  }
  if (st.st_size == 0) {
    ::close(fd);
    fail(path_, "is empty, not a results file");
  }
  store_ = std::make_shared<PageStore>(fd, static_cast<std::uint64_t>(st.st_size), direct);
  file_ = H5Fopen(path_.c_str(), H5F_ACC_RDWR, page_access(store_, path_).get());
  if (file_ < 0) {
    const int e = errno;
    discard();
    fail(path_, cat("cannot open the results file for a change (a damaged file?)",
                    e == EIO ? ": cannot read it: " + errno_text(e) : std::string()));
  }
  return static_cast<hid_t>(file_);
}

void CommittedFile::commit() {
  if (file_ < 0) fail(path_, "commit without changes");
  fault_point();
  const hid_t f = static_cast<hid_t>(file_);
  if (H5Fflush(f, H5F_SCOPE_LOCAL) < 0) {
    discard();
    fail(path_, "cannot flush the file to its pages in memory");
  }
  const herr_t closed = H5Fclose(f);  // to the pages and past the file's end
  file_ = -1;
  if (closed < 0) {
    discard();
    fail(path_, "cannot close the file");
  }
  if (const int e = store_->deferred_error()) {
    discard();  // the working file removed, or the file on disk cut back to its committed end
    fail(path_, cat("cannot write the file: ", errno_text(e)));
  }
  const std::shared_ptr<PageStore> store = std::move(store_);
  written += store->direct_bytes();
  if (store->disk_size() == 0)  // a new file, in <file>.partial
    commit_fresh(*store);
  else if (!update_in_place(*store))
    replace_whole(*store);
}

void CommittedFile::commit_fresh(const PageStore& s) {
  recover(path_);  // a journal left beside the file belongs to the file being replaced
  const std::string work = path_ + ".partial";
  if (::ftruncate(s.disk(), static_cast<off_t>(s.size())) != 0 || ::fsync(s.disk()) != 0) {
    const int e = errno;
    ::unlink(work.c_str());
    fail(path_, cat("cannot write the file: ", work, ": ", errno_text(e)));
  }
  fault_point();
  if (std::rename(work.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    ::unlink(work.c_str());
    fail(path_, cat("cannot move ", work, " into place: ", errno_text(e)));
  }
  sync_directory_of(path_);
  fault_point();
}

void CommittedFile::replace_whole(const PageStore& s) {
  recover(path_);  // a journal left beside the file belongs to the file being replaced
  const std::string work = path_ + ".partial";
  write_new(work, path_, [&](int fd) {
    return stream_range(s, {0, s.size()}, [fd](const char* d, std::size_t n, std::uint64_t) {
      return write_all(fd, d, n, -1);
    });
  });
  // What the change wrote past the end of the file it was opened over is dropped from it (its
  // readers look no further than that end).
  if (s.direct()) (void)::ftruncate(s.disk(), static_cast<off_t>(s.disk_size()));
  fault_point();
  if (std::rename(work.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    fail(path_, cat("cannot move ", work, " into place: ", errno_text(e)));
  }
  sync_directory_of(path_);
  fault_point();
}

// False (nothing done) when the file cannot be updated in place: the change was not opened for
// writing over it, the file at the path is not that file any more (or has other names), or a
// reader has it open (HDF5 holds a shared lock while a file is open). The exclusive lock keeps
// readers out until the file is complete again. What the change wrote past the end of the file
// is there already: it is forced to the disk before the journal, which then holds only the
// pages changed before that end (HDF5's metadata).
bool CommittedFile::update_in_place(const PageStore& s) {
  if (!s.direct()) return false;
  const int fd = s.disk();
  struct stat was {
  }, st{};
  if (::fstat(fd, &was) != 0 || ::lstat(path_.c_str(), &st) != 0 || !S_ISREG(st.st_mode) ||
      st.st_nlink != 1 || st.st_dev != was.st_dev || st.st_ino != was.st_ino ||
      static_cast<std::uint64_t>(was.st_size) < s.disk_size() ||
      ::flock(fd, LOCK_EX | LOCK_NB) != 0)
    return false;
  const auto cut_back = [&] {  // the file as committed, unlocked
    (void)::ftruncate(fd, static_cast<off_t>(s.disk_size()));
    ::flock(fd, LOCK_UN);
  };
  // The new data, past the old end, on the disk first.
  if (::ftruncate(fd, static_cast<off_t>(std::max(s.size(), s.disk_size()))) != 0 ||
      ::fsync(fd) != 0) {
    const int e = errno;
    cut_back();
    fail(path_, cat("cannot write the file: ", errno_text(e)));
  }
  fault_point();  // the new data written, the file's metadata not yet
  // The pages that changed before the old end, against the file itself (under the lock).
  std::vector<Range> ranges;
  if (!s.changed_ranges(ranges)) {
    ::flock(fd, LOCK_UN);
    return false;  // replaced whole, from the file as the change left it
  }
  const std::string jp = journal_path_of(path_);
  try {
    write_new(jp, path_, [&](int j) { return write_journal(j, s, ranges); });
    sync_directory_of(jp);
  } catch (...) {
    cut_back();
    throw;
  }
  fault_point();  // the journal complete, the file's metadata untouched
  if (!apply_change(fd, s, ranges)) {
    const int e = errno;
    ::flock(fd, LOCK_UN);  // the journal stays: the next writer or reader completes the commit
    fail(path_, cat("cannot update the file in place: ", errno_text(e), "; ", jp,
                    " holds the change (applied by the next run or --resume)"));
  }
  fault_point();  // the file complete, the journal still there
  ::flock(fd, LOCK_UN);
  if (::unlink(jp.c_str()) != 0) fail(path_, cat("cannot remove ", jp, ": ", errno_text(errno)));
  sync_directory_of(jp);
  return true;
}

void CommittedFile::discard() noexcept {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
  file_ = -1;
  if (store_) {
    written += store_->direct_bytes();
    if (store_->disk_size() == 0)  // a new file
      ::unlink((path_ + ".partial").c_str());
    else if (store_->direct())  // the file as committed: what the change wrote past its end cut
      (void)::ftruncate(store_->disk(), static_cast<off_t>(store_->disk_size()));
  }
  store_.reset();
}

}  // namespace ltl
