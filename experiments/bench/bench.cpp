//                       Performance benchmark of ALG2 (make bench)
//
// What:     for P2 bars (the Fig 3 geometry refined, glued contact on x2 = 0 present), the Fig 5
//           half disc, and H8 gutters (the Fig 6 geometry refined, unilateral contact present) of
//           growing size: analysis and factorization time of the global matrix (4.5), nnz(L),
//           the time of one ALG2 iteration split into its phases (global step = right-hand side
//           + triangular solve + Gbar u; local strain step (4.6); local contact step (4.7);
//           multiplier update and residuals (4.3)-(4.4)), read from the IterationRecord timings
//           of Solver::solve_step, on 1 and on 2 OpenMP threads, and the peak memory. The
//           triangular solve is compared with its memory-bandwidth floor
//             2 sweeps x 8 bytes x nnz(L) / (read bandwidth of this machine),
//           the bandwidth being measured here by a STREAM-like loop; Table 5 compares our
//           supernodal sweeps with CHOLMOD's supernodal and simplicial solves on the same factor.
//           Table 7: the bytes written to append a step to a results file of each case.
//           Table 6: memory, the peak and what is not the factor, per cell and per contact point.
//           Discussion of the numbers: paper_notes/performance.md.
//
// Run:      make bench               (all sizes up to 2e5 cells, ~5 min on 2 cores, 5.5 GB peak)
//           build/experiments/bench [--quick] [--iters N] [--max-cells N] [--only 2d|3d|NAME]
//
// Method:   every case runs in a child process (the same executable, --case K), so that its
//           peak resident memory (VmHWM) is its own. Each case: mesh, Solver (factorization, 2
//           threads), then for 1 and 2 threads a fresh initial state and warm + iters ALG2
//           iterations (tol unreachable, blow-up test off, sweeps = 1: one global solve per
//           iteration). The first `warm` iterations are discarded; each phase is reported as
//           its minimum over the remaining iterations (the machine is shared: the minimum is the
//           least disturbed), the total as the minimum of the per-iteration sums, with the
//           median in brackets. The 1- and 2-thread runs do the same iterations from the same
//           state. Single-threaded kernels timed outside the loop (bandwidth, strain step alone,
//           Table 5) use the thread's CPU time, which preemption does not inflate.

#include <cholmod.h>
#include <dlfcn.h>
#include <omp.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "config.hpp"
#include "contact_step.hpp"
#include "global_step.hpp"
#include "results.hpp"
#include "results_commit.hpp"

namespace {

using clock_type = std::chrono::steady_clock;
double since(clock_type::time_point t0) {
  return std::chrono::duration<double>(clock_type::now() - t0).count();
}
/// CPU time of the calling thread (s): unlike the wall clock, not inflated when the shared
/// machine preempts us (single-threaded measurements only).
double thread_cpu() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

// ------------------------------------------------------------------------------------------
// Machine state.

std::string loadavg() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  f >> a >> b >> c;
  return a + " " + b + " " + c;
}

