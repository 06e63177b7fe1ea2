#include "cli.hpp"

#include <cstdio>
#include <filesystem>
#include <vector>

#include "config.hpp"
#include "error.hpp"

namespace ltl {

namespace {
void usage(const Command& c) {
  std::fprintf(stderr,
               "usage: %s %s [-o RESULTS.h5] [--set key=value]... [--resume] [--stop-after N]"
               " [-v | -q]\n"
               "  -o FILE         results file (default: results/<name>.h5)\n"
               "  --set key=value override a configuration value, e.g. --set algorithm.R=4\n"
               "  --resume        continue from the last step stored in the results file\n"
               "  --stop-after N  compute N more steps and stop (the file can be resumed)\n"
               "  -v / -q         print every iteration / print nothing\n",
               c.program.c_str(), c.default_config.empty() ? "CONFIG.toml" : "[CONFIG.toml]");
}
}  // namespace

int cli_main(int argc, char** argv, const Command& command) {
  std::string config, output;
  std::vector<std::string> overrides;
  RunOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool has_value = i + 1 < argc;
    if ((a == "-o" || a == "--set" || a == "--stop-after") && !has_value) {
      std::fprintf(stderr, "%s: %s needs a value\n", command.program.c_str(), a.c_str());
      return 2;
    }
    if (a == "-o") {
      output = argv[++i];
    } else if (a == "--set") {
      overrides.push_back(argv[++i]);
    } else if (a == "--resume") {
      options.resume = true;
    } else if (a == "--stop-after") {
      try {
        options.stop_after = std::stoi(argv[++i]);
      } catch (const std::exception&) {
        std::fprintf(stderr, "%s: --stop-after needs a whole number\n", command.program.c_str());
        return 2;
      }
    } else if (a == "-v") {
      options.verbosity = 2;
    } else if (a == "-q") {
      options.verbosity = 0;
    } else if (a == "-h" || a == "--help") {
      usage(command);
      return 0;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "%s: unknown option '%s'\n", command.program.c_str(), a.c_str());
      usage(command);
      return 2;
    } else if (config.empty()) {
      config = a;
    } else {
      usage(command);
      return 2;
    }
  }
  if (config.empty()) config = command.default_config;
  if (config.empty()) {
    usage(command);
    return 2;
  }
  try {
    const Problem problem = load_problem(config, overrides);
    options.output = output.empty() ? "results/" + problem.name + ".h5" : output;
    const auto dir = std::filesystem::path(options.output).parent_path();
    if (!dir.empty()) std::filesystem::create_directories(dir);
    const RunSummary s = run(problem, options);
    if (options.verbosity > 0)
      std::printf("%s: steps %d..%d, setup %.3f s, solver %.3f s, wrote %s\n", problem.name.c_str(),
                  s.first_step, s.last_step, s.setup_seconds, s.solver_seconds,
                  options.output.c_str());
    if (command.report) command.report(problem, s);
  } catch (const Error& e) {
    std::fprintf(stderr, "%s: error: %s\n", command.program.c_str(), e.what());
    return 1;
  }
  return 0;
}

}  // namespace ltl
