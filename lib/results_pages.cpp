// The pages of a results file being changed, and the HDF5 file driver that keeps them
// (results_pages.hpp).
#include "results_pages.hpp"

#include <H5FDpublic.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <new>

#if H5_VERSION_GE(1, 13, 2)
#include <H5FDdevelop.h>  // the driver interface moved there (not compiled here: Debian has 1.10)
#endif

namespace ltl {

PageStore::PageStore(int fd, std::uint64_t size)
    : disk_(fd), disk_size_(size), disk_end_(size), size_(size) {}

PageStore::~PageStore() {
  if (disk_ >= 0) ::close(disk_);
}

namespace {
/// Reads all of [at, at + n) of `fd` into `out`; false (errno set; EIO when the file is shorter).
bool pread_all(int fd, char* out, std::size_t n, std::uint64_t at) {
  for (std::size_t done = 0; done < n;) {
    const ssize_t k = ::pread(fd, out + done, n - done, static_cast<off_t>(at + done));
    if (k < 0 && errno == EINTR) continue;
    if (k <= 0) {
      if (k == 0) errno = EIO;  // the file on disk shrank under us
      return false;
    }
    done += static_cast<std::size_t>(k);
  }
  return true;
}
}  // namespace

bool PageStore::read_disk(std::uint64_t at, std::size_t n, char* out) const {
  const std::size_t from_disk = at < disk_end_ ? std::min<std::uint64_t>(n, disk_end_ - at) : 0;
  if (!pread_all(disk_, out, from_disk, at)) return false;
  std::memset(out + from_disk, 0, n - from_disk);
  return true;
}

bool PageStore::read(std::uint64_t at, std::size_t n, char* out) const {
  const std::uint64_t end = at + n;
  for (std::uint64_t p = at; p < end;) {
    const auto held = pages_.lower_bound(p / kPage);
    if (held != pages_.end() && held->first == p / kPage) {
      const std::size_t off = p % kPage, len = std::min<std::uint64_t>(kPage - off, end - p);
      std::memcpy(out + (p - at), held->second.get() + off, len);
      p += len;
      continue;
    }
    // Not held up to the next held page: from the disk in one read.
    const std::uint64_t stop =
        held == pages_.end() ? end : std::min<std::uint64_t>(end, held->first * kPage);
    if (!read_disk(p, stop - p, out + (p - at))) return false;
    p = stop;
  }
  return true;
}

bool PageStore::write(std::uint64_t at, std::size_t n, const char* in) {
  const std::uint64_t end = at + n;
  for (std::uint64_t p = at; p < end;) {
    const std::uint64_t index = p / kPage;
    const std::size_t off = p % kPage, len = std::min<std::uint64_t>(kPage - off, end - p);
    auto& page = pages_[index];
    if (!page) {
      page.reset(new char[kPage]);
      // A page written in part keeps the rest of what the file holds there.
      if (len < kPage && !read_disk(index * kPage, kPage, page.get())) {
        pages_.erase(index);
        return false;
      }
    }
    std::memcpy(page.get() + off, in + (p - at), len);
    p += len;
  }
  size_ = std::max(size_, end);
  return true;
}

void PageStore::truncate(std::uint64_t n) {
  if (n < size_) {
    pages_.erase(pages_.lower_bound((n + kPage - 1) / kPage), pages_.end());
    const auto last = pages_.find(n / kPage);
    if (last != pages_.end()) std::memset(last->second.get() + n % kPage, 0, kPage - n % kPage);
    disk_end_ = std::min(disk_end_, n);
  }
  size_ = n;
}

void PageStore::add(std::vector<Range>& out, std::uint64_t at, std::uint64_t n) const {
  if (!out.empty() && out.back().offset + out.back().length == at && at != disk_size_)
    out.back().length += n;
  else
    out.push_back({at, n});
}

bool PageStore::changed_ranges(std::vector<Range>& out) const {
  out.clear();
  // The pages written, and those the file on disk holds stale bytes in (cut, then grown again).
  std::vector<std::uint64_t> candidates;
  candidates.reserve(pages_.size());
  for (const auto& [index, page] : pages_) candidates.push_back(index);
  const std::uint64_t stale_end = std::min(size_, disk_size_);
  if (disk_end_ < stale_end) {
    for (std::uint64_t i = disk_end_ / kPage; i * kPage < stale_end; ++i) candidates.push_back(i);
    std::sort(candidates.begin(), candidates.end());
    candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  }
  std::unique_ptr<char[]> now(new char[kPage]), disk(new char[kPage]);
  for (const std::uint64_t i : candidates) {
    const std::uint64_t s = i * kPage;
    if (s >= size_) break;
    const std::size_t len = std::min<std::uint64_t>(kPage, size_ - s);
    // The part before the end of the file on disk is compared with it; the part past it is new.
    // A range lies on one side of that end, never across (the commit writes the part past it
    // first).
    const std::size_t below = s < disk_size_ ? std::min<std::uint64_t>(len, disk_size_ - s) : 0;
    if (below > 0) {
      if (!read(s, below, now.get()) || !pread_all(disk_, disk.get(), below, s)) return false;
      if (std::memcmp(now.get(), disk.get(), below) != 0) add(out, s, below);
    }
    if (below < len) add(out, s + below, len - below);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// The file driver. HDF5 asks it for the bytes at an address (read), gives it bytes to keep
// (write), and tells it the end of the allocated space (eoa) and when to cut the file there
// (truncate). Its property-list information and its open files hold the store by shared_ptr.

namespace {

using Shared = std::shared_ptr<PageStore>;

struct PagedFile {
  H5FD_t pub;  // first: HDF5 sees a PagedFile* as its H5FD_t*
  Shared* store;
  haddr_t eoa;
};

PageStore& store_of(const H5FD_t* f) {
  return **reinterpret_cast<const PagedFile*>(f)->store;
}

void* info_copy(const void* info) {
  return new (std::nothrow) Shared(*static_cast<const Shared*>(info));
}

herr_t info_free(void* info) {
  delete static_cast<Shared*>(info);
  return 0;
}

void* info_get(H5FD_t* f) {
  return info_copy(reinterpret_cast<PagedFile*>(f)->store);
}

H5FD_t* open(const char*, unsigned flags, hid_t fapl, haddr_t) {
  const auto* info = static_cast<const Shared*>(H5Pget_driver_info(fapl));
  if (!info || !*info) return nullptr;
  PageStore& s = **info;
  if (!(flags & H5F_ACC_CREAT) && s.disk() < 0 && s.size() == 0) return nullptr;  // no file
  if (flags & H5F_ACC_TRUNC) s.truncate(0);
  auto* f = new (std::nothrow) PagedFile{};
  if (!f) return nullptr;
  f->store = new (std::nothrow) Shared(*info);
  if (!f->store) {
    delete f;
    return nullptr;
  }
  return &f->pub;
}

herr_t close(H5FD_t* f) {
  auto* p = reinterpret_cast<PagedFile*>(f);
  delete p->store;
  delete p;
  return 0;
}

herr_t query(const H5FD_t*, unsigned long* flags) {
  // As HDF5's own drivers that keep a file in one address space (sec2, core): metadata and small
  // raw data aggregated, metadata accumulated, small raw data read through the sieve buffer.
  if (flags)
    *flags = H5FD_FEAT_AGGREGATE_METADATA | H5FD_FEAT_ACCUMULATE_METADATA | H5FD_FEAT_DATA_SIEVE |
             H5FD_FEAT_AGGREGATE_SMALLDATA;
  return 0;
}

haddr_t get_eoa(const H5FD_t* f, H5FD_mem_t) {
  return reinterpret_cast<const PagedFile*>(f)->eoa;
}

herr_t set_eoa(H5FD_t* f, H5FD_mem_t, haddr_t addr) {
  reinterpret_cast<PagedFile*>(f)->eoa = addr;
  return 0;
}

haddr_t get_eof(const H5FD_t* f, H5FD_mem_t) {
  return store_of(f).size();
}

herr_t read(H5FD_t* f, H5FD_mem_t, hid_t, haddr_t addr, size_t size, void* buf) {
  return store_of(f).read(addr, size, static_cast<char*>(buf)) ? 0 : -1;
}

herr_t write(H5FD_t* f, H5FD_mem_t, hid_t, haddr_t addr, size_t size, const void* buf) {
  return store_of(f).write(addr, size, static_cast<const char*>(buf)) ? 0 : -1;
}

herr_t truncate(H5FD_t* f, hid_t, hbool_t) {
  store_of(f).truncate(reinterpret_cast<PagedFile*>(f)->eoa);
  return 0;
}

hid_t driver() {
  static const hid_t id = [] {
    static H5FD_class_t cls{};
#if H5_VERSION_GE(1, 13, 2)
    cls.version = H5FD_CLASS_VERSION;
    cls.value = static_cast<H5FD_class_value_t>(511);  // in the range left to applications
#endif
    cls.name = "ltl_pages";
    cls.maxaddr = (static_cast<haddr_t>(1) << 63) - 1;  // off_t's range, as sec2
    cls.fc_degree = H5F_CLOSE_WEAK;
    cls.fapl_size = sizeof(Shared);
    cls.fapl_get = info_get;
    cls.fapl_copy = info_copy;
    cls.fapl_free = info_free;
    cls.open = open;
    cls.close = close;
    cls.query = query;
    cls.get_eoa = get_eoa;
    cls.set_eoa = set_eoa;
    cls.get_eof = get_eof;
    cls.read = read;
    cls.write = write;
    cls.truncate = truncate;
    const H5FD_mem_t map[] = H5FD_FLMAP_DICHOTOMY;
    std::copy(std::begin(map), std::end(map), std::begin(cls.fl_map));
    return H5FDregister(&cls);
  }();
  return id;
}

}  // namespace

h5::Handle page_access(const std::shared_ptr<PageStore>& store, const std::string& file) {
  if (driver() < 0) h5::fail(file, "cannot register the HDF5 file driver of the results writer");
  h5::Handle fapl =
      h5::checked(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, file, "cannot create an access list");
  h5::ok(H5Pset_driver(fapl.get(), driver(), &store), file,
         "cannot select the file driver of the results writer");
  return fapl;
}

}  // namespace ltl
