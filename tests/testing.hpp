// Helpers shared by the tests: paths, and problems built in code.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "problem.hpp"

#ifndef LTL_TEST_DIR
#define LTL_TEST_DIR "tests"
#endif
#ifndef LTL_BINARY_DIR
#define LTL_BINARY_DIR "build"
#endif

namespace ltl::testing {

inline std::string test_path(const std::string& rel) {
  return std::string(LTL_TEST_DIR) + "/" + rel;
}
inline std::string source_path(const std::string& rel) {
  return std::string(LTL_TEST_DIR) + "/../" + rel;
}
inline std::string binary_path(const std::string& rel) {
  return std::string(LTL_BINARY_DIR) + "/" + rel;
}

/// A fresh temporary directory for one test.
inline std::filesystem::path temp_dir(const std::string& name) {
  auto dir = std::filesystem::temp_directory_path() /
             ("ltl_" + name + "_" + std::to_string(std::random_device{}()));
  std::filesystem::create_directories(dir);
  return dir;
}

inline void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

/// Default algorithm parameters for verification runs: tight tolerance.
inline AlgorithmParams tight(double Rq, double R = 1.0) {
  AlgorithmParams a;
  a.R = R;
  a.q = Rq / R;
  a.q_c = Rq / R;
  a.tol = 1e-12;
  a.max_iter = 20000;
  return a;
}

}  // namespace ltl::testing
