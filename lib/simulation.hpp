// The time loop (2.1): one ALG2 solve per time step, each converged step appended to the
// results file as soon as it is done. run(solver, options) is, in lib/simulation.cpp:
//
//   ResultsWriter results(solver, options);      // lock, --resume, --stop-after
//   State s = results.start_state();             // initial state, or the file's last step
//   for (int p = results.next_step(); p <= results.last_step(); ++p)   // (2.1)
//     results.append(solve_time_step(solver, p, s, options.verbosity)); // (4.1)-(4.4)
//   RunSummary summary = results.finish(s);      // + one summary line
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "admissibility.hpp"
#include "alg2.hpp"
#include "problem.hpp"

namespace ltl {

class FieldSource;  // lib/results.hpp

struct RunOptions {
  std::string output;   ///< results file (.h5); empty: write nothing
  bool resume = false;  ///< continue from the last step stored in `output`
  int verbosity = 1;    ///< 0: silent, 1: one line per step (and per 50 iterations), 2: every
                        ///< iteration
  int stop_after = 0;   ///< stop (as if interrupted) after this many steps; 0: run to the end
  /// --init: start from the last step of this results file, computed on another mesh of the
  /// same body (lib/nested_start.hpp); the run computes its own steps 1..P. Not with resume.
  std::string init;
  /// --checkpoint: > 0, the iterate of the step in progress is saved in `output` every this many
  /// seconds of wall time and when the run is interrupted, as /unconverged/NNNNNN with attribute
  /// checkpoint = 1 (never a result); --resume continues the step from it. 0: not saved.
  double checkpoint_seconds = 0;
};

struct RunSummary {
  int first_step = 1, last_step = 0;  ///< steps computed by this run
  std::vector<int> iterations;        ///< per computed step
  double solver_seconds = 0;          ///< time in the iterations (not setup or output)
  double setup_seconds = 0;           ///< discretization, assembly and factorization
  /// The peak resident memory (VmHWM, bytes; 0 where /proc is missing) of the process; of a
  /// distributed solver (Ranks::All) the smallest and the largest over its ranks, which the
  /// run's last line prints (equal on one process).
  double peak_memory_min = 0, peak_memory_max = 0;
  /// The last converged state; under mpirun the state between steps (Solver::initial_state),
  /// E and lambda on the rank's rows: Solver::whole_state gathers it.
  State state;
  /// Load subdivision (solve_time_step): per computed step the number of substeps it took (1:
  /// the full increment converged), and the failed attempts of the whole run.
  std::vector<int> substeps;
  int failed_attempts = 0;
};

/// One solve of a time step at one load factor (the full increment or a substep of it).
struct StepAttempt {
  double from = 0, to = 0;  ///< the load factor at the start and at the end of the attempt
  bool converged = false;
  int iterations = 0;
  double seconds = 0;  ///< wall time of its iterations
  std::string status;  ///< StepReport::status (with the equilibrium and admissibility checks)
};

/// One time step p as computed by solve_time_step: ALG2's report and the state it left.
struct TimeStep {
  int p = 0;
  StepReport report;
  const State* state = nullptr;  ///< the caller's state, updated in place
  /// The admissibility of the state (lib/admissibility.hpp), checked when it is finite.
  AdmissibilityReport admissibility;
  /// Load subdivision: every solve of the step in order (the full increment first; the last one
  /// is `report`), the number of substeps that make up the step when it converged (1: the full
  /// increment), and why a failed step was not subdivided (empty when it was tried).
  std::vector<StepAttempt> attempts;
  int substeps = 1;
  std::string not_subdivided;
  int failed_attempts() const;
};

/// Load subdivision: a failed step is retried from step p-1's state with its load increment
/// halved, recursively on the failing half, at most this many times (smallest substep 1/8 of
/// the increment).
constexpr int kMaxHalvings = 3;

/// [LTL87 (2.1)-(2.2)] Time step p, backward Euler in beta: sets the load factor of step p
/// (LoadRamp), keeps beta_{p-1} for the dissipation and iterates ALG2 (4.1)-(4.4) from `state`
/// (step p-1's {E, e, beta, lambda, lambda_c}) to convergence (then Newton, algorithm.solver).
/// A step that fails (divergence, cap, not in equilibrium, inadmissible) is retried from step
/// p-1's state with its load increment (the LoadRamp factor from step p-1's to step p's; 0 before
/// step 1) halved, the failing half halved again, at most kMaxHalvings times; only the last
/// substep's state is the step's. Not subdivided: a step whose load factor does not change (a
/// constant load after step 1, a problem without dead loads or prescribed displacements, which
/// follow the same factor), and glue with dissipation (contact.d0 > 0: its
/// term (6.4)-(6.5) divides by the solver's dt, fixed at the precompute, so a substep would
/// dissipate as over the whole dt). Every attempt is in TimeStep::attempts and in the status. A
/// step converged by the iterate residuals but not in equilibrium (force residual above
/// algorithm.max_force_residual, a loaded problem) is marked not converged, and so is one that is
/// not admissible (check_admissibility: a node inside the obstacle, det F <= 0, a cell on the
/// rotated branch, a tension without glue, beta outside [0, 1]; status "inadmissible: ..."). Prints
/// progress (verbosity 2: every iteration; 1: every 50 iterations of a static problem, every 2000
/// of an evolution, with the step's ETA at its mean rate, and one line per converged step).
/// Never throws on divergence: ResultsWriter::append reports it. Ctrl-C or SIGTERM inside an
/// InterruptScope (lib/interrupt.hpp) throws Interrupted at the next iteration.
/// With `clock`, the step line ends with the run's ETA: the mean time of the steps computed so
/// far times the steps left.
struct RunClock {
  std::chrono::steady_clock::time_point start;  ///< when the first step of this run started
  int first = 1, last = 1;                      ///< the steps this run computes
};
/// Checkpoints of the step in progress (RunOptions::checkpoint_seconds): `save` is called with
/// the iterate every `every` seconds of wall time of a solve and when a signal arrives (before the
/// step stops); `resume`, when not null, is the iterate of this step saved by an earlier run at the
/// step's full load factor after `resume_iterations` iterations: the step continues from it
/// (beta_{p-1} and the retries of load subdivision still come from `state`, the step's start).
struct StepCheckpoints {
  double every = 0;
  std::function<void(int p, double load_factor, const State& iterate, int iterations)> save;
  const State* resume = nullptr;
  int resume_iterations = 0;
};
TimeStep solve_time_step(Solver& solver, int p, State& state, int verbosity = 1,
                         const RunClock* clock = nullptr,
                         const StepCheckpoints* checkpoints = nullptr);

/// The results file of a run (lib/results.hpp layout) and its bookkeeping:
///  - the output path is checked (never over an input of the run, a directory or a file that is
///    not a results file) and `<output>.lock` is held for the whole run (a second writer is
///    refused);
///  - --resume: the file must have been written by this problem (configuration, geometry, mesh
///    fingerprints); the run continues after its last step;
///  - --stop-after N: last_step() is N steps after next_step() (the file says "stopped after
///    step p" and can be resumed);
///  - the file is created with the first step written (an existing file stays until then) and
///    each converged step is appended at once, so an interrupted run keeps its completed steps.
/// With an empty output nothing is written; the summary is kept all the same.
class ResultsWriter {
 public:
  /// Checks the output path, takes the lock, on --resume checks and reads the file's last step;
  /// then prints the problem's size and algorithm (verbosity > 0). Throws Error.
  ResultsWriter(const Solver& solver, const RunOptions& options);
  ResultsWriter(const ResultsWriter&) = delete;
  ResultsWriter& operator=(const ResultsWriter&) = delete;
  ~ResultsWriter();

