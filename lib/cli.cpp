#include "cli.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <new>
#include <system_error>
#include <thread>
#include <vector>

#include "config.hpp"
#include "error.hpp"
#include "interrupt.hpp"
#include "mpi_comm.hpp"

namespace ltl {

namespace {

char g_program[256] = "ltl";

/// Under mpirun, a rank other than 0: rank 0 says what every rank would (say, usage,
/// report_exception).
bool other_rank() {
  return mpi::size() > 1 && mpi::rank() != 0;
}

/// parse's messages on stderr. Under mpirun every rank parses the same command line: rank 0
/// alone says what is wrong with it (the others exit with the same status, silent).
__attribute__((format(printf, 1, 2))) void say(const char* format, ...) {
  if (other_rank()) return;
  std::va_list args;
  va_start(args, format);
  std::vfprintf(stderr, format, args);
  va_end(args);
}

// The last resort of the error boundary: an exception that cannot propagate (thrown inside an
// OpenMP region of ours or of gmsh, e.g. std::bad_alloc while meshing or assembling) ends the
// program through std::terminate. Print it as one line and exit 1 instead of aborting. Nothing
// needs unwinding for the results: the file is only ever replaced whole (a stale .partial or
// .lock beside it is harmless and reused by the next run).
[[noreturn]] void on_terminate() {
  std::string what = "unknown exception";
  if (const std::exception_ptr e = std::current_exception()) {
    try {
      std::rethrow_exception(e);
    } catch (const std::bad_alloc&) {
      what =
          "out of memory (the mesh or the problem is too large for this machine; use a coarser "
          "mesh)";
    } catch (const std::exception& x) {
      what = x.what();
    } catch (const std::string& x) {
      what = "gmsh: " + x;
    } catch (...) {
    }
  } else {
    what = "internal error (std::terminate without an exception)";
  }
  std::fprintf(stderr, "%s: error: %s\n", g_program, what.c_str());
  std::fflush(stderr);
  std::_Exit(1);
}

void usage(const std::string& program, const std::string& default_config, FILE* to = stderr) {
  if (to == stderr && other_rank()) return;  // rank 0's (say)
  std::fprintf(to,
               "usage: %s %s [-o RESULTS.h5] [--set key=value]... [--resume | --init FILE]"
               " [--stop-after N] [--checkpoint SECONDS] [-v | -q]\n"
               "  -o FILE         results file (default: results/<name>.h5)\n"
               "  --set key=value override a configuration value, e.g. --set algorithm.R=4\n"
               "  --resume        continue from the last step stored in the results file\n"
               "  --init FILE     start from the last step of FILE, a results file computed on\n"
               "                  another mesh of the same body (nested start)\n"
               "  --stop-after N  compute N more steps and stop (the file can be resumed)\n"
               "  --checkpoint S  save the iterate of the step in progress every S seconds and\n"
               "                  when interrupted (not a result); --resume continues from it\n"
               "  -v / -q         print every iteration / print nothing\n",
               program.c_str(), default_config.empty() ? "CONFIG.toml" : "[CONFIG.toml]");
}

/// Fills `cmd` from argv; returns -1 to go on, else the exit status (0 after -h, 2 on misuse).
int parse(int argc, char** argv, const std::string& default_config, CommandLine& cmd) {
  const char* program = cmd.program.c_str();
  RunOptions& options = cmd.options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if ((a == "-o" || a == "--set" || a == "--stop-after" || a == "--init" ||
         a == "--checkpoint") &&
        !has_value) {
      say("%s: %s needs a value\n", program, a.c_str());
      return 2;
    }
    if (a == "-o") {
      cmd.output = argv[++i];
      // An empty value (-o "$UNSET" in a script) is an error, not the default path.
      if (cmd.output.empty()) {
        say("%s: -o '': the results file name is empty\n", program);
        return 2;
      }
    } else if (a == "--set") {
      cmd.overrides.push_back(argv[++i]);
    } else if (a == "--resume") {
      options.resume = true;
    } else if (a == "--init") {
      options.init = argv[++i];
      if (options.init.empty()) {
        say("%s: --init '': the results file name is empty\n", program);
        return 2;
      }
    } else if (a == "--stop-after") {
      // The whole argument must be a number >= 1: "3abc", "-1", "0" and overflow are refused.
      const char* text = argv[++i];
      char* end = nullptr;
      errno = 0;
      const long n = std::strtol(text, &end, 10);
      if (end == text || *end != '\0' || errno == ERANGE || n < 1 || n > INT_MAX) {
        say("%s: --stop-after '%s': needs a whole number >= 1\n", program, text);
        return 2;
      }
      options.stop_after = static_cast<int>(n);
    } else if (a == "--checkpoint") {
      // Seconds of wall time between two saves of a step's iterate: a number > 0 ("10m" and
      // "0" are refused: 0 would save at every iteration, a rate nobody wants by accident).
      const char* text = argv[++i];
      char* end = nullptr;
      errno = 0;
      const double t = std::strtod(text, &end);
      if (end == text || *end != '\0' || errno == ERANGE || !(t > 0) || !std::isfinite(t)) {
        say("%s: --checkpoint '%s': needs a number of seconds > 0\n", program, text);
        return 2;
      }
      options.checkpoint_seconds = t;
    } else if (a == "-v") {
      options.verbosity = 2;
    } else if (a == "-q") {
      options.verbosity = 0;
    } else if (a == "-h" || a == "--help") {
      usage(cmd.program, default_config, stdout);
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      say("%s: unknown option '%s'\n", program, a.c_str());
      usage(cmd.program, default_config);
      return 2;
    } else if (cmd.config.empty()) {
      cmd.config = a;
    } else {
      usage(cmd.program, default_config);
      return 2;
    }
  }
  if (options.resume && !options.init.empty()) {
    say("%s: --resume and --init exclude each other (--resume continues the results "
        "file's own steps; --init starts a new run from another file)\n",
        program);
    return 2;
  }
  if (cmd.config.empty()) cmd.config = default_config;
  if (cmd.config.empty()) {
    usage(cmd.program, default_config);
    return 2;
  }
  return -1;
}

}  // namespace

