//          Iterations to tolerance against mesh size, plain and Anderson (make bench)
//
// What:     ALG2 (4.1)-(4.4), plain (algorithm.acceleration = "none", the paper's iteration) and
//           with safeguarded Anderson acceleration ("anderson", depth m), on the Fig 5 half disc
//           refined (K = 7, 14, 28, 56, 112 edges per quarter circle; R = 20 as in `refinement
//           fig5`) and on the Fig 6 gutter at levels L = 1, 2, 3 ((nt, na, nl) = L x (2, 9, 15)
//           hexahedra as in `refinement fig6`; L = 1 is the paper's 270 H8). For each run:
//           iterations to r_G + r_B < 1e-6 (performance.md's table) and to the
//           configuration's own tolerance (fig5.toml 1e-9, fig6.toml 1e-8), the accelerated
//           iterates kept/rejected by the safeguard, the wall time of one iteration (after the
//           factorization; it depends on the load of the machine, printed with every row, the
//           iteration counts do not), and the largest difference of u between the two runs
//           relative to max |u| (the fixed point must not move). Then, per mesh family and
//           tolerance, the growth exponent a of iterations ~ N^a (N = nodes), least squares on
//           the logarithms, next to the target a <= 0.2.
//
// Run:      build/experiments/bench_accel [--quick] [--depth M] [--cap-seconds S]
//                                         [--trace CASE] [key=value]...
//           (from the repository root; --quick: K = 7, 14, 28 and gutter levels 1, 2;
//           --cap-seconds: a run still iterating after S seconds of iterations (default 600) is
//           stopped and reported as "> n" iterations; key=value overrides every case, e.g.
//           algorithm.accelerate=multipliers; --trace CASE prints r_G + r_B and the safeguard's
//           verdict per iteration of CASE, e.g. --trace "fig5 K=7")
//
// Method:   one thread (OMP_NUM_THREADS is respected); each run is a fresh Solver from the rest
//           state, iterated to the configuration's tolerance. The iterate sequence does not
//           depend on the tolerance (only the stopping test r_G + r_B < tol does, lib/
//           iteration.cpp), so the iterations to 1e-6 are read from the same run's history: the
//           first iteration with r_G + r_B < 1e-6 is where a run with tol = 1e-6 stops. A run
//           that reaches neither its iteration cap (algorithm.max_iter) nor convergence within
//           --cap-seconds is stopped from the progress callback; its count is a lower bound and
//           is left out of the fitted exponent (which is then marked).
//           Discussion of the numbers: paper_notes/performance.md, "Iterations against mesh
//           size (make bench)" and "Anderson acceleration".

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"

namespace {

constexpr double kIssueTol = 1e-6;       // the tolerance of the iteration table (performance.md)
constexpr double kTargetExponent = 0.2;  // the target: growth with refinement <= N^0.2

struct Case {
  std::string name, config;
  std::vector<std::string> overrides;
};

/// Thrown from the progress callback to stop a run at the wall-time cap.
struct TimeCap {};

struct Run {
  int nodes = 0, cells = 0, iterations = 0, kept = 0, rejected = 0;
  int at_issue_tol = -1;  ///< first iteration with r_G + r_B < 1e-6 (-1: not reached)
  double tol = 0;         ///< the configuration's tolerance
  bool converged = false, timed_out = false;
  std::string status;
  double seconds = 0;  ///< wall time of the iterations (after the factorization)
  Eigen::MatrixXd u;
};

std::string loadavg() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return a + " " + b + " " + c;
}

Run run(const Case& c, std::vector<std::string> overrides, bool trace, double cap_seconds) {
  overrides.insert(overrides.begin(), c.overrides.begin(), c.overrides.end());
  const ltl::Problem p = ltl::load_problem(c.config, overrides);
  ltl::Solver solver(p);
  ltl::State s = solver.initial_state();
  Run out;
  out.nodes = p.mesh.num_nodes();
  out.cells = p.mesh.num_cells();
  out.tol = p.algorithm.tol;
  // The progress callback sees every iteration: the first one below 1e-6, and the time cap.
  auto progress = [&](const ltl::IterationRecord& h) {
    if (trace) std::printf("  %6d  %.6e  %2d\n", h.n, h.r_G + h.r_B, h.accelerated);
    // (A rejected accelerated iterate, accelerated = -1, is not tested for convergence.)
    if (out.at_issue_tol < 0 && h.accelerated >= 0 && h.r_G + h.r_B < kIssueTol)
      out.at_issue_tol = h.n;
    out.iterations = h.n;
    out.seconds = h.wall;
    if (h.wall > cap_seconds) throw TimeCap{};
  };
  try {
    const ltl::StepReport r = solver.solve_step(s, s.beta, progress);
    out.iterations = r.iterations;
    out.kept = r.accepted;
    out.rejected = r.rejected;
    out.converged = r.converged;
    out.status = r.status;
    out.seconds = r.history.back().wall;
    out.u = s.u;
  } catch (const TimeCap&) {
    out.timed_out = true;
    out.status = "stopped at the time cap";
  }
  return out;
}

