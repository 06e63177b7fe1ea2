// ltl_run: solve your own problem from a configuration file and write the results (HDF5 +
// XDMF for ParaView). The figure drivers run the same recipe with the paper's configurations
// and then print their figure's numbers.
//
//   build/experiments/ltl_run CONFIG.toml [-o RESULTS.h5] [--set key=value]... [--resume]
//                             [--stop-after N] [-v | -q]
//
// Every configuration key is described in experiments/README.md.
#include "cli.hpp"

// The recipe (lib/cli.hpp, lib/simulation.hpp): load -> discretize and precompute -> solve the
// time steps, each written as soon as it converges.
static void solve_and_report(const ltl::CommandLine& cmd) {
  const ltl::Problem problem = ltl::load_problem(cmd);  // the configuration, validated
  ltl::Solver solver{ltl::Discretization(problem)};     // discretize; K factorized once (4.5)
  ltl::run(solver, ltl::run_options(cmd, problem));     // (2.1): ALG2 per step, written at once
}

// Errors: one line on stderr, exit status 1; bad usage: 2.
int main(int argc, char** argv) {
  return ltl::guarded_main(argc, argv, "ltl_run", "", solve_and_report);
}
