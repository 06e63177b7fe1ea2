//                 The global step (4.5): Cholesky factor against CG + AMG (make bench-amg)
//
// What:     on the Fig 6 gutter refined through its mesh parameters (nt x na x nl H8, the sizes of
//           `make bench`), the two global solvers of algorithm.global_solver, in real ALG2
//           iterations: the setup (analysis + factorization, or the AMG hierarchy), the bytes of
//           the factor or of the hierarchy, the cost of the global solve per ALG2 iteration (one
//           triangular solve per factor, or CG to the inexact tolerance of lib/cg_amg.hpp,
//           warm-started), the CG iterations per solve, and the peak resident memory with the
//           bytes per cell outside the factor / hierarchy (the peak, the resident memory
//           and malloc's live bytes while iterating), the bytes per contact point (the points'
//           arrays and the contact kernel), the largest gutter that fits in 24 GB from these
//           measured numbers (fits_24GB_cells); the setup's phases (mesh,
//           discretization, precompute) with the peak reached by the end of each, and the cost
//           of an ALG2 iteration split into its phases (global solve, local strain step, contact
//           step, update). --predict also prints, without factorizing, CHOLMOD's AMD count of
//           nnz(L) for larger gutters (the memory a factor would need), from the matrix alone;
//           --also-predict prints it after a case's iterations, from the same mesh.
//
// Run:      build-petsc/experiments/bench_amg [--iters N] [--warm N] [--min-cells N]
//               [--max-cells N] [--solvers cholesky,cg-amg] [--also-predict] [--predict MAX]
//           Every (size, solver) runs in a child process (--case NAME SOLVER), so that its peak
//           memory (VmHWM) is its own. The 10^6-cell row of performance.md (one command line):
//               OMP_NUM_THREADS=1 bench_amg --warm 2 --iters 3 --min-cells 900000
//                   --max-cells 1000000 --solvers cg-amg --also-predict
//           (about 2-4 min and 4.6 GB, 10 GB before the memory layout of performance.md's
//           second pass; its Cholesky case would need 23-29 GB: not in 24 GB).
//           Needs a build with PETSc for the CG + AMG rows (they are reported as not run
//           otherwise). Counts (bytes, iterations) do not depend on the load
//           of the machine; times do: the load average is printed beside them.
//           Numbers and discussion: paper_notes/performance.md, "Memory per cell, and CG + AMG".

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "cg_amg.hpp"
#include "config.hpp"
#include "contact_step.hpp"
#include "global_step.hpp"

namespace {

struct Gutter {
  int nt, na, nl;
  long cells() const { return 1L * nt * na * nl; }
  std::string name() const { return "gutter-" + std::to_string(cells()); }
  std::vector<std::string> overrides() const {
    return {"mesh.parameters.nt=" + std::to_string(nt), "mesh.parameters.na=" + std::to_string(na),
            "mesh.parameters.nl=" + std::to_string(nl)};
  }
};

/// The gutters of `make bench`, and larger ones for the prediction alone.
const std::vector<Gutter> kGutters = {{2, 9, 15},     {2, 18, 30},   {3, 30, 50},    {4, 40, 75},
                                      {6, 60, 110},   {8, 80, 160},  {10, 100, 200}, {11, 110, 250},
                                      {12, 120, 280}, {16, 160, 390}};

/// A line of /proc/self/status, in MB.
double status_mb(const char* key) {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind(key, 0) == 0) return std::atof(line.c_str() + std::string(key).size()) / 1024.0;
  return -1;
}

/// Bytes live on the heap (malloc's count, mmapped blocks included), in MB.
double live_mb() {
  const struct mallinfo2 mi = mallinfo2();
  return (static_cast<double>(mi.uordblks) + static_cast<double>(mi.hblkhd)) / 1048576.0;
}

std::string loadavg() {
  std::ifstream f("/proc/loadavg");
  std::string a;
  f >> a;
  return a;
}

using clock_type = std::chrono::steady_clock;
double seconds_since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}

std::string source(const std::string& rel) {
  return std::string(LTL_SOURCE_DIR) + "/" + rel;
}

