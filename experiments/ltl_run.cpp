// ltl_run: solve your own problem from a configuration file and write the results (HDF5 +
// XDMF for ParaView). The figure drivers run the same recipe with the paper's configurations
// and then print their figure's numbers.
//
//   build/experiments/ltl_run CONFIG.toml [-o RESULTS.h5] [--set key=value]... [--resume]
//                             [--stop-after N] [-v | -q]
//
// Every configuration key is described in experiments/README.md.
#include <utility>

#include "cli.hpp"

// The recipe (lib/cli.hpp, lib/simulation.hpp): load -> discretize -> solve the time steps,
// each written as soon as it converges -> summary.
static void solve_and_report(const ltl::CommandLine& cmd) {
  const ltl::Problem problem = ltl::load_problem(cmd);             // the configuration, validated
  const ltl::RunOptions options = ltl::run_options(cmd, problem);  // -o or results/<name>.h5
  const ltl::Stopwatch setup;
  ltl::Discretization discrete(problem);    // cells, contact points, Dirichlet data, loads
  ltl::Solver solver(std::move(discrete));  // ALG2's precompute: K with R q factorized once (4.5)
  ltl::ResultsWriter results(solver, options, setup.seconds());  // locked; --resume, --stop-after
  ltl::State s = results.start_state();  // the initial state, or the file's last step
  for (int p = results.next_step(); p <= results.last_step(); ++p)          // (2.1) time steps
    results.append(ltl::solve_time_step(solver, p, s, options.verbosity));  // ALG2 (4.1)-(4.4)
  ltl::print_summary(problem, options, results.finish(s));
}

// Errors: one line on stderr, exit status 1; bad usage: 2.
int main(int argc, char** argv) {
  return ltl::guarded_main(argc, argv, "ltl_run", "", solve_and_report);
}
