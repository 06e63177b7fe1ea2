#include "simulation.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>

#include "error.hpp"
#include "hash.hpp"
#include "measures.hpp"
#include "output_guard.hpp"
#include "results.hpp"
#include "version.hpp"

namespace ltl {

namespace {

namespace fs = std::filesystem;

/// What to change when a step does not converge: the parameters used, the rule of the defaults
/// (derive_algorithm_defaults) and the usual remedies.
std::string divergence_hint(const Problem& problem, double factor) {
  const AlgorithmParams& a = problem.algorithm;
  const Material& m = problem.material;
  const double C = m.C1 + (m.incompressible() ? m.C2 : 0.0);
  const int dim = problem.mesh.dim;
  return cat(
      " Parameters used: ", describe_algorithm(a), "; R q = ", a.R * a.q,
      " Pa = ", a.R * a.q / m.C1, " C1 (load factor ", factor,
      "). What to change: R q must be at least ",
      dim == 3 ? "4 C1 in 3-D" : "2.6 C1 in plane strain",
      " and larger under contact pressures or stresses above 2 C1: raise algorithm.R (x2); ",
      "leave R, q, q_c out to get the defaults q = 2 (C1 + C2) = ", 2 * C,
      " Pa, R q = ", dim == 3 ? 8 : 6,
      " (C1 + C2), q_c = q / h (2-D) or q / (3 h) (3-D), h the contact facet size, with glue "
      "at least kappa / R; a residual that ",
      "decreases slowly needs algorithm.max_iter or acceleration = \"anderson\"; a load too "
      "large for one step needs a load ramp ([load] ramp = \"linear\", ramp_time, more time.steps)"
      " (experiments/README.md, \"Choosing R, q, q_c\").");
}

/// What is written for a step: the state, its report (history, equilibrium measure) and the
/// stresses. Plane strain: the out-of-plane stress sigma33 from the law (F33 = 1) and the
/// mean stress -(sigma11 + sigma22 + sigma33) / 3.
StepData step_data(const Solver& solver, const TimeStep& step) {
  const Problem& problem = solver.problem();
  const State& state = *step.state;
  StepData d;
  d.p = step.p;
  d.t = step.p * problem.time.dt;
  d.state = &state;
  d.report = &step.report;
  d.P = solver.piola(state);
  d.sigma = solver.cauchy(state);
  d.pressure = solver.pressure(state);
  const int nc = problem.mesh.num_cells();
  if (problem.mesh.dim == 2 && state.E.rows() == 2 * nc) {
    d.sigma33.resize(nc);
    for (int c = 0; c < nc; ++c) {
      const Eigen::Matrix2d E = state.E.block<2, 2>(2 * c, 0).transpose();
      const Eigen::Matrix2d Pc = d.P.block<2, 2>(2 * c, 0).transpose();
      d.sigma33(c) = problem.material.plane_strain_sigma33(E, Pc);
      d.pressure(c) = -(d.sigma.block<2, 2>(2 * c, 0).trace() + d.sigma33(c)) / 3;
    }
  }
  d.contact_pressure = solver.contact_pressure(state);
  d.gap = solver.contact_gap(state);
  // Every measure of the step (lib/measures.hpp), one definition each.
  const StepMeasures m = step_measures(solver, state);
  d.measures = stored_measures(m, problem.mesh.dim);
  if (step.admissibility.h > 0)
    for (StoredMeasure& a : stored_measures(step.admissibility)) d.measures.push_back(a);
  d.in_contact = m.in_contact;
  return d;
}

}  // namespace

TimeStep solve_time_step(Solver& solver, int p, State& state, int verbosity) {
  const Problem& problem = solver.problem();
  const int P = problem.time.steps;
  solver.set_load_factor(problem.ramp.factor(p, problem.time.dt));  // LoadRamp
  const double load_scale = solver.external_load().cwiseAbs().maxCoeff();
  const Eigen::VectorXd beta_prev = state.beta;
  auto progress = [&](const IterationRecord& r) {
    // Long steps show progress: every 50 iterations of a static problem, every 2000 of a
    // time step of an evolution.
    if (verbosity >= 2 || (verbosity == 1 && r.n % (P == 1 ? 50 : 2000) == 0))
      std::printf("  it %5d  r_G %.3e  r_B %.3e  %.3f s\n", r.n, r.r_G, r.r_B, r.wall),
          std::fflush(stdout);
  };
  TimeStep step{p, solver.solve_step(state, beta_prev, progress), &state, {}};
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
  if (state.u.allFinite() && state.E.allFinite()) {
    step.admissibility = check_admissibility(solver.discretization(), state);
    report.det_min = step.admissibility.det_F_min;
    if (report.converged && !step.admissibility.admissible()) {
      report.converged = false;
      report.status = cat("inadmissible: converged (r_G + r_B < tol, in equilibrium) but ",
                          step.admissibility.message());
    }
  }
  if (!report.converged) return step;
  if (verbosity > 0 && (P > 1 || verbosity == 1))
    std::printf(
        "step %4d/%d  t = %8.2f s  %5d iterations  r_G %.2e  r_B %.2e  force residual %.1e  "
        "%.3f s%s%s%s\n",
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
            : "");
  std::fflush(stdout);
  return step;
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
      start_(solver.initial_state()) {
  const Problem& problem = problem_;
  summary_.setup_seconds = solver.setup_seconds();
  if (options.resume && options.output.empty()) throw Error("--resume needs a results file");
  if (!options.output.empty()) {
    check_output_path(problem, options.output);
    file_->lock.emplace(options.output);
  }
  int p0 = 1;
  if (options.resume) {
    const std::string& out = options.output;
    const ResumePoint resumed = resume_point(problem, out, ids_, start_);
    start_ = resumed.state;
    p0 = resumed.next_step;
    file_->results = ResultsFile::open(out);
    file_->results->set_status("running");
  }
  first_ = p0;
  const int P = problem.time.steps;
  last_ = options.stop_after > 0 && options.stop_after <= P - p0 ? p0 + options.stop_after - 1 : P;
  summary_.first_step = p0;
  summary_.last_step = p0 - 1;
  if (options.verbosity > 0)
    std::printf("%s: %d cells, %d nodes, %d contact points, %d factor(s), setup %.3f s\n",
                problem.name.c_str(), problem.mesh.num_cells(), problem.mesh.num_nodes(),
                solver.facets() ? solver.facets()->size() : 0, solver.global_step().num_factors(),
                solver.setup_seconds());
  if (options.verbosity > 0)
    std::printf("%s: algorithm %s\n", problem.name.c_str(),
                describe_algorithm(problem.algorithm).c_str());
}

ResultsWriter::~ResultsWriter() = default;

void ResultsWriter::append(const TimeStep& step) {
  const Problem& problem = problem_;
  const Solver& solver = solver_;
  const std::string& output = options_.output;
  std::optional<ResultsFile>& file = file_->results;
  const int p = step.p, P = problem.time.steps;
  const StepReport& report = step.report;
  // The results file, created with the first step written (an existing file stays until then).
  const auto create_file = [&] {
    RunInfo info{problem.name, problem.config_text, resolved_configuration(problem),
                 problem.config_path, library_versions()};
    for (const auto& [key, value] : ids_) info.attributes[key] = value;
    info.attributes["code_version"] = code_version();
    info.attributes["git_version"] = git_version();
    const Mesh::Boundary* cb =
        problem.contact ? &problem.mesh.boundary(problem.contact->group) : nullptr;
    const FacetOperators* points = solver.facets();
    return ResultsFile::create(output, problem.mesh, info, cb, points ? &points->centre : nullptr,
                               points ? &points->area : nullptr,
                               points && !points->nodes.empty() ? &points->nodes : nullptr, false,
                               &solver.cells().vol);
  };
  summary_.solver_seconds += report.history.empty() ? 0 : report.history.back().wall;
  if (!report.converged) {
    const auto& last = report.history.back();
    const bool unbalanced = report.status.rfind("converged by", 0) == 0;
    const bool inadmissible = report.status.rfind("inadmissible", 0) == 0;
    // A diverged step (NaN, blow-up, iteration cap) keeps its last iterate and history in the
    // results file as /unconverged/NNNNNN, never as a result, so that a user can plot why: in
    // the run's file, or in a new one when this run has none yet (not over another run's file).
    std::string saved;
    if (!unbalanced && !output.empty() && (file || !fs::exists(output))) {
      if (!file) file = create_file();
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
    if (!saved.empty())
      file->save_unconverged(step_data(solver, step), msg);
    else if (file)
      file->set_status(msg);
    throw Error(cat(
        problem.name, ": ", msg, file && p > 1 ? cat("; ", output, " keeps steps 1..", p - 1) : "",
        ".", unbalanced || inadmissible ? "" : divergence_hint(problem, solver.load_factor())));
  }
  if (!output.empty()) {
    if (!file) file = create_file();
    file->append(step_data(solver, step), p == P ? "complete" : "running");
  }
  summary_.iterations.push_back(report.iterations);
  summary_.last_step = p;
}

RunSummary ResultsWriter::finish(const State& last) {
  std::optional<ResultsFile>& file = file_->results;
  const int P = problem_.time.steps, last_done = summary_.last_step;
  if (file && last_done != P) file->set_status(cat("stopped after step ", last_done));
  if (file && options_.resume && last_done == first_ - 1 && last_done == P)
    file->set_status("complete");
  summary_.state = last;
  return summary_;
}

RunSummary run(Solver& solver, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step) {
  ResultsWriter results(solver, options);
  State state = results.start_state();
  for (int p = results.next_step(); p <= results.last_step(); ++p) {  // (2.1)
    results.append(solve_time_step(solver, p, state, options.verbosity));
    if (on_step) on_step(solver, p, state);
  }
  const RunSummary summary = results.finish(state);
  const Problem& problem = solver.problem();
  if (options.verbosity > 0 && summary.last_step < summary.first_step)  // a finished run resumed
    std::printf(
        "%s: nothing to do: %s already holds steps 1..%d (time.steps = %d; raise it to "
        "extend the run)\n",
        problem.name.c_str(), options.output.c_str(), summary.last_step, problem.time.steps);
  else if (options.verbosity > 0)
    std::printf("%s: steps %d..%d, setup %.3f s, solver %.3f s, wrote %s\n", problem.name.c_str(),
                summary.first_step, summary.last_step, summary.setup_seconds,
                summary.solver_seconds, options.output.c_str());
  return summary;
}

RunSummary run(const Problem& problem, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step) {
  Solver solver(problem);  // bad input and failed factorizations throw here: no file is written
  return run(solver, options, on_step);
}

}  // namespace ltl