/// The iteration count of a run at tolerance `issue ? 1e-6 : its own`, formatted; "> n" when
/// the run stopped (cap) before reaching it. `count` is set to the count, or -1 then.
std::string count(const Run& r, bool issue, int& n) {
  const bool reached = issue ? r.at_issue_tol > 0 : r.converged;
  n = reached ? (issue ? r.at_issue_tol : r.iterations) : -1;
  return reached ? std::to_string(n) : "> " + std::to_string(r.iterations);
}

/// Least-squares slope a of log(iterations) against log(nodes) over the runs that reached the
/// tolerance; `left_out` counts those that did not. NAN with fewer than 2 points.
double exponent(const std::vector<Run>& runs, bool issue, int& left_out) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0, n = 0;
  left_out = 0;
  for (const Run& r : runs) {
    int it;
    count(r, issue, it);
    if (it <= 0) {
      ++left_out;
      continue;
    }
    const double x = std::log(r.nodes), y = std::log(it);
    sx += x, sy += y, sxx += x * x, sxy += x * y, n += 1;
  }
  return n < 2 ? NAN : (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

std::string verdict(double a, int left_out) {
  char buf[96];
  if (std::isnan(a)) return "   -  (fewer than 2 converged sizes)";
  std::snprintf(buf, sizeof buf, "%5.2f (%s%s)", a, a <= kTargetExponent ? "met" : "not met",
                left_out ? ", capped sizes left out" : "");
  return buf;
}

}  // namespace

