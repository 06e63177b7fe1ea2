// Small helpers of the results files: the versions of the libraries in use, and numbers as text.
#pragma once

#include <map>
#include <string>

namespace ltl {

/// Versions of the libraries in use, as attributes: keys "eigen", "cholmod" (compile time),
/// "hdf5" (run time), "gmsh" (compile time), values like "3.4.0".
std::map<std::string, std::string> library_versions();

/// The shortest of %.15g, %.16g, %.17g that reads back as x.
std::string shortest_number(double x);

}  // namespace ltl
