//              Iterations to tolerance with and without Anderson acceleration (make bench)
//
// What:     ALG2 (4.1)-(4.4), plain (algorithm.acceleration = "none", the paper's iteration) and
//           with safeguarded Anderson acceleration ("anderson", depth m), on the Fig 5 half disc
//           refined (K = 7, 14, 28, 56 edges per quarter circle; R = 20 as in refinement fig5)
//           and on the Fig 6 gutter at its size and coarser/finer. For each: iterations, wall time
//           of the iterations (after the factorization), the accelerated iterates kept/rejected
//           by the safeguard, and the largest difference of u between the two runs relative to
//           max |u| (the fixed point must not move). Then the fitted growth exponent
//           iterations ~ nodes^p over each family, by least squares on the logarithms.
//
// Run:      build/experiments/bench_accel [--quick] [--depth M] [--trace CASE] [key=value]...
//           (from the repository root; --quick: K = 7, 14, 28 and the two smaller gutters;
//           key=value overrides every case, e.g. algorithm.accelerate=multipliers;
//           --trace CASE prints r_G + r_B and the safeguard's verdict per iteration of CASE)
//
// Method:   one thread (OMP_NUM_THREADS is respected); each run is a fresh Solver from the rest
//           state; the tolerance is each configuration's own (fig5.toml 1e-9, fig6.toml 1e-8).
//           Discussion of the numbers: paper_notes/performance.md, "Anderson acceleration".

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"

namespace {

struct Case {
  std::string name, config;
  std::vector<std::string> overrides;
};

struct Run {
  int nodes = 0, iterations = 0, kept = 0, rejected = 0;
  bool converged = false;
  double seconds = 0;
  Eigen::MatrixXd u;
};

Run run(const Case& c, std::vector<std::string> overrides, bool trace) {
  overrides.insert(overrides.begin(), c.overrides.begin(), c.overrides.end());
  const ltl::Problem p = ltl::load_problem(c.config, overrides);
  ltl::Solver solver(p);
  ltl::State s = solver.initial_state();
  const ltl::StepReport r = solver.solve_step(s, s.beta);
  if (trace)
    for (const auto& h : r.history)
      std::printf("  %6d  %.6e  %2d\n", h.n, h.r_G + h.r_B, h.accelerated);
  Run out;
  out.nodes = p.mesh.num_nodes();
  out.iterations = r.iterations;
  out.kept = r.accepted;
  out.rejected = r.rejected;
  out.converged = r.converged;
  out.seconds = r.history.back().wall;
  out.u = s.u;
  return out;
}

// Least-squares slope of log(iterations) against log(nodes).
double exponent(const std::vector<Run>& runs) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  const double n = runs.size();
  for (const Run& r : runs) {
    const double x = std::log(r.nodes), y = std::log(r.iterations);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace

int main(int argc, char** argv) try {
  bool quick = false;
  int depth = 10;
  std::string trace;
  std::vector<std::string> extra;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else if (!std::strcmp(argv[i], "--depth") && i + 1 < argc)
      depth = std::stoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--trace") && i + 1 < argc)
      trace = argv[++i];
    else
      extra.push_back(argv[i]);
  }
  const std::string fig5 = "experiments/fig5/fig5.toml", fig6 = "experiments/fig6/fig6.toml";
  std::vector<std::vector<Case>> families(2);
  for (int K : {7, 14, 28, 56}) {
    if (quick && K > 28) continue;
    const std::string k = std::to_string(K);
    families[0].push_back(
        {"fig5 K=" + k,
         fig5,
         {"mesh.parameters.n=" + k, "mesh.parameters.nd=" + k, "algorithm.R=20"}});
  }
  const int gutter[3][2] = {{10, 6}, {15, 9}, {30, 18}};  // nl, na (fig6.toml: 15, 9)
  for (int g = 0; g < 3; ++g) {
    if (quick && g == 2) continue;
    const std::string nl = std::to_string(gutter[g][0]), na = std::to_string(gutter[g][1]);
    families[1].push_back({"fig6 nl=" + nl + " na=" + na,
                           fig6,
                           {"mesh.parameters.nl=" + nl, "mesh.parameters.na=" + na}});
  }
  std::vector<std::string> plain = extra, accel = extra;
  plain.push_back("algorithm.acceleration=none");
  accel.push_back("algorithm.acceleration=anderson");
  accel.push_back("algorithm.depth=" + std::to_string(depth));

  std::printf("Anderson acceleration of ALG2, depth %d (plain = the paper's iteration)\n\n", depth);
  std::printf("%-20s %7s | %8s %9s | %8s %11s %9s | %7s %9s\n", "case", "nodes", "plain it",
              "time s", "AA it", "kept/rej", "time s", "it ratio", "|du|/|u|");
  for (const auto& family : families) {
    std::vector<Run> P, A;
    for (const Case& c : family) {
      if (!trace.empty() && trace != c.name) continue;
      P.push_back(run(c, plain, false));
      A.push_back(run(c, accel, trace == c.name));
      const Run &p = P.back(), &a = A.back();
      const double du = (p.u - a.u).cwiseAbs().maxCoeff() / p.u.cwiseAbs().maxCoeff();
      std::printf("%-20s %7d | %7d%s %9.3f | %7d%s %5d/%-5d %9.3f | %7.1f %9.1e\n", c.name.c_str(),
                  p.nodes, p.iterations, p.converged ? " " : "!", p.seconds, a.iterations,
                  a.converged ? " " : "!", a.kept, a.rejected, a.seconds,
                  double(p.iterations) / a.iterations, du);
      std::fflush(stdout);
    }
    if (P.size() >= 2)
      std::printf("%-20s growth exponent iterations ~ nodes^p: plain %.2f, Anderson %.2f\n\n", "",
                  exponent(P), exponent(A));
  }
  std::printf("(! = not converged within algorithm.max_iter)\n");
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_accel: %s\n", e.what());
  return 1;
}