int main(int argc, char** argv) try {
  bool quick = false;
  int depth = 10;
  double cap_seconds = 600;
  std::string trace;
  std::vector<std::string> extra;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "-h") || !std::strcmp(argv[i], "--help")) {
      std::printf(
          "usage: bench_accel [--quick] [--depth M] [--cap-seconds S] [--trace CASE] "
          "[key=value]...\n");
      return 0;
    } else if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else if (!std::strcmp(argv[i], "--depth") && i + 1 < argc)
      depth = std::stoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--cap-seconds") && i + 1 < argc)
      cap_seconds = std::stod(argv[++i]);
    else if (!std::strcmp(argv[i], "--trace") && i + 1 < argc)
      trace = argv[++i];
    else if (std::strchr(argv[i], '='))
      extra.push_back(argv[i]);
    else {  // a usage error: exit status 2, nothing run
      std::fprintf(stderr,
                   "bench_accel: unexpected argument '%s' (usage: bench_accel [--quick] [--depth "
                   "M] [--cap-seconds S] [--trace CASE] [key=value]...)\n",
                   argv[i]);
      return 2;
    }
  }
  const std::string fig5 = "experiments/fig5/fig5.toml", fig6 = "experiments/fig6/fig6.toml";
  std::vector<std::vector<Case>> families(2);
  // Fig 5 as `refinement fig5` makes it: n = nd = K, R = 20.
  for (int K : {7, 14, 28, 56, 112}) {
    if (quick && K > 28) continue;
    const std::string k = std::to_string(K);
    families[0].push_back(
        {"fig5 K=" + k,
         fig5,
         {"mesh.parameters.n=" + k, "mesh.parameters.nd=" + k, "algorithm.R=20"}});
  }
  // The gutter as `refinement fig6` makes it: (nt, na, nl) = L x (2, 9, 15).
  for (int L : {1, 2, 3}) {
    if (quick && L > 2) continue;
    families[1].push_back({"fig6 L=" + std::to_string(L),
                           fig6,
                           {"mesh.parameters.nt=" + std::to_string(2 * L),
                            "mesh.parameters.na=" + std::to_string(9 * L),
                            "mesh.parameters.nl=" + std::to_string(15 * L)}});
  }
  std::vector<std::string> plain = extra, accel = extra, newton = extra;
  plain.push_back("algorithm.acceleration=none");
  newton.push_back("algorithm.solver=newton");  // ALG2 into Newton's basin (newton.hpp)
  accel.push_back("algorithm.acceleration=anderson");
  accel.push_back("algorithm.depth=" + std::to_string(depth));

  std::printf(
      "Iterations to tolerance against mesh size: plain ALG2 (the paper's iteration) and Anderson "
      "depth %d\n",
      depth);
  std::printf("load average at start: %s; wall-time cap per run %.0f s of iterations%s\n",
              loadavg().c_str(), cap_seconds, quick ? "; --quick (largest sizes skipped)" : "");
  std::printf(
      "columns: iterations to r_G + r_B < 1e-6 / to the configuration's tol; ms = wall time per "
      "iteration (load-dependent, 1-min load at the end of the row); Newton: outer iterations "
      "(ALG2 + Newton) to force residual 1e-8 and its solver seconds\n\n");
  std::printf("%-10s %6s %7s %5s | %8s %8s %7s | %8s %8s %11s %7s | %6s %8s | %6s %7s %8s | %5s\n",
              "case", "cells", "nodes", "tol", "plain", "plain", "ms/it", "AA", "AA", "kept/rej",
              "ms/it", "ratio", "|du|/|u|", "Newton", "seconds", "|du|/|u|", "load");
  std::printf("%-10s %6s %7s %5s | %8s %8s %7s | %8s %8s %11s %7s | %6s %8s | %6s %7s %8s | %5s\n",
              "", "", "", "", "1e-6", "tol", "", "1e-6", "tol", "", "", "(tol)", "", "its", "",
              "vs plain", "");
  for (auto& family : families) {
    std::vector<Run> P, A, N;
    for (const Case& c : family) {
      if (!trace.empty() && trace != c.name) continue;
      std::fprintf(stderr, "bench_accel: %s ...\n", c.name.c_str());
      P.push_back(run(c, plain, false, cap_seconds));
      A.push_back(run(c, accel, trace == c.name, cap_seconds));
      N.push_back(run(c, newton, false, cap_seconds));
      const Run &p = P.back(), &a = A.back(), &nt = N.back();
      int n;
      const std::string p6 = count(p, true, n), pt = count(p, false, n);
      const std::string a6 = count(a, true, n), at = count(a, false, n);
      char ratio[16] = "-", du[16] = "-", kr[24];
      if (p.converged && a.converged) {
        std::snprintf(ratio, sizeof ratio, "%.1f", double(p.iterations) / a.iterations);
        std::snprintf(du, sizeof du, "%.1e",
                      (p.u - a.u).cwiseAbs().maxCoeff() / p.u.cwiseAbs().maxCoeff());
      }
      if (a.timed_out)
        std::snprintf(kr, sizeof kr, "-");
      else
        std::snprintf(kr, sizeof kr, "%d/%d", a.kept, a.rejected);
      char nits[16] = "-", ndu[16] = "-";
      if (nt.converged) std::snprintf(nits, sizeof nits, "%d", nt.iterations);
      if (nt.converged && p.converged)
        std::snprintf(ndu, sizeof ndu, "%.1e",
                      (p.u - nt.u).cwiseAbs().maxCoeff() / p.u.cwiseAbs().maxCoeff());
      std::string load = loadavg();
      load = load.substr(0, load.find(' '));
      std::printf(
          "%-10s %6d %7d %5.0e | %8s %8s %7.2f | %8s %8s %11s %7.2f | %6s %8s | %6s %7.3f %8s | "
          "%5s\n",
          c.name.c_str(), p.cells, p.nodes, p.tol, p6.c_str(), pt.c_str(),
          1e3 * p.seconds / std::max(1, p.iterations), a6.c_str(), at.c_str(), kr,
          1e3 * a.seconds / std::max(1, a.iterations), ratio, du, nits, nt.seconds, ndu,
          load.c_str());
      for (const Run* r : {&p, &a, &nt})
        if (!r->converged)
          std::printf("%-10s   %s: %s\n", "",
                      r == &p   ? "plain"
                      : r == &a ? "Anderson"
                                : "Newton",
                      r->status.c_str());
      std::fflush(stdout);
    }
    if (P.size() >= 2) {
      std::printf("%-10s growth exponent a in iterations ~ nodes^a (target a <= %.1f):\n", "",
                  kTargetExponent);
      for (const bool issue : {true, false}) {
        int lp, la;
        const double ep = exponent(P, issue, lp), ea = exponent(A, issue, la);
        std::printf("%-10s   to %-5s  plain %s   Anderson %s\n", "", issue ? "1e-6" : "tol",
                    verdict(ep, lp).c_str(), verdict(ea, la).c_str());
      }
      int ln;
      const double en = exponent(N, false, ln);
      std::printf("%-10s   Newton (outer iterations to force residual 1e-8): %s\n", "",
                  verdict(en, ln).c_str());
    }
    std::printf("\n");
  }
  std::printf(
      "(> n: stopped at the iteration or time cap after n iterations, tolerance not "
      "reached)\nload average at the end: %s\n",
      loadavg().c_str());
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_accel: %s\n", e.what());
  return 1;
}