  /// The solver's initial state, the last step stored in the file on --resume, or the nested
  /// start from options.init (lib/nested_start.hpp). Handed over, not copied (the writer keeps
  /// no whole state of its own): call it once.
  State start_state() { return std::move(start_); }
  /// The first step to compute: 1, or one after the file's last step on --resume.
  int next_step() const { return first_; }
  /// The last step to compute: time.steps, or earlier with --stop-after.
  int last_step() const { return last_; }

  /// A converged step is written (status "complete" at the last of time.steps, else
  /// "running"). A step that did not converge ends the run with an Error that says why and what
  /// to change; its last iterate and history are kept in the file as /unconverged/NNNNNN (never
  /// as a result) and the file keeps steps 1..p-1.
  void append(const TimeStep& step);

  /// Ctrl-C or SIGTERM (lib/interrupt.hpp) during step p: marks the file "interrupted by ...
  /// during step p" (when this run has one) and throws Interrupted naming what was kept. The
  /// lock is released when the writer is destroyed, so the file can be resumed at once.
  [[noreturn]] void interrupted(int p, int signal);

  /// --checkpoint: saves the iterate of step p, iterating at `load_factor` after `iterations`
  /// iterations, in the results file (ResultsFile::save_checkpoint; created when this run has
  /// none yet, never over an earlier run's file), and says so on the console. A failed save is
  /// a warning, not the end of the run. Nothing without an output (the ranks other than 0).
  /// `iterate` is in the form Solver::iterate_to_writer gives: under mpirun E and lambda on each
  /// rank's rows, and then it is collective (every rank calls it: rank 0 reads the ranks' rows a
  /// block at a time, StepFields::written).
  void checkpoint(int p, double load_factor, const State& iterate, int iterations);
  /// On --resume, the checkpoint of next_step() to continue from (null: none, or not usable), and
  /// the iterations it was saved after.
  const State* resume_iterate() const { return resume_iterate_ ? &*resume_iterate_ : nullptr; }
  int resume_iterations() const { return resume_iterations_; }