/// Peak resident set size of this process (MB), from /proc/self/status.
double peak_rss_mb() {
  std::ifstream f("/proc/self/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) / 1024.0;
  return -1;
}

/// OpenBLAS (pthreads build, used by CHOLMOD) has its own thread pool: set it with OpenMP's.
void set_threads(int n) {
  omp_set_num_threads(n);
  using fn = void (*)(int);
  if (auto f = reinterpret_cast<fn>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(n);
}

// ------------------------------------------------------------------------------------------
// STREAM-like bandwidth: arrays of 2^24 doubles (128 MB each, 4x the L3), best of 10.

struct Bandwidth {
  double read = 0, triad = 0;  ///< GB/s: sum of one array (8 B/elt); a = b + s c (24 B/elt)
};

/// Times f (best of reps): thread CPU time on 1 thread (robust to preemption), wall otherwise.
template <class F>
double best_of(int reps, int threads, F&& f) {
  double best = 1e300;
  for (int rep = 0; rep < reps; ++rep) {
    const auto w0 = clock_type::now();
    const double c0 = thread_cpu();
    f();
    best = std::min(best, threads == 1 ? thread_cpu() - c0 : since(w0));
  }
  return best;
}

Bandwidth measure_bandwidth(int threads) {
  const long n = 1L << 24;
  std::unique_ptr<double[]> a(new double[n]), b(new double[n]), c(new double[n]);
  set_threads(threads);
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) a[i] = 1.0, b[i] = 2.0, c[i] = 0.5;  // first touch, same split
  Bandwidth bw;
  volatile double sink = 0;
  const double tr = best_of(10, threads, [&] {
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0;  // four sums: not bound by the add latency
#pragma omp parallel for schedule(static) reduction(+ : s0, s1, s2, s3)
    for (long i = 0; i < n; i += 4) {
      s0 += a[i];
      s1 += a[i + 1];
      s2 += a[i + 2];
      s3 += a[i + 3];
    }
    sink = sink + s0 + s1 + s2 + s3;
  });
  const double tt = best_of(10, threads, [&] {
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) a[i] = b[i] + 0.5 * c[i];
  });
  bw.read = 8.0 * n / tr / 1e9;
  bw.triad = 24.0 * n / tt / 1e9;
  (void)sink;
  return bw;
}

// ------------------------------------------------------------------------------------------
// Cases.

struct Case {
  std::string name, kind, config;
  std::vector<std::string> overrides;
  long cells;  ///< expected number of cells (for --max-cells)
};

std::string src(const std::string& rel) {
  return std::string(LTL_SOURCE_DIR) + "/" + rel;
}

std::vector<Case> all_cases() {
  std::vector<Case> cs;
  // Fig 3 bar L x H = 1 x 0.2 m, nx x ny rectangles split in two P2 triangles; nx = 5 ny gives
  // square rectangles (Fig 3 itself: 28 x 3). Glued contact on the whole bottom face.
  const int bars[][2] = {{28, 3}, {50, 10}, {110, 22}, {225, 45}, {500, 100}, {710, 142}};
  for (auto& b : bars) {
    const long cells = 2L * b[0] * b[1];
    cs.push_back({"bar-" + std::to_string(cells),
                  "2d",
                  src("experiments/fig3/fig3_literal.toml"),
                  {"mesh.parameters.nx=" + std::to_string(b[0]),
                   "mesh.parameters.ny=" + std::to_string(b[1])},
                  cells});
  }
  // Fig 5 half disc (122 P2 triangles), the small-matrix case.
  cs.push_back({"disc-122", "2d", src("experiments/fig5/fig5.toml"), {}, 122});
  // Fig 6 gutter quarter: nt x na x nl H8 (Fig 6 itself: 2 x 9 x 15 = 270).
  const int gutters[][3] = {{2, 9, 15},   {2, 18, 30},  {3, 30, 50},   {4, 40, 75},
                            {6, 60, 110}, {8, 80, 160}, {10, 100, 200}};
  for (auto& g : gutters) {
    const long cells = 1L * g[0] * g[1] * g[2];
    cs.push_back({"gutter-" + std::to_string(cells),
                  "3d",
                  src("experiments/fig6/fig6.toml"),
                  {"mesh.parameters.nt=" + std::to_string(g[0]),
                   "mesh.parameters.na=" + std::to_string(g[1]),
                   "mesh.parameters.nl=" + std::to_string(g[2])},
                  cells});
  }
  return cs;
}

// ------------------------------------------------------------------------------------------
// One case (child process): prints one line "RESULT key=value ...".

struct Phases {
  std::vector<double> global, solve, strain, contact, update, total;
};

