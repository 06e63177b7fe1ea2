// The readings study's table (figures/readings.py, paper_notes/readings.md) is built from the
// results files: two tiny runs of ltl_run (the Fig 3 bar on a 4 x 1 mesh, two steps of 15 s, the
// pulled-up and the pressed-down reading), the table printed with --table-only, then one file
// replaced by a run with another load: its row changes, the other does not.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "testing.hpp"

namespace fs = std::filesystem;
using ltl::testing::binary_path;
using ltl::testing::source_path;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Runs ltl_run on the Fig 3 configuration, reduced, with the traction g2 = s 10 (1 - x1) kPa.
int run_bar(const fs::path& out, double kpa) {
  const std::string cmd =
      binary_path("experiments/ltl_run") + " " + source_path("experiments/fig3/fig3.toml") +
      " -q -o " + out.string() +
      " --set mesh.parameters.nx=4 --set mesh.parameters.ny=1 --set 'time.dt=\"15 s\"'"
      " --set time.steps=2 --set 'algorithm.q_c=\"3e7 Pa/m\"'"
      " --set 'load.traction=[{group=\"top\", value=[\"0 Pa\", \"" +
      std::to_string(kpa) + " kPa\"], gradient=[[\"0 Pa/m\", \"0 Pa/m\"], [\"" +
      std::to_string(-kpa) + " kPa/m\", \"0 Pa/m\"]]}]' > " + (out.string() + ".log") + " 2>&1";
  return std::system(cmd.c_str());
}

// The table's row of `name` (a line starting with "| name |").
std::string row(const std::string& table, const std::string& name) {
  std::istringstream in(table);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("| " + name + " |", 0) == 0) return line;
  return "";
}

}  // namespace

TEST(Readings, TableIsBuiltFromTheResultFiles) {
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "/usr/bin/python3 is missing";
  const fs::path dir = ltl::testing::temp_dir("readings");
  ASSERT_EQ(run_bar(dir / "up.h5", 10), 0) << read_text(dir / "up.h5.log");
  ASSERT_EQ(run_bar(dir / "down.h5", -10), 0) << read_text(dir / "down.h5.log");
  const std::string cmd = "/usr/bin/python3 " + source_path("figures/readings.py") + " " +
                          dir.string() + " --table-only > ";
  ASSERT_EQ(std::system((cmd + (dir / "t1.md").string() + " 2>&1").c_str()), 0)
      << read_text(dir / "t1.md");
  const std::string t1 = read_text(dir / "t1.md");
  const std::string up1 = row(t1, "up"), down1 = row(t1, "down");
  ASSERT_FALSE(up1.empty()) << t1;
  ASSERT_FALSE(down1.empty()) << t1;
  // Two stored steps (15, 30 s): the 30 s columns have numbers, 100 s and 800 s are ".".
  EXPECT_NE(up1.find("stable to 30 s"), std::string::npos) << up1;
  EXPECT_NE(up1, down1);

  // Replace one file: a pull of 5 kPa instead of 10.
  fs::remove(dir / "up.h5");
  ASSERT_EQ(run_bar(dir / "up.h5", 5), 0) << read_text(dir / "up.h5.log");
  ASSERT_EQ(std::system((cmd + (dir / "t2.md").string() + " 2>&1").c_str()), 0)
      << read_text(dir / "t2.md");
  const std::string t2 = read_text(dir / "t2.md");
  EXPECT_NE(row(t2, "up"), up1) << t2;
  EXPECT_EQ(row(t2, "down"), down1) << t2;
  fs::remove_all(dir);
}
