#include "simulation.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <utility>

#include "config.hpp"
#include "error.hpp"
#include "hash.hpp"
#include "interrupt.hpp"
#include "measures.hpp"
#include "mpi_comm.hpp"
#include "mpi_newton.hpp"  // NewtonSolveStats
#include "nested_start.hpp"
#include "output_guard.hpp"
#include "reactions.hpp"
#include "results.hpp"
#include "step_fields.hpp"
#include "version.hpp"

namespace ltl {

namespace {

namespace fs = std::filesystem;

/// What to change when a step does not converge: the parameters used, the rule of the defaults
/// (derive_algorithm_defaults) and the usual remedies.
std::string divergence_hint(const Problem& problem, double factor, const TimeStep& step) {
  const AlgorithmParams& a = problem.algorithm;
  const Material& m = problem.material;
  const double C = m.C1 + (m.incompressible() ? m.C2 : 0.0);
  const int dim = problem.mesh.dim;
  // R q far above the default rule's: ALG2's steps are tiny (r_G + r_B small) far from equilibrium.
  const double huge = a.R * a.q / default_Rq(problem);
  return cat(
      " Parameters used: ", describe_algorithm(a), "; R q = ", a.R * a.q,
      " Pa = ", a.R * a.q / m.C1, " C1 (load factor ", factor, "). What to change: ",
      huge > 100 ? cat("R q is ", huge,
                       " x the default rule's: ALG2 then creeps (its iterate residuals are "
                       "small far from equilibrium), lower algorithm.R or use algorithm.solver = "
                       "\"newton\"; otherwise ")
                 : "",
      "R q must be at least ", dim == 3 ? "4 C1 in 3-D" : "2.6 C1 in plane strain",
      " and larger under contact pressures or stresses above 2 C1: raise algorithm.R (x2); ",
      "leave R, q, q_c out to get the defaults q = 2 (C1 + C2) = ", 2 * C,
      " Pa, R q = ", dim == 3 ? 8 : 6,
      " (C1 + C2), q_c = q / h (2-D) or q / (3 h) (3-D), h the contact facet size, with glue "
      "at least kappa / R; a residual that ",
      "decreases slowly needs algorithm.max_iter or acceleration = \"anderson\"",
      step.failed_attempts() > 1
          ? cat("; the load increment was already subdivided (", step.failed_attempts(),
                " failed attempts, the smallest substep 1/", 1 << kMaxHalvings,
                " of the increment): a finer load ramp alone is unlikely to help")
      : step.not_subdivided.find("no dead load") != std::string::npos
          ? "; nothing loads the problem (no dead load, no prescribed displacement), so the "
            "step could not be subdivided"
          : "; a load too large for one step needs a load ramp ([load] ramp = \"linear\", "
            "ramp_time, more time.steps)",
      " (experiments/README.md, \"Choosing R, q, q_c\").");
}

/// What is written for a step: the state, its report (history, equilibrium measure), its
/// measures and its support fields. The other fields (the Derived rows of
/// lib/results_fields.hpp: the stresses, one definition each, the strain's derived fields, the
/// contact pressure and gap) and the state's own are made one at a time as the writer asks for
/// them (`fields`, StepFields; null: the measures only). Under mpirun every rank computes the
/// measures, which are sums over the ranks' cells (collective), and the fields rank 0 asks for
/// are made on each rank's cells (StepFields::written).
StepData step_data(const Solver& solver, const TimeStep& step, StepFields* fields) {
  const Problem& problem = solver.problem();
  const State& state = *step.state;
  StepData d;
  d.p = step.p;
  d.t = step.p * problem.time.dt;
  d.state = &state;
  d.source = fields;
  d.report = &step.report;
  // Every measure of the step (lib/measures.hpp), one definition each.
  // Under mpirun u is on each rank's ghost layer's rows (Solver::state_rows).
  IterateRows at;
  const IterateRows* rows = solver.state_rows(at);
  const StepMeasures m = step_measures(solver.discretization(), state, 0, rows);
  d.measures = stored_measures(m, problem.mesh.dim);
  if (step.admissibility.h > 0)
    for (StoredMeasure& a : stored_measures(step.admissibility)) d.measures.push_back(a);
  // Load subdivision (solve_time_step): what it took to reach the step.
  d.measures.push_back({"substeps", static_cast<double>(step.substeps), "1",
                        "substeps of the load increment that made this step (1: the full "
                        "increment; the stored state and history are the last substep's)"});
  d.measures.push_back({"failed_attempts", static_cast<double>(step.failed_attempts()), "1",
                        "solves of this step that failed before it was done in substeps (the "
                        "step's status lists them)"});
  d.in_contact = m.in_contact;
  // The load factor of the step (LoadRamp; the last substep's) and the supports' reactions.
  d.measures.push_back({"load_factor", solver.load_factor(), "1",
                        "load factor of the step ([load] ramp): multiplies the body force, the "
                        "tractions and the prescribed displacements"});
  const SupportReactions r =
      support_reactions(solver.discretization(), state, solver.load_factor(), rows);
  d.fields["reactions"] = r.force;
  d.fields["support_u"] = r.u;
  d.conditions = joined_labels(r);
  return d;
}

}  // namespace

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

/// A duration for the progress lines: "45 s", "12 min 5 s", "3 h 20 min".
std::string duration_text(double seconds) {
  const long s = std::lround(std::max(seconds, 0.0));
  if (s < 60) return cat(s, " s");
  if (s < 3600) return cat(s / 60, " min ", s % 60, " s");
  return cat(s / 3600, " h ", (s % 3600) / 60, " min");
}

/// The time left in a step, extrapolated from the decrease of r_G + r_B between the first printed
/// record `before` and `now` (geometric, as ALG2 converges; the mean rate, as the residual is
/// not monotone from one line to the next) down to `tol`: "  ETA ~ 2 min 5 s
/// (step, at its mean rate)", or why there is none.
std::string step_eta(const IterationRecord& before, const IterationRecord& now, double tol) {
  const double r0 = before.r_G + before.r_B, r1 = now.r_G + now.r_B;
  const int dn = now.n - before.n;
  if (before.n == 0 || dn <= 0) return "";
  if (!(r1 < r0) || !(r1 > 0)) return "  ETA unknown (the residual did not decrease)";
  const double rate = std::log(r1 / r0) / dn;  // < 0
  const double left = std::max(std::log(tol / r1) / rate, 0.0);
  return cat("  ETA ~ ", duration_text(left * (now.wall - before.wall) / dn),
             " (step, at its mean rate)");
}

/// The load factors of LoadRamp at the start and the end of step p (0 before step 1).
struct Increment {
  double f0, f1;
};
Increment load_increment(const Problem& problem, int p) {
  return {p > 1 ? problem.ramp.factor(p - 1, problem.time.dt) : 0.0,
          problem.ramp.factor(p, problem.time.dt)};
}

/// A load so small against the stiffness that its response is lost in round-off (a body force of
/// 1e-300 N/m^3): the largest nodal load against C1 h^(dim-1), h the mean cell size, the force
/// of a unit strain on a cell. Below 1e-12 (the strain it causes, 1e4 round-offs) the equilibrium
/// check cannot tell the solution from noise: an Error naming the load, not "not in equilibrium".
/// Not checked when prescribed displacements drive the step.
void check_load_scale(const Solver& solver, double load_scale, int p) {
  const Problem& problem = solver.problem();
  const int dim = problem.mesh.dim;
  if (!(load_scale > 0) || solver.discretization().dirichlet().max_abs_value() > 0) return;
  const double h = std::pow(solver.discretization().volume() / problem.mesh.num_cells(), 1.0 / dim);
  const double unit = problem.material.C1 * std::pow(h, dim - 1);
  if (load_scale >= 1e-12 * unit) return;
  throw Error(cat(problem.name, ": the loads at step ", p,
                  " are below round-off relative to the "
                  "stiffness: the largest nodal load is ",
                  load_scale, dim == 2 ? " N/m" : " N",
                  ", while a strain of 1 on a cell of the mesh (C1 h^", dim - 1, ", h = ", h,
                  " m) takes ", unit, dim == 2 ? " N/m" : " N",
                  "; the displacements it causes (a strain of about ", load_scale / unit,
                  ") are lost in round-off. Check the values and units of load.body_force and "
                  "load.traction (a load of zero is allowed: leave it out)"));
}

/// The signal (Ctrl-C, SIGTERM) the run stops for, or 0: this process's (interrupt_signal); of a
/// distributed solver the largest over its ranks, the same on every rank (collective: one
/// reduction of one value). A scheduler's SIGTERM reaches the ranks at different moments, and a
/// rank's own record could stop it one iteration before the others, which would then wait for
/// it in the next iteration's sums; decided together, every rank stops at the same iteration
/// (paper_notes/mpi.md, "A signal stops every rank at the same iteration; an error of one rank
/// ends the job"). `due` (optional): is a checkpoint due by this rank's clock, in: and by any
/// rank's, out (the same reduction), so that the ranks save together.
int run_signal(const Solver& solver, bool* due = nullptr) {
  double v[2] = {static_cast<double>(interrupt_signal()), due && *due ? 1.0 : 0.0};
  if (solver.cell_partition()) mpi::max(v, 2);
  if (due) *due = v[1] != 0;
  return static_cast<int>(v[0]);
}

/// One solve of step p at the load factor `factor` from `state`: ALG2 (then Newton), the
/// equilibrium check and the admissibility check. Prints iteration progress only. beta_prev:
/// beta_{p-1} when `state` is not the step's start (a checkpoint continued), else state.beta.
/// checkpoints: the iterate saved every `every` seconds and at a signal, its iteration count
/// after `prior` iterations of an earlier run.
TimeStep solve_at_factor(Solver& solver, int p, double factor, State& state, int verbosity,
                         const Eigen::VectorXd* beta_prev_given = nullptr,
                         const StepCheckpoints* checkpoints = nullptr, int prior = 0) {
  const Problem& problem = solver.problem();
  const int P = problem.time.steps;
  // LoadRamp, or a substep of its increment: the dead loads and the prescribed displacements.
  solver.set_load_factor(factor);
  const double load_scale = solver.largest_load();
  check_load_scale(solver, load_scale, p);
  const Eigen::VectorXd beta_prev = beta_prev_given ? *beta_prev_given : state.beta;
  IterationRecord shown;  // the first record printed: the rate of the step since then
  const bool saving = checkpoints && checkpoints->save && checkpoints->every > 0;
  auto saved = std::chrono::steady_clock::now();
  auto progress = [&](const IterationRecord& r) {
    // --checkpoint: the iterate (ALG2's, or during a Newton phase Newton's) every `every`
    // seconds, and before a signal stops the step.
    bool due =
        saving && std::chrono::duration<double>(std::chrono::steady_clock::now() - saved).count() >=
                      checkpoints->every;
    const int signal = run_signal(solver, &due);  // both decided over the ranks
    if (saving && (signal != 0 || due)) {
      // The caller's state is ALG2's iterate in ALG2's phases of one process; else the iterate is
      // made (Newton's; over the ranks the state between steps of ALG2's rows) by every rank
      // (collective), and only for a save; the writer reads E and lambda from the ranks' rows a
      // block at a time (ResultsWriter::checkpoint). Until 2026-12-03 the Newton phase's save
      // refused it over the ranks ("E is 122 x 2, expected 244 x 2") and saved ALG2's last
      // iterate on one process, and ALG2 gathered E and lambda whole at every iteration.
      const std::optional<State> iterate = solver.iterate_to_writer(state);
      checkpoints->save(p, factor, iterate ? *iterate : state, prior + r.n);
      saved = std::chrono::steady_clock::now();
    }
    check_interrupt(signal);  // Ctrl-C, SIGTERM (lib/interrupt.hpp): stop at this iteration
    // Long steps show progress: every 50 iterations of a static problem, every 2000 of a
    // time step of an evolution, with the time left at the step's mean rate since its first line.
    if (verbosity >= 2 || (verbosity == 1 && r.n % (P == 1 ? 50 : 2000) == 0)) {
      std::printf("  it %5d  r_G %.3e  r_B %.3e  %.3f s%s\n", r.n, r.r_G, r.r_B, r.wall,
                  verbosity == 1 ? step_eta(shown, r, problem.algorithm.tol).c_str() : "");
      std::fflush(stdout);
      if (shown.n == 0) shown = r;
    }
  };
  TimeStep step;
  step.p = p;
  step.report = solver.solve_step(state, beta_prev, progress);
  step.state = &state;
  StepReport& report = step.report;
  // The stopping test looks at changes of the iterate; with a huge R they are small after one
  // iteration far from equilibrium. A step is converged only if it is also in equilibrium
  // (skipped for a problem without loads, where the measure is not relative).
  const double bound = problem.algorithm.max_force_residual;
  if (report.converged && !(report.force_residual <= bound) && load_scale > 0) {
    report.converged = false;
    report.status =
        cat("converged by the iterate residuals but the force residual ", report.force_residual,
            " exceeds ", bound, " (algorithm.max_force_residual); lower algorithm.tol or R");
  }
  // A converged state must also be a physical one (lib/admissibility.hpp); one that is not is
  // reported like a divergence (ResultsWriter::append).
  // (Under mpirun each rank holds its rows of E: the ranks agree before the collective check.)
  double not_finite = state.u.allFinite() && state.E.allFinite() ? 0 : 1;
  if (solver.rows_between_steps()) mpi::max(&not_finite, 1);
  if (not_finite == 0) {
    IterateRows at;
    step.admissibility = check_admissibility(solver.discretization(), state, solver.state_rows(at));
    report.det_min = step.admissibility.det_F_min;
    if (report.converged && !step.admissibility.admissible()) {
      report.converged = false;
      report.status = cat("inadmissible: converged (r_G + r_B < tol, in equilibrium) but ",
                          step.admissibility.message());
    }
  }
  return step;
}

/// Why a failed step, whose load factor goes from f0 to f1, cannot be subdivided (empty: it
/// can).
std::string subdivision_refused(const Solver& solver, double f0, double f1) {
  const Problem& problem = solver.problem();
  if (std::any_of(problem.contacts.begin(), problem.contacts.end(), [](const ContactCondition& c) {
        return c.adhesion.d0 > 0 && c.adhesion.glued();
      }))
    return "not subdivided: glue with dissipation (contact.d0 > 0), whose term (6.4)-(6.5) "
           "divides by the time step dt of the solver: a substep of the load would dissipate as "
           "over the whole dt";
  if (f1 == f0)
    return cat("not subdivided: the load factor does not change at this step (", f1,
               "); nothing to subdivide");
  const bool displaced = solver.discretization().dirichlet().max_abs_value() > 0;
  if (!(solver.largest_load() > 0) && !displaced)
    return "not subdivided: no dead load and no prescribed displacement";
  return "";
}

std::string attempts_text(const std::vector<StepAttempt>& attempts) {
  std::string s;
  for (const StepAttempt& a : attempts)
    s += cat(s.empty() ? "" : "; ", a.from, " -> ", a.to, ": ",
             a.converged ? cat("converged in ", a.iterations, " iterations")
                         : cat("failed after ", a.iterations, " iterations (",
                               a.status.substr(0, a.status.find(": ")), ")"));
  return s;
}

}  // namespace

