//              The Newton phase on MPI ranks: the cost of a linear solve (paper_notes/mpi.md)
//
// What:     one step of CONFIG with algorithm.solver = "newton" (ALG2, then Newton), and the
//           cost of Newton's linear solves (lib/mpi_newton.hpp): the symbolic analysis (once per
//           Newton phase), the numeric factorization (once per Newton step) and the solves (5-7
//           multiplier sweeps per step) of the augmented tangent, and the full KKT system's LU
//           when it is used; serial (CHOLMOD, UMFPACK) with --serial, else distributed over the
//           ranks of mpirun (MUMPS; with algorithm.global_solver="cg-amg" no factorization but
//           GMRES + GAMG over the ranks, lib/newton_krylov.hpp, and its solves are reported). Times
//           are the largest over the ranks, with the load average; then every rank's peak resident
//           memory.
//
// Run:      mpirun -n P build-mpi/experiments/bench_mpi_newton CONFIG [--serial] [key=value]...
//           e.g. the gutter at level 2 (`refinement fig6`'s mesh, 2 160 H8):
//           bench_mpi_newton experiments/fig6/fig6.toml mesh.parameters.nt=4
//               mesh.parameters.na=18 mesh.parameters.nl=30
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"
#include "mpi_comm.hpp"
#include "mpi_newton.hpp"

namespace {

std::string loadavg() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + "/" + b + "/" + c;
}

double max_of(double v) {
  ltl::mpi::max(&v, 1);
  return v;
}

const char* kUsage = "usage: bench_mpi_newton CONFIG [--serial] [key=value]...\n";

