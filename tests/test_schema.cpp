// The configuration schema (lib/config_schema.hpp): the resolved configuration a run stores is
// accepted back by load_problem and repeats the run bit for bit, for every figure's
// configuration (a step or two, or a coarse variant) and for the keys the figures leave at their
// defaults (load ramps, adaptive R, prescribed displacements, eps, the exact kernel); and the key
// table of experiments/README.md is the one the schema generates.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "config.hpp"
#include "config_schema.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

using namespace ltl;
namespace fs = std::filesystem;

namespace {

struct Run {
  std::vector<State> states;
  std::vector<int> iterations;
  std::string resolved;  ///< the attribute config_resolved of the results file
};

Run run_and_record(const Problem& p, const fs::path& out) {
  Run r;
  RunOptions o;
  o.output = out.string();
  o.verbosity = 0;
  r.iterations =
      run(p, o, [&](const Solver&, int, const State& s) { r.states.push_back(s); }).iterations;
  r.resolved = ResultsFile::read_attribute(o.output, "config_resolved");
  return r;
}

/// Every entry equal, bit for bit (NaN nowhere in a converged state).
void expect_same(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, const std::string& what) {
  ASSERT_EQ(a.rows(), b.rows()) << what;
  ASSERT_EQ(a.cols(), b.cols()) << what;
  EXPECT_EQ(a, b) << what << ": max difference " << (a - b).cwiseAbs().maxCoeff();
}

/// Runs `config` with `overrides`, then the resolved configuration its results file stores
/// (from another folder, no overrides), and checks that the second run repeats the first bit for
/// bit and stores the same resolved configuration.
void expect_resolved_repeats_the_run(const std::string& config,
                                     const std::vector<std::string>& overrides) {
  const fs::path dir = ltl::testing::temp_dir("schema_resolved");
  const Run first = run_and_record(load_problem(config, overrides), dir / "first.h5");
  ASSERT_FALSE(first.states.empty()) << config;
  ASSERT_FALSE(first.resolved.empty()) << config;
  fs::create_directories(dir / "elsewhere");
  const fs::path resolved = dir / "elsewhere" / "resolved.toml";
  ltl::testing::write_file(resolved, first.resolved);
  const Run second = run_and_record(load_problem(resolved.string()), dir / "second.h5");
  EXPECT_EQ(second.resolved, first.resolved) << config;
  EXPECT_EQ(second.iterations, first.iterations) << config;
  ASSERT_EQ(second.states.size(), first.states.size()) << config;
  for (std::size_t p = 0; p < first.states.size(); ++p) {
    const State &a = first.states[p], &b = second.states[p];
    const std::string at = config + ", step " + std::to_string(p + 1);
    expect_same(a.u, b.u, at + ": u");
    expect_same(a.E, b.E, at + ": E");
    expect_same(a.lambda, b.lambda, at + ": lambda");
    expect_same(a.e, b.e, at + ": e");
    expect_same(a.beta, b.beta, at + ": beta");
    expect_same(a.lambda_c, b.lambda_c, at + ": lambda_c");
  }
  std::printf("  %s: %zu step(s), %d iterations, repeated bit for bit from its resolved record\n",
              fs::path(config).filename().c_str(), first.states.size(),
              first.iterations.empty() ? 0 : first.iterations.back());
  fs::remove_all(dir);
}

std::string figure(const std::string& rel) {
  return ltl::testing::source_path("experiments/" + rel);
}

}  // namespace

// Figs 3 and 4 (both readings, glued, compressible and Mooney-Rivlin, [[fixed]]): two time steps.
TEST(Schema, ResolvedConfigurationRepeatsFigs3And4) {
  for (const char* f :
       {"fig3/fig3.toml", "fig3/fig3_literal.toml", "fig4/fig4.toml", "fig4/fig4_literal.toml"})
    expect_resolved_repeats_the_run(figure(f), {"time.steps=2"});
}

// Fig 5 (pure contact, [[symmetry]]) at its resolution with a looser tolerance, and Fig 6 (3-D,
// H8) on a coarse mesh.
TEST(Schema, ResolvedConfigurationRepeatsFigs5And6) {
  expect_resolved_repeats_the_run(figure("fig5/fig5.toml"), {"algorithm.tol=1e-6"});
  expect_resolved_repeats_the_run(
      figure("fig6/fig6.toml"),
      {"mesh.parameters.na=4", "mesh.parameters.nl=4", "algorithm.tol=1e-5"});
}

