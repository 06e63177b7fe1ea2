//                 ALG2 over MPI ranks: the cost of one iteration (make bench-mpi)
//
// What:     on the Fig 6 gutter refined through its mesh parameters (nt x na x nl H8), plain ALG2
//           distributed over the ranks of mpirun (lib/alg2_mpi.cpp): after `--warm` iterations,
//           `--iters` timed ones, split into the global phase (right-hand side, its sum over the
//           ranks, the distributed KSP or the replicated factor, Gbar u), the strain step, the
//           contact step and the update (with the gather of the owned blocks); the seconds in our
//           collectives (Allreduce, Allgatherv) and in KSPSolve; the bytes received per rank and
//           iteration by our collectives and by PETSc's messages; the KSP iterations per solve;
//           the peak resident memory of every rank (VmHWM). Times are the largest over the
//           ranks; the load average is printed beside them. A second line, "MEM ...": the
//           resident size (VmRSS / VmHWM / the allocator's live bytes to 0.1 MB; MB, largest rank)
//           after each setup phase (start, mesh read, solver set up, the last iteration, the step's
//           end; after the mesh read also the largest rank but rank 0, which alone runs gmsh,
//           and the seconds load_problem took; after the later phases the live bytes of the
//           largest rank but rank 0) and the bytes per cell the largest rank holds
//           (Solver::holdings); then the resident size split into anonymous, file-backed and
//           shared-memory pages at the start and at the step's end (MB, largest rank each, and
//           the largest rank but rank 0: mpi::resident_split), the file-backed ones the
//           libraries' code, shared by a node's ranks.
//           PETSC_OPTIONS=-ltl_mpi_whole: the whole discretization on every rank (the memory
//           before the partition of the operators, paper_notes/mpi.md).
//
//           --cuts K1,K2,...: only the partition of the cells into K parts for each K, by
//           slabs and by PT-Scotch (run on the ranks of mpirun): the facets cut, the largest part
//           over the mean, the partitioner's seconds; then it stops.
//           --stop-test 1: after the last timed iteration, the equilibrium stopping test (4.5)
//           at the iterate once as ALG2 evaluates it (Solver::iterate_equilibrium_error: on a
//           ghost layer at the iterate's rows) and once on the state between steps made from
//           the iterate, u made whole (the form it took until the fourth session of
//           2026-12-04): a line
//           "STOP ...", the milliseconds, our bytes received and VmHWM after each, largest rank.
//           Not with the timed iterations' bytes.
//           --body cube N: a cube of N^3 H8 glued to its base instead (experiments/bench/
//           cube.toml), a compact body for the partition of the cells (PETSC_OPTIONS=
//           -ltl_mpi_slabs: slabs instead of PT-Scotch's graph partition).
//
// Run:      mpirun -n P build-mpi/experiments/bench_mpi NT NA NL [--iters N] [--warm N]
//               [--solver mumps|cg-amg] [--distribute 1] [--stop-test 1] [--label TEXT]
//           mpirun -n P build-mpi/experiments/bench_mpi --body cube N [options]
//           (make bench-mpi runs the table of paper_notes/mpi.md). Without MPI (the default
//           build) it runs on one rank with the serial solver.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <string>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <vector>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"
#include "measures.hpp"
#include "mpi_comm.hpp"
#include "mpi_global.hpp"

namespace {

std::string loadavg() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + "/" + b + "/" + c;
}

/// Every rank's value, on every rank (a sum of one-hot vectors).
std::vector<double> all_ranks(double v) {
  std::vector<double> x(ltl::mpi::size(), 0.0);
  x[ltl::mpi::rank()] = v;
  ltl::mpi::sum(x.data(), static_cast<long>(x.size()));
  return x;
}
/// The bytes the allocator has handed out and not taken back (glibc's mallinfo2: the heap's
/// blocks in use and the mmapped ones; PETSc's and MUMPS's allocations included); 0 elsewhere.
double live_heap_bytes() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
  const struct mallinfo2 m = mallinfo2();
  return static_cast<double>(m.uordblks + m.hblkhd);
