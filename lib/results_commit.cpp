// The crash-safe commit of a results file (results_commit.hpp): the whole-file replacement, the
// in-place update with its redo journal, and the recovery of a journal left by a killed writer.
#include "results_commit.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/mman.h>
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

/// Writes `data` to `work` (created afresh, with the mode of `file` when it exists) and forces
/// it to the disk; a failure (ENOSPC) removes `work` and names `file`.
void write_file(const std::string& work, const std::vector<char>& data, const std::string& file) {
  const int fd = create_fresh(work, mode_of(file), file);
  if (!write_all(fd, data.data(), data.size(), -1) || ::fsync(fd) != 0) {
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

struct Range {
  std::uint64_t offset = 0, length = 0;
};

struct Journal {
  std::uint64_t old_size = 0, new_size = 0;
  std::vector<std::pair<Range, const char*>> ranges;  ///< into the journal's bytes
};

void put_u64(std::vector<char>& out, std::uint64_t v) {
  char b[8];
  std::memcpy(b, &v, 8);
  out.insert(out.end(), b, b + 8);
}

std::uint64_t get_u64(const char* p) {
  std::uint64_t v;
  std::memcpy(&v, p, 8);
  return v;
}

std::pair<std::uint64_t, std::uint64_t> checksum(const char* data, std::size_t n) {
  std::uint64_t s1 = 0, s2 = 0;
  for (std::size_t i = 0; i < n / 8; ++i) {
    const std::uint64_t w = get_u64(data + 8 * i);
    s1 += w;
    s2 += (i + 1) * w;
  }
  return {s1, s2};
}

/// The byte ranges in which `next` differs from the file `fd` of prev_size bytes (mapped: no
/// copy of the previous image is kept in memory), by pages of 4 KiB, adjacent pages merged, and
/// what `next` adds past the end of the file. nullopt when the file cannot be mapped.
std::optional<std::vector<Range>> changed_ranges(int fd, std::size_t prev_size,
                                                 const std::vector<char>& next) {
  constexpr std::size_t page = 4096;
  std::vector<Range> out;
  const std::size_t common = std::min(prev_size, next.size());
  if (common > 0) {
    void* mapped = ::mmap(nullptr, prev_size, PROT_READ, MAP_SHARED, fd, 0);
    if (mapped == MAP_FAILED) return std::nullopt;
    const char* prev = static_cast<const char*>(mapped);
    for (std::size_t at = 0; at < common; at += page) {
      const std::size_t n = std::min(page, common - at);
      if (std::memcmp(prev + at, next.data() + at, n) == 0) continue;
      if (!out.empty() && out.back().offset + out.back().length == at)
        out.back().length += n;
      else
        out.push_back({at, n});
    }
    ::munmap(mapped, prev_size);
  }
  if (next.size() > common) out.push_back({common, next.size() - common});
  return out;
}

std::vector<char> journal_bytes(std::size_t prev_size, const std::vector<char>& next,
                                const std::vector<Range>& ranges) {
  std::vector<char> j(kJournalHead, kJournalHead + 8);
  put_u64(j, prev_size);
  put_u64(j, next.size());
  put_u64(j, ranges.size());
  for (const Range& r : ranges) {
    put_u64(j, r.offset);
    put_u64(j, r.length);
    j.insert(j.end(), next.data() + r.offset, next.data() + r.offset + r.length);
    j.resize(j.size() + (8 - r.length % 8) % 8, '\0');
  }
  const auto [s1, s2] = checksum(j.data(), j.size());
  put_u64(j, s1);
  put_u64(j, s2);
  j.insert(j.end(), kJournalTail, kJournalTail + 8);
  return j;
}

/// The journal in `bytes`, or nullopt when it is incomplete or damaged.
std::optional<Journal> parse_journal(const std::vector<char>& bytes) {
  const std::size_t n = bytes.size();
  if (n < 56 || n % 8 || std::memcmp(bytes.data(), kJournalHead, 8) != 0 ||
      std::memcmp(bytes.data() + n - 8, kJournalTail, 8) != 0)
    return std::nullopt;
  const auto [s1, s2] = checksum(bytes.data(), n - 24);
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
    : path_(std::move(o.path_)),
      file_(std::exchange(o.file_, -1)),
      committed_size_(o.committed_size_),
      fresh_(o.fresh_) {}

CommittedFile& CommittedFile::operator=(CommittedFile&& o) noexcept {
  if (this != &o) {
    discard();
    path_ = std::move(o.path_);
    file_ = std::exchange(o.file_, -1);
    committed_size_ = o.committed_size_;
    fresh_ = o.fresh_;
  }
  return *this;
}

hid_t CommittedFile::create() {
  discard();
  h5::quiet();
  const std::string work = path_ + ".partial";
  file_ = H5Fcreate(work.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, h5::memory_access(path_).get());
  if (file_ < 0)
    fail(path_,
         "cannot create the file (does its directory exist, is it writable, is the file "
         "open elsewhere?)");
  fresh_ = true;
  committed_size_.reset();
  return static_cast<hid_t>(file_);
}

hid_t CommittedFile::begin() {
  if (file_ >= 0) return static_cast<hid_t>(file_);
  h5::quiet();
  struct stat st {};
  if (::lstat(journal_path_of(path_).c_str(), &st) == 0) recover(path_);
  // Opened in memory from the image on disk (the core driver without a backing store writes
  // nothing to disk); the name given to H5Fopen must not exist, so a stale working file is
  // removed first. The file is mapped only while the property list takes HDF5's copy of it, so
  // that at most two images are in memory (HDF5's and, at the commit, the one written out) and
  // none between changes.
  const std::string work = path_ + ".partial";
  if (::lstat(work.c_str(), &st) == 0 && !S_ISDIR(st.st_mode)) ::unlink(work.c_str());
  h5::Handle fapl = h5::memory_access(path_);
  {  // mapped, not read into a buffer of ours: HDF5 copies the page cache's pages
    const int fd = ::open(path_.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) fail(path_, cat("cannot open the results file: ", errno_text(errno)));
    struct stat fs {};
    if (::fstat(fd, &fs) != 0 || !S_ISREG(fs.st_mode)) {
      ::close(fd);
      fail(path_, "is not a regular file");
    }
    const std::size_t size = static_cast<std::size_t>(fs.st_size);
    if (size == 0) {
      ::close(fd);
      fail(path_, "is empty, not a results file");
    }
    void* image = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    ::close(fd);
    if (image == MAP_FAILED) fail(path_, cat("cannot map the file: ", errno_text(errno)));
    const herr_t set = H5Pset_file_image(fapl.get(), image, size);
    ::munmap(image, size);
    h5::ok(set, path_, "cannot load the file into memory");
    committed_size_ = size;
  }
  file_ = H5Fopen(work.c_str(), H5F_ACC_RDWR, fapl.get());
  if (file_ < 0)
    fail(path_, cat("cannot open the results file in memory for writing (a damaged file, or ", work,
                    " is in the way?)"));
  fresh_ = false;
  return static_cast<hid_t>(file_);
}

void CommittedFile::commit() {
  if (file_ < 0) fail(path_, "commit without changes");
  fault_point();
  const hid_t f = static_cast<hid_t>(file_);
  if (H5Fflush(f, H5F_SCOPE_LOCAL) < 0) {
    discard();
    fail(path_, "cannot flush the file to its image in memory");
  }
  const ssize_t size = H5Fget_file_image(f, nullptr, 0);
  std::vector<char> image(size > 0 ? static_cast<std::size_t>(size) : 0);
  if (size <= 0 || H5Fget_file_image(f, image.data(), image.size()) != size) {
    discard();
    fail(path_, "cannot get the image of the file in memory");
  }
  const herr_t closed = H5Fclose(f);  // in memory: writes nothing
  file_ = -1;
  if (closed < 0) fail(path_, "cannot close the file in memory");
  if (fresh_ || !committed_size_ || !update_in_place(image)) replace_whole(image);
  committed_size_ = image.size();
  fresh_ = false;
}

void CommittedFile::replace_whole(const std::vector<char>& image) {
  committed_size_.reset();  // whatever happens, the file on disk is unknown until it is in place
  recover(path_);           // a journal left beside the file belongs to the file being replaced
  const std::string work = path_ + ".partial";
  write_file(work, image, path_);
  fault_point();
  if (std::rename(work.c_str(), path_.c_str()) != 0) {
    const int e = errno;
    fail(path_, cat("cannot move ", work, " into place: ", errno_text(e)));
  }
  sync_directory_of(path_);
  fault_point();
}

// False (nothing done) when the file cannot be updated in place: it is not the file last
// committed (its size differs, it has other names), it cannot be opened for writing, or a reader
// has it open (HDF5 holds a shared lock while a file is open). The exclusive lock keeps readers
// out until the file is complete again.
bool CommittedFile::update_in_place(const std::vector<char>& image) {
  const int fd = ::open(path_.c_str(), O_RDWR | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_nlink != 1 ||
      static_cast<std::size_t>(st.st_size) != *committed_size_ ||
      ::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd);
    return false;
  }
  // The pages that changed, against the file itself (under the lock).
  const auto ranges = changed_ranges(fd, *committed_size_, image);
  if (!ranges) {
    ::close(fd);
    return false;
  }
  const std::string jp = journal_path_of(path_);
  const std::vector<char> bytes = journal_bytes(*committed_size_, image, *ranges);
  const Journal j = *parse_journal(bytes);
  try {
    write_file(jp, bytes, path_);
    sync_directory_of(jp);
  } catch (...) {
    ::close(fd);
    throw;
  }
  fault_point();  // the journal complete, the file untouched
  const Applied applied = apply_journal(fd, j);
  if (applied != Applied::Done) {
    const int e = errno;
    committed_size_.reset();
    if (applied == Applied::FailedPastEnd && ::ftruncate(fd, static_cast<off_t>(j.old_size)) == 0 &&
        ::fsync(fd) == 0) {
      ::close(fd);
      ::unlink(jp.c_str());  // the previous file is intact
      fail(path_, cat("cannot write the file: ", errno_text(e)));
    }
    ::close(fd);  // the journal stays: the next writer or reader completes the commit
    fail(path_, cat("cannot update the file in place: ", errno_text(e), "; ", jp,
                    " holds the change (applied by the next run or --resume)"));
  }
  fault_point();  // the file complete, the journal still there
  ::close(fd);    // releases the lock
  if (::unlink(jp.c_str()) != 0) fail(path_, cat("cannot remove ", jp, ": ", errno_text(errno)));
  sync_directory_of(jp);
  return true;
}

void CommittedFile::discard() noexcept {
  if (file_ < 0) return;
  H5Fclose(static_cast<hid_t>(file_));
  file_ = -1;
  std::error_code ec;
  std::filesystem::remove(path_ + ".partial", ec);
}

}  // namespace ltl