double vmin(const std::vector<double>& v) {
  return *std::min_element(v.begin(), v.end());
}
double vmed(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Standalone local strain step over the cells of a state (1 thread, thread CPU time): ns per
/// cell, best of several passes.
template <int d>
double strain_standalone(const ltl::Solver& solver, const ltl::State& s, int& failures) {
  const double Rq = solver.problem().algorithm.R * solver.problem().algorithm.q;
  const Eigen::MatrixXd GU = solver.discretization().cells().Gbar * s.u;
  const int nc = static_cast<int>(GU.rows() / d);
  std::vector<Eigen::Matrix<double, d, d>> D(nc);
  for (int c = 0; c < nc; ++c) {
    D[c] = Rq * GU.template block<d, d>(d * c, 0) - s.lambda.template block<d, d>(d * c, 0);
    D[c].diagonal().array() += Rq;
  }
  ltl::StrainStep step(solver.problem().material, Rq);
  double best = 1e300;
  Eigen::Matrix<double, d, d> E, acc = Eigen::Matrix<double, d, d>::Zero();
  const int reps = std::max(5, 2000000 / std::max(nc, 1));
  for (int rep = 0; rep < std::min(reps, 200); ++rep) {
    failures = 0;
    const double t0 = thread_cpu();
    for (int c = 0; c < nc; ++c) {
      if (!step.solve(D[c], E)) ++failures;
      acc += E;
    }
    best = std::min(best, thread_cpu() - t0);
  }
  volatile double sink = acc.sum();
  (void)sink;
  return best / nc * 1e9;
}

/// CHOLMOD's own solves on one of our factors, for Table 5 (only the benchmark needs them):
/// its supernodal sweeps (cholmod_super_lsolve / ltsolve, BLAS per supernode) on the factor as
/// it is, and cholmod_solve2 on a copy converted to simplicial LL' (same numbers, column
/// storage). The right-hand sides are in the factor's permuted order, as in our sweeps.
class CholmodSolves {
 public:
  CholmodSolves(const ltl::Cholesky& ours) {
    cholmod_start(&cm_);
    L_ = const_cast<cholmod_factor*>(ours.factor());  // read-only for the solves below
    const int n = ours.rows(), nc = ours.columns();
    Y_ = cholmod_allocate_dense(n, nc, n, CHOLMOD_REAL, &cm_);
    E_ = cholmod_allocate_dense(nc, L_->maxesize, nc, CHOLMOD_REAL, &cm_);
    Ls_ = cholmod_copy_factor(L_, &cm_);
    cholmod_change_factor(CHOLMOD_REAL, 1, 0, 1, 1, Ls_, &cm_);
    rhs_.resize(static_cast<std::size_t>(n) * nc);
    for (std::size_t k = 0; k < rhs_.size(); ++k) rhs_[k] = std::sin(0.37 * k);
  }
  /// The same right-hand sides before every solve (a solve in place would drift).
  void refill(double* y) const { std::copy(rhs_.begin(), rhs_.end(), y); }
  void refill() { refill(static_cast<double*>(Y_->x)); }
  ~CholmodSolves() {
    cholmod_free_dense(&W2_, &cm_);
    cholmod_free_dense(&W_, &cm_);
    cholmod_free_dense(&X_, &cm_);
    cholmod_free_dense(&E_, &cm_);
    cholmod_free_dense(&Y_, &cm_);
    cholmod_free_factor(&Ls_, &cm_);
    cholmod_finish(&cm_);
  }
  void supernodal() {
    cholmod_super_lsolve(L_, Y_, E_, &cm_);
    cholmod_super_ltsolve(L_, Y_, E_, &cm_);
  }
  void simplicial() {  // CHOLMOD_LDLt on an LL' factor is L L' x = b, without L->Perm
    cholmod_solve2(CHOLMOD_LDLt, Ls_, Y_, nullptr, &X_, nullptr, &W_, &W2_, &cm_);
  }

 private:
  cholmod_common cm_;
  cholmod_factor *L_ = nullptr, *Ls_ = nullptr;
  cholmod_dense *Y_ = nullptr, *E_ = nullptr, *X_ = nullptr, *W_ = nullptr, *W2_ = nullptr;
  std::vector<double> rhs_;
};

/// The triangular solves alone (1 thread, thread CPU time, best of reps) on the factors of the
/// case's global step (all factors, all columns): our sweeps (ltl::Cholesky), CHOLMOD's
/// supernodal sweeps and CHOLMOD's simplicial solve. Writes ms into out under keys sv_<name>.
void solve_variants(const ltl::Solver& solver, std::map<std::string, double>& out) {
  const ltl::GlobalStep& gs = solver.global_step();
  std::vector<std::unique_ptr<CholmodSolves>> theirs;
  std::vector<ltl::Cholesky*> ours;
  double entries = 0;
  for (int k = 0; k < gs.num_factors(); ++k) {
    ours.push_back(const_cast<ltl::Cholesky*>(&gs.factor(k)));
    theirs.push_back(std::make_unique<CholmodSolves>(gs.factor(k)));
    entries += gs.factor(k).entries();
  }
  out["sv_entries"] = entries;
  const std::pair<const char*, std::function<void()>> variants[] = {
      {"ours",
       [&] {
         for (std::size_t k = 0; k < ours.size(); ++k) {
           theirs[k]->refill(ours[k]->block());
           ours[k]->solve_in_place();
         }
       }},
      {"cholsup",
       [&] {
         for (auto& t : theirs) {
           t->refill();
           t->supernodal();
         }
       }},
      {"simplicial", [&] {
         for (auto& t : theirs) {
           t->refill();
           t->simplicial();
         }
       }}};
  for (const auto& [name, run] : variants) {
    run();
    double once = thread_cpu();
    run();
    once = thread_cpu() - once;
    const int reps = static_cast<int>(std::clamp(0.5 / std::max(once, 1e-7), 3.0, 2000.0));
    out[std::string("sv_") + name] = 1e3 * best_of(reps, 1, run);
  }
}

/// The bytes written (lib/results_commit.hpp's count) to append a step of state `s` (its stresses,
/// contact pressure and gap) to a results file of this problem: the mean over steps 2..4 (step 1
/// carries the mesh); and the size of the 4-step file.
std::pair<double, double> write_cost(const ltl::Solver& solver, const ltl::State& s) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("ltl_bench_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "bench.h5").string();
  const ltl::Problem& pb = solver.problem();
  const ltl::Discretization& d = solver.discretization();
  ltl::ResultsOptions options;
  options.cell_volume = d.cells().vol;
  if (!pb.contacts.empty()) options.contact.facets = &pb.mesh.boundary(pb.contacts[0].group);
  if (d.points()) {
    options.contact.centre = d.points()->centre;
    options.contact.area = d.points()->area;
    options.contact.nodes = d.points()->nodes;
  }
  ltl::RunInfo info;
  info.name = pb.name;
  double bytes = 0;
  {
    ltl::ResultsFile file = ltl::ResultsFile::create(path, pb.mesh, info, options);
    const ltl::Discretization::Stresses stress = d.stresses(s);
    ltl::StepData step;
    step.state = &s;
    step.fields = {{"P", stress.P}, {"sigma", stress.sigma}, {"pressure", stress.pressure}};
    if (stress.sigma33.size()) step.fields["sigma33"] = stress.sigma33;
    if (d.points()) {
      step.fields["contact_pressure"] = d.contact_pressure(s);
      step.fields["gap"] = d.contact_gap(s);
    }
    for (step.p = 1; step.p <= 4; ++step.p) {
      const std::uint64_t before = ltl::bytes_committed();
      file.append(step);
      if (step.p > 1) bytes += static_cast<double>(ltl::bytes_committed() - before) / 3;
    }
  }
  const double size = static_cast<double>(fs::file_size(path));
  fs::remove_all(dir);
  return {bytes, size};
}

int run_case(const Case& c, int iters, int warm) {
  std::map<std::string, std::string> out;
  auto put = [&](const std::string& k, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    out[k] = buf;
  };
  put("load0", std::atof(loadavg().c_str()));
  set_threads(2);
  std::vector<std::string> ov = c.overrides;
  // ALG2 alone, never stopping before the count: tol below any residual, blow-up test off.
  for (const char* o : {"algorithm.tol=1e-300", "algorithm.blowup=1e100", "algorithm.sweeps=1",
                        "algorithm.solver=alg2"})
    ov.push_back(o);
  ov.push_back("algorithm.max_iter=" + std::to_string(iters + warm));
  auto t0 = clock_type::now();
  const ltl::Problem problem = ltl::load_problem(c.config, ov);
  put("t_mesh", since(t0));
  t0 = clock_type::now();
  ltl::Solver solver(problem);
  put("t_solver", since(t0));
  const ltl::GlobalStep& gs = solver.global_step();
  put("cells", problem.mesh.num_cells());
  put("nodes", problem.mesh.num_nodes());
  put("facets", solver.discretization().points() ? solver.discretization().points()->size() : 0);
  put("factors", gs.num_factors());
  {
    double cols = 0;
    for (int k = 0; k < gs.num_factors(); ++k) cols += gs.factor_columns(k);
    put("columns", cols);
  }
  put("nnzL", gs.factor_nonzeros());
  put("t_analyze", gs.analyze_seconds());
  put("t_factorize", gs.factorize_seconds());
  put("peak_setup", peak_rss_mb());
  {  // Memory: the factors as stored, and the contact kernel per contact point (sparse).
    double factor_bytes = 0;
    for (int k = 0; k < gs.num_factors(); ++k) factor_bytes += 8.0 * gs.factor(k).entries();
    put("factor_bytes", factor_bytes);
    if (!problem.contacts.empty()) {
      ltl::Adhesion adhesion = problem.contacts[0].adhesion;
      adhesion.dt = problem.time.dt;
      const ltl::ContactStep cs(*solver.discretization().points(), adhesion, 1.0);
      put("kernel_bytes", cs.kernel_bytes());
    }
  }

  ltl::State s;
  for (int threads : {1, 2}) {
    set_threads(threads);
    s = solver.initial_state();
    const Eigen::VectorXd beta_prev = s.beta;
    Phases ph;
    double solve_before = gs.solve_seconds(), cpu_before = thread_cpu();
    std::vector<double> cpu;
    int n = 0;
    auto progress = [&](const ltl::IterationRecord& r) {
      const double solve = gs.solve_seconds() - solve_before;
      solve_before = gs.solve_seconds();
      const double c = thread_cpu();
      const double dc = c - cpu_before;
      cpu_before = c;
      if (++n <= warm) return;
      cpu.push_back(dc);
      ph.global.push_back(r.t_global);
      ph.solve.push_back(solve);
      ph.strain.push_back(r.t_strain);
      ph.contact.push_back(r.t_contact);
      ph.update.push_back(r.t_update);
      ph.total.push_back(r.t_global + r.t_strain + r.t_contact + r.t_update);
    };
    const ltl::StepReport rep = solver.solve_step(s, beta_prev, progress);
    if (ph.total.empty()) {
      std::fprintf(stderr, "%s: no iterations timed (%s)\n", c.name.c_str(), rep.status.c_str());
      return 1;
    }
    const std::string t = std::to_string(threads);
    put("global" + t, vmin(ph.global));
    put("solve" + t, vmin(ph.solve));
    put("strain" + t, vmin(ph.strain));
    put("contact" + t, vmin(ph.contact));
    put("update" + t, vmin(ph.update));
    put("total" + t, vmin(ph.total));
    put("total_med" + t, vmed(ph.total));
    put("strain_med" + t, vmed(ph.strain));
    put("solve_med" + t, vmed(ph.solve));
    put("iters" + t, static_cast<double>(ph.total.size()));
    put("cpu" + t, vmin(cpu));
    put("failures" + t, rep.strain_failures);
    put("rB" + t, rep.history.back().r_B);
  }
  put("peak", peak_rss_mb());
  set_threads(1);
  if (gs.factor_nonzeros() <= 3e7) {
    std::map<std::string, double> sv;
    solve_variants(solver, sv);
    for (const auto& [k, v] : sv) put(k, v);
  }
  int failures = 0;
  put("strain_alone_ns", solver.dim() == 2 ? strain_standalone<2>(solver, s, failures)
                                           : strain_standalone<3>(solver, s, failures));
  put("strain_alone_failures", failures);
  const auto [step_bytes, file_bytes] = write_cost(solver, s);
  put("write_step", step_bytes);
  put("write_file", file_bytes);
  put("load1", std::atof(loadavg().c_str()));
  std::printf("RESULT name=%s kind=%s", c.name.c_str(), c.kind.c_str());
  for (const auto& [k, v] : out) std::printf(" %s=%s", k.c_str(), v.c_str());
  std::printf("\n");
  return 0;
}

// ------------------------------------------------------------------------------------------
// Parent: bandwidth, one child per case, tables.

std::map<std::string, std::string> parse_result(const std::string& line) {
  std::map<std::string, std::string> m;
  std::istringstream in(line.substr(7));
  std::string kv;
  while (in >> kv) {
    const auto eq = kv.find('=');
    if (eq != std::string::npos) m[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  int iters = 30, warm = 3, case_index = -1;
  long max_cells = 250000;
  bool quick = false;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "bench: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--case") {
      case_index = std::atoi(next().c_str());
    } else if (a == "--iters") {
      iters = std::atoi(next().c_str());
    } else if (a == "--warm") {
      warm = std::atoi(next().c_str());
    } else if (a == "--max-cells") {
      max_cells = std::atol(next().c_str());
    } else if (a == "--only") {
      only = next();
    } else if (a == "--quick") {
      quick = true;
    } else {
      const bool help = a == "-h" || a == "--help";
      std::fprintf(
          help ? stdout : stderr,
          "usage: bench [--quick] [--iters N] [--warm N] [--max-cells N] [--only 2d|3d|NAME]\n");
      return help ? 0 : 2;
    }
  }
  const std::vector<Case> cases = all_cases();
  if (case_index >= 0) {
    try {
      return run_case(cases.at(case_index), iters, warm);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench: case %d: %s\n", case_index, e.what());
      return 1;
    }
  }
  if (quick) {
    iters = std::min(iters, 10);
    max_cells = std::min(max_cells, 20000L);
  }

  std::printf("ALG2 benchmark (LTL87): %d timed iterations per run after %d warm-up ones\n", iters,
              warm);
  {
    std::ifstream f("/proc/cpuinfo");
    std::string line;
    while (std::getline(f, line))
      if (line.rfind("model name", 0) == 0) {
        std::printf("machine: %s, %d logical CPUs\n", line.substr(line.find(':') + 2).c_str(),
                    omp_get_num_procs());
        break;
      }
  }
  std::printf("load average at start: %s\n", loadavg().c_str());
  const Bandwidth bw1 = measure_bandwidth(1), bw2 = measure_bandwidth(2);
  std::printf(
      "memory bandwidth (STREAM-like, 128 MB arrays, best of 10; 1 thread: CPU time, 2 "
      "threads: wall):\n  1 thread read %.1f GB/s, triad %.1f GB/s; 2 threads read %.1f "
      "GB/s, triad %.1f GB/s\n\n",
      bw1.read, bw1.triad, bw2.read, bw2.triad);
  std::fflush(stdout);

  std::vector<std::map<std::string, std::string>> rows;
  char exe[4096] = {0};
  const ssize_t len = readlink("/proc/self/exe", exe, sizeof exe - 1);
  const std::string self = len > 0 ? std::string(exe, len) : std::string(argv[0]);
  for (std::size_t k = 0; k < cases.size(); ++k) {
    const Case& c = cases[k];
    if (c.cells > max_cells ||
        (!only.empty() && c.kind != only && c.name.find(only) == std::string::npos))
      continue;
    std::fprintf(stderr, "bench: %s ...\n", c.name.c_str());
    const std::string cmd = "'" + self + "' --case " + std::to_string(k) + " --iters " +
                            std::to_string(iters) + " --warm " + std::to_string(warm);
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) continue;
    char buf[8192];
    while (std::fgets(buf, sizeof buf, p)) {
      const std::string line = buf;
      if (line.rfind("RESULT ", 0) == 0) rows.push_back(parse_result(line));
    }
    const int status = pclose(p);
    if (status != 0) std::fprintf(stderr, "bench: %s failed (status %d)\n", c.name.c_str(), status);
  }

  auto num = [](const std::map<std::string, std::string>& r, const std::string& k) {
    auto it = r.find(k);
    return it == r.end() ? 0.0 : std::atof(it->second.c_str());
  };
  auto ms = [&](const std::map<std::string, std::string>& r, const std::string& k) {
    return 1e3 * num(r, k);
  };

  std::printf("Table 1. Setup (2 threads): mesh and factorization of (4.5), peak memory (VmHWM)\n");
  std::printf("%-13s %8s %8s %7s %7s %11s %8s %8s %10s %9s %8s\n", "case", "cells", "nodes",
              "facets", "fac/col", "nnz(L)", "L MB", "mesh s", "analyze s", "factor s", "peak MB");
  for (const auto& r : rows) {
    char fc[32];
    std::snprintf(fc, sizeof fc, "%.0f/%.0f", num(r, "factors"), num(r, "columns"));
    std::printf("%-13s %8.0f %8.0f %7.0f %7s %11.0f %8.1f %8.3f %10.3f %9.3f %8.0f\n",
                r.at("name").c_str(), num(r, "cells"), num(r, "nodes"), num(r, "facets"), fc,
                num(r, "nnzL"), 8 * num(r, "nnzL") / 1e6, num(r, "t_mesh"), num(r, "t_analyze"),
                num(r, "t_factorize"), num(r, "peak"));
  }

  for (int t : {1, 2}) {
    const std::string s = std::to_string(t);
    const double bw = (t == 1 ? bw1 : bw2).read;
    std::printf(
        "\nTable %d. One ALG2 iteration on %d thread%s, ms: minimum over the iterations of each "
        "phase (wall clock, IterationRecord)\n",
        t + 1, t, t == 1 ? "" : "s");
    std::printf(
        "  global = rhs assembly + triangular solve + Gbar u (+ facet means); solve = "
        "GlobalStep::solve; floor = 2 x 8 B x nnz(L) / %.1f GB/s;\n  other = global - "
        "solve + update (the update includes the residuals); total = min of the sums "
        "[median]%s\n",
        bw, t == 1 ? "; cpu = min CPU time of the (only) computing thread per iteration" : "");
    std::printf("%-13s %8s %8s %8s %5s %8s %7s %8s %8s %18s %8s %6s\n", "case", "global", "solve",
                "floor", "x", "strain", "ns/cell", "contact", "update", "total [median]",
                t == 1 ? "cpu" : "", "other%");
    for (const auto& r : rows) {
      const double floor = 16.0 * num(r, "nnzL") / (bw * 1e9) * 1e3;
      const double other = ms(r, "global" + s) - ms(r, "solve" + s) + ms(r, "update" + s);
      char tot[64], cpu[32] = "";
      std::snprintf(tot, sizeof tot, "%.3f [%.3f]", ms(r, "total" + s), ms(r, "total_med" + s));
      if (t == 1) std::snprintf(cpu, sizeof cpu, "%.3f", ms(r, "cpu1"));
      std::printf("%-13s %8.3f %8.3f %8.3f %5.2f %8.3f %7.0f %8.3f %8.3f %18s %8s %6.1f\n",
                  r.at("name").c_str(), ms(r, "global" + s), ms(r, "solve" + s), floor,
                  ms(r, "solve" + s) / floor, ms(r, "strain" + s),
                  num(r, "strain" + s) / num(r, "cells") * 1e9, ms(r, "contact" + s),
                  ms(r, "update" + s), tot, cpu, 100 * other / ms(r, "total" + s));
    }
  }

  std::printf(
      "\nTable 4. Speed-up on 2 threads vs 1 (ratio of the minima); local strain step "
      "alone on the final state (1 thread, CPU time); load average during the case\n");
  std::printf("%-13s %7s %7s %7s %7s %7s %9s %8s %11s\n", "case", "global", "solve", "strain",
              "contact", "total", "alone ns", "failures", "load");
  for (const auto& r : rows) {
    char load[64];
    std::snprintf(load, sizeof load, "%.2f-%.2f", num(r, "load0"), num(r, "load1"));
    std::printf("%-13s %7.2f %7.2f %7.2f %7.2f %7.2f %9.0f %8.0f %11s\n", r.at("name").c_str(),
                num(r, "global1") / num(r, "global2"), num(r, "solve1") / num(r, "solve2"),
                num(r, "strain1") / num(r, "strain2"),
                num(r, "contact2") > 0 ? num(r, "contact1") / num(r, "contact2") : 0.0,
                num(r, "total1") / num(r, "total2"), num(r, "strain_alone_ns"),
                num(r, "failures1") + num(r, "failures2"), load);
  }

  std::printf(
      "\nTable 5. Triangular solves alone, one call (all factors, all columns), 1 thread, "
      "CPU time, best of many: ours (ltl::Cholesky's sweeps, the default) vs "
      "CHOLMOD's supernodal sweeps (BLAS per supernode) vs CHOLMOD simplicial; floor as in "
      "Table 2 (%.1f GB/s); stored = values stored by the supernodal factor\n",
      bw1.read);
  std::printf("%-13s %11s %11s %9s %9s %6s %10s %11s\n", "case", "nnz(L)", "stored", "floor ms",
              "ours ms", "x", "CHOLMOD sn", "simplicial");
  for (const auto& r : rows) {
    if (num(r, "sv_ours") <= 0) continue;
    const double floor = 16.0 * num(r, "nnzL") / (bw1.read * 1e9) * 1e3;
    std::printf("%-13s %11.0f %11.0f %9.3f %9.3f %6.2f %10.3f %11.3f\n", r.at("name").c_str(),
                num(r, "nnzL"), num(r, "sv_entries"), floor, num(r, "sv_ours"),
                num(r, "sv_ours") / floor, num(r, "sv_cholsup"), num(r, "sv_simplicial"));
  }
  std::printf(
      "\nTable 6. Memory: peak resident memory (VmHWM) after the setup and at the end, the "
      "factors as stored, the rest per cell = (end peak - factors) / cells (the discretization, "
      "the state, the work arrays, Anderson's history when on, the runtime), and the contact "
      "kernel (sparse, adhesion_kernel.hpp) per contact point\n");
  std::printf("%-13s %8s %7s %10s %10s %8s %13s %12s\n", "case", "cells", "facets", "setup MB",
              "peak MB", "L MB", "rest B/cell", "kernel B/pt");
  for (const auto& r : rows) {
    const double rest = (num(r, "peak") * 1048576.0 - num(r, "factor_bytes")) / num(r, "cells");
    std::printf("%-13s %8.0f %7.0f %10.0f %10.0f %8.1f %13.0f %12.1f\n", r.at("name").c_str(),
                num(r, "cells"), num(r, "facets"), num(r, "peak_setup"), num(r, "peak"),
                num(r, "factor_bytes") / 1e6, rest,
                num(r, "facets") > 0 ? num(r, "kernel_bytes") / num(r, "facets") : 0.0);
  }
  std::printf(
      "\nTable 7. Results file: bytes written per step appended (lib/results_commit.hpp: the "
      "step's data past the file's end, then its metadata pages through the journal; about the "
      "step once), mean of steps 2..4 of a 4-step file\n");
  std::printf("%-13s %8s %14s %14s %9s\n", "case", "cells", "file (4 steps)",
              "bytes written "
              "per step",
              "x file/4");
  for (const auto& r : rows)
    std::printf("%-13s %8.0f %14.0f %14.0f %9.2f\n", r.at("name").c_str(), num(r, "cells"),
                num(r, "write_file"), num(r, "write_step"),
                num(r, "write_step") / (num(r, "write_file") / 4));
  std::printf("\nload average at end: %s\n", loadavg().c_str());
  return 0;
}
