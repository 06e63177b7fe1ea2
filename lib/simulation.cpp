#include "simulation.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "error.hpp"
#include "results.hpp"

namespace ltl {

RunSummary run(const Problem& problem, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step) {
  using clock = std::chrono::steady_clock;
  RunSummary summary;
  const auto t0 = clock::now();
  Solver solver(problem);  // bad input and failed factorizations throw here: no file is written
  summary.setup_seconds = std::chrono::duration<double>(clock::now() - t0).count();

  State state = solver.initial_state();
  int p0 = 1;
  std::optional<ResultsFile> file;
  if (options.resume) {
    if (options.output.empty()) throw Error("--resume needs a results file");
    const std::string stored = ResultsFile::read_attribute(options.output, "config");
    if (stored != problem.config_text)
      throw Error(cat(options.output,
                      ": cannot resume: the file was written with a different "
                      "configuration"));
    if (auto last = ResultsFile::read_last_step(options.output)) {
      state = last->state;
      p0 = last->p + 1;
    }
    file = ResultsFile::open(options.output);
    file->set_status("running");
  } else if (!options.output.empty()) {
    std::filesystem::remove(options.output);  // a stale file must not pass for this run's
  }
  summary.first_step = p0;
  if (options.verbosity > 0)
    std::printf("%s: %d cells, %d nodes, %d contact points, %d factor(s), setup %.3f s\n",
                problem.name.c_str(), problem.mesh.num_cells(), problem.mesh.num_nodes(),
                solver.facets() ? solver.facets()->size() : 0, solver.global_step().num_factors(),
                summary.setup_seconds);

  const int P = problem.time.steps;
  int last_done = p0 - 1;
  for (int p = p0; p <= P; ++p) {
    if (options.stop_after > 0 && p - p0 >= options.stop_after) break;
    const Eigen::VectorXd beta_prev = state.beta;
    auto progress = [&](const IterationRecord& r) {
      // Long steps show progress: every 50 iterations of a static problem, every 2000 of a
      // time step of an evolution.
      if (options.verbosity >= 2 || (options.verbosity == 1 && r.n % (P == 1 ? 50 : 2000) == 0))
        std::printf("  it %5d  r_G %.3e  r_B %.3e  %.3f s\n", r.n, r.r_G, r.r_B, r.wall),
            std::fflush(stdout);
    };
    const StepReport report = solver.solve_step(state, beta_prev, progress);
    summary.solver_seconds += report.history.empty() ? 0 : report.history.back().wall;
    if (!report.converged) {
      const auto& last = report.history.back();
      const std::string msg = cat("diverged at step ", p, " (t = ", p * problem.time.dt,
                                  " s): ", report.status, "; last residuals r_G = ", last.r_G,
                                  ", r_B = ", last.r_B, ". Nothing was written for this step");
      if (file) file->set_status(msg);
      throw Error(cat(problem.name, ": ", msg,
                      file ? cat("; ", options.output, " keeps steps 1..", p - 1) : "", "."));
    }
    if (options.verbosity > 0 && (P > 1 || options.verbosity == 1))
      std::printf(
          "step %4d/%d  t = %8.2f s  %5d iterations  r_G %.2e  r_B %.2e  force residual %.1e  "
          "%.3f s%s%s\n",
          p, P, p * problem.time.dt, report.iterations, report.history.back().r_G,
          report.history.back().r_B, report.force_residual, report.history.back().wall,
          report.strain_failures
              ? cat("  (", report.strain_failures, " local strain solves not at round-off)").c_str()
              : "",
          report.accepted + report.rejected
              ? cat("  Anderson ", report.accepted, " kept / ", report.rejected, " rejected")
                    .c_str()
              : "");
    std::fflush(stdout);
    if (!options.output.empty()) {
      if (!file) {
        RunInfo info{problem.name, problem.config_text, problem.config_path, library_versions()};
        info.attributes["code_version"] = LTL_VERSION;
        info.attributes["git_version"] = LTL_GIT_VERSION;
        const Mesh::Boundary* cb =
            problem.contact ? &problem.mesh.boundary(problem.contact->group) : nullptr;
        file = ResultsFile::create(
            options.output, problem.mesh, info, cb,
            solver.facets() ? &solver.facets()->centre : nullptr,
            solver.facets() ? &solver.facets()->area : nullptr,
            solver.facets() && !solver.facets()->nodes.empty() ? &solver.facets()->nodes : nullptr);
      }
      StepData d;
      d.p = p;
      d.t = p * problem.time.dt;
      d.state = &state;
      d.report = &report;
      d.P = solver.piola(state);
      d.sigma = solver.cauchy(state);
      d.pressure = solver.pressure(state);
      d.contact_pressure = solver.contact_pressure(state);
      d.gap = solver.contact_gap(state);
      file->append(d);
    }
    summary.iterations.push_back(report.iterations);
    last_done = p;
    if (on_step) on_step(solver, p, state);
  }
  summary.last_step = last_done;
  if (file) file->set_status(last_done == P ? "complete" : cat("stopped after step ", last_done));
  summary.state = state;
  return summary;
}

}  // namespace ltl
