// The resolved configuration of a problem, written into every results file (root attribute
// config_resolved).
#pragma once

#include <string>

#include "problem.hpp"

namespace ltl {

/// The resolved configuration of a problem as TOML text: every value in SI (units in
/// comments), every default filled in, in the sections of the configuration file. Written into
/// results files as the root attribute config_resolved beside the text as given.
std::string resolved_configuration(const Problem& problem);

}  // namespace ltl
