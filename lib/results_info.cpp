// Small helpers of the results files (results_info.hpp).
#include "results_info.hpp"

#include <cholmod.h>
#include <gmsh.h>
#include <hdf5.h>

#include <Eigen/Core>
#include <cstdio>
#include <cstdlib>

#include "error.hpp"

namespace ltl {

std::map<std::string, std::string> library_versions() {
  unsigned major = 0, minor = 0, release = 0;
  const bool hdf5 = H5get_libversion(&major, &minor, &release) >= 0;
  return {
      {"eigen", cat(EIGEN_WORLD_VERSION, '.', EIGEN_MAJOR_VERSION, '.', EIGEN_MINOR_VERSION)},
      {"cholmod", cat(CHOLMOD_MAIN_VERSION, '.', CHOLMOD_SUB_VERSION, '.', CHOLMOD_SUBSUB_VERSION)},
      {"hdf5", hdf5 ? cat(major, '.', minor, '.', release) : std::string(H5_VERSION)},
      {"gmsh", GMSH_API_VERSION},
  };
}

std::string shortest_number(double x) {
  char buf[40];
  for (int precision : {15, 16, 17}) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, x);
    if (std::strtod(buf, nullptr) == x) break;
  }
  return buf;
}

}  // namespace ltl
