// The pages of a results file being changed (lib/results_pages.hpp): the store against a plain
// model of the file's bytes under random writes, cuts and reads; the changed ranges it reports
// turn the file on disk into the new file, and name only pages that differ; and through HDF5 and
// the commit, a change holds the pages it writes, not the file.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "results_commit.hpp"
#include "results_pages.hpp"
#include "testing.hpp"

namespace fs = std::filesystem;
using ltl::PageStore;

namespace {

constexpr std::size_t kPage = PageStore::kPage;

class Pages : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = ltl::testing::temp_dir("pages"); }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  /// A file of `n` random bytes; its content in `bytes`.
  std::string disk_file(std::size_t n, std::mt19937& rng, std::vector<char>& bytes) {
    bytes.resize(n);
    for (char& c : bytes) c = static_cast<char>(rng());
    const std::string path = (dir_ / "disk.bin").string();
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(n));
    return path;
  }
  fs::path dir_;
};

/// The bytes [at, at + n) of `model`, zeros past its end.
std::vector<char> slice(const std::vector<char>& model, std::size_t at, std::size_t n) {
  std::vector<char> out(n, 0);
  for (std::size_t i = 0; i < n && at + i < model.size(); ++i) out[i] = model[at + i];
  return out;
}

// Random writes (within a page, across pages, past the end), cuts (below and within the file on
// disk, then grown again) and reads, each checked against a vector of bytes; every 50
// operations, the changed ranges are applied to the file as the commit finds it (the file on
// disk; direct, with what was written past its end) and must give the model exactly, must not
// cross the end of the file on disk (direct: must lie before it), and every page they name below
// that end must differ from the disk. Direct, the committed bytes never change.
TEST_F(Pages, TheStoreIsTheFileItsChangedRangesMakeTheNewFile) {
  std::mt19937 rng(20261129);
  std::vector<char> disk;
  const std::size_t disk_size = 5 * kPage + 123;
  const std::string path = disk_file(disk_size, rng, disk);
  int checks = 0, cuts_below_disk = 0;
  const std::string copy = (dir_ / "direct.bin").string();
  for (int episode = 0; episode < 14; ++episode) {
    // Episodes 6 to 11: direct, over a copy of the file open for writing. 12 and 13: direct over
    // a file open for reading only, where every write past its end fails: the store must stay
    // the file (those writes kept in pages), the error kept for the commit.
    const bool direct = episode >= 6, broken = episode >= 12;
    if (direct) fs::copy_file(path, copy, fs::copy_options::overwrite_existing);
    const int fd = ::open((direct ? copy : path).c_str(), direct && !broken ? O_RDWR : O_RDONLY);
    ASSERT_GE(fd, 0);
    PageStore s(fd, disk_size, direct);
    ASSERT_EQ(s.direct(), direct);
    std::vector<char> model = disk;
    const auto pick = [&](std::size_t n) { return static_cast<std::size_t>(rng() % (n + 1)); };
    for (int op = 1; op <= 400; ++op) {
      const int kind = static_cast<int>(rng() % 10);
      if (kind < 5) {  // write: small, or up to three pages, anywhere up to past the end
        const std::size_t at = pick(model.size() + 2 * kPage);
        const std::size_t n = 1 + (kind < 3 ? pick(64) : pick(3 * kPage));
        std::vector<char> data(n);
        for (char& c : data) c = static_cast<char>(rng());
        ASSERT_TRUE(s.write(at, n, data.data()));
        if (model.size() < at + n) model.resize(at + n, 0);
        std::copy(data.begin(), data.end(), model.begin() + static_cast<std::ptrdiff_t>(at));
      } else if (kind < 6 && episode % 2 == 1) {  // cut or grow (every other episode)
        const std::size_t n = pick(model.size() + kPage);
        cuts_below_disk += n < disk_size;
        s.truncate(n);
        model.resize(n, 0);
      } else {  // read anywhere, past the end too
        const std::size_t at = pick(model.size() + kPage), n = pick(3 * kPage);
        std::vector<char> got(n);
        ASSERT_TRUE(s.read(at, n, got.data()));
        ASSERT_EQ(got, slice(model, at, n)) << "episode " << episode << ", op " << op;
      }
      ASSERT_EQ(s.size(), model.size());
      if (broken) continue;
      if (op % 50 != 0) continue;
      std::vector<PageStore::Range> ranges;
      ASSERT_TRUE(s.changed_ranges(ranges));
      // The file as the commit finds it: direct, the file on disk (the committed bytes before its
      // old end untouched, the new ones past it), set to the new size before the journal.
      std::vector<char> file = disk;
      if (direct) {
        std::ifstream in(copy, std::ios::binary);
        file.assign(std::istreambuf_iterator<char>(in), {});
        ASSERT_GE(file.size(), disk_size);
        ASSERT_TRUE(std::equal(disk.begin(), disk.end(), file.begin())) << "the old file changed";
        file.resize(std::max<std::size_t>(s.size(), disk_size), 0);
        EXPECT_EQ(s.held_bytes() % kPage, 0u);
      }
      std::uint64_t last_end = 0;
      for (const auto& r : ranges) {
        ASSERT_GE(r.offset, last_end);  // sorted, disjoint
        ASSERT_GT(r.length, 0u);
        EXPECT_FALSE(r.offset < disk_size && r.offset + r.length > disk_size);
        if (direct) {
          EXPECT_LT(r.offset, disk_size);  // what lies past it is in the file already
        }
        last_end = r.offset + r.length;
        ASSERT_LE(last_end, s.size());
        std::vector<char> bytes(r.length);
        ASSERT_TRUE(s.read(r.offset, r.length, bytes.data()));
        if (file.size() < last_end) file.resize(last_end, 0);
        std::copy(bytes.begin(), bytes.end(), file.begin() + static_cast<std::ptrdiff_t>(r.offset));
        for (std::uint64_t p = r.offset; p < std::min<std::uint64_t>(last_end, disk_size);
             p += kPage) {
          const std::size_t n = std::min<std::uint64_t>(kPage, disk_size - p);
          EXPECT_NE(slice(model, p, n), slice(disk, p, n)) << "page at " << p << " unchanged";
        }
      }
      file.resize(s.size(), 0);  // as the commit's ftruncate
      ASSERT_EQ(file, model) << "episode " << episode << ", op " << op;
      ++checks;
    }
    if (broken) {
      EXPECT_EQ(s.deferred_error(), EBADF);
    }
  }
  EXPECT_EQ(checks, 96);  // 12 episodes x 8 (the broken ones are checked by their reads)
  EXPECT_GT(cuts_below_disk, 20);
}