int TimeStep::failed_attempts() const {
  int n = 0;
  for (const StepAttempt& a : attempts) n += !a.converged;
  return n;
}

TimeStep solve_time_step(Solver& solver, int p, State& state, int verbosity, const RunClock* clock,
                         const StepCheckpoints* checkpoints) {
  const Problem& problem = solver.problem();
  const int P = problem.time.steps;
  const auto [f0, f1] = load_increment(problem, p);
  std::vector<StepAttempt> attempts;
  int substeps = 0;
  TimeStep step;
  // The attempt just made (`step`), a -> b, recorded; true if it converged.
  const auto record = [&](double a, double b) {
    const StepReport& r = step.report;
    attempts.push_back({a, b, r.converged, r.iterations,
                        r.history.empty() ? 0.0 : r.history.back().wall, r.status});
    return r.converged;
  };
  // One attempt a -> b from the current state, a substep when it converges.
  const auto attempt = [&](double a, double b) {
    step = solve_at_factor(solver, p, b, state, verbosity, nullptr, checkpoints);
    return record(a, b) && (++substeps, true);
  };
  // The attempt a -> b failed: the state goes back to a's (`at_a`, a kept copy of it) and the
  // increment is done as two halves at `depth`, each halved again when it fails while halvings
  // are left. The first half starts from a too and goes back to the same copy; the second starts
  // from the midpoint, kept once the first half converged. So no state is kept twice: at most
  // one copy per distinct load factor still to go back to (the step's start and the midpoints
  // of halves in progress). The states kept are, under mpirun, E and lambda on the rank's cells
  // and u on its block of nodes (Solver::kept_copy).
  const std::function<bool(double, double, int, const State&)> in_halves =
      [&](double a, double b, int depth, const State& at_a) {
        const StepReport& r = step.report;
        if (verbosity > 0)
          std::printf(
              "step %4d/%d  load factor %g -> %g failed after %d iterations (%s); retried "
              "in two halves\n",
              p, P, a, b, r.iterations, r.status.substr(0, r.status.find(": ")).c_str()),
              std::fflush(stdout);
        solver.restore(at_a, state);
        const double m = a + (b - a) / 2;
        const bool last = depth >= kMaxHalvings;
        if (!attempt(a, m) && (last || !in_halves(a, m, depth + 1, at_a))) return false;
        const State at_m = last ? State{} : solver.kept_copy(state);
        return attempt(m, b) || (!last && in_halves(m, b, depth + 1, at_m));
      };
  const State start = solver.kept_copy(state);
  // A checkpoint of this step (--resume): the first attempt continues from it, beta_{p-1} and
  // the retries from the step's start.
  const bool resumed = checkpoints && checkpoints->resume;
  if (resumed) state = *checkpoints->resume;
  step = solve_at_factor(solver, p, f1, state, verbosity, resumed ? &start.beta : nullptr,
                         checkpoints, resumed ? checkpoints->resume_iterations : 0);
  std::string refused;
  if (!record(f0, f1)) {
    refused = subdivision_refused(solver, f0, f1);
    if (refused.empty()) in_halves(f0, f1, 1, start);
  }
  step.attempts = std::move(attempts);
  step.substeps = step.report.converged ? std::max(substeps, 1) : 0;
  step.not_subdivided = refused;
  StepReport& report = step.report;
  const int failed = step.failed_attempts();
  if (failed > 0 && report.converged)
    report.status =
        cat(report.status, "; load increment ", f0, " -> ", f1, " done in ", step.substeps,
            " substeps after ", failed, " failed attempt(s): ", attempts_text(step.attempts));
  else if (failed > 1)
    report.status =
        cat(report.status, "; the step was retried with its load increment ", f0, " -> ", f1,
            " halved up to ", kMaxHalvings, " times: ", attempts_text(step.attempts));
  else if (!report.converged && !refused.empty())
    report.status = cat(report.status, " (", refused, ")");
  if (!report.converged) return step;
  if (verbosity > 0 && (P > 1 || verbosity == 1))
    std::printf(
        "step %4d/%d  t = %8.2f s  %5d iterations  r_G %.2e  r_B %.2e  force residual %.1e  "
        "%.3f s%s%s%s%s%s\n",
        p, P, p * problem.time.dt, report.iterations, report.history.back().r_G,
        report.history.back().r_B, report.force_residual, report.history.back().wall,
        report.strain_failures
            ? cat("  (", report.strain_failures, " local strain solves not at round-off)").c_str()
            : "",
        report.accepted + report.rejected
            ? cat("  Anderson ", report.accepted, " kept / ", report.rejected, " rejected").c_str()
            : "",
        problem.algorithm.adaptive_R
            ? cat("  R = ", report.R, " (", report.R_changes, " changes)").c_str()
            : "",
        failed
            ? cat("  (last of ", step.substeps, " substeps, ", failed, " failed attempts)").c_str()
            : "",
        clock && clock->last > p
            ? cat("  ETA ", duration_text(seconds_since(clock->start) / (p - clock->first + 1) *
                                          (clock->last - p)))
                  .c_str()
            : "");
  std::fflush(stdout);
  return step;
}