/// CHOLMOD's AMD count of nnz(L) over the Dirichlet sets' matrices, without factorizing.
double predicted_lnz(const ltl::Discretization& disc) {
  // The sparsity pattern is all the symbolic analysis reads: unit weights will do.
  const ltl::SpMat K = ltl::global_matrix(disc.cells(), disc.points(), 1.0, 1.0, 1.0);
  return ltl::GlobalStep::predicted_factor_nonzeros(K, disc.dirichlet());
}

/// One gutter with one global solver: warm + iters ALG2 iterations from the initial state.
/// With `also_predict`, CHOLMOD's predicted nnz(L) of the same mesh afterwards (a PREDICT line).
int run_case(const Gutter& g, const std::string& solver_name, int iters, int warm,
             bool also_predict) {
  const double base = status_mb("VmRSS:");  // the libraries and the runtime, before the problem
  std::vector<std::string> ov = g.overrides();
  for (const char* o : {"algorithm.tol=1e-300", "algorithm.blowup=1e100", "algorithm.sweeps=1",
                        "algorithm.solver=alg2"})
    ov.push_back(o);
  ov.push_back("algorithm.max_iter=" + std::to_string(iters + warm));
  ov.push_back("algorithm.global_solver=\"" + solver_name + "\"");
  // The setup in its three phases, each with the peak (VmHWM, monotone) reached by its end: the
  // mesh (gmsh, read into the Problem), the discretization (operators, contact points), the
  // precompute (assembly of K, then the factors or the AMG hierarchies, and the work arrays).
  auto t = clock_type::now();
  const ltl::Problem problem = ltl::load_problem(source("experiments/fig6/fig6.toml"), ov);
  const double t_mesh = seconds_since(t), hwm_mesh = status_mb("VmHWM:"), live_mesh = live_mb();
  ltl::Discretization disc(problem);
  const double t_disc = disc.build_seconds(), hwm_disc = status_mb("VmHWM:"), live_disc = live_mb();
  t = clock_type::now();
  ltl::Solver solver(std::move(disc));
  const double t_pre = seconds_since(t), hwm_pre = status_mb("VmHWM:"), live_pre = live_mb();
  const ltl::GlobalStep& gs = solver.global_step();
  const bool cg = gs.solver() == ltl::GlobalSolver::CgAmg;
  double factor_bytes = 0;
  for (int k = 0; !cg && k < gs.num_factors(); ++k) factor_bytes += 8.0 * gs.factor(k).entries();
  const double store_bytes = cg ? gs.amg_bytes() : factor_bytes;
  const double setup = cg ? gs.amg_setup_seconds() : gs.analyze_seconds() + gs.factorize_seconds();
  ltl::State s = solver.initial_state();
  const Eigen::VectorXd beta_prev = s.beta;
  double t0 = 0, wall0 = 0, wall = 0, tg = 0, ts = 0, tc = 0, tu = 0;
  long it0 = 0, calls0 = 0, solves0 = 0;
  int n = 0;
  solver.solve_step(s, beta_prev, [&](const ltl::IterationRecord& rec) {
    ++n;
    if (n > warm) {  // a timed iteration: its phases (alg2.hpp) and its wall time
      tg += rec.t_global;
      ts += rec.t_strain;
      tc += rec.t_contact;
      tu += rec.t_update;
      wall = rec.wall;
    }
    if (n != warm) return;
    wall0 = rec.wall;
    t0 = gs.solve_seconds();
    calls0 = gs.solve_calls();
    it0 = gs.cg_iterations();
    solves0 = gs.cg_solves();
  });
  const int timed = n - warm;
  const long calls = gs.solve_calls() - calls0;
  const double per_call_ms = calls > 0 ? 1e3 * (gs.solve_seconds() - t0) / calls : 0;
  const long solves = gs.cg_solves() - solves0;
  const double its = solves > 0 ? double(gs.cg_iterations() - it0) / solves : 0;
  auto per_it_ms = [&](double sec) { return timed > 0 ? 1e3 * sec / timed : 0.0; };
  // The peak (VmHWM, reached in the setup: the factorization's workspace, the assembly's
  // triplets) and the resident memory while iterating (VmRSS), both less the base and the
  // factor / hierarchy, per cell; and the bytes live on the heap while iterating (malloc's count:
  // what the solver holds, the setup's transients freed), less the factor / hierarchy, per cell.
  const double peak = status_mb("VmHWM:"), rss = status_mb("VmRSS:");
  const double live = live_mb();
  auto per_cell = [&](double mb) { return ((mb - base) * 1048576.0 - store_bytes) / g.cells(); };
  // Per contact point: what the contact surface stores (the points' arrays and averaging
  // operators, lib/contact_points.hpp, and the contact step's adhesion kernel), counted from
  // the objects' sizes.
  const ltl::ContactPoints* pts = solver.discretization().points();
  const int n_points = pts ? pts->size() : 0;
  double point_bytes = 0;
  if (pts) {
    auto sparse = [](const ltl::SpMatR& M) {
      return 12.0 * static_cast<double>(M.nonZeros()) + 4.0 * (M.outerSize() + 1);
    };
    point_bytes = 8.0 * (pts->area.size() + pts->centre.size() + pts->gap.size()) +
                  sparse(pts->mean) + sparse(pts->meanT_area) + 4.0 * pts->nodes.size();
    for (const Eigen::MatrixXd& v : pts->vertices) point_bytes += 8.0 * v.size();
    ltl::Adhesion adhesion = problem.contacts.front().adhesion;
    adhesion.dt = problem.time.dt;
    point_bytes += ltl::ContactStep(*pts, adhesion, 1.0).kernel_bytes();
  }
  // The largest gutter that fits in 24 GB (GiB, as VmHWM counts), from this case's measured
  // numbers: base + (peak rest per cell) N + store(N), the store (AMG hierarchy) linear in N
  // (measured N^0.99-1.02, performance.md), the factor as N^1.28 (measured from 102 400 to
  // 302 500 cells, performance.md); bisection on N.
  const double rest_b = per_cell(peak), budget = 24.0 * 1073741824.0 - base * 1048576.0;
  const double store_exp = cg ? 1.0 : 1.28;
  auto need = [&](double n) {
    return rest_b * n + store_bytes * std::pow(n / static_cast<double>(g.cells()), store_exp);
  };
  double lo = 0, hi = 1e12;
  for (int k = 0; k < 200 && hi - lo > 1; ++k)
    (need((lo + hi) / 2) > budget ? hi : lo) = (lo + hi) / 2;
  std::printf(
      "RESULT %s %s cells=%ld nodes=%d factors=%d setup_s=%.3f store_MB=%.1f solve_ms=%.3f "
      "cg_its_per_solve=%.2f base_MB=%.0f peak_MB=%.0f rss_MB=%.0f peak_rest_B_per_cell=%.0f "
      "rss_rest_B_per_cell=%.0f live_rest_B_per_cell=%.0f store_B_per_cell=%.0f "
      "contact_points=%d contact_B_per_point=%.0f fits_24GB_cells=%.3g load=%s\n",
      g.name().c_str(), cg ? "cg-amg" : "cholesky", g.cells(), problem.mesh.num_nodes(),
      gs.num_factors(), setup, store_bytes / 1e6, per_call_ms, its, base, peak, rss, per_cell(peak),
      per_cell(rss), (live * 1048576.0 - store_bytes) / g.cells(), store_bytes / g.cells(),
      n_points, n_points > 0 ? point_bytes / n_points : 0.0, lo, loadavg().c_str());
  std::printf(
      "SETUP %s %s mesh_s=%.2f disc_s=%.2f precompute_s=%.2f (of which %s %.2f) "
      "peak_MB_after_mesh=%.0f after_disc=%.0f after_precompute=%.0f live_MB_after_mesh=%.0f "
      "after_disc=%.0f after_precompute=%.0f\n",
      g.name().c_str(), cg ? "cg-amg" : "cholesky", t_mesh, t_disc, t_pre,
      cg ? "amg_setup" : "analysis+factorization", setup, hwm_mesh, hwm_disc, hwm_pre, live_mesh,
      live_disc, live_pre);
  std::printf(
      "ITER %s %s timed=%d ms_per_iteration=%.1f global=%.1f (solve %.1f, rest %.1f) "
      "strain=%.1f contact=%.1f update=%.1f threads=%s load=%s\n",
      g.name().c_str(), cg ? "cg-amg" : "cholesky", timed, per_it_ms(wall - wall0), per_it_ms(tg),
      per_it_ms(gs.solve_seconds() - t0), per_it_ms(tg - (gs.solve_seconds() - t0)), per_it_ms(ts),
      per_it_ms(tc), per_it_ms(tu),
      std::getenv("OMP_NUM_THREADS") ? std::getenv("OMP_NUM_THREADS") : "default",
      loadavg().c_str());
  std::fflush(stdout);
  if (also_predict) {
    const double lnz = predicted_lnz(solver.discretization());
    std::printf("PREDICT %s cells=%ld nodes=%d nnzL_amd_all_factors=%.0f factor_GB=%.1f\n",
                g.name().c_str(), g.cells(), problem.mesh.num_nodes(), lnz, 8.0 * lnz / 1e9);
  }
  return 0;
}

