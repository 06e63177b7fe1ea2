// Bad input gets a clear error: what is wrong and where (file, line, key, group, facet), a
// non-zero exit, and no results file. Divergence is reported as such and never written as a result.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "testing.hpp"

namespace fs = std::filesystem;
using ltl::testing::source_path;

namespace {

struct Outcome {
  int status;
  std::string err;
  bool wrote;
};

// Runs ltl_run on a configuration text (geometry paths may use @SRC@ for the source tree).
Outcome run_config(const std::string& name, std::string text, const std::string& extra = "") {
  const fs::path dir = ltl::testing::temp_dir("cli_" + name);
  for (std::size_t at; (at = text.find("@SRC@")) != std::string::npos;)
    text.replace(at, 5, source_path(""));
  ltl::testing::write_file(dir / "case.toml", text);
  const fs::path out = dir / "out.h5", err = dir / "err.txt";
  const std::string cmd = ltl::testing::binary_path("experiments/ltl_run") + " " +
                          (dir / "case.toml").string() + " -q -o " + out.string() + " " + extra +
                          " 2> " + err.string();
  const int rc = std::system(cmd.c_str());
  std::ifstream in(err);
  std::stringstream ss;
  ss << in.rdbuf();
  Outcome o{WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ss.str(), fs::exists(out)};
  fs::remove_all(dir);
  return o;
}

// A valid small problem (the Fig 5 half cylinder, coarse) to break one key at a time.
const std::string kValid = ltl::testing::coarse_fig5_config("@SRC@experiments/fig5/half_disc.geo");

std::string with(const std::string& from, const std::string& to) {
  std::string t = kValid;
  const auto at = t.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return t.replace(at, from.size(), to);
}

void expect_error(const Outcome& o, const std::vector<std::string>& words) {
  EXPECT_EQ(o.status, 1) << o.err;
  EXPECT_FALSE(o.wrote) << "a results file was written for a failed run";
  for (const auto& w : words)
    EXPECT_NE(o.err.find(w), std::string::npos) << "'" << w << "' not in: " << o.err;
}

}  // namespace

TEST(BadInput, TheValidCaseRunsAndWrites) {
  const Outcome o = run_config("valid", kValid);
  EXPECT_EQ(o.status, 0) << o.err;
  EXPECT_TRUE(o.wrote);
}

TEST(BadInput, ConfigurationErrorsNameFileLineAndKey) {
  expect_error(run_config("unknown", with("C2 = \"65 kPa\"", "C2 = \"65 kPa\"\nC4 = 1")),
               {"case.toml:9", "material.C4", "unknown key"});
  expect_error(run_config("missing", with("C1 = \"435 kPa\"\n", "")), {"material.C1", "missing"});
  expect_error(run_config("negative", with("C1 = \"435 kPa\"", "C1 = \"-435 kPa\"")),
               {"case.toml:7", "material.C1", "must be > 0"});
  expect_error(run_config("unit", with("C1 = \"435 kPa\"", "C1 = \"435 m\"")),
               {"material.C1", "unit 'm'"});
  expect_error(run_config("R", with("R = 5", "R = 0")), {"case.toml:20", "algorithm.R", "> 0"});
  expect_error(run_config("qc", with("q_c = \"1 MPa/m\"", "q_c = \"-1 MPa/m\"")),
               {"algorithm.q_c", "> 0"});
  expect_error(run_config("beta0", with("beta0 = 0.0", "beta0 = 1.5")),
               {"contact.beta0", "[0, 1]"});
  expect_error(run_config("eps", with("beta0 = 0.0", "beta0 = 0.0\neps = -1e-9")),
               {"contact.eps", "> 0"});
  expect_error(run_config("kappa", with("beta0 = 0.0", "beta0 = 0.0\nkappa = \"-1 Pa/m\"")),
               {"contact.kappa", ">= 0"});
  expect_error(run_config("dt", with("dt = \"1 s\"", "dt = \"0 s\"")), {"time.dt", "> 0"});
  expect_error(run_config("rho", with("R = 5", "R = 5\nupdate = \"bermudez-moreno\"\nrho = 0.3")),
               {"algorithm.rho", "1/2 < rho <= 1"});
  expect_error(run_config("model", with("model = \"mooney-rivlin\"", "model = \"neo-hooke\"")),
               {"material.model", "mooney-rivlin"});
  expect_error(run_config("vector", with("body_force = [0, \"-400 kN/m^3\"]", "body_force = [0]")),
               {"load.body_force", "2 components"});
  expect_error(run_config("toml", with("[material]", "[material")), {"case.toml:5", "TOML"});
  expect_error(run_config("cli", kValid, "--set algorithm.sweeps=0"), {"algorithm.sweeps"});
}