// A store with nothing written reports no change; the same bytes written back report none.
TEST_F(Pages, BytesWrittenAsTheyWereAreNoChange) {
  std::mt19937 rng(7);
  std::vector<char> disk;
  const std::string path = disk_file(3 * kPage + 10, rng, disk);
  const int fd = ::open(path.c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  PageStore s(fd, disk.size());
  std::vector<PageStore::Range> ranges;
  ASSERT_TRUE(s.changed_ranges(ranges));
  EXPECT_TRUE(ranges.empty());
  ASSERT_TRUE(s.write(100, 2 * kPage, disk.data() + 100));
  ASSERT_TRUE(s.changed_ranges(ranges));
  EXPECT_TRUE(ranges.empty());
  EXPECT_EQ(s.held_bytes(), 3 * kPage);
  char one = static_cast<char>(disk[kPage + 5] ^ 1);
  ASSERT_TRUE(s.write(kPage + 5, 1, &one));
  ASSERT_TRUE(s.changed_ranges(ranges));
  ASSERT_EQ(ranges.size(), 1u);
  EXPECT_EQ(ranges[0].offset, kPage);
  EXPECT_EQ(ranges[0].length, kPage);
}

/// Writes a 1-D dataset of doubles `name` holding `v`.
void write_doubles(hid_t f, const char* name, const std::vector<double>& v) {
  const hsize_t n = v.size();
  const hid_t space = H5Screate_simple(1, &n, nullptr);
  const hid_t set =
      H5Dcreate2(f, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(set, 0);
  ASSERT_GE(H5Dwrite(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
  H5Dclose(set);
  H5Sclose(space);
}

/// The dataset `name` of the file at `path`, read with HDF5's default driver.
std::vector<double> read_doubles(const std::string& path, const char* name) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_GE(f, 0);
  const hid_t set = H5Dopen2(f, name, H5P_DEFAULT);
  EXPECT_GE(set, 0);
  const hid_t space = H5Dget_space(set);
  std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
  EXPECT_GE(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()), 0);
  H5Sclose(space);
  H5Dclose(set);
  H5Fclose(f);
  return v;
}

// Through HDF5: a file of 4 MB committed, then two changes, each holding the pages it writes
// (a small new dataset; 1000 values overwritten in the middle of the large one, written back
// through HDF5's sieve buffer of 64 KiB), not the file.
// What the default driver then reads is what was written, the untouched values read from disk.
TEST_F(Pages, AChangeHoldsThePagesItWritesNotTheFile) {
  const std::string path = (dir_ / "f.h5").string();
  std::vector<double> big(500000), small(100);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = 0.5 * static_cast<double>(i);
  for (std::size_t i = 0; i < small.size(); ++i) small[i] = -1.0 * static_cast<double>(i);
  ltl::CommittedFile file(path);
  write_doubles(file.create(), "/big", big);
  EXPECT_LE(file.held_bytes(), 4 * kPage);  // a new file goes straight into <file>.partial
  EXPECT_GE(fs::file_size(path + ".partial"), 8 * big.size());
  file.commit();
  EXPECT_FALSE(fs::exists(path + ".partial"));
  EXPECT_EQ(file.held_bytes(), 0u);
  const auto size = fs::file_size(path);
  EXPECT_GT(size, 8 * big.size());

  write_doubles(file.begin(), "/small", small);
  ASSERT_GE(H5Fflush(file.id(), H5F_SCOPE_LOCAL), 0);
  const std::size_t held_small = file.held_bytes();
  file.commit();
  EXPECT_LE(held_small, 16 * kPage) << "of a file of " << size << " bytes";

  {
    const hid_t f = file.begin();
    const hid_t set = H5Dopen2(f, "/big", H5P_DEFAULT);
    ASSERT_GE(set, 0);
    const hid_t space = H5Dget_space(set);
    const hsize_t start = 250000, count = 1000;
    H5Sselect_hyperslab(space, H5S_SELECT_SET, &start, nullptr, &count, nullptr);
    const hid_t mem = H5Screate_simple(1, &count, nullptr);
    const std::vector<double> ones(count, 1.0);
    ASSERT_GE(H5Dwrite(set, H5T_NATIVE_DOUBLE, mem, space, H5P_DEFAULT, ones.data()), 0);
    H5Sclose(mem);
    H5Sclose(space);
    H5Dclose(set);
    ASSERT_GE(H5Fflush(f, H5F_SCOPE_LOCAL), 0);
    // What HDF5 writes back of raw data goes through its sieve buffer (64 KiB).
    EXPECT_LE(file.held_bytes(), 8 * count + 64 * 1024 + 4 * kPage);
    file.commit();
  }
  for (std::size_t i = 250000; i < 251000; ++i) big[i] = 1.0;
  EXPECT_EQ(read_doubles(path, "/big"), big);
  EXPECT_EQ(read_doubles(path, "/small"), small);
  EXPECT_FALSE(fs::exists(ltl::journal_path_of(path)));
  std::printf("file %llu bytes; a change adding 800 bytes held %zu bytes\n",
              static_cast<unsigned long long>(size), held_small);
}

}  // namespace

namespace {

// A writer killed in the middle of a change leaves the committed file with the bytes it wrote
// past the end: readers do not look there, and the next change writes over them and cuts the
// rest (the file ends where HDF5's allocated space ends).
TEST_F(Pages, BytesLeftPastTheEndByAKilledChangeAreNeitherReadNorKept) {
  const std::string path = (dir_ / "t.h5").string();
  const std::vector<double> a(1000, 1.5), b(3000, -2.0);
  ltl::CommittedFile file(path);
  write_doubles(file.create(), "/a", a);
  file.commit();
  const auto size = fs::file_size(path);
  {
    std::ofstream out(path, std::ios::binary | std::ios::app);
    const std::string junk(100000, '\x5a');
    out.write(junk.data(), static_cast<std::streamsize>(junk.size()));
  }
  EXPECT_EQ(read_doubles(path, "/a"), a);
  write_doubles(file.begin(), "/b", b);
  file.commit();
  EXPECT_EQ(read_doubles(path, "/a"), a);
  EXPECT_EQ(read_doubles(path, "/b"), b);
  EXPECT_LT(fs::file_size(path), size + 8 * b.size() + 8 * PageStore::kPage);
  EXPECT_FALSE(fs::exists(ltl::journal_path_of(path)));
}

}  // namespace