// --resume under mpirun: rank 0's resume point (the next step and the whole state of the last
// step written, as a serial run stores it, the checkpoint of the next step if it continues
// from one, and the file of --init when step 1 starts from it again) sent to every rank, so that
// a file written by any number of ranks resumes on any other number. Returns the next step.
static void broadcast_state(State& s) {
  for (Eigen::MatrixXd* m : {&s.u, &s.E, &s.lambda, &s.e, &s.lambda_c})
    mpi::broadcast(m->data(), m->size());
  mpi::broadcast(s.beta.data(), s.beta.size());
}
static int resume_across_ranks(State& s, int next_step, std::optional<State>& iterate,
                               int& iterations, std::string& restart) {
  restart = mpi::broadcast(restart);
  double head[3] = {static_cast<double>(next_step), iterate ? 1.0 : 0.0,
                    static_cast<double>(iterations)};
  mpi::broadcast(head, 3);
  broadcast_state(s);
  if (head[1] > 0) {
    if (!iterate) iterate = s;  // the shapes; the values follow
    broadcast_state(*iterate);
    iterations = static_cast<int>(head[2]);
  }
  return static_cast<int>(head[0]);
}

struct ResultsWriter::File {
  std::optional<ResultsFile> results;  ///< open once resumed or once the first step is written
  std::optional<OutputLock> lock;      ///< held while the writer lives
};

