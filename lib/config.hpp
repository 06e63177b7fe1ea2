// The configuration layer: reading a problem from a human-readable configuration file (TOML, via
// toml++), with units, and writing a problem back as its resolved configuration. Every key is one
// row of the schema (config_schema.hpp, lib/config_schema.cpp): adding a key is adding a row
// there, and the reader, --set, the resolved configuration and the key table of
// experiments/README.md follow.
//
// Every physical value is either a plain number (SI) or a string "<number> <unit>", e.g.
// C1 = "187.5 kPa", dt = "5 s", kappa = "1e9 Pa/m". Units are checked against the quantity the
// key expects. Unknown keys, missing values, wrong units and out-of-range values are errors that
// name the file, the line and the key. See experiments/README.md for every key.
#pragma once

#include <string>
#include <vector>

#include "problem.hpp"

namespace ltl {

/// Reads `path` (relative file names inside it are relative to its folder), applies the
/// overrides ("algorithm.R=4", "time.steps=3", "mesh.parameters.nx=56": a dotted key and a TOML
/// value), loads the mesh with gmsh and validates the problem.
Problem load_problem(const std::string& path, const std::vector<std::string>& overrides = {});

/// The resolved configuration of a problem as TOML text: every key of the schema with its value
/// in SI (units in comments), every default filled in. Written into results files as the root
/// attribute config_resolved beside the text as given; load_problem reads it back into the same
/// problem (the same run, bit for bit).
std::string resolved_configuration(const Problem& problem);

/// Converts "<number> <unit>" to SI for a quantity of canonical unit `si` ("Pa", "Pa/m", "m",
/// "J/m^2", "1/m", "s", "1"); throws an Error naming `key` if the unit does not fit.
double parse_quantity(const std::string& text, const std::string& si, const std::string& key);

}  // namespace ltl
