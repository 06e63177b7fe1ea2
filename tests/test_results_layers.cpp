// The layers of the results files: the one field table against the Python reader and the layout
// table of experiments/README.md, the cost of appending a step (bytes written in proportion to the
// step, not to the file), and readers during and after an in-place commit.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "error.hpp"
#include "results.hpp"
#include "results_commit.hpp"
#include "results_fields.hpp"
#include "testing.hpp"

namespace fs = std::filesystem;
using namespace ltl;
using ltl::testing::source_path;

namespace {

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(' '), b = s.find_last_not_of(' ');
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

TEST(FieldTable, PythonReaderHoldsTheGeneratedTable) {
  const std::string py = read_text(source_path("figures/ltl_results.py"));
  const std::size_t a = py.find("# BEGIN FIELDS"), b = py.find("# END FIELDS\n");
  ASSERT_NE(a, std::string::npos) << "figures/ltl_results.py has no '# BEGIN FIELDS' line";
  ASSERT_NE(b, std::string::npos) << "figures/ltl_results.py has no '# END FIELDS' line";
  EXPECT_EQ(py.substr(a, b + 13 - a), python_field_table())
      << "replace the block of figures/ltl_results.py by the text above (the field table of "
         "lib/results_fields.hpp changed)";
}

TEST(FieldTable, ReadmeLayoutTableAgrees) {
  // The rows "| `name` | shape | unit | what |" of the layout table in experiments/README.md.
  std::istringstream readme(read_text(source_path("experiments/README.md")));
  std::map<std::string, std::pair<std::string, std::string>> rows;
  for (std::string line; std::getline(readme, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    std::vector<std::string> cells;
    for (std::size_t at = 1, next; (next = line.find(" |", at)) != std::string::npos; at = next + 2)
      cells.push_back(trim(line.substr(at, next - at)));
    if (cells.size() < 3 || cells[0].size() < 3) continue;
    std::string name = cells[0].substr(1, cells[0].find('`', 1) - 1);
    name = name.substr(name.rfind('/') + 1);
    rows[name] = {cells[1], cells[2]};
  }
  int checked = 0;
  for (const Field& f : kFields) {
    const auto it = rows.find(f.name);
    ASSERT_NE(it, rows.end()) << "experiments/README.md has no row for the field " << f.name;
    if (f.shape == Shape::Table) continue;  // tables: their shapes are described in words
    EXPECT_EQ(it->second.first, shape_text(f)) << f.name << ": shape in experiments/README.md";
    EXPECT_EQ(it->second.second, unit_text(f)) << f.name << ": unit in experiments/README.md";
    ++checked;
  }
  EXPECT_GE(checked, 15);
}

TEST(FieldTable, NamesAreUniqueAndStepFieldsHaveUnits) {
  std::map<std::string, int> seen;
  for (const Field& f : kFields) {
    EXPECT_EQ(++seen[f.name], 1) << f.name;
    EXPECT_EQ(find_field(f.name), &f);
    EXPECT_NE(std::string(f.unit_2d), "") << f.name;
    EXPECT_NE(std::string(f.description), "") << f.name;
  }
  EXPECT_EQ(find_field("no such field"), nullptr);
  const std::string msg = [] {
    try {
      field("no_such_field", "x.h5");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  }();
  EXPECT_NE(msg.find("x.h5: internal: no field no_such_field"), std::string::npos) << msg;
}

// ---- appending a step --------------------------------------------------------------------------

class AppendCost : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = ltl::testing::temp_dir("append_cost"); }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

/// An n x n grid of squares on [0, 1]^2, each cut into two six-node triangles, with the bottom
/// edge as the contact boundary (n three-node facets).
Mesh grid(int n) {
  Mesh m;
  m.dim = 2;
  const int side = 2 * n + 1;
  const auto id = [&](int i, int j) { return j * side + i; };
  m.X.resize(side * side, 2);
  for (int j = 0; j < side; ++j)
    for (int i = 0; i < side; ++i) m.X.row(id(i, j)) << 0.5 * i / n, 0.5 * j / n;
  m.cells.resize(2 * n * n, 6);
  for (int b = 0, c = 0; b < n; ++b)
    for (int a = 0; a < n; ++a) {
      const int i = 2 * a, j = 2 * b;
      m.cells.row(c++) << id(i, j), id(i + 2, j), id(i, j + 2), id(i + 1, j), id(i + 1, j + 1),
          id(i, j + 1);
      m.cells.row(c++) << id(i + 2, j), id(i + 2, j + 2), id(i, j + 2), id(i + 2, j + 1),
          id(i + 1, j + 2), id(i + 1, j + 1);
    }
  Mesh::Boundary bottom;
  bottom.name = "bottom";
  bottom.facets.resize(n, 3);
  for (int a = 0; a < n; ++a)
    bottom.facets.row(a) << id(2 * a, 0), id(2 * a + 2, 0), id(2 * a + 1, 0);
  m.boundaries.push_back(bottom);
  m.source = "grid";
  return m;
}

/// Bytes this process has passed to write(2) and friends (/proc/self/io, wchar).
long long wchar() {
  std::ifstream io("/proc/self/io");
  std::string key;
  long long value = -1;
  while (io >> key >> value)
    if (key == "wchar:") return value;
  return -1;
}

/// A step of distinct values with every field a run writes.
struct Step {
  State state;
  StepReport report;
  StepData data;
};

void fill(Step& s, const Mesh& m, int points, int p) {
  const int nc = m.num_cells(), dim = 2;
  s.state.u = Eigen::MatrixXd::Constant(m.num_nodes(), dim, 1e-3 * p);
  s.state.E = Eigen::MatrixXd::Constant(dim * nc, dim, 1.0 + 1e-4 * p);
  s.state.lambda = Eigen::MatrixXd::Constant(dim * nc, dim, 2.0 * p);
  s.state.e = Eigen::MatrixXd::Constant(points, dim, 1e-4 * p);
  s.state.lambda_c = Eigen::MatrixXd::Constant(points, dim, -3.0 * p);
  s.state.beta = Eigen::VectorXd::Constant(points, 1.0);
  s.report.iterations = 50;
  s.report.converged = true;
  for (int n = 1; n <= 50; ++n) {
    IterationRecord h;
    h.n = n;
    h.r_G = h.r_B = 1.0 / n;
    s.report.history.push_back(h);
  }
  s.data.p = p;
  s.data.t = p;
  s.data.state = &s.state;
  s.data.report = &s.report;
  s.data.fields["P"] = s.state.lambda;
  s.data.fields["sigma"] = s.state.lambda;
  s.data.fields["sigma33"] = Eigen::VectorXd::Constant(nc, 5.0 * p);
  s.data.fields["pressure"] = Eigen::VectorXd::Constant(nc, 7.0 * p);
  s.data.fields["contact_pressure"] = Eigen::VectorXd::Constant(points, 1.0 * p);
  s.data.fields["gap"] = Eigen::VectorXd::Constant(points, 0.0);
}

ResultsOptions options_of(const Mesh& m) {
  ResultsOptions o;
  o.contact.facets = &m.boundaries[0];
  o.contact.nodes.resize(2 * m.boundaries[0].facets.rows() + 1);
  for (int k = 0; k < static_cast<int>(o.contact.nodes.size()); ++k) o.contact.nodes[k] = k;
  o.commit = false;
  return o;
}

RunInfo info() {
  RunInfo i;
  i.name = "grid";
  i.config_text = "[time]\nsteps = 20\n";
  return i;
}

// Twenty steps of 800 cells: each step written in place costs about its own bytes once (its data
// past the file's end, then a few pages of metadata through the journal), so the whole run writes
// at most 1.25x the final file (1.07x measured); a journal carrying the data too would write
// about 2x, a file replaced whole at every step about (20 + 1) / 2 = 10.5x.
TEST_F(AppendCost, BytesWrittenGrowWithTheStepNotWithTheFile) {
  const Mesh m = grid(20);
  const int points = 41, steps = 20;
  const std::string path = (dir_ / "run.h5").string();
  const long long w0 = wchar();
  const std::uint64_t c0 = bytes_committed();
  ASSERT_GE(w0, 0) << "no /proc/self/io";
  std::vector<long long> per_step;
  {
    ResultsFile r = ResultsFile::create(path, m, info(), options_of(m));
    for (int p = 1; p <= steps; ++p) {
      Step s;
      fill(s, m, points, p);
      const long long before = wchar();
      r.append(s.data, p == steps ? "complete" : "running");
      per_step.push_back(wchar() - before);
    }
  }
  const long long written = wchar() - w0;
  const double size = static_cast<double>(fs::file_size(path));
  const double xdmf = static_cast<double>(fs::file_size(dir_ / "run.xdmf") +
                                          fs::file_size(dir_ / "run_contact.xdmf"));
  std::printf(
      "%d steps: file %.0f bytes, written %lld bytes (%.2fx), per step: first %lld, "
      "last %lld; counted by the commit %llu\n",
      steps, size, written, written / size, per_step.front(), per_step.back(),
      static_cast<unsigned long long>(bytes_committed() - c0));
  EXPECT_LE(written, 1.25 * size);
  // The last step costs about what the second one does (not the file's size).
  EXPECT_LT(per_step.back(), 1.5 * per_step[1] + 2 * xdmf);
  EXPECT_LE(static_cast<long long>(bytes_committed() - c0), written);
  // What was written is what a reader sees.
  const auto last = ResultsFile::read_last_step(path);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->p, steps);
  EXPECT_EQ(last->state.u(3, 1), 1e-3 * steps);
  EXPECT_EQ(ResultsFile::read_attribute(path, "status"), "complete");
  EXPECT_FALSE(fs::exists(journal_path_of(path)));
}

// A reader that has the file open (HDF5 holds a shared lock meanwhile) keeps seeing the file it
// opened: the writer then replaces the file whole instead of changing it in place; without a
// reader the next step is written in place.
TEST_F(AppendCost, AnOpenReaderKeepsACompleteFile) {
  const Mesh m = grid(4);
  const std::string path = (dir_ / "run.h5").string();
  ResultsFile r = ResultsFile::create(path, m, info(), options_of(m));
  Step s1, s2, s3;
  fill(s1, m, 9, 1);
  fill(s2, m, 9, 2);
  fill(s3, m, 9, 3);
  r.append(s1.data);
  r.append(s2.data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  struct stat before {
  }, after{};
  ASSERT_EQ(::stat(path.c_str(), &before), 0);
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(f, 0);
  r.append(s3.data);
  ASSERT_EQ(::stat(path.c_str(), &after), 0);
  EXPECT_NE(before.st_ino, after.st_ino);  // replaced whole (renamed), not changed in place

  H5G_info_t g;
  const hid_t steps = H5Gopen2(f, "/steps", H5P_DEFAULT);
  ASSERT_GE(steps, 0);
  ASSERT_GE(H5Gget_info(steps, &g), 0);
  EXPECT_EQ(g.nlinks, 2u);  // the file as opened
  const hid_t set = H5Dopen2(f, "/steps/000002/u", H5P_DEFAULT);
  ASSERT_GE(set, 0);
  Eigen::MatrixXd buf(m.num_nodes(), 2);
  ASSERT_GE(H5Dread(set, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()), 0);
  EXPECT_EQ(buf(0, 0), 2e-3);
  H5Dclose(set);
  H5Gclose(steps);
  H5Fclose(f);
  EXPECT_EQ(ResultsFile::read_last_step(path)->p, 3);
  // With no reader left, the next step is written in place.
  Step s4;
  fill(s4, m, 9, 4);
  r.append(s4.data);
  struct stat later {};
  ASSERT_EQ(::stat(path.c_str(), &later), 0);
  EXPECT_EQ(later.st_ino, after.st_ino);
  EXPECT_EQ(ResultsFile::read_last_step(path)->p, 4);
}

}  // namespace

namespace {

/// Runs `command` in a shell; its exit status (-1 if it did not exit).
int shell(const std::string& command) {
  const int rc = std::system(command.c_str());
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// A writer killed in the middle of an in-place commit (LTL_FAULT_AT_WRITE=k, each k a write
// event of the run) that leaves the journal beside the file: the C++ and the Python readers see
// the file with the journal applied (the step being committed), and --resume writes it into the
// file, removes the journal and finishes the run. A journal cut by the kill is ignored.
TEST_F(AppendCost, AJournalLeftByAKilledWriterIsAppliedByReadersAndResume) {
  ltl::testing::write_file(dir_ / "case.toml", ltl::testing::coarse_fig5_config(
                                                   source_path("experiments/fig5/half_disc.geo")));
  const std::string run = "cd '" + dir_.string() + "' && ";
  const std::string ltl_run = ltl::testing::binary_path("experiments/ltl_run") +
                              " case.toml -q -o out.h5 --set time.steps=2";
  const fs::path out = dir_ / "out.h5";
  int journals = 0;
  for (int k = 1; k < 200; ++k) {
    for (const char* f : {"out.h5", "out.h5.journal", "out.xdmf", "out_contact.xdmf"})
      fs::remove(dir_ / f);
    const int rc =
        shell(run + "LTL_FAULT_AT_WRITE=" + std::to_string(k) + " " + ltl_run + " 2> /dev/null");
    if (rc == 0) break;  // k is past the last write event
    if (!fs::exists(dir_ / "out.h5.journal")) continue;
    // A complete journal ends with its trailer; a kill while it was written leaves it cut, and
    // the file as it was (step 1).
    const std::string journal = read_text(dir_ / "out.h5.journal");
    const bool complete = journal.size() >= 8 && journal.substr(journal.size() - 8) == "LTLJEND1";
    journals += complete;
    const auto last = ResultsFile::read_last_step(out.string());
    ASSERT_TRUE(last) << "k = " << k;
    EXPECT_EQ(last->p, complete ? 2 : 1) << "k = " << k;  // step 2 is committed in place
    const std::string py = run + "/usr/bin/python3 -c 'import sys; sys.path.insert(0, \"" +
                           source_path("figures") +
                           "\"); import ltl_results; r = ltl_results.load(\"out.h5\"); "
                           "sys.exit(0 if r.steps[-1].p == " +
                           std::to_string(last->p) + " else 1)'";
    EXPECT_EQ(shell(py), 0) << "k = " << k << ": the Python reader does not apply the journal";
    ASSERT_EQ(shell(run + ltl_run + " --resume"), 0) << "k = " << k;
    EXPECT_FALSE(fs::exists(dir_ / "out.h5.journal")) << "k = " << k;
    EXPECT_EQ(ResultsFile::read_last_step(out.string())->p, 2) << "k = " << k;
    EXPECT_EQ(ResultsFile::read_attribute(out.string(), "status"), "complete") << "k = " << k;
  }
  std::printf("kills that left a complete journal: %d\n", journals);
  EXPECT_GE(journals, 3);  // the journal written; the new data written; the file complete
}

}  // namespace