ResultsWriter::ResultsWriter(const Solver& solver, const RunOptions& options)
    : solver_(solver),
      problem_(solver.problem()),
      options_(options),
      ids_(identity(solver.problem())),
      file_(std::make_unique<File>()),
      // Whole when a file's state replaces it (--resume: its shapes are a file's; --init), cut
      // to the rank's rows at the end.
      start_(solver.initial_state(options.resume || !options.init.empty())) {
  const Problem& problem = problem_;
  summary_.setup_seconds = solver.setup_seconds();
  // Under mpirun only rank 0 has the results file (ltl_run): it reads the resume point, and the
  // other ranks receive it (resume_across_ranks below).
  const bool reader = mpi::rank() == 0;
  if (options.resume && reader && options.output.empty())
    throw Error("--resume needs a results file");
  if (!reader && solver.rows_between_steps() && !options.output.empty())
    throw Error(
        "under mpirun only rank 0 writes the results file: give the output path to rank 0 "
        "alone (as ltl_run does)");
  if (!options.output.empty()) {
    check_output_path(problem, options.output);
    file_->lock.emplace(options.output);
  }
  int p0 = 1;
  std::string restart;  // the file of --init when step 1 starts from it again (below)
  if (options.resume && !reader) {
    p0 = resume_across_ranks(start_, 0, resume_iterate_, resume_iterations_, restart);
  } else if (options.resume) {
    const std::string& out = options.output;
    const ResumePoint resumed = resume_point(problem, out, ids_, start_);
    start_ = resumed.state;
    p0 = resumed.next_step;
    for (const std::string& change : resumed.changes)
      if (options.verbosity > 0)
        std::printf("%s: resumed with a changed setting: %s\n", problem.name.c_str(),
                    change.c_str());
    // Step 1 of a run started with --init starts from that file's state again (below, on every
    // rank): its beta is beta_0 of the step, and load subdivision retries from it.
    const std::string init = ResultsFile::read_attribute(out, "initial_from");
    if (p0 == 1 && !init.empty() && p0 <= problem.time.steps) {
      if (!fs::exists(init))
        throw Error(cat(out, ": cannot resume: its step 1 starts from ", init,
                        " (--init), which no longer exists; restore that file, or start the run "
                        "again"));
      restart = init;
    }
    // The checkpoint of step p0 (--checkpoint): continued when it was saved at the step's full
    // load factor (not at a substep of load subdivision) on fields of this problem's shapes.
    if (auto c = p0 <= problem.time.steps ? ResultsFile::read_checkpoint(out, p0)
                                          : std::optional<StoredStep>()) {
      const double f1 = problem.ramp.factor(p0, problem.time.dt);
      const State& s = c->state;
      if (!same_shapes(s, start_))
        throw Error(cat(out, ": cannot resume: the checkpoint of step ", p0,
                        " has the fields of another mesh or contact surface"));
      if (std::abs(c->load_factor - f1) <= 1e-12 * std::max(1.0, std::abs(f1))) {
        resume_iterate_ = s;
        resume_iterations_ = c->iterations;
        if (options.verbosity > 0)
          std::printf(
              "%s: step %d continues from its checkpoint, saved after %d iterations "
              "(the iteration counts of this run start again at 1)\n",
              problem.name.c_str(), p0, c->iterations);
      } else if (options.verbosity > 0) {
        std::printf(
            "%s: note: the checkpoint of step %d was saved at load factor %g, a substep of "
            "the step's %g (load subdivision): not used, the step starts again\n",
            problem.name.c_str(), p0, c->load_factor, f1);
      }
    }
    file_->results = ResultsFile::open(out);
    file_->results->set_status("running");
    if (mpi::size() > 1)
      resume_across_ranks(start_, p0, resume_iterate_, resume_iterations_, restart);
  }
  // The nested start again, on every rank: on a rank's cells it is collective (nested_start).
  if (!restart.empty()) {
    const NestedStart nested = nested_start(solver, restart, "initial_from");
    start_ = nested.state;
    if (options.verbosity > 0)
      std::printf("%s: step 1 starts again from %s\n", problem.name.c_str(),
                  nested.summary().c_str());
  }
  if (!options.init.empty()) {  // --init: the nested start (lib/nested_start.hpp)
    if (options.resume) throw Error("--resume and --init exclude each other");
    std::error_code ec;
    if (!options.output.empty() && fs::exists(options.output) &&
        fs::equivalent(options.output, options.init, ec))
      throw Error(cat(options.output, ": refusing to write the results over the file of --init (",
                      options.init, "); choose another output path"));
    const NestedStart nested = nested_start(solver, options.init);
    start_ = nested.state;
    const double f1 = problem.ramp.factor(1, problem.time.dt);
    if (options.verbosity > 0) {
      std::printf("%s: %s\n", problem.name.c_str(), nested.summary().c_str());
      if (std::abs(nested.source_load_factor - f1) > 1e-12)
        std::printf("%s: note: the source step is at load factor %g, this run's step 1 at %g\n",
                    problem.name.c_str(), nested.source_load_factor, f1);
    }
  }
  // Under mpirun: the state between steps, E and lambda on the rank's rows and u on its ghost
  // layer's (Solver::hold_rows).
  solver.hold_rows(start_);
  if (resume_iterate_) solver.hold_rows(*resume_iterate_);
  first_ = p0;
  const int P = problem.time.steps;
  last_ = options.stop_after > 0 && options.stop_after <= P - p0 ? p0 + options.stop_after - 1 : P;
  summary_.first_step = p0;
  summary_.last_step = p0 - 1;
  if (options.verbosity > 0)
    std::printf("%s: %d cells, %d nodes, %d contact points, %s, setup %.3f s\n",
                problem.name.c_str(), problem.mesh.num_cells(), problem.mesh.num_nodes(),
                solver.discretization().points() ? solver.discretization().points()->size() : 0,
                solver.global_step_summary().c_str(), solver.setup_seconds());
  if (options.verbosity > 0)
    std::printf("%s: algorithm %s\n", problem.name.c_str(),
                describe_algorithm(problem.algorithm).c_str());
  // A ramp that ends after the last step: the run never reaches the full load (not an error:
  // --resume --set time.steps=... extends it), said once, so that "complete" is not misread.
  const double final_factor = problem.ramp.factor(P, problem.time.dt);
  if (options.verbosity > 0 && problem.ramp.kind == LoadRamp::Kind::Linear && final_factor < 1)
    std::printf(
        "%s: note: load.ramp_time = %g s is after the last step (t = %g s): the run ends "
        "at load factor %g\n",
        problem.name.c_str(), problem.ramp.ramp_time, P * problem.time.dt, final_factor);
}