TEST(BadInput, MeshAndGroupErrors) {
  expect_error(run_config("group", with("group = \"symmetry_x\"", "group = \"symetry_x\"")),
               {"half_disc.geo", "'symetry_x'", "'symmetry_x'"});
  expect_error(run_config("geo", with("fig5/half_disc.geo", "fig5/no_such.geo")),
               {"no_such.geo", "cannot open"});
  // A body resting on nothing: no Dirichlet part and no contact surface.
  expect_error(run_config("floating", with("[contact]\ngroup = \"contact\"\nplane_point = [0, -1]\n"
                                           "plane_normal = [0, -1]\nbeta0 = 0.0\n",
                                           "")),
               {"rigid motion"});
  // The plane cuts the body: the contact surface starts inside the obstacle.
  expect_error(run_config("inside", with("plane_point = [0, -1]", "plane_point = [0, -0.5]")),
               {"starts inside the obstacle", "contact node 0 of 'contact'"});
  // A contact group that is not on the boundary.
  const fs::path dir = ltl::testing::temp_dir("cli_geo");
  ltl::testing::write_file(dir / "inner.geo",
                           "Point(1)={0,0,0};Point(2)={1,0,0};Point(3)={1,1,0};Point(4)={0,1,0};"
                           "Point(5)={0.2,0.5,0};Point(6)={0.8,0.5,0};"
                           "Line(1)={1,2};Line(2)={2,3};Line(3)={3,4};Line(4)={4,1};Line(5)={5,6};"
                           "Curve Loop(1)={1,2,3,4};Plane Surface(1)={1};Curve{5} In Surface{1};"
                           "Physical Curve(\"bottom\")={1};Physical Curve(\"inside\")={5};Physical "
                           "Surface(\"b\")={1};\n");
  std::string t = with("@SRC@experiments/fig5/half_disc.geo", (dir / "inner.geo").string());
  t = t.replace(t.find("parameters = { n = 4, nd = 4 }"), 30, "");  // inner.geo defines none
  t = t.replace(t.find("group = \"symmetry_x\""), 20, "group = \"bottom\"");
  t = t.replace(t.find("group = \"contact\""), 17, "group = \"inside\"");
  t = t.replace(t.find("plane_point = [0, -1]"), 21, "plane_point = [0, 0.4]");
  expect_error(run_config("interior", t), {"contact.group", "'inside'", "not on the boundary"});
  fs::remove_all(dir);
}

TEST(Divergence, IterationCapIsReportedAndNothingIsWritten) {
  // Nothing is written as a result; the failed step's history and last iterate are saved apart
  // (/unconverged/000001, tests/test_output.cpp), so the file exists but holds no step.
  // ALG2 alone: the Newton phase would reach equilibrium within the cap.
  const Outcome o =
      run_config("cap", with("tol = 1e-4", "tol = 1e-12\nmax_iter = 5\nsolver = \"alg2\""));
  EXPECT_EQ(o.status, 1) << o.err;
  EXPECT_TRUE(o.wrote) << "the unconverged iterate was not saved";
  for (const char* w : {"diverged at step 1", "iteration cap reached",
                        "Nothing was written as a result", "group /unconverged/000001"})
    EXPECT_NE(o.err.find(w), std::string::npos) << "'" << w << "' not in: " << o.err;
  // Every attempt fails, so the load subdivision (1.5) goes down to its last halving and no
  // further: 0 -> 1, then 0 -> 1/2, 0 -> 1/4, 0 -> 1/8 (kMaxHalvings = 3), each failed.
  for (const char* w :
       {"0 -> 1: failed", "0 -> 0.5: failed", "0 -> 0.25: failed", "0 -> 0.125: failed"})
    EXPECT_NE(o.err.find(w), std::string::npos) << "'" << w << "' not in: " << o.err;
  EXPECT_EQ(o.err.find("0.0625"), std::string::npos) << o.err;
}
