// ltl_run: solve your own problem from a configuration file and write the results (HDF5 +
// XDMF for ParaView). The figure drivers are the same program with the paper's configurations.
//
//   build/experiments/ltl_run CONFIG.toml [-o RESULTS.h5] [--set key=value]... [--resume]
//                             [--stop-after N] [-v | -q]
//
// Every configuration key is described in experiments/README.md.
#include "cli.hpp"

int main(int argc, char** argv) {
  return ltl::cli_main(argc, argv, {"ltl_run", "", {}});
}
