// The command line shared by the generic runner (ltl_run) and the figure drivers:
//
//   PROGRAM [CONFIG.toml] [-o RESULTS.h5] [--set key=value]... [--resume] [--stop-after N]
//           [-v | -q]
//
// Exit status: 0 when every time step converged, 1 on any error (bad input, failed
// factorization, divergence), 2 on bad command-line usage.
#pragma once

#include <functional>
#include <string>

#include "simulation.hpp"

namespace ltl {

struct Command {
  std::string program;         ///< name in messages
  std::string default_config;  ///< used when no CONFIG is given (empty: CONFIG is required)
  /// Called once after a successful run (e.g. to print the numbers of a figure).
  std::function<void(const Problem&, const RunSummary&)> report;
};

int cli_main(int argc, char** argv, const Command& command);

}  // namespace ltl
