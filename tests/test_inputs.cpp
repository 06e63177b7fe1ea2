// The input side of a user's own problem :
//   - ALG2's R, q, q_c derived from the moduli and the mesh when the configuration leaves them
//     out (derive_algorithm_defaults): a 2-D and a 3-D block pressed on a plane with NO
//     [algorithm] keys converge to their closed form; explicit values are kept;
//   - --set reaches list entries and its errors name the --set argument;
//   - a body free to slide along a frictionless plane is refused, naming the free direction;
//   - load ramps (LoadRamp): each step of a linear ramp or a table is the closed form for that
//     step's load; a finished run extended to a later horizon equals the longer run bitwise.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include "config.hpp"
#include "error.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

namespace fs = std::filesystem;
using namespace ltl;
using ltl::testing::source_path;
using ltl::testing::test_path;
using ltl::testing::write_file;

namespace {

const std::string kBlock = source_path("experiments/first_problem/block.toml");

// [LTL87 (1.5)] Incompressible Mooney-Rivlin block pressed by a dead pressure p on a plane,
// free laterally: the vertical stretch l of the homogeneous state.
//   plane strain: F = diag(1/l, l),              p = 2 (l^-3 - l)(C1 + C2);
//   3-D:          F = diag(l^-1/2, l^-1/2, l),   p = 2 (l^-2 - l)(C1 + C2 / l).
// Both are decreasing in l on (0, 1]: bisection.
double stretch_under(int dim, double C1, double C2, double p) {
  auto pressure = [&](double l) {
    return dim == 2 ? 2 * (std::pow(l, -3) - l) * (C1 + C2)
                    : 2 * (std::pow(l, -2) - l) * (C1 + C2 / l);
  };
  double lo = 0.2, hi = 1.0;
  for (int k = 0; k < 200; ++k) {
    const double mid = 0.5 * (lo + hi);
    (pressure(mid) > p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

// max over nodes of |u - (F - I) X| / H for the homogeneous state of stretch l (H the height).
double block_error(const Mesh& mesh, const Eigen::MatrixXd& u, double l, double H) {
  const int d = mesh.dim;
  Eigen::Vector3d stretch;
  if (d == 2) {
    stretch << 1 / l, l, 1;
  } else {
    stretch << 1 / std::sqrt(l), 1 / std::sqrt(l), l;
  }
  double worst = 0;
  for (int i = 0; i < mesh.num_nodes(); ++i)
    for (int k = 0; k < d; ++k)
      worst = std::max(worst, std::abs(u(i, k) - (stretch(k) - 1) * mesh.X(i, k)));
  return worst / H;
}

struct Outcome {
  int status;
  std::string err;
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Runs ltl_run in `dir` with `args`; returns the exit status and stderr.
Outcome run_cli(const fs::path& dir, const std::string& args) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "cd '" + dir.string() + "' && " +
                          ltl::testing::binary_path("experiments/ltl_run") + " " + args + " 2> '" +
                          err.string() + "' > /dev/null";
  const int rc = std::system(cmd.c_str());
  Outcome r{WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, read_text(err)};
  fs::remove(err);
  return r;
}

/// A folder with the first-problem block (block.toml, block.geo), `from` replaced by `to`.
struct BlockFolder {
  fs::path dir;
  explicit BlockFolder(const std::string& name, const std::string& from = "",
                       const std::string& to = "")
      : dir(ltl::testing::temp_dir("inputs_" + name)) {
    std::string text = read_text(kBlock);
    if (!from.empty()) {
      const auto at = text.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) text.replace(at, from.size(), to);
    }
    write_file(dir / "block.toml", text);
    fs::copy_file(source_path("experiments/first_problem/block.geo"), dir / "block.geo");
  }
  ~BlockFolder() { fs::remove_all(dir); }
  std::string config() const { return (dir / "block.toml").string(); }
};

// The 3-D block: the unit box of 3^3 hexahedra (tests/geometry/box.geo) on the plane z = 0,
// symmetry x = 0 and y = 0, pressure p on the top, no [algorithm] table.
std::string box_config(double p) {
  std::ostringstream s;
  s.precision(17);
  s << "name = \"box\"\n[mesh]\ngeometry = \"" << test_path("geometry/box.geo")
    << "\"\nparameters = { n = 3 }\n[material]\nmodel = \"mooney-rivlin\"\nC1 = \"100 kPa\"\n"
       "C2 = \"30 kPa\"\n[[symmetry]]\ngroup = \"x0\"\ncomponent = \"x\"\n[[symmetry]]\n"
       "group = \"y0\"\ncomponent = \"y\"\n[[load.traction]]\ngroup = \"z1\"\nvalue = [0, 0, "
    << -p
    << "]\n[contact]\ngroup = \"z0\"\nplane_point = [0, 0, 0]\nplane_normal = [0, 0, -1]\n"
       "beta0 = 0.0\n";
  return s.str();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Defaults from the material (derive_algorithm_defaults).
// ---------------------------------------------------------------------------------------------

TEST(AlgorithmDefaults, Eq1_5_PlaneStrainBlockWithoutAlgorithmKeysMatchesClosedForm) {
  const Problem p = load_problem(kBlock);
  const double C1 = 200e3, C2 = 50e3, H = 0.05, pressure = 100e3;
  // The rule: q = 2 (C1 + C2), R q = 6 (C1 + C2) in 2-D, q_c = q / h (h = mean facet length of
  // the contact surface: 8 edges over the half width 0.1 m).
  EXPECT_TRUE(p.algorithm.R_derived && p.algorithm.q_derived && p.algorithm.q_c_derived);
  EXPECT_DOUBLE_EQ(p.algorithm.q, 2 * (C1 + C2));
  EXPECT_DOUBLE_EQ(p.algorithm.R * p.algorithm.q, 6 * (C1 + C2));
  const auto& bottom = p.mesh.boundary("bottom");
  EXPECT_NEAR(p.algorithm.h, 0.1 / bottom.facets.rows(), 1e-12);
  EXPECT_DOUBLE_EQ(p.algorithm.q_c, p.algorithm.q / p.algorithm.h);

  const auto r = ltl::testing::solve_one_step(p);
  const double l = stretch_under(2, C1, C2, pressure);
  const double err = block_error(p.mesh, r.s.u, l, H);
  const Eigen::VectorXd pc = r.solver->discretization().contact_pressure(r.s);
  const double perr = (pc.array() - pressure).abs().maxCoeff() / pressure;
  std::printf(
      "  2-D block, defaults %s: %d iterations, l = %.6f, max |u - u_exact| / H = %.1e, "
      "max |p_c - p| / p = %.1e\n",
      describe_algorithm(p.algorithm).c_str(), r.report.iterations, l, err, perr);
  EXPECT_LT(err, 1e-6);
  EXPECT_LT(perr, 1e-5);
  EXPECT_LT(r.report.iterations, 500);
}

TEST(AlgorithmDefaults, Eq1_5_ThreeDBlockWithoutAlgorithmKeysMatchesClosedForm) {
  const double C1 = 100e3, C2 = 30e3, pressure = 100e3;
  const fs::path dir = ltl::testing::temp_dir("inputs_box");
  write_file(dir / "box.toml", box_config(pressure));
  const Problem p = load_problem((dir / "box.toml").string());
  fs::remove_all(dir);
  EXPECT_DOUBLE_EQ(p.algorithm.q, 2 * (C1 + C2));
  EXPECT_DOUBLE_EQ(p.algorithm.R * p.algorithm.q, 8 * (C1 + C2));
  EXPECT_NEAR(p.algorithm.h, 1.0 / 3, 1e-12);
  EXPECT_DOUBLE_EQ(p.algorithm.q_c, p.algorithm.q / (3 * p.algorithm.h));
  const auto r = ltl::testing::solve_one_step(p);
  const double l = stretch_under(3, C1, C2, pressure);
  const double err = block_error(p.mesh, r.s.u, l, 1.0);
  std::printf("  3-D block, defaults %s: %d iterations, l = %.6f, max |u - u_exact| / H = %.1e\n",
              describe_algorithm(p.algorithm).c_str(), r.report.iterations, l, err);
  EXPECT_LT(err, 1e-6);
  EXPECT_LT(r.report.iterations, 1000);
}

// The contact surface must be part of the boundary: every contact facet a facet of exactly one
// cell (Problem::validate). In 3-D, a box of two layers of hexahedra: its bottom is a contact
// surface, the interface of the layers ("mid", each facet shared by two cells) is refused.
TEST(ContactSurface, AnInteriorSurfaceOfHexahedraIsRefused) {
  const fs::path dir = ltl::testing::temp_dir("inputs_layers");
  write_file(dir / "layers.geo",
             "Point(1)={0,0,0};Point(2)={1,0,0};Point(3)={1,1,0};Point(4)={0,1,0};"
             "Line(1)={1,2};Line(2)={2,3};Line(3)={3,4};Line(4)={4,1};"
             "Curve Loop(1)={1,2,3,4};Plane Surface(1)={1};"
             "Transfinite Curve{1,2,3,4}=3;Transfinite Surface{1};Recombine Surface{1};"
             "a[]=Extrude {0,0,0.5} { Surface{1}; Layers{2}; Recombine; };"
             "b[]=Extrude {0,0,0.5} { Surface{a[0]}; Layers{2}; Recombine; };"
             "Physical Surface(\"z0\")={1};Physical Surface(\"mid\")={a[0]};"
             "Physical Surface(\"z1\")={b[0]};Physical Surface(\"y0\")={a[2],b[2]};"
             "Physical Surface(\"x0\")={a[5],b[5]};Physical Volume(\"b\")={a[1],b[1]};\n");
  std::string text = box_config(100e3);
  text.replace(text.find(test_path("geometry/box.geo")), test_path("geometry/box.geo").size(),
               (dir / "layers.geo").string());
  text.replace(text.find("parameters = { n = 3 }\n"), 23, "");
  write_file(dir / "z0.toml", text);
  const Problem p = load_problem((dir / "z0.toml").string());
  EXPECT_EQ(p.mesh.nodes_per_cell(), 8);
  EXPECT_EQ(p.mesh.num_cells(), 16);
  EXPECT_EQ(p.mesh.boundary("mid").facets.rows(), 4);
  text.replace(text.find("group = \"z0\""), 12, "group = \"mid\"");
  write_file(dir / "mid.toml", text);
  std::string message;
  try {
    load_problem((dir / "mid.toml").string());
  } catch (const Error& e) {
    message = e.what();
  }
  for (const char* w : {"contact.group", "'mid' facet 0", "is not on the boundary of the body"})
    EXPECT_NE(message.find(w), std::string::npos) << "'" << w << "' not in: '" << message << "'";
  fs::remove_all(dir);
}

TEST(AlgorithmDefaults, ExplicitValuesAreKept) {
  // Fig 5 states R, q, q_c: they are used as written, none derived.
  const Problem fig5 = load_problem(source_path("experiments/fig5/fig5.toml"));
  EXPECT_EQ(fig5.algorithm.R, 5.0);
  EXPECT_EQ(fig5.algorithm.q, 1e6);
  EXPECT_EQ(fig5.algorithm.q_c, 1e6);
  EXPECT_FALSE(fig5.algorithm.R_derived || fig5.algorithm.q_derived || fig5.algorithm.q_c_derived);
  // One key given: the others follow the rule from it (R from the given q, q_c = q / h).
  const Problem p = load_problem(kBlock, {"algorithm.q=\"1 MPa\""});
  EXPECT_FALSE(p.algorithm.q_derived);
  EXPECT_EQ(p.algorithm.q, 1e6);
  EXPECT_DOUBLE_EQ(p.algorithm.R, 6 * 250e3 / 1e6);
  EXPECT_DOUBLE_EQ(p.algorithm.q_c, 1e6 / p.algorithm.h);
}

TEST(AlgorithmDefaults, Eq4_7_GluedBlockPulledOffConvergesWithoutAlgorithmKeys) {
  // The block of first_problem glued to the plane (kappa = 1/eps = 1e9 Pa/m, w = 1 J/m^2) and
  // pulled up by 10 kPa. With q_c = q / h = 4e7 Pa/m it hit the iteration cap (beta jumping
  // between 0 and 1); with glue q_c is at least kappa / R.
  const Problem p = load_problem(
      kBlock, {"contact.beta0=1", "contact.w=\"1 J/m^2\"", "contact.kappa=\"1e9 Pa/m\"",
               "load.traction[0].value=[0, \"10 kPa\"]"});
  EXPECT_TRUE(p.algorithm.q_c_derived);
  EXPECT_DOUBLE_EQ(p.algorithm.R, 3);
  EXPECT_DOUBLE_EQ(p.algorithm.q_c, 1e9 / 3);
  EXPECT_GT(p.algorithm.q_c, p.algorithm.q / p.algorithm.h);
  EXPECT_NE(describe_algorithm(p.algorithm).find("with glue at least kappa / R"),
            std::string::npos);
  const auto r = ltl::testing::solve_one_step(p);
  EXPECT_LT(r.report.iterations, 500);  // 161
  // The glue holds (beta = 1) except at the free corner x1 = 0.1, where the peel stress
  // concentrates (measured beta = 0.022), and carries the pull: sum w p = -10 kPa x 0.1 m.
  int broken = -1, count = 0;
  for (int i = 0; i < r.s.beta.size(); ++i)
    if (r.s.beta(i) < 1) broken = i, ++count;
  EXPECT_EQ(count, 1);
  ASSERT_GE(broken, 0);
  EXPECT_NEAR(r.solver->discretization().points()->centre(0, broken), 0.1, 1e-12);
  const Eigen::VectorXd pc = r.solver->discretization().contact_pressure(r.s);
  EXPECT_NEAR(r.solver->discretization().points()->area.dot(pc), -1000.0, 1e-2);
  std::printf("  glued block pulled off, defaults %s: %d iterations\n",
              describe_algorithm(p.algorithm).c_str(), r.report.iterations);
  // Without glue the rule is unchanged (q_c = q / h).
  const Problem free = load_problem(kBlock);
  EXPECT_DOUBLE_EQ(free.algorithm.q_c, free.algorithm.q / free.algorithm.h);
}

// ---------------------------------------------------------------------------------------------
// --set on list entries, and errors that name the --set argument.
// ---------------------------------------------------------------------------------------------

TEST(SetOverrides, ReachListEntries) {
  const Problem p = load_problem(kBlock, {"load.traction[0].value=[0, \"-50 kPa\"]"});
  ASSERT_EQ(p.tractions.size(), 1u);
  EXPECT_EQ(p.tractions[0].g.value(1), -50e3);
  EXPECT_EQ(p.tractions[0].group, "top");
  // An entry of a plain array.
  const Problem q = load_problem(kBlock, {"contact.plane_point[1]=\"-1 mm\""});
  EXPECT_EQ(q.contacts[0].plane_point(1), -1e-3);
  EXPECT_EQ(q.contacts[0].plane_point(0), 0.0);
}

struct BadInput {
  std::string name, from, to, args;
  std::vector<std::string> words;  ///< all in the message
  std::string absent = "";         ///< not in the message ("" : no check)
};

class InputErrors : public ::testing::TestWithParam<BadInput> {};

TEST_P(InputErrors, ExitStatusOneAndAMessageNamingTheInput) {
  const BadInput& c = GetParam();
  BlockFolder f(c.name, c.from, c.to);
  const Outcome r = run_cli(f.dir, "block.toml -q -o out.h5 " + c.args);
  EXPECT_EQ(r.status, 1) << r.err;
  for (const auto& w : c.words)
    EXPECT_NE(r.err.find(w), std::string::npos) << "'" << w << "' not in: " << r.err;
  if (!c.absent.empty()) {
    EXPECT_EQ(r.err.find(c.absent), std::string::npos) << r.err;
  }
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_FALSE(fs::exists(f.dir / "out.h5"));
}

const std::string kSymmetry =
    "[[symmetry]]                     # half of the block: u1 = 0 on x1 = 0\ngroup = \"left\"\n"
    "component = \"x\"\n";

const std::vector<BadInput>& bad_inputs() {
  static const std::vector<BadInput> cases = {
      {"set_index_out_of_range",
       "",
       "",
       "--set 'load.traction[3].value=[0, 1]'",
       {"--set 'load.traction[3].value=[0, 1]'", "load.traction' has 1 entry",
        "[3] does not exist"}},
      {"set_index_not_array",
       "",
       "",
       "--set 'material[0].C1=1'",
       {"--set 'material[0].C1=1'", "'material' is not an array"}},
      {"set_unknown_key",
       "",
       "",
       "--set algorithm.RR=3",
       {"--set 'algorithm.RR=3'", "key 'algorithm.RR'", "unknown key"},
       ":0"},
      {"set_list_entry_wrong_unit",
       "",
       "",
       "--set 'load.traction[0].value=[0, \"5 m\"]'",
       {"--set 'load.traction[0].value=[0, \"5 m\"]'", "key 'load.traction[0].value'", "unit 'm'"}},
      {"set_value_out_of_range",
       "",
       "",
       "--set algorithm.R=-2",
       {"--set 'algorithm.R=-2'", "key 'algorithm.R'", "must be > 0"},
       ":0"},
      // A body free to slide: no symmetry plane, only the frictionless plane below.
      {"free_to_slide_2d",
       kSymmetry,
       "",
       "",
       {"block.toml", "contact.group", "free to slide along the contact plane", "the x direction",
        "[[symmetry]]"}},
      {"free_to_slide_no_glue_yet",  // glue stiffness but beta0 = 0: nothing holds
       kSymmetry,
       "",
       "--set contact.kappa=1e9",
       {"free to slide", "the x direction"}},
      // Load ramps.
      {"ramp_unknown",
       "[contact]",
       "[load]\nramp = \"quadratic\"\n[contact]",
       "",
       {"block.toml", "key 'load.ramp'", "\"linear\""}},
      {"ramp_linear_without_time",
       "",
       "",
       "--set load.ramp=linear",
       {"key 'load.ramp_time'", "missing value"}},
      {"ramp_time_without_linear",
       "",
       "",
       "--set 'load.ramp_time=\"5 s\"'",
       {"key 'load.ramp_time'", "needs ramp = \"linear\""}},
      {"ramp_table_longer_than_steps",
       "",
       "",
       "--set load.ramp=table --set 'load.factor=[0.5, 1]'",
       {"key 'load.factor'", "has 2 entries but time.steps = 1", "--stop-after"}},
      {"ramp_table_not_numbers",
       "",
       "",
       "--set load.ramp=table --set 'load.factor=[\"a\"]'",
       {"key 'load.factor[0]'", "expected a number"}},
  };
  return cases;
}

INSTANTIATE_TEST_SUITE_P(Inputs, InputErrors, ::testing::ValuesIn(bad_inputs()),
                         [](const auto& info) { return info.param.name; });

TEST(Sliding, ThreeDBlockWithOneSymmetryPlaneIsFreeAlongY) {
  const fs::path dir = ltl::testing::temp_dir("inputs_slide3d");
  std::string text = box_config(1e5);
  const std::string y0 = "[[symmetry]]\ngroup = \"y0\"\ncomponent = \"y\"\n";
  text.replace(text.find(y0), y0.size(), "");
  write_file(dir / "box.toml", text);
  try {
    load_problem((dir / "box.toml").string());
    ADD_FAILURE() << "accepted";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("free to slide along the contact plane in the direction (0, 1, 0), the y "
                     "direction"),
              std::string::npos)
        << m;
  }
  fs::remove_all(dir);
}

TEST(Sliding, TheFiguresAndAGluedBlockAreAccepted) {
  for (const char* c : {"experiments/fig3/fig3.toml", "experiments/fig4/fig4.toml",
                        "experiments/fig5/fig5.toml", "experiments/fig6/fig6.toml"})
    EXPECT_NO_THROW(load_problem(source_path(c))) << c;
  // Glue (kappa > 0, beta0 > 0) holds every component: no symmetry plane needed.
  BlockFolder f("glued", kSymmetry, "");
  EXPECT_NO_THROW(load_problem(f.config(), {"contact.beta0=1.0", "contact.kappa=1e9"}));
}

// ---------------------------------------------------------------------------------------------
// Load ramps (LoadRamp) and the extension of a finished run.
// ---------------------------------------------------------------------------------------------

TEST(LoadRamp, FactorOfEachStep) {
  LoadRamp r;
  EXPECT_EQ(r.factor(1, 1.0), 1.0);
  r.kind = LoadRamp::Kind::Linear;
  r.ramp_time = 4;
  EXPECT_EQ(r.factor(1, 1.0), 0.25);
  EXPECT_EQ(r.factor(3, 1.0), 0.75);
  EXPECT_EQ(r.factor(6, 1.0), 1.0);
  r.kind = LoadRamp::Kind::Table;
  r.table = {0.5, 0.2};
  EXPECT_EQ(r.factor(1, 1.0), 0.5);
  EXPECT_EQ(r.factor(2, 1.0), 0.2);
  EXPECT_EQ(r.factor(9, 1.0), 0.2);
}

// Each step of a linear ramp (and of a table) is the closed form for that step's pressure.
TEST(LoadRamp, Eq1_5_EveryStepOfALinearRampIsTheClosedFormOfItsLoad) {
  const double C1 = 200e3, C2 = 50e3, H = 0.05, pressure = 100e3;
  for (const std::vector<std::string>& ramp :
       {std::vector<std::string>{"load.ramp=linear", "load.ramp_time=\"4 s\"", "time.steps=5"},
        std::vector<std::string>{"load.ramp=table", "load.factor=[0.3, 0.1, 1.6]",
                                 "time.steps=3"}}) {
    const Problem p = load_problem(kBlock, ramp);
    int seen = 0;
    RunOptions o;
    o.verbosity = 0;
    run(p, o, [&](const Solver& solver, int step, const State& s) {
      const double factor = p.ramp.factor(step, p.time.dt);
      EXPECT_EQ(solver.load_factor(), factor);
      // (factor 0 is not used: unloaded, the block may lift off by any amount)
      const double l = stretch_under(2, C1, C2, factor * pressure);
      const double err = block_error(p.mesh, s.u, l, H);
      std::printf("  %s step %d: load factor %.2f, l = %.6f, max |u - u_exact| / H = %.1e\n",
                  ramp[0].c_str(), step, factor, l, err);
      EXPECT_LT(err, 1e-6) << "step " << step;
      ++seen;
    });
    EXPECT_EQ(seen, p.time.steps);
  }
}

TEST(LoadRamp, ExtendingAFinishedRunEqualsTheLongerRunBitwise) {
  BlockFolder f("extend");
  const std::vector<std::string> ramp = {"load.ramp=linear", "load.ramp_time=\"3 s\""};
  auto with = [&](std::vector<std::string> v, const std::string& extra) {
    v.push_back(extra);
    return v;
  };
  RunOptions o;
  o.verbosity = 0;
  o.output = (f.dir / "long.h5").string();
  run(load_problem(f.config(), with(ramp, "time.steps=4")), o);
  o.output = (f.dir / "short.h5").string();
  run(load_problem(f.config(), with(ramp, "time.steps=2")), o);
  ASSERT_EQ(ResultsFile::read_attribute(o.output, "status"), "complete");
  o.resume = true;  // the finished 2-step run, extended to 4 steps
  const RunSummary s = run(load_problem(f.config(), with(ramp, "time.steps=4")), o);
  EXPECT_EQ(s.first_step, 3);
  EXPECT_EQ(s.last_step, 4);
  const auto a = ResultsFile::read_last_step((f.dir / "long.h5").string());
  const auto b = ResultsFile::read_last_step(o.output);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->p, 4);
  EXPECT_EQ(b->p, 4);
  const auto bits = [](const auto& x, const auto& y) {
    return x.rows() == y.rows() && x.cols() == y.cols() &&
           std::memcmp(x.data(), y.data(), sizeof(double) * x.size()) == 0;
  };
  EXPECT_TRUE(bits(a->state.u, b->state.u) && bits(a->state.E, b->state.E) &&
              bits(a->state.lambda, b->state.lambda) && bits(a->state.e, b->state.e) &&
              bits(a->state.lambda_c, b->state.lambda_c) && bits(a->state.beta, b->state.beta));
  EXPECT_EQ(a->iterations, b->iterations);
  // Resuming the finished run again does nothing and says so (exit 0).
  const Outcome r = run_cli(f.dir,
                            "block.toml -o short.h5 --resume --set load.ramp=linear "
                            "--set 'load.ramp_time=\"3 s\"' --set time.steps=4 2>&1");
  EXPECT_EQ(r.status, 0) << r.err;
  // Extending a run written without [time] by --set time.steps (the identity ignores the
  // empty table left behind).
  o.output = (f.dir / "plain.h5").string();
  o.resume = false;
  run(load_problem(f.config()), o);
  o.resume = true;
  EXPECT_NO_THROW(run(load_problem(f.config(), {"time.steps=2"}), o));
  EXPECT_EQ(ResultsFile::read_last_step(o.output)->p, 2);
}