int bench(int argc, char** argv) {
  bool serial = false;
  std::vector<std::string> overrides = {"algorithm.solver=newton"};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      if (ltl::mpi::rank() == 0) std::printf("%s", kUsage);
      return 0;
    }
    if (a == "--serial") {
      serial = true;
    } else if (a.rfind("-", 0) == 0) {
      std::fprintf(stderr, "bench_mpi_newton: unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    } else if (i > 1) {
      overrides.push_back(a);
    }
  }
  if (argc < 2 || std::string(argv[1]).rfind("-", 0) == 0) {
    std::fprintf(stderr, "%s", kUsage);
    return 2;
  }
  // As ltl_run builds it: the problem moved into the solver; on several ranks each discretizes
  // its own cells (alg2.hpp).
  ltl::Solver solver(ltl::load_problem(argv[1], overrides),
                     serial ? ltl::Ranks::One : ltl::Ranks::All);
  const ltl::Problem& problem = solver.problem();
  ltl::State s = solver.initial_state();
  const Eigen::VectorXd beta_prev = s.beta;
  const ltl::mpi::Traffic c0 = ltl::mpi::traffic();
  const double petsc0 = ltl::mpi::petsc_bytes_received(),
               msgs0 = ltl::mpi::petsc_messages_received(), red0 = ltl::mpi::petsc_reductions();
  const auto t0 = std::chrono::steady_clock::now();
  const ltl::StepReport r = solver.solve_step(s, beta_prev);
  const double wall =
      max_of(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  // The step's messages, this rank's receipts: our collectives (lib/mpi_comm.hpp: bytes, calls)
  // and PETSc's (the Krylov solves, the assemblies), then their largest over the ranks.
  const ltl::mpi::Traffic c1 = ltl::mpi::traffic();
  const double ours_bytes = max_of(c1.bytes - c0.bytes), ours_calls = max_of(c1.calls - c0.calls);
  const double petsc_bytes = max_of(ltl::mpi::petsc_bytes_received() - petsc0);
  const double petsc_msgs = max_of(ltl::mpi::petsc_messages_received() - msgs0);
  const double petsc_red = max_of(ltl::mpi::petsc_reductions() - red0);
  const ltl::NewtonSolveStats st = ltl::newton_solve_stats();
  auto per = [](double s, long n) { return n > 0 ? max_of(s) / n : 0.0; };
  // Every rank's VmHWM in 10^6 KiB (/usr/bin/time's %M / 10^6, the unit of mpi.md's tables).
  std::vector<double> peak(ltl::mpi::size(), 0.0);
  peak[ltl::mpi::rank()] = ltl::mpi::peak_resident_bytes() / 1024e6;
  ltl::mpi::sum(peak.data(), static_cast<long>(peak.size()));
  if (ltl::mpi::rank() == 0) {
    std::printf("%s: %d cells, %d nodes, %d rank(s), %s; %s\n", problem.name.c_str(),
                solver.discretization().num_cells(), solver.discretization().num_nodes(),
                ltl::mpi::size(), serial ? "serial" : "distributed", r.status.c_str());
    std::printf("  iterations %d (Newton %d, %d phase(s)), step wall %.3f s, load %s\n",
                r.iterations, r.newton_iterations, r.newton_attempts, wall, loadavg().c_str());
    std::printf(
        "  the step's messages (largest rank): ours %.0f B in %.0f collectives; PETSc's %.0f B in "
        "%.0f messages, %.0f reductions\n",
        ours_bytes, ours_calls, petsc_bytes, petsc_msgs, petsc_red);
  }
  // Collective: every rank computes the maxima.
  const double ca = per(st.cholmod_analysis_s, st.cholmod_analyses);
  const double cf = per(st.cholmod_factor_s, st.cholmod_factorizations);
  const double cs = per(st.cholmod_solve_s, st.cholmod_solves);
  const double ul = per(st.umfpack_s, st.umfpack_factorizations);
  const double ma = per(st.mumps_analysis_s, st.mumps_analyses);
  const double mf = per(st.mumps_factor_s, st.mumps_factorizations);
  const double ms = per(st.mumps_solve_s, st.mumps_solves);
  const double ml = per(st.mumps_lu_s, st.mumps_lu_factorizations);
  // The tangent's entries a rank sent to other ranks' rows per assembly: the largest, and the sum.
  const double sent = st.mumps_factorizations > 0
                          ? static_cast<double>(st.mumps_offrank_entries) / st.mumps_factorizations
                          : 0.0;
  double sent_max = sent, sent_sum = sent;
  ltl::mpi::max(&sent_max, 1);
  ltl::mpi::sum(&sent_sum, 1);
  if (ltl::mpi::rank() == 0) {
    std::printf(
        "  CHOLMOD: %ld analyses %.4f s, %ld factorizations %.4f s, %ld solves %.5f s each\n",
        st.cholmod_analyses, ca, st.cholmod_factorizations, cf, st.cholmod_solves, cs);
    std::printf("  UMFPACK: %ld LU (analysis + factorization + solve) %.4f s each\n",
                st.umfpack_factorizations, ul);
    std::printf(
        "  MUMPS:   %ld analyses %.4f s, %ld factorizations %.4f s, %ld solves %.5f s each\n",
        st.mumps_analyses, ma, st.mumps_factorizations, mf, st.mumps_solves, ms);
    std::printf("  MUMPS LU: %ld (%ld analyses), %.4f s each\n", st.mumps_lu_factorizations,
                st.mumps_lu_analyses, ml);
    std::printf(
        "  tangent entries sent to other ranks' rows per assembly: %.0f (largest rank), %.0f "
        "(all ranks)\n",
        sent_max, sent_sum);
    std::printf("  MUMPS workspace short of its estimate + 20 %%: %ld refactorization(s)\n",
                st.mumps_workspace_retries);
    std::printf(
        "  Krylov (GMRES + GAMG): %ld solves, %ld iterations (at most %ld), %ld failed, set-up "
        "%.2f s, iterations %.2f s; rank 0's rows: %ld of A, %ld of G\n",
        st.krylov_solves, st.krylov_iterations, st.krylov_max_iterations, st.krylov_failures,
        st.krylov_setup_s, st.krylov_solve_s, st.krylov_rows, st.krylov_constraint_rows);
    std::printf("  peak resident memory per rank (VmHWM, 10^6 KiB):");
    for (double g : peak) std::printf(" %.2f", g);
    std::printf("\n");
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ltl::mpi::Session session(&argc, &argv);
  try {
    return bench(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_mpi_newton: %s\n", e.what());
    ltl::mpi::abort(1);
  }
}
