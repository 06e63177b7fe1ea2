// ltl_run: solve your own problem from a configuration file and write the results (HDF5 +
// XDMF for ParaView). The figure drivers run the same recipe with the paper's configurations
// and then print their figure's numbers.
//
//   build/experiments/ltl_run CONFIG.toml [-o RESULTS.h5] [--set key=value]...
//                             [--resume | --init FILE] [--stop-after N] [-v | -q]
//
// --init FILE: the nested start, from the last step of a results file of another (coarser) mesh
// of the same body (lib/nested_start.hpp).
//
// Built with MPI (-DLTL_WITH_MPI=ON, build-mpi/), `mpirun -n P ltl_run ...` distributes ALG2
// over the P ranks (lib/alg2_mpi.cpp, paper_notes/mpi.md): rank 0 alone prints and writes the
// results file, with the serial layout; --resume continues a file written by any number of ranks
// (rank 0 reads it and sends the state to the others).
//
// Every configuration key is described in experiments/README.md.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

#include "cli.hpp"
#include "error.hpp"
#include "interrupt.hpp"
#include "mpi_comm.hpp"

// The recipe (lib/cli.hpp, lib/simulation.hpp): load -> discretize and precompute -> solve the
// time steps, each written as soon as it converges.
static void solve_and_report(const ltl::CommandLine& cmd) {
  ltl::Problem problem = ltl::load_problem(cmd);  // the configuration, validated
  ltl::RunOptions options = ltl::run_options(cmd, problem);
  const bool ranks = ltl::mpi::size() > 1;
  if (ranks && ltl::mpi::rank() != 0) {  // rank 0 reads, writes the results file and prints
    options.output.clear();
    options.verbosity = 0;
  }
  // Discretize (on several ranks each rank discretizes its own cells only, a slab); K
  // factorized once (4.5), or the distributed KSP set up once over the ranks.
  // The problem moves into the solver (one copy of the mesh).
  std::exception_ptr stop;  // a signal, the same iteration on every rank (run_signal)
  {
    ltl::Solver solver{std::move(problem), ranks ? ltl::Ranks::All : ltl::Ranks::One};
    // LTL_TEST_FAIL_RANK=r (tests/check_mpi_run.sh): rank r alone throws after step 1, as a rank
    // that runs out of memory would; r:setup, once its solver is set up (its PETSc objects are
    // then left to MPI_Abort, mpi::collective_teardown: their destruction is collective).
    const char* fail = std::getenv("LTL_TEST_FAIL_RANK");
    const int fail_rank = ranks && fail ? std::atoi(fail) : -1;
    const bool at_setup = fail && std::strstr(fail, ":setup");
    if (fail_rank == ltl::mpi::rank() && at_setup)
      throw ltl::Error(
          ltl::cat("rank ", fail_rank, " fails alone once set up (LTL_TEST_FAIL_RANK)"));
    try {
      ltl::run(solver, options, [&](const ltl::Solver&, int p, const ltl::State&) {
        if (p == 1 && ltl::mpi::rank() == fail_rank && !at_setup)
          throw ltl::Error(
              ltl::cat("rank ", fail_rank, " fails alone after step 1 (LTL_TEST_FAIL_RANK)"));
      });  // (2.1): ALG2 per step, written at once
    } catch (const ltl::Interrupted&) {
      stop = std::current_exception();  // the ranks destroy the solver together, then say it
    } catch (...) {
      // Under mpirun an error may be this rank's alone (memory exhausted on one rank): the
      // others wait for it in their collectives, and so would this rank in the Solver's
      // destruction (MUMPS's is collective), so the job ends here, before it. An error of every
      // rank (a divergence, a failed write: collective, rank 0's message) is said by rank 0
      // alone: the other ranks wait one second before they say theirs (report_exception), and
      // are ended meanwhile.
      if (!ranks) throw;
      ltl::mpi::abort(ltl::report_exception("ltl_run"));
    }
  }
  if (stop) std::rethrow_exception(stop);
}

// Errors: one line on stderr, exit status 1; bad usage: 2. Under mpirun a failing rank ends
// every rank (MPI_Abort), which would otherwise wait for it: during the time steps before the
// Solver is destroyed (solve_and_report above), otherwise after its message. An error that every
// rank meets is said once, by rank 0 (the others wait a second first: report_exception). A signal
// (Ctrl-C, SIGTERM: status 128 + the signal) stops every rank at the same iteration
// (lib/simulation.cpp, run_signal): they end together, MPI finalized, rank 0 alone saying what was
// kept.
int main(int argc, char** argv) {
  ltl::mpi::Session session(&argc, &argv);
  if (ltl::mpi::size() > 1 && ltl::mpi::rank() != 0) std::freopen("/dev/null", "w", stdout);
  const int status = ltl::guarded_main(argc, argv, "ltl_run", "", solve_and_report);
  // Bad usage (2) is every rank's, said by rank 0 (lib/cli.cpp): the ranks end together.
  if (status == 1 && ltl::mpi::size() > 1) ltl::mpi::abort(status);
  return status;
}
