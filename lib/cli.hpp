// The command line shared by the generic runner (ltl_run) and the figure drivers:
//
//   PROGRAM [CONFIG.toml] [-o RESULTS.h5] [--set key=value]... [--resume | --init FILE]
//           [--stop-after N] [-v | -q]
//
// Exit status: 0 when every time step converged, 1 on any error (bad input, failed
// factorization, divergence), 2 on bad command-line usage, 128 + N when stopped by signal N
// (130: Ctrl-C, 143: SIGTERM; the results file is marked "interrupted" and can be resumed).
//
// A driver's main() is guarded_main around its recipe (experiments/fig5/fig5.cpp):
//   load_problem(cmd) -> run_options(cmd, problem) -> Solver{Discretization(problem)} ->
//   run(solver, options) (the time steps, lib/simulation.hpp) -> the figure's report.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "simulation.hpp"

namespace ltl {

/// The parsed command line.
struct CommandLine {
  std::string program;                 ///< name in messages
  std::string config;                  ///< CONFIG.toml (or the driver's default)
  std::vector<std::string> overrides;  ///< --set key=value, in order
  std::string output;                  ///< -o (empty: the configuration's output.file, else
                                       ///< results/<name>.h5)
  /// --resume, --init, --stop-after, -v / -q (options.output: see run_options)
  RunOptions options;
};

/// Inside a catch block: the exception being handled as one line "PROGRAM: error: ..." on
/// stderr (an Interrupted: its message, none if empty), and the exit status: 1, or 128 + the
/// signal for an Interrupted. guarded_main's error boundary; ltl_run's under mpirun too. Under
/// mpirun a rank other than 0 waits one second before it says an error: one that every rank
/// meets (a bad configuration, a divergence) is then said once, by rank 0, whose MPI_Abort ends
/// the others meanwhile (ltl_run); one rank's own error, after that second.
int report_exception(const std::string& program);

/// Parses the command line (usage errors: a message and exit status 2; -h: usage, 0), then
/// calls `body` inside the one error boundary: whatever it throws (our errors, the standard
/// library's, gmsh's strings, memory exhaustion, even through std::terminate) is one line
/// "PROGRAM: error: ..." on stderr and exit status 1. Returns 0 when `body` returns.
/// `default_config` is used when no CONFIG is given (empty: CONFIG is required).
int guarded_main(int argc, char** argv, const std::string& program,
                 const std::string& default_config,
                 const std::function<void(const CommandLine&)>& body);

/// The configuration of the command line with its --set overrides, validated (lib/config.hpp).
Problem load_problem(const CommandLine& cmd);

/// The run options of the command line with the results file resolved: -o, else the
/// configuration's output.file, else results/<name>.h5; its directory is created (a path below
/// a regular file is an Error).
RunOptions run_options(const CommandLine& cmd, const Problem& problem);

/// For a figure computed with the paper's ALG2 from step 1: the same steps solved with
/// algorithm.solver = "newton" (lib/newton.hpp), printed on one line beside ALG2's count: the
/// iterations (ALG2 + Newton, every step), the largest force residual and, at the last step,
/// max |u_Newton - u_ALG2| / max |u|. Nothing for a resumed run.
void print_newton_beside(const Problem& problem, const RunSummary& run);

}  // namespace ltl