  /// Marks a stopped run "stopped after step p" (or a resumed finished run "complete") and
  /// returns the summary, with `last` the last converged state, moved into it (the run's own
  /// state: no copy of u and of the rank's rows at the end of a run; the writer's summary is
  /// left empty).
  RunSummary finish(State last);

 private:
  struct File;
  const Solver& solver_;
  const Problem& problem_;
  RunOptions options_;
  std::map<std::string, std::string> ids_;  ///< fingerprints a resumed file must match
  std::unique_ptr<File> file_;              ///< the lock, and the file once opened or created
  State start_;
  int first_ = 1, last_ = 0;
  RunSummary summary_;
  std::optional<State> resume_iterate_;  ///< resume_iterate()
  int resume_iterations_ = 0;
  int saved_step_ = 0, saved_iterations_ = 0;  ///< the last checkpoint saved by this run
  bool checkpoint_refused_ = false;            ///< an earlier run's file is at the output
  /// The results file, created (mesh, configuration, contact surface) when this run has none.
  void create_file(FieldSource& fields);
  /// checkpoint() on the writer (rank 0), its fields read from `fields`.
  void save_checkpoint(int p, double load_factor, const State& iterate, int iterations,
                       FieldSource& fields);
};

/// [LTL87 (2.1)-(2.2)] Backward Euler in beta: for p = 1..P, start from step p-1's
/// {E, e, beta, lambda, lambda_c}, keep beta_{p-1} for the dissipation, iterate to
/// convergence. A step that does not converge ends the run with an Error (nothing is written
/// for that step; an existing results file is marked "diverged at step p").
/// `on_step` (optional) sees every converged step (the state between steps, Solver::initial_state).
/// The composition of the pieces above, then
/// one summary line (verbosity > 0).
RunSummary run(Solver& solver, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step = {});
/// The same with the solver built here from the problem.
RunSummary run(const Problem& problem, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step = {});

}  // namespace ltl