// The first problem (Newton by default, a traction), the peel, and the keys the figures leave at
// their defaults: a table and a linear load ramp, adaptive R, Anderson, a prescribed displacement
// with a gradient, eps instead of kappa, the exact kernel on facet-mean contact, d0, w.
TEST(Schema, ResolvedConfigurationRepeatsTheKeysFiguresLeaveOut) {
  const std::string block = figure("first_problem/block.toml");
  expect_resolved_repeats_the_run(block, {});
  expect_resolved_repeats_the_run(
      block, {"displacement=[{group = \"top\", value = [\"0 m\", \"-1 mm\"], gradient = [[0, 0], "
              "[0.001, 0]]}]",
              "load.ramp=\"table\"", "load.factor=[0.5, 1]", "time.steps=2",
              "algorithm.solver=\"alg2\"", "algorithm.adaptive_R=true", "algorithm.adapt_every=5",
              "algorithm.R_min=0.5", "algorithm.max_refactorizations=2",
              "algorithm.acceleration=\"anderson\"", "algorithm.depth=3"});
  // The peel (a ramped [[fixed]] value lifting a glued strip), and a support on one component.
  expect_resolved_repeats_the_run(figure("peel/peel.toml"), {"time.steps=2"});
  expect_resolved_repeats_the_run(
      figure("peel/peel.toml"),
      {"fixed=[{group = \"right\", component = \"y\", value = \"2 mm\"}]", "time.steps=2"});
  expect_resolved_repeats_the_run(
      block, {"load.ramp=\"linear\"", "load.ramp_time=\"2 s\"", "time.steps=2", "contact.eps=1e-9",
              "contact.w=\"1 J/m^2\"", "contact.d0=10", "discretization.contact=\"facet-mean\"",
              "contact.kernel=\"exact\""});
}

// The command line accepts the record too: ltl_run on the first problem, then ltl_run on the
// resolved configuration its results file stores, give the same displacement, bit for bit.
TEST(Schema, LtlRunAcceptsTheResolvedConfigurationItStored) {
  const fs::path dir = ltl::testing::temp_dir("schema_ltl_run");
  const std::string ltl_run = ltl::testing::binary_path("experiments/ltl_run");
  const auto run_cli = [&](const std::string& config, const fs::path& out) {
    return std::system((ltl_run + " '" + config + "' -o '" + out.string() + "' -q").c_str());
  };
  ASSERT_EQ(run_cli(figure("first_problem/block.toml"), dir / "first.h5"), 0);
  ltl::testing::write_file(
      dir / "resolved.toml",
      ResultsFile::read_attribute((dir / "first.h5").string(), "config_resolved"));
  ASSERT_EQ(run_cli((dir / "resolved.toml").string(), dir / "second.h5"), 0);
  const auto a = ResultsFile::read_last_step((dir / "first.h5").string()),
             b = ResultsFile::read_last_step((dir / "second.h5").string());
  ASSERT_TRUE(a && b);
  EXPECT_GT(a->state.u.cwiseAbs().maxCoeff(), 0.0);
  expect_same(a->state.u, b->state.u, "u");
  expect_same(a->state.lambda_c, b->state.lambda_c, "lambda_c");
  fs::remove_all(dir);
}

// The resolved configuration states every key that applies: no default is left implicit, and
// nothing is written that the reader would refuse (it is read back above).
TEST(Schema, ResolvedConfigurationStatesEveryApplicableKey) {
  const Problem p = load_problem(figure("fig5/fig5.toml"), {"output.file=\"fig5_out.h5\""});
  ASSERT_FALSE(p.output_file.empty());
  const std::string text = resolved_configuration(p);
  int stated = 0;
  for (const config::Key& k : config::configuration_schema().keys) {
    if (k.section == "fixed" || k.section == "displacement" || k.section == "load.traction" ||
        k.name == "eps" || k.name == "ramp_time" || k.name == "factor" || k.name == "C3" ||
        k.name == "mu" || k.name == "alpha" || k.name == "Jm" || k.section == "output")
      continue;  // not in Fig 5 (C3, mu, alpha, Jm: other laws), or written as another key
                 // (eps as kappa)
    EXPECT_NE(text.find("\n" + k.name + " = "), std::string::npos) << k.section << "." << k.name;
    ++stated;
  }
  EXPECT_GE(stated, 45);
  // Nor [output] file: a rerun of the record must not write over the run it repeats.
  for (const char* absent : {"\ndim = ", "\nnodes = ", "[[dirichlet]]", "\neps = ", "[output]"})
    EXPECT_EQ(text.find(absent), std::string::npos) << absent;
}

// experiments/README.md's key table is the schema's (`make keys` rewrites it).
TEST(Schema, ReadmeKeyTableIsGenerated) {
  std::ifstream in(ltl::testing::source_path("experiments/README.md"));
  std::stringstream s;
  s << in.rdbuf();
  const std::string readme = s.str();
  const std::string begin = "<!-- keys: generated from lib/config_schema.cpp by `make keys` -->\n",
                    end = "<!-- end of keys -->";
  const auto b = readme.find(begin), e = readme.find(end);
  ASSERT_NE(b, std::string::npos) << "no marker " << begin;
  ASSERT_NE(e, std::string::npos) << "no marker " << end;
  const std::string table = readme.substr(b + begin.size(), e - b - begin.size());
  EXPECT_EQ(table, config::key_table_markdown()) << "run `make keys`";
  // One row per key of the schema.
  const std::size_t rows = std::count(table.begin(), table.end(), '\n');
  EXPECT_EQ(rows, config::configuration_schema().keys.size() + 2);
}