ResultsWriter::~ResultsWriter() = default;

void ResultsWriter::append(const TimeStep& step) {
  const Problem& problem = problem_;
  const Solver& solver = solver_;
  const std::string& output = options_.output;
  std::optional<ResultsFile>& file = file_->results;
  const int p = step.p, P = problem.time.steps;
  const StepReport& report = step.report;
  for (const StepAttempt& a : step.attempts) summary_.solver_seconds += a.seconds;
  if (step.attempts.empty())
    summary_.solver_seconds += report.history.empty() ? 0 : report.history.back().wall;
  summary_.failed_attempts += step.failed_attempts();
  if (!report.converged) {
    const auto& last = report.history.back();
    const bool unbalanced = report.status.rfind("converged by", 0) == 0;
    const bool inadmissible = report.status.rfind("inadmissible", 0) == 0;
    // A diverged step (NaN, blow-up, iteration cap) keeps its last iterate and history in the
    // results file as /unconverged/NNNNNN, never as a result, so that a user can plot why: in
    // the run's file, or in a new one when this run has none yet (not over another run's file).
    std::string saved;  // (the file created, if need be, when saving below)
    if (!unbalanced && !output.empty() && (file || !fs::exists(output))) {
      char group[32];
      std::snprintf(group, sizeof group, "/unconverged/%06d", p);
      saved = cat("; its iteration history and last iterate are saved in ", output, ", group ",
                  group, " (not a result)");
    }
    const std::string msg = cat(unbalanced     ? "not in equilibrium at step "
                                : inadmissible ? "inadmissible state at step "
                                               : "diverged at step ",
                                p, " (t = ", p * problem.time.dt, " s): ", report.status,
                                "; last residuals r_G = ", last.r_G, ", r_B = ", last.r_B,
                                ". Nothing was written as a result for this step", saved);
    // A discretization of some cells (a rank's) sums its measures over the ranks: every rank
    // computes the step's data, and makes the fields rank 0 asks for until it has saved
    // (StepFields::written; a failed save fails every rank alike).
    if (!saved.empty() || solver.discretization().partial()) {
      StepFields fields(solver, *step.state);
      const StepData data = step_data(solver, step, &fields);
      const std::string failure = fields.written([&] {
        if (saved.empty()) return;
        if (!file) create_file(fields);
        file->save_unconverged(data, msg);
      });
      if (!failure.empty()) throw Error(failure);
    } else if (file)
      file->set_status(msg);
    // Every rank of a distributed solver reaches this divergence together and waits here until
    // rank 0 has saved (with the replicated factor, whose fields rank 0 makes alone), for ltl_run
    // ends them all (MPI_Abort) as soon as one of them throws.
    if (solver.distributed()) mpi::barrier();
    throw Error(cat(
        problem.name, ": ", msg, file && p > 1 ? cat("; ", output, " keeps steps 1..", p - 1) : "",
        ".",
        unbalanced || inadmissible ? "" : divergence_hint(problem, solver.load_factor(), step)));
  }
  // Collective with a partial discretization: every rank computes the measures, and makes the
  // fields rank 0 asks for while it writes (StepFields::written); a failed write fails every rank
  // with rank 0's message.
  StepFields fields(solver, *step.state);
  std::optional<StepData> data;
  if (solver.discretization().partial()) data = step_data(solver, step, &fields);
  const std::string failure = fields.written([&] {
    if (output.empty()) return;
    const bool existed = file.has_value();
    try {
      if (!file) create_file(fields);
      if (!data) data = step_data(solver, step, &fields);
      file->append(*data, p == P ? "complete" : "running");
    } catch (const Error& e) {
      // A write that fails (a full disk) keeps the previous file whole; its status must not say
      // "running" for ever: it is rewritten (same size as the file kept) when there is room.
      if (!existed) throw;
      const std::string why = cat("failed to write step ", p, ": ", e.what());
      try {
        file->set_status(why);
      } catch (const Error&) {
        throw Error(cat(e.what(), "; ", output, " keeps steps 1..", p - 1,
                        ", but its stored status could not be updated either (it still says "
                        "'running'): free some space, then continue with --resume"));
      }
      throw Error(cat(e.what(), "; ", output, " keeps steps 1..", p - 1,
                      " (status: failed to write step ", p,
                      "); free some space, then continue with --resume"));
    }
  });
  if (!failure.empty()) throw Error(failure);
  summary_.iterations.push_back(report.iterations);
  summary_.substeps.push_back(step.substeps);
  summary_.last_step = p;
}