#else
  return 0;
#endif
}
double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double max_of(double v) {
  ltl::mpi::max(&v, 1);
  return v;
}

const char* kUsage =
    "usage: bench_mpi NT NA NL [--iters N] [--warm N] [--solver mumps|cg-amg] [--distribute 1]"
    " [--stop-test 1] [--label TEXT]\n       bench_mpi --body cube N [the same options]\n";

int bench(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::printf("%s", kUsage);
      return 0;
    }
  int iters = 20, warm = 3;
  std::string solver_name = "mumps", label = "-", body = "gutter", cuts;
  bool distribute = false;  // --distribute 1: the distributed solver on one rank too
  bool stop_test = false;   // --stop-test 1: the equilibrium stopping test's two forms
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool known = a == "--iters" || a == "--warm" || a == "--solver" || a == "--label" ||
                       a == "--distribute" || a == "--body" || a == "--cuts" || a == "--stop-test";
    if (a.rfind("-", 0) == 0 && (!known || i + 1 >= argc)) {
      std::fprintf(stderr, "bench_mpi: bad option %s\n%s", a.c_str(), kUsage);
      return 2;
    }
    if (!known) {
      positional.push_back(a);
      continue;
    }
    const std::string v = argv[++i];
    if (a == "--iters") iters = std::atoi(v.c_str());
    if (a == "--warm") warm = std::atoi(v.c_str());
    if (a == "--solver") solver_name = v;
    if (a == "--label") label = v;
    if (a == "--distribute") distribute = std::atoi(v.c_str()) != 0;
    if (a == "--stop-test") stop_test = std::atoi(v.c_str()) != 0;
    if (a == "--body") body = v;
    if (a == "--cuts") cuts = v;
  }
  const bool cube = body == "cube";
  if (positional.size() != (cube ? 1u : 3u) || (!cube && body != "gutter") ||
      (solver_name != "mumps" && solver_name != "cg-amg")) {
    std::fprintf(stderr, "%s", kUsage);
    return 2;
  }
  std::vector<std::string> ov;
  if (cube)
    ov = {"mesh.parameters.n=" + positional[0]};
  else
    ov = {"mesh.parameters.nt=" + positional[0], "mesh.parameters.na=" + positional[1],
          "mesh.parameters.nl=" + positional[2]};
  ov.insert(ov.end(), {"algorithm.tol=1e-300", "algorithm.blowup=1e100", "algorithm.solver=alg2",
                       "algorithm.max_iter=" + std::to_string(iters + warm)});
  if (solver_name == "cg-amg") ov.push_back("algorithm.global_solver=\"cg-amg\"");
  // The resident memory (VmRSS, then VmHWM) after each setup phase, the largest over the ranks.
  std::string phases;
  auto phase = [&](const char* name) {
    const double rss = max_of(ltl::mpi::resident_bytes() / 1048576.0);
    const double hwm = max_of(ltl::mpi::peak_resident_bytes() / 1048576.0);
    const double live = max_of(live_heap_bytes() / 1048576.0);
    // ... and the largest live heap of the ranks other than rank 0 (which makes the mesh and
    // writes the results), after the mesh.
    const double other = max_of(ltl::mpi::rank() != 0 ? live_heap_bytes() / 1048576.0 : 0.0);
    phases += ltl::cat(" ", name, "=", static_cast<int>(rss), "/", static_cast<int>(hwm), "/",
                       std::round(10 * live) / 10);
    if (ltl::mpi::size() > 1 && std::string(name) != "start" && std::string(name) != "mesh")
      phases += ltl::cat(" (other ranks ", std::round(10 * other) / 10, ")");
  };
  phase("start");
  // The resident size split (anonymous / file-backed / shared memory; mpi::resident_split), at
  // the start and at the step's end, the largest over the ranks: the file-backed pages are the
  // libraries' code, one copy per node however many ranks map it.
  auto split = [&](const char* name) {
    const ltl::mpi::ResidentSplit r = ltl::mpi::resident_split();
    const bool other = ltl::mpi::rank() != 0;
    const auto mb = [&](double b) { return std::round(10 * max_of(b / 1048576.0)) / 10; };
    const auto mb_other = [&](double b) {  // the largest rank but rank 0
      return std::round(10 * max_of(other ? b / 1048576.0 : 0.0)) / 10;
    };
    std::string t =
        ltl::cat(" ", name, "=", mb(r.anonymous), "/", mb(r.file), "/", mb(r.shared_memory));
    if (ltl::mpi::size() > 1)
      t += ltl::cat(" (other ranks ", mb_other(r.anonymous), "/", mb_other(r.file), "/",
                    mb_other(r.shared_memory), ")");
    return t;
  };
  std::string splits = split("start");
  const double t_load = now_seconds();
  ltl::Problem problem =
      ltl::load_problem(std::string(LTL_SOURCE_DIR) +
                            (cube ? "/experiments/bench/cube.toml" : "/experiments/fig6/fig6.toml"),
                        ov);
  const double load_s = max_of(now_seconds() - t_load);
  phase("mesh");
  {  // the mesh phase of the ranks that do not run gmsh (load_mesh: rank 0 alone does)
    const bool other = ltl::mpi::rank() != 0;
    const double rss = max_of(other ? ltl::mpi::resident_bytes() / 1048576.0 : 0);
    const double hwm = max_of(other ? ltl::mpi::peak_resident_bytes() / 1048576.0 : 0);
    const double live = max_of(other ? live_heap_bytes() / 1048576.0 : 0);
    if (ltl::mpi::size() > 1)
      phases += ltl::cat(" (other ranks ", static_cast<int>(rss), "/", static_cast<int>(hwm), "/",
                         static_cast<int>(live), ", load_s ", std::round(100 * load_s) / 100, ")");
    else
      phases += ltl::cat(" (load_s ", std::round(100 * load_s) / 100, ")");
  }
  if (!cuts.empty()) {  // the partitions alone
    for (std::size_t at = 0; at < cuts.size();) {
      const std::size_t end = std::min(cuts.find(',', at), cuts.size());
      const int K = std::atoi(cuts.substr(at, end - at).c_str());
      at = end + 1;
      const double t0 = now_seconds();
      const ltl::mpi::Partition graph = ltl::graph_cells(problem.mesh, K);
      const double graph_s = max_of(now_seconds() - t0);
      const ltl::mpi::Partition slabs = ltl::slab_cells(problem.mesh, K);
      int largest = 0;
      for (int r = 0; r < K; ++r)
        largest = std::max(largest, graph.offset[r + 1] - graph.offset[r]);
      const double mean = static_cast<double>(problem.mesh.num_cells()) / K;
      if (ltl::mpi::rank() == 0)
        std::printf(
            "CUT label=%s body=%s cells=%d on_ranks=%d parts=%d facets_cut_slabs=%ld "
            "facets_cut_graph=%ld graph_largest_over_mean=%.3f graph_s=%.2f\n",
            label.c_str(), body.c_str(), problem.mesh.num_cells(), ltl::mpi::size(), K,
            ltl::cut_facets(problem.mesh, slabs), ltl::cut_facets(problem.mesh, graph),
            largest / mean, graph_s);
    }
    return 0;
  }
  const int P = ltl::mpi::size();
  const bool all = P > 1 || distribute;
  // The problem moves into the solver's discretization (one copy of the mesh per rank).
  ltl::Solver solver(std::move(problem), all ? ltl::Ranks::All : ltl::Ranks::One);
  const ltl::Mesh& mesh = solver.problem().mesh;
  phase("solver");
  const double setup = max_of(solver.setup_seconds());
  ltl::State s = solver.initial_state();
  const Eigen::VectorXd beta_prev = s.beta;
  double wall0 = 0, wall = 0, tg = 0, ts = 0, tc = 0, tu = 0;
  ltl::mpi::Traffic c0;
  double petsc0 = 0, msgs0 = 0, red0 = 0, ksp_s0 = 0;
  long ksp_it0 = 0, ksp_solves0 = 0;
  int n = 0;
  std::string stop_line;         // --stop-test
  ltl::mpi::Traffic stop_moved;  // its traffic, left out of the iterations'
  solver.solve_step(s, beta_prev, [&](const ltl::IterationRecord& rec) {
    ++n;
    if (n > warm) {
      tg += rec.t_global;
      ts += rec.t_strain;
      tc += rec.t_contact;
      tu += rec.t_update;
      wall = rec.wall;
    }
    if (n == warm + iters) phase("last_iteration");  // before the end of the step's gathers
    if (n == warm + iters && stop_test) {
      // The stopping test (4.5) in its two forms, outside the timed iterations' traffic.
      const ltl::mpi::Traffic a0 = ltl::mpi::traffic();
      double t0 = now_seconds();
      const double on_rows = solver.iterate_equilibrium_error().value_or(NAN);
      const double rows_ms = 1e3 * max_of(now_seconds() - t0);
      const ltl::mpi::Traffic a1 = ltl::mpi::traffic();
      const double rows_hwm = max_of(ltl::mpi::peak_resident_bytes() / 1048576.0);
      t0 = now_seconds();
      std::optional<ltl::State> w = solver.iterate_to_writer(s);
      if (w) solver.whole_u(w->u);  // the state between steps with u whole, as it was
      const double between =
          w ? ltl::equilibrium_error(solver.discretization(), *w, solver.load_factor()) : NAN;
      const double between_ms = 1e3 * max_of(now_seconds() - t0);
      const ltl::mpi::Traffic a2 = ltl::mpi::traffic();
      const double between_hwm = max_of(ltl::mpi::peak_resident_bytes() / 1048576.0);
      stop_moved = {a2.bytes - a0.bytes, a2.calls - a0.calls, a2.seconds - a0.seconds};
      const double rows_bytes = max_of(a1.bytes - a0.bytes);
      const double between_bytes = max_of(a2.bytes - a1.bytes);
      stop_line =
          ltl::cat("STOP label=", label, " ranks=", ltl::mpi::size(), " at_rows: error=", on_rows,
                   " ms=", rows_ms, " bytes=", rows_bytes, " hwm_MB=", rows_hwm,
                   " between_steps: error=", between, " ms=", between_ms, " bytes=", between_bytes,
                   " hwm_MB=", between_hwm, "\n");
    }
    if (n != warm) return;
    wall0 = rec.wall;
    c0 = ltl::mpi::traffic();
    petsc0 = ltl::mpi::petsc_bytes_received();
    msgs0 = ltl::mpi::petsc_messages_received();
    red0 = ltl::mpi::petsc_reductions();
    const ltl::RankShare r = solver.rank_share();
    ksp_s0 = r.ksp_seconds;
    ksp_it0 = r.ksp_iterations;
    ksp_solves0 = r.ksp_solves;
  });
  phase("step_end");
  splits += split("step_end");
  const int timed = n - warm;
  ltl::mpi::Traffic c1 = ltl::mpi::traffic();
  c1.bytes -= stop_moved.bytes;
  c1.calls -= stop_moved.calls;
  c1.seconds -= stop_moved.seconds;
  const ltl::RankShare r = solver.rank_share();
  auto ms = [&](double sec) { return timed > 0 ? 1e3 * max_of(sec) / timed : 0.0; };
  const double bytes_ours = max_of((c1.bytes - c0.bytes) / timed);
  const double calls_ours = max_of((c1.calls - c0.calls) / timed);
  const double bytes_petsc = max_of((ltl::mpi::petsc_bytes_received() - petsc0) / timed);
  const double msgs_petsc = max_of((ltl::mpi::petsc_messages_received() - msgs0) / timed);
  const double reductions = max_of((ltl::mpi::petsc_reductions() - red0) / timed);
  const long solves = r.ksp_solves - ksp_solves0;
  const double its = solves > 0 ? double(r.ksp_iterations - ksp_it0) / solves : 0.0;
  const std::vector<double> peak = all_ranks(ltl::mpi::peak_resident_bytes() / 1048576.0);
  const double ghosts = max_of(static_cast<double>(r.ghosts));
  // The ghost layer's rows of other ranks (u scattered in, b added out), the largest rank.
  const double layer = max_of(static_cast<double>(r.layer_ghosts));
  // The ranks' rows of the distributed matrices (summed over the Dirichlet sets): the largest
  // over the mean (node_ranks gives a rank the nodes it shares with higher ranks).
  const std::vector<double> rows = all_ranks(static_cast<double>(r.rows));
  double rows_sum = 0, rows_max = 0;
  for (double v : rows) rows_sum += v, rows_max = std::max(rows_max, v);
  const double rows_ratio = rows_sum > 0 ? rows_max * P / rows_sum : 0.0;
  std::string peaks;
  for (double p : peak) peaks += (peaks.empty() ? "" : ",") + std::to_string(static_cast<int>(p));
  // What the largest rank holds, bytes per cell (Solver::holdings).
  const ltl::Holdings h = solver.holdings();
  const double nc = mesh.num_cells();
  const std::string held =
      ltl::cat("mesh=", static_cast<int>(max_of(h.mesh) / nc),
               " operators=", static_cast<int>(max_of(h.operators) / nc),
               " cell_arrays=", static_cast<int>(max_of(h.cell_arrays) / nc),
               " node_arrays=", static_cast<int>(max_of(h.node_arrays) / nc),
               " contact=", static_cast<int>(max_of(h.contact) / nc),
               " cells_with_operators=", static_cast<int>(max_of(h.cells_with_operators)));
  // Every collective before the print, on every rank.
  const double t_it = ms(wall - wall0), t_g = ms(tg), t_ksp = ms(r.ksp_seconds - ksp_s0),
               t_coll = ms(c1.seconds - c0.seconds), t_s = ms(ts), t_c = ms(tc), t_u = ms(tu);
  if (ltl::mpi::rank() == 0)
    std::printf(
        "MPI label=%s ranks=%d solver=%s cells=%d nodes=%d setup_s=%.2f timed=%d "
        "ms_per_it=%.2f global=%.2f (ksp %.2f, collectives %.2f) strain=%.2f contact=%.2f "
        "update=%.2f ksp_its_per_solve=%.1f bytes_per_it_ours=%.0f calls_per_it=%.0f "
        "bytes_per_it_petsc=%.0f messages_per_it_petsc=%.0f reductions_per_it_petsc=%.0f "
        "ghosts=%.0f layer_ghosts=%.0f rows_max_over_mean=%.3f peak_MB_per_rank=%s load=%s\n"
        "MEM label=%s ranks=%d rss/hwm_MB_after:%s held_B_per_cell: %s "
        "anon/file/shmem_MB:%s\n",
        label.c_str(), P,
        all ? (r.replicated_cholesky ? "replicated-cholesky"
               : r.mumps             ? "mumps"
                                     : "cg-gamg")
            : "serial",
        mesh.num_cells(), mesh.num_nodes(), setup, timed, t_it, t_g, t_ksp, t_coll, t_s, t_c, t_u,
        its, bytes_ours, calls_ours, bytes_petsc, msgs_petsc, reductions, ghosts, layer, rows_ratio,
        peaks.c_str(), loadavg().c_str(), label.c_str(), P, phases.c_str(), held.c_str(),
        splits.c_str());
  if (ltl::mpi::rank() == 0 && !stop_line.empty()) std::printf("%s", stop_line.c_str());
  std::fflush(stdout);
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ltl::mpi::Session session(&argc, &argv);
  int status = 1;
  try {
    status = bench(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_mpi: error: %s\n", e.what());
    ltl::mpi::abort(1);
  }
  return status;
}
