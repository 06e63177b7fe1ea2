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

PageStore::PageStore(int fd, std::uint64_t size, bool direct)
    : disk_(fd),
      disk_size_(size),
      disk_end_(size),
      size_(size),
      split_(direct ? size : UINT64_MAX),
      direct_end_(size) {}

PageStore::~PageStore() {
  if (disk_ >= 0) ::close(disk_);
}

namespace {
/// Reads all of [at, at + n) of `fd` into `out`; false (errno set; EIO when the file is shorter,
/// unless `short_ok`: then what lies past its end is left as it is).
bool pread_all(int fd, char* out, std::size_t n, std::uint64_t at, bool short_ok = false) {
  for (std::size_t done = 0; done < n;) {
    const ssize_t k = ::pread(fd, out + done, n - done, static_cast<off_t>(at + done));
    if (k < 0 && errno == EINTR) continue;
    if (k == 0 && short_ok) return true;
    if (k <= 0) {
      if (k == 0) errno = EIO;  // the file on disk shrank under us
      return false;
    }
    done += static_cast<std::size_t>(k);
  }
  return true;
}
}  // namespace

bool PageStore::backing(const Pages& pages, std::uint64_t at, std::size_t n, char* out) const {
  std::memset(out, 0, n);
  // Before split_: the committed file's bytes still part of this one; past it (direct): the
  // bytes written into the file.
  const bool below = &pages == &below_;
  const std::uint64_t from = below ? 0 : split_, to = below ? disk_end_ : direct_end_;
  const std::uint64_t lo = std::max(at, from), hi = std::min<std::uint64_t>(at + n, to);
  // Past split_ the file may end short of direct_end_ (a write that failed half-way): zeros.
  return lo >= hi || pread_all(disk_, out + (lo - at), hi - lo, lo, !below);
}

bool PageStore::read_layer(const Pages& pages, std::uint64_t at, std::size_t n, char* out) const {
  const std::uint64_t end = at + n;
  for (std::uint64_t p = at; p < end;) {
    const auto held = pages.lower_bound(p / kPage);
    if (held != pages.end() && held->first == p / kPage) {
      const std::size_t off = p % kPage, len = std::min<std::uint64_t>(kPage - off, end - p);
      std::memcpy(out + (p - at), held->second.get() + off, len);
      p += len;
      continue;
    }
    // Not held up to the next held page: from underneath in one read.
    const std::uint64_t stop =
        held == pages.end() ? end : std::min<std::uint64_t>(end, held->first * kPage);
    if (!backing(pages, p, stop - p, out + (p - at))) return false;
    p = stop;
  }
  return true;
}

bool PageStore::read(std::uint64_t at, std::size_t n, char* out) const {
  const std::size_t below = at < split_ ? std::min<std::uint64_t>(n, split_ - at) : 0;
  return (below == 0 || read_layer(below_, at, below, out)) &&
         (below == n || read_layer(past_, at + below, n - below, out + below));
}

bool PageStore::write_layer(Pages& pages, std::uint64_t at, std::size_t n, const char* in) {
  const std::uint64_t end = at + n;
  for (std::uint64_t p = at; p < end;) {
    const std::uint64_t index = p / kPage;
    const std::size_t off = p % kPage, len = std::min<std::uint64_t>(kPage - off, end - p);
    auto& page = pages[index];
    if (!page) {
      page.reset(new char[kPage]);
      // A page written in part keeps the rest of what the file holds there.
      if (len < kPage && !backing(pages, index * kPage, kPage, page.get())) {
        pages.erase(index);
        return false;
      }
    }
    std::memcpy(page.get() + off, in + (p - at), len);
    p += len;
  }
  return true;
}

bool PageStore::write_direct(std::uint64_t at, std::size_t n, const char* in) {
  for (std::size_t done = 0; done < n;) {
    const ssize_t k = ::pwrite(disk_, in + done, n - done, static_cast<off_t>(at + done));
    if (k < 0 && errno == EINTR) continue;
    if (k < 0) {
      direct_end_ = std::max(direct_end_, at + done);
      return false;
    }
    done += static_cast<std::size_t>(k);
    direct_bytes_ += static_cast<std::uint64_t>(k);
  }
  direct_end_ = std::max(direct_end_, at + n);
  return true;
}

bool PageStore::write(std::uint64_t at, std::size_t n, const char* in) {
  const std::size_t below = at < split_ ? std::min<std::uint64_t>(n, split_ - at) : 0;
  if (below > 0 && !write_layer(below_, at, below, in)) return false;
  if (below < n) {
    const std::uint64_t past_at = at + below;
    const std::size_t past_n = n - below;
    // Into the file; after a failed write (a full disk), into pages, the error kept for the
    // commit, so that HDF5 sees a consistent file until then.
    if (deferred_error_ == 0 && !write_direct(past_at, past_n, in + below)) deferred_error_ = errno;
    if (deferred_error_ != 0 && !write_layer(past_, past_at, past_n, in + below)) return false;
  }
  size_ = std::max(size_, at + n);
  return true;
}

void PageStore::truncate(std::uint64_t n) {
  if (n < size_) {
    for (Pages* pages : {&below_, &past_}) {
      pages->erase(pages->lower_bound((n + kPage - 1) / kPage), pages->end());
      const auto last = pages->find(n / kPage);
      if (last != pages->end()) std::memset(last->second.get() + n % kPage, 0, kPage - n % kPage);
    }
    disk_end_ = std::min(disk_end_, n);
    if (direct() && direct_end_ > std::max(n, split_)) {
      // The file's own bytes past the cut are dropped (read as zeros from now on, whether or not
      // the file could be cut).
      direct_end_ = std::max(n, split_);
      if (::ftruncate(disk_, static_cast<off_t>(direct_end_)) != 0 && deferred_error_ == 0)
        deferred_error_ = errno;
    }
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
  candidates.reserve(below_.size());
  for (const auto& [index, page] : below_) candidates.push_back(index);
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
    if (below < len && !direct()) add(out, s + below, len - below);
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
  if (flags & H5F_ACC_TRUNC) (*info)->truncate(0);
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