namespace {
/// Reads the pseudo-field `name` of the mesh (StepFields::kMeshX, kMeshCells), rows x cols, from
/// the ranks when the file is made, by blocks of 16 384 rows as the writer reads a step field
/// (results_layout.cpp), into `to` (resized; Eigen::MatrixXd or, cast, Eigen::MatrixXi): no
/// whole array of doubles for the connectivity.
template <class Matrix>
void mesh_from_ranks(FieldSource& fields, const char* name, Eigen::Index rows, Eigen::Index cols,
                     Matrix& to) {
  constexpr Eigen::Index kRowsPerBlock = 16384;
  const auto [n, c] = fields.open(name);
  if (n != rows || c != cols)
    throw Error(cat("internal: the mesh's ", name, " read from the ranks is ", n, " x ", c,
                    ", not ", rows, " x ", cols));
  to.resize(rows, cols);
  Eigen::MatrixXd block;
  for (Eigen::Index first = 0; first < rows; first += kRowsPerBlock) {
    const Eigen::Index count = std::min(kRowsPerBlock, rows - first);
    fields.read(name, first, count, block);
    to.middleRows(first, count) = block.cast<typename Matrix::Scalar>();
  }
  fields.close(name);
}
}  // namespace

// The results file, created with the first step written (an existing file stays until then), or
// with the first iterate saved (a divergence, a checkpoint) when no file is at the output. Under
// mpirun the mesh's connectivity and positions, which the ranks release after their set-up
// (Discretization::release_mesh_cells, release_mesh_X), are read from their parts by blocks of
// cells (StepFields::kMeshCells) and of nodes (StepFields::kMeshX), into a copy of the mesh held
// while the file is made.
void ResultsWriter::create_file(FieldSource& fields) {
  const Problem& problem = problem_;
  std::optional<Mesh> whole;
  const bool no_cells = problem.mesh.cells.rows() == 0 && problem.mesh.num_cells() > 0,
             no_X = problem.mesh.X.rows() == 0 && problem.mesh.num_nodes() > 0;
  if (no_cells || no_X) whole = problem.mesh;  // the boundary parts, and what was kept
  if (no_X)
    mesh_from_ranks(fields, StepFields::kMeshX, problem.mesh.num_nodes(), problem.mesh.dim,
                    whole->X);
  if (no_cells)
    mesh_from_ranks(fields, StepFields::kMeshCells, problem.mesh.num_cells(),
                    problem.mesh.nodes_per_cell(), whole->cells);
  if (whole) {  // whole again: its fingerprint made from what was read
    whole->released_cells = whole->released_nodes = 0;
    whole->released_fingerprint.clear();
  }
  const Mesh& mesh = whole ? *whole : problem.mesh;
  RunInfo info{problem.name, problem.config_text, resolved_configuration(problem),
               problem.config_path, library_versions()};
  for (const auto& [key, value] : ids_) info.attributes[key] = value;
  info.attributes["code_version"] = code_version();
  info.attributes["git_version"] = git_version();
  if (!options_.init.empty()) info.attributes["initial_from"] = options_.init;
  ResultsOptions options;
  options.commit = false;
  // Every cell's volume: the discretization's, or on a rank's cells (which it holds alone)
  // ResultsFile::create's cell_volumes(mesh).
  if (!solver_.discretization().partial())
    options.cell_volume = solver_.discretization().cells().vol;
  std::vector<std::string> groups;  // one per obstacle
  for (const ContactCondition& cc : problem.contacts) groups.push_back(cc.group);
  Mesh::Boundary facets;  // several obstacles: their facets, one after the other
  options.contact = contact_output(mesh, groups, solver_.discretization().points(), facets);
  file_->results = ResultsFile::create(options_.output, mesh, info, options);
}

