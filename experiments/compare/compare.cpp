// Uzawa (4.1)-(4.4) against Bermudez-Moreno (7.7)-(7.10) on every figure's problem.
//
//   Paper: section 7 ("this BERMUDEZ-MORENO algorithm appears, within a small variant, as a
//          particular case of algorithm (4.1)-(4.4)") and section 8 ("The use of the
//          BERMUDEZ-MORENO variant of section 7 did not bring any speed-up of the algorithm").
//   Anderson: every figure also runs with algorithm.acceleration = "anderson" (variants
//          "...-anderson"): the accelerated iteration next to the paper's plain one; Figs 5
//          and 6 also with algorithm.solver = "newton" ("uzawa-newton").
//   Make:  make compare
//   Run:   build/experiments/compare [OUTDIR]        (default results/compare)
//
// The two iterations differ only in the multiplier update:
//
//   Uzawa:            u^n <- (4.1)(G^{n-1}, lambda^{n-1});  G^n <- (4.2)(u^n, lambda^{n-1})
//                     lambda^n = lambda^{n-1} - rho R q B(u^n, G^n)
//   Bermudez-Moreno:  u^n <- (7.7);  lambda^{n-1/2} = lambda^{n-1} - R q B(u^n, G^{n-1})  (7.8)
//                     G^n <- (7.9)(u^n, lambda^{n-1/2})
//                     lambda^n = lambda^{n-1/2} - (2 rho - 1) R q B(u^n, G^n)            (7.10)
//
// Every run writes its own HDF5 file OUTDIR/<problem>-<variant>.h5 (histories of both residual
// parts and wall time per iteration); figures/compare.py draws one page per problem and the
// parameter sweeps from those files. This program prints the table of iterations and time to
// tolerance.
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "config.hpp"
#include "error.hpp"
#include "simulation.hpp"

namespace {

struct Run {
  std::string problem, variant, config;
  std::vector<std::string> overrides;
};

// 1. The problems: Figs 3 and 4 before and through the peel, Figs 5 and 6 as in the paper.
//    Fig 3's own variant uses two block relaxations per update; Bermudez-Moreno does one, so
//    Uzawa with one sweep is shown too. Figs 3 and 4 under their literal reading R1 (pulled up,
//    the peel runs away: the hard case; paper_notes/readings.md), as measured in section8.md.
std::vector<Run> runs() {
  const std::string uzawa = "algorithm.update=uzawa", bm = "algorithm.update=bermudez-moreno";
  // Each figure also with safeguarded Anderson acceleration (default depth and accelerated
  // variables; paper_notes/performance.md, "Anderson acceleration"), the iteration the paper's
  // plain one is compared with.
  const std::string anderson = "algorithm.acceleration=anderson";
  std::vector<Run> r;
  for (const std::string fig : {"fig3", "fig4"}) {
    const std::string cfg = "experiments/" + fig + "/" + fig + "_literal.toml";
    r.push_back({fig, "uzawa-2sweeps", cfg, {uzawa, "algorithm.sweeps=2"}});
    r.push_back({fig, "uzawa", cfg, {uzawa, "algorithm.sweeps=1"}});
    r.push_back({fig, "bermudez-moreno", cfg, {bm, "algorithm.sweeps=1"}});
    r.push_back({fig, "uzawa-2sweeps-anderson", cfg, {uzawa, "algorithm.sweeps=2", anderson}});
  }
  for (const std::string fig : {"fig5", "fig6"}) {
    const std::string cfg = "experiments/" + fig + "/" + fig + ".toml";
    r.push_back({fig, "uzawa", cfg, {uzawa}});
    r.push_back({fig, "bermudez-moreno", cfg, {bm}});
    r.push_back({fig, "uzawa-anderson", cfg, {uzawa, anderson}});
    r.push_back({fig, "bermudez-moreno-anderson", cfg, {bm, anderson}});
    // ALG2 into the basin of Newton's method on the same discrete problem (lib/newton.hpp):
    // the history's last rows are Newton's (r_G = force residual, r_B = constraint residual).
    r.push_back({fig, "uzawa-newton", cfg, {uzawa, "algorithm.solver=newton"}});
  }
  // 2. Sweeps of R (both updates) and rho (Bermudez-Moreno) on Fig 5 and on the first six
  //    steps of Fig 3.
  for (const double R : {1.0, 2.0, 5.0, 10.0, 20.0}) {
    const std::string Rs = "algorithm.R=" + std::to_string(R);
    char tag[32];
    std::snprintf(tag, sizeof tag, "R%g", R);
    r.push_back(
        {"sweep-fig5", std::string("uzawa-") + tag, "experiments/fig5/fig5.toml", {uzawa, Rs}});
    r.push_back({"sweep-fig5",
                 std::string("bermudez-moreno-") + tag,
                 "experiments/fig5/fig5.toml",
                 {bm, Rs}});
  }
  for (const double R : {4.0, 8.0, 16.0, 32.0}) {
    const std::string Rs = "algorithm.R=" + std::to_string(R);
    char tag[32];
    std::snprintf(tag, sizeof tag, "R%g", R);
    for (const auto& [name, upd] : {std::pair{"uzawa-", uzawa}, std::pair{"bermudez-moreno-", bm}})
      r.push_back({"sweep-fig3",
                   std::string(name) + tag,
                   "experiments/fig3/fig3_literal.toml",
                   {upd, Rs, "algorithm.sweeps=1", "time.steps=6"}});
  }
  for (const double rho : {0.55, 0.7, 0.8, 0.9, 1.0}) {
    char tag[32];
    std::snprintf(tag, sizeof tag, "rho%g", rho);
    r.push_back({"sweep-fig5",
                 std::string("bermudez-moreno-") + tag,
                 "experiments/fig5/fig5.toml",
                 {bm, "algorithm.rho=" + std::to_string(rho)}});
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc > 2 || (argc == 2 && argv[1][0] == '-')) {  // no option is a directory name
    const bool help =
        argc == 2 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help");
    std::fprintf(help ? stdout : stderr, "usage: compare [OUTDIR]   (default results/compare)\n");
    return help ? 0 : 2;
  }
  const std::string out = argc > 1 ? argv[1] : "results/compare";
  std::filesystem::create_directories(out);
  std::printf("%-12s %-26s %10s %12s  %s\n", "problem", "variant", "iterations", "solver [s]",
              "status");
  int failures = 0;
  for (const Run& r : runs()) {
    const std::string file = out + "/" + r.problem + "-" + r.variant + ".h5";
    try {
      const ltl::Problem p = ltl::load_problem(r.config, r.overrides);
      ltl::RunOptions options;
      options.output = file;
      options.verbosity = 0;
      const ltl::RunSummary s = ltl::run(p, options);
      int total = 0;
      for (int n : s.iterations) total += n;
      std::printf("%-12s %-26s %10d %12.3f  converged\n", r.problem.c_str(), r.variant.c_str(),
                  total, s.solver_seconds);
    } catch (const ltl::Error& e) {
      // A variant that does not converge is a result of the comparison, not a crash: report it
      // (its file keeps the steps that converged, marked "diverged") and go on.
      ++failures;
      std::printf("%-12s %-26s %10s %12s  %s\n", r.problem.c_str(), r.variant.c_str(), "-", "-",
                  e.what());
    }
    std::fflush(stdout);
  }
  std::printf("%d run(s) did not converge\n", failures);
  return 0;
}
