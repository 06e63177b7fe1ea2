// The time loop (2.1): one ALG2 solve per time step, each converged step appended to the
// results file as soon as it is done.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "alg2.hpp"
#include "problem.hpp"

namespace ltl {

struct RunOptions {
  std::string output;   ///< results file (.h5); empty: write nothing
  bool resume = false;  ///< continue from the last step stored in `output`
  int verbosity = 1;    ///< 0: silent, 1: one line per step (and per 50 iterations), 2: every
                        ///< iteration
  int stop_after = 0;   ///< stop (as if interrupted) after this many steps; 0: run to the end
};

struct RunSummary {
  int first_step = 1, last_step = 0;  ///< steps computed by this run
  std::vector<int> iterations;        ///< per computed step
  double solver_seconds = 0;          ///< time in the iterations (not setup or output)
  double setup_seconds = 0;           ///< discretization, assembly and factorization
  State state;                        ///< the last converged state
};

/// [LTL87 (2.1)-(2.2)] Backward Euler in beta: for p = 1..P, start from step p-1's
/// {E, e, beta, lambda, lambda_c}, keep beta_{p-1} for the dissipation, iterate to
/// convergence. A step that does not converge ends the run with an Error (nothing is written
/// for that step; an existing results file is marked "diverged at step p").
/// `on_step` (optional) sees every converged step.
RunSummary run(const Problem& problem, const RunOptions& options,
               const std::function<void(const Solver&, int, const State&)>& on_step = {});

}  // namespace ltl