int report_exception(const std::string& program) {
  const char* prog = program.c_str();
  try {
    throw;
  } catch (const Interrupted& e) {  // Ctrl-C, SIGTERM: what was kept, and 128 + the signal
    std::fflush(stdout);
    if (*e.what()) std::fprintf(stderr, "%s: %s\n", prog, e.what());  // (empty: another rank's)
    return 128 + e.signal();
  } catch (...) {
  }
  // Rank 0 first (cli.hpp): 1024 ranks that diverge together print one message, not 1024, and
  // the writer's (where the last iterate is saved) rather than another rank's.
  if (other_rank()) std::this_thread::sleep_for(std::chrono::seconds(1));
  try {
    throw;
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog, e.what());
  } catch (const std::filesystem::filesystem_error& e) {
    std::fprintf(stderr, "%s: error: file system: %s\n", prog, e.what());
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr,
                 "%s: error: out of memory (the mesh or the problem is too large for this "
                 "machine; use a coarser mesh)\n",
                 prog);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: error: %s\n", prog, e.what());
  } catch (const std::string& e) {  // gmsh 4.8 throws strings
    std::fprintf(stderr, "%s: error: gmsh: %s\n", prog, e.c_str());
  } catch (const char* e) {
    std::fprintf(stderr, "%s: error: %s\n", prog, e);
  } catch (...) {
    std::fprintf(stderr, "%s: error: unknown exception (a library threw something unexpected)\n",
                 prog);
  }
  return 1;
}

int guarded_main(int argc, char** argv, const std::string& program,
                 const std::string& default_config,
                 const std::function<void(const CommandLine&)>& body) {
  std::snprintf(g_program, sizeof g_program, "%s", program.c_str());
  std::set_terminate(on_terminate);
  CommandLine cmd;
  cmd.program = program;
  if (const int status = parse(argc, argv, default_config, cmd); status >= 0) return status;
  // The one error boundary: whatever is thrown (our errors, the standard library's, gmsh's
  // strings, memory exhaustion) is one line on stderr and exit status 1. The results file is
  // written atomically (results.hpp), so an error leaves the previous file or none.
  try {
    body(cmd);
  } catch (...) {
    return report_exception(program);
  }
  return 0;
}

Problem load_problem(const CommandLine& cmd) {
  return load_problem(cmd.config, cmd.overrides);
}

RunOptions run_options(const CommandLine& cmd, const Problem& problem) {
  RunOptions options = cmd.options;
  options.output = !cmd.output.empty()            ? cmd.output
                   : !problem.output_file.empty() ? problem.output_file
                                                  : "results/" + problem.name + ".h5";
  const auto dir = std::filesystem::path(options.output).parent_path();
  for (auto d = dir; !d.empty(); d = d.parent_path()) {  // a path below a regular file
    std::error_code ec;
    const auto st = std::filesystem::status(d, ec);
    if (std::filesystem::exists(st) && !std::filesystem::is_directory(st))
      throw Error(cat(options.output, ": cannot write the results file: '", d.string(),
                      "' is not a directory"));
    if (d == d.parent_path()) break;
  }
  if (!dir.empty()) std::filesystem::create_directories(dir);
  return options;
}

void print_newton_beside(const Problem& problem, const RunSummary& run) {
  if (run.iterations.empty() || run.first_step != 1) return;
  Problem q = problem;
  q.algorithm.solver = NonlinearSolver::Newton;
  Solver solver(q);
  State s = solver.initial_state();
  int total = 0, newton = 0;
  double worst = 0;
  for (int p = 1; p <= run.last_step; ++p) {
    const TimeStep t = solve_time_step(solver, p, s, 0);
    for (const StepAttempt& a : t.attempts) total += a.iterations;
    newton += t.report.newton_iterations;
    worst = std::max(worst, t.report.force_residual);
    if (!t.report.converged) {
      std::printf("  Newton on the same discrete problem: step %d not converged (%s)\n", p,
                  t.report.status.c_str());
      return;
    }
  }
  int alg2 = 0;
  for (int n : run.iterations) alg2 += n;
  const double scale = run.state.u.cwiseAbs().maxCoeff();
  std::printf(
      "  Newton on the same discrete problem: converged%s, %d iterations (%d ALG2 + %d Newton) "
      "against ALG2's %d; force residual at most %.1e; at the last step max |u_Newton - u_ALG2| "
      "/ max |u| = %.1e\n",
      run.last_step > 1 ? " at every step" : "", total, total - newton, newton, alg2, worst,
      (s.u - run.state.u).cwiseAbs().maxCoeff() / (scale > 0 ? scale : 1.0));
}

}  // namespace ltl
