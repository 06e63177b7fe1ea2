// One scalar measure of a time step as the results file stores it (/steps/N/measures/<name>):
// the measures (lib/measures.hpp) and the admissibility check (lib/admissibility.hpp) produce
// them, the results writer (lib/results.hpp) writes them. A leaf, so that neither of the first
// two depends on the writer.
#pragma once

#include <string>

namespace ltl {

/// One scalar measure of a step (lib/measures.hpp: stored_measures), written as the scalar
/// dataset /steps/N/measures/<name> with its "unit" and "description" attributes.
struct StoredMeasure {
  std::string name;
  double value = 0;
  std::string unit, description;
};

}  // namespace ltl