void ResultsWriter::checkpoint(int p, double load_factor, const State& iterate, int iterations) {
  // Under mpirun with the iterate on the ranks' rows (Solver::iterate_to_writer) every rank comes
  // here: rank 0 writes, reading E and lambda a block of cells at a time, and the other ranks
  // serve those blocks (StepFields::written), so that no rank holds a whole E or lambda. The
  // state's fields alone: a checkpoint is no result. A failed save (a full disk) is a warning
  // (save_checkpoint); anything else thrown while saving ends the run on every rank with rank
  // 0's message.
  StepFields fields(solver_, iterate, StepFields::Fields::State);
  const std::string failure =
      fields.written([&] { save_checkpoint(p, load_factor, iterate, iterations, fields); });
  if (!failure.empty()) throw Error(failure);
}

void ResultsWriter::save_checkpoint(int p, double load_factor, const State& iterate, int iterations,
                                    FieldSource& fields) {
  const std::string& out = options_.output;
  std::optional<ResultsFile>& file = file_->results;
  if (out.empty() || checkpoint_refused_) return;
  const int verbosity = options_.verbosity;
  if (!file && fs::exists(out)) {  // an earlier run's file: replaced by this run's first step only
    checkpoint_refused_ = true;
    if (verbosity > 0)
      std::printf(
          "%s: --checkpoint: not saved: %s holds an earlier run's results, which this run "
          "replaces only when its first step is complete; remove it or choose another -o "
          "to have checkpoints before then\n",
          problem_.name.c_str(), out.c_str());
    return;
  }
  const auto t0 = std::chrono::steady_clock::now();
  StepReport report;  // the equilibrium measure is not evaluated for a checkpoint: NaN
  report.force_residual = report.det_error = report.penetration =
      std::numeric_limits<double>::quiet_NaN();
  report.iterations = iterations;
  report.status = cat("checkpoint after ", iterations, " iterations, at load factor ", load_factor,
                      ": still iterating");
  StepData data;
  data.p = p;
  data.t = p * problem_.time.dt;
  data.state = &iterate;
  data.report = &report;
  data.source = &fields;
  char group[32];
  std::snprintf(group, sizeof group, "/unconverged/%06d", p);
  try {
    if (!file) create_file(fields);
    file->save_checkpoint(
        data, load_factor,
        cat("running: step ", p, " in progress; its iterate after ", iterations,
            " iterations is saved as ", group,
            " (a checkpoint, not a result): --resume continues the step from it"));
  } catch (const Error& e) {  // a full disk: the run goes on without this checkpoint
    if (verbosity > 0)
      std::printf("%s: --checkpoint: step %d, iteration %d not saved (%s); the run goes on\n",
                  problem_.name.c_str(), p, iterations, e.what());
    return;
  }
  saved_step_ = p;
  saved_iterations_ = iterations;
  if (verbosity > 0)
    std::printf("  checkpoint: step %d after %d iterations saved in %s %s (%.2f s)\n", p,
                iterations, out.c_str(), group,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  std::fflush(stdout);
}

void ResultsWriter::interrupted(int p, int signal) {
  // Under mpirun every rank stops here at the same iteration (run_signal): rank 0, the writer,
  // says what was kept; the others' Interrupted is silent (an empty message).
  if (solver_.cell_partition() && mpi::rank() != 0) throw Interrupted(signal, "");
  std::optional<ResultsFile>& file = file_->results;
  const std::string& out = options_.output;
  std::string kept = out.empty()       ? "nothing was to be written"
                     : fs::exists(out) ? cat("no step was written; ", out, " is unchanged")
                                       : cat("no step was written (no ", out, ")");
  // A checkpoint of step p saved by this run (--checkpoint): --resume continues from it.
  const std::string saved =
      saved_step_ == p
          ? cat("; step ", p, "'s iterate after ", saved_iterations_,
                " iterations is saved (a checkpoint): --resume continues the step from it")
          : "";
  if (file) {
    kept =
        cat(out, p > 1 ? cat(" keeps steps 1..", p - 1) : std::string(" holds no completed step"),
            " (status 'interrupted ...'); continue the run with --resume", saved);
    try {
      file->set_status(
          cat("interrupted by ", signal_name(signal), " during step ", p, "; ",
              p > 1 ? cat("steps 1..", p - 1, " are complete") : std::string("no step is complete"),
              " (continue with --resume)", saved));
    } catch (const Error& e) {
      kept = cat(out, " keeps steps 1..", p - 1, " (its status could not be updated: ", e.what(),
                 "); continue with --resume");
    }
  }
  throw Interrupted(signal, cat(problem_.name, ": interrupted by ", signal_name(signal),
                                " during step ", p, " (t = ", p * problem_.time.dt, " s); ", kept));
}

RunSummary ResultsWriter::finish(State last) {
  std::optional<ResultsFile>& file = file_->results;
  const int P = problem_.time.steps, last_done = summary_.last_step;
  if (file && last_done != P) file->set_status(cat("stopped after step ", last_done));
  if (file && options_.resume && last_done == first_ - 1 && last_done == P)
    file->set_status("complete");
  summary_.state = std::move(last);
  return std::move(summary_);
}

RunSummary run(Solver& solver, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step) {
  InterruptScope interrupts;  // Ctrl-C, SIGTERM: a clean stop (lib/interrupt.hpp)
  ResultsWriter results(solver, options);
  State state = results.start_state();
  const RunClock clock{std::chrono::steady_clock::now(), results.next_step(), results.last_step()};
  StepCheckpoints checkpoints;  // --checkpoint, and the one --resume continues from
  checkpoints.every = options.checkpoint_seconds;
  checkpoints.save = [&results](int p, double f, const State& s, int n) {
    results.checkpoint(p, f, s, n);
  };
  for (int p = results.next_step(); p <= results.last_step(); ++p) {  // (2.1)
    TimeStep step;
    checkpoints.resume = p == results.next_step() ? results.resume_iterate() : nullptr;
    checkpoints.resume_iterations = results.resume_iterations();
    try {
      check_interrupt(run_signal(solver));
      step = solve_time_step(solver, p, state, options.verbosity, &clock, &checkpoints);
    } catch (const Interrupted& i) {
      results.interrupted(p, i.signal());
    }
    results.append(step);
    if (on_step) on_step(solver, p, state);
  }
  RunSummary summary = results.finish(std::move(state));  // the state's one copy
  const Problem& problem = solver.problem();
  // The peak resident memory (VmHWM) of the process; of a distributed solver the smallest and
  // the largest over the ranks (collective: every rank of it gets here).
  const bool ranks = solver.cell_partition() != nullptr;
  std::uint64_t lo = static_cast<std::uint64_t>(mpi::peak_resident_bytes()), hi = lo;
  if (ranks) mpi::min_max(lo, lo, hi);
  summary.peak_memory_min = static_cast<double>(lo);
  summary.peak_memory_max = static_cast<double>(hi);
  // Of it, the pages of the executable's and the libraries' files (RssFile now, the largest over
  // the ranks): their code, which a node keeps once for all its ranks (paper_notes/mpi.md,
  // "What the resident size is made of").
  double code = mpi::resident_split().file;
  if (ranks) mpi::max(&code, 1);
  const std::string of_it = code > 0 ? cat(" (", ranks ? "up to " : "", std::lround(code / 1e6),
                                           " MB of it the libraries' code",
                                           ranks ? ", shared by a node's ranks" : "", ")")
                                     : std::string();
  const std::string memory =
      hi == 0 ? std::string()
      : ranks ? cat(", peak memory per rank ", std::lround(lo / 1e6), "-", std::lround(hi / 1e6),
                    " MB over ", mpi::size(), " ranks", of_it)
              : cat(", peak memory ", std::lround(hi / 1e6), " MB", of_it);
  if (options.verbosity > 0 && summary.last_step < summary.first_step)  // a finished run resumed
    std::printf(
        "%s: nothing to do: %s already holds steps 1..%d (time.steps = %d; raise it to "
        "extend the run)\n",
        problem.name.c_str(), options.output.c_str(), summary.last_step, problem.time.steps);
  else if (options.verbosity > 0)
    std::printf("%s: steps %d..%d, setup %.3f s, solver %.3f s%s, wrote %s\n", problem.name.c_str(),
                summary.first_step, summary.last_step, summary.setup_seconds,
                summary.solver_seconds, memory.c_str(), options.output.c_str());
  if (const NewtonSolveStats& st = newton_solve_stats(); options.verbosity > 0 && st.krylov_solves)
    std::printf(
        "%s: Newton's Krylov solves (newton_krylov.hpp): %ld, GMRES iterations %.1f per solve "
        "(at most %ld), %ld not converged; assembly and AMG set-up %.1f s, GMRES %.1f s\n",
        problem.name.c_str(), st.krylov_solves,
        static_cast<double>(st.krylov_iterations) / st.krylov_solves, st.krylov_max_iterations,
        st.krylov_failures, st.krylov_setup_s, st.krylov_solve_s);
  if (options.verbosity > 0 && summary.failed_attempts > 0) {
    std::string which;
    for (std::size_t k = 0; k < summary.substeps.size(); ++k)
      if (summary.substeps[k] > 1)
        which += cat(which.empty() ? "" : ", ", summary.first_step + static_cast<int>(k), " (",
                     summary.substeps[k], " substeps)");
    std::printf("%s: load subdivision: %d failed attempt(s) retried; steps done in substeps: %s\n",
                problem.name.c_str(), summary.failed_attempts, which.c_str());
  }
  return summary;
}

RunSummary run(const Problem& problem, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step) {
  Solver solver(problem);  // bad input and failed factorizations throw here: no file is written
  return run(solver, options, on_step);
}

}  // namespace ltl