/// CHOLMOD's AMD count of nnz(L) of the largest Dirichlet set's matrix, without factorizing.
int predict(const Gutter& g) {
  std::vector<std::string> ov = g.overrides();
  const ltl::Problem problem = ltl::load_problem(source("experiments/fig6/fig6.toml"), ov);
  const ltl::Discretization disc(problem);
  const double lnz = predicted_lnz(disc);
  std::printf("PREDICT %s cells=%ld nodes=%d nnzL_amd_all_factors=%.0f peak_MB=%.0f\n",
              g.name().c_str(), g.cells(), problem.mesh.num_nodes(), lnz, status_mb("VmHWM:"));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int iters = 20, warm = 5;
  long max_cells = 40000, predict_cells = 0, min_cells = 0;
  std::string solvers = "cholesky,cg-amg";
  bool also_predict = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench_amg: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--case" || a == "--predict-case") {
      const std::string name = next();
      const std::string solver = a == "--case" ? next() : "";
      for (const Gutter& g : kGutters)
        if (g.name() == name) {
          try {
            return a == "--case" ? run_case(g, solver, iters, warm, also_predict) : predict(g);
          } catch (const std::exception& e) {
            std::fprintf(stderr, "bench_amg: %s: %s\n", name.c_str(), e.what());
            return 1;
          }
        }
      std::fprintf(stderr, "bench_amg: no case %s\n", name.c_str());
      return 2;
    } else if (a == "--iters") {
      iters = std::atoi(next().c_str());
    } else if (a == "--warm") {
      warm = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--also-predict") {
      also_predict = true;
    } else if (a == "--max-cells") {
      max_cells = std::atol(next().c_str());
    } else if (a == "--min-cells") {
      min_cells = std::atol(next().c_str());
    } else if (a == "--solvers") {
      solvers = next();
    } else if (a == "--predict") {
      predict_cells = std::atol(next().c_str());
    } else {
      std::fprintf(stderr,
                   "usage: bench_amg [--iters N] [--warm N] [--max-cells N] [--min-cells N] "
                   "[--solvers cholesky,cg-amg] [--also-predict] [--predict MAX_CELLS]\n"
                   "       bench_amg [--iters N] [--warm N] [--also-predict] --case gutter-CELLS "
                   "cholesky|cg-amg\n"
                   "       bench_amg --predict-case gutter-CELLS\n");
      return a == "--help" ? 0 : 2;
    }
  }
  char exe[4096] = {0};
  const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
  const std::string self = len > 0 ? std::string(exe, len) : std::string(argv[0]);
  std::printf("bench_amg: %d timed ALG2 iterations after %d, PETSc %s; load average %s\n", iters,
              warm, ltl::CgAmg::available() ? "built in" : "absent (no cg-amg rows)",
              loadavg().c_str());
  std::fflush(stdout);
  for (const Gutter& g : kGutters) {
    if (g.cells() >= min_cells && g.cells() <= max_cells)
      for (const char* solver : {"cholesky", "cg-amg"}) {
        if (solvers.find(solver) == std::string::npos) continue;
        if (std::string(solver) == "cg-amg" && !ltl::CgAmg::available()) continue;
        const std::string cmd = "'" + self + "' --iters " + std::to_string(iters) + " --warm " +
                                std::to_string(warm) + (also_predict ? " --also-predict" : "") +
                                " --case " + g.name() + " " + solver;
        if (std::system(cmd.c_str()) != 0) std::printf("%s %s: failed\n", g.name().c_str(), solver);
        std::fflush(stdout);
      }
    if (g.cells() >= min_cells && g.cells() <= predict_cells) {
      const std::string cmd = "'" + self + "' --predict-case " + g.name();
      if (std::system(cmd.c_str()) != 0) std::printf("%s predict: failed\n", g.name().c_str());
      std::fflush(stdout);
    }
  }
  return 0;
}
