// Loads as users pose them (lib/reactions.hpp, experiments/README.md "Configuration keys"):
//   - a prescribed displacement ([[fixed]] with a per-component value) ramped by [load] ramp,
//     against the closed form of a homogeneous plane-strain stretch of an incompressible
//     Mooney-Rivlin block [LTL87 (1.5)]: the reaction per metre of depth is the nominal stress
//     P11 = 2 (C1 + C2) (lambda - lambda^-3) times the height, lambda = 1 + factor x delta / a;
//   - the same with ALG2 alone and with the Newton phase: the same state;
//   - the reactions of a bar under a ramped traction balance the applied load [LTL87 (1.2)]:
//     sum of the reactions = -(traction x face length x load factor) at every step;
//   - the load factor and the reactions stored with every step.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "config.hpp"
#include "error.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

using namespace ltl;
namespace fs = std::filesystem;

namespace {

/// Dataset `name` of step p of a results file (an absolute `name` as it is), row-major, with
/// its shape.
struct Array {
  std::vector<double> data;
  std::vector<hsize_t> dims;
  double at(int i, int j) const { return data.at(i * dims.at(1) + j); }
};
Array read_array(const std::string& file, int p, const std::string& name) {
  char path[96];
  if (name[0] == '/')
    std::snprintf(path, sizeof path, "%s", name.c_str());
  else
    std::snprintf(path, sizeof path, "/steps/%06d/%s", p, name.c_str());
  Array a;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return a;
  if (H5Lexists(f, path, H5P_DEFAULT) > 0) {
    const hid_t d = H5Dopen2(f, path, H5P_DEFAULT);
    const hid_t s = H5Dget_space(d);
    a.dims.resize(H5Sget_simple_extent_ndims(s));
    H5Sget_simple_extent_dims(s, a.dims.data(), nullptr);
    a.data.resize(H5Sget_simple_extent_npoints(s));
    H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.data.data());
    H5Sclose(s);
    H5Dclose(d);
  }
  H5Fclose(f);
  return a;
}

/// The string attribute `conditions` of step p ("" if absent).
std::string conditions_of(const std::string& file, int p) {
  char path[32];
  std::snprintf(path, sizeof path, "/steps/%06d", p);
  std::string value;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (H5Aexists_by_name(f, path, "conditions", H5P_DEFAULT) > 0) {
    const hid_t a = H5Aopen_by_name(f, path, "conditions", H5P_DEFAULT, H5P_DEFAULT);
    const hid_t t = H5Aget_type(a);
    char* buffer = nullptr;
    if (H5Tis_variable_str(t) > 0 && H5Aread(a, t, &buffer) >= 0 && buffer) value = buffer;
    if (buffer) H5free_memory(buffer);
    H5Tclose(t);
    H5Aclose(a);
  }
  H5Fclose(f);
  return value;
}

/// The measure `name` of step p.
double measure_of(const std::string& file, int p, const std::string& name) {
  const Array a = read_array(file, p, "measures/" + name);
  return a.data.empty() ? std::nan("") : a.data[0];
}

/// A square block [0, a]^2 (a = 0.1 m, tests/geometry/square.geo) with the given boundary
/// conditions and loads.
std::string block_config(const std::string& body) {
  return "name = \"loads\"\n[mesh]\ngeometry = \"" +
         ltl::testing::test_path("geometry/square.geo") + "\"\nparameters = { a = 0.1, n = 3 }\n" +
         body;
}

/// Runs the configuration file `path` with overrides into a temporary results file; returns the
/// file (the caller removes the folder) and the last state.
struct LoadRun {
  fs::path dir;
  std::string file;
  State last;
  int steps = 0;
};
LoadRun run_file(const std::string& name, const std::string& path,
                 const std::vector<std::string>& overrides = {}) {
  LoadRun r;
  r.dir = ltl::testing::temp_dir("loads_" + name);
  const Problem problem = load_problem(path, overrides);
  RunOptions options;
  options.output = r.file = (r.dir / "out.h5").string();
  options.verbosity = 0;
  const RunSummary s = run(problem, options);
  r.last = s.state;
  r.steps = s.last_step;
  return r;
}

// The stretch (tests/geometry/stretch.toml): symmetry planes x = 0 and y = 0, the right face
// x = a pulled to x = a + factor x delta in x alone (free to slide in y), the top free:
// F = diag(lambda, 1 / lambda).
const double kC1 = 435e3, kC2 = 65e3, kA = 0.1, kDelta = 0.02;
const std::string kStretch = ltl::testing::test_path("geometry/stretch.toml");

}  // namespace

TEST(Loads, Eq1_5_RampedPrescribedStretchReactionMatchesClosedForm) {
  const LoadRun r = run_file("stretch", kStretch);
  ASSERT_EQ(r.steps, 3);
  for (int p = 1; p <= 3; ++p) {
    const double factor = p / 3.0, lambda = 1 + factor * kDelta / kA;
    EXPECT_NEAR(measure_of(r.file, p, "load_factor"), factor, 1e-14) << "step " << p;
    // [LTL87 (1.5)] plane strain, det F = 1: W = (C1 + C2)(lambda^2 + lambda^-2 - 2), the nominal
    // stress P11 = dW/dlambda, the force per metre of depth on the face of height a.
    const double P11 = 2 * (kC1 + kC2) * (lambda - std::pow(lambda, -3));
    const Array R = read_array(r.file, p, "reactions"), U = read_array(r.file, p, "support_u");
    ASSERT_EQ(R.dims, (std::vector<hsize_t>{3, 2})) << "step " << p;
    // [[fixed]] entries come first, then [[symmetry]], then [[displacement]].
    EXPECT_EQ(conditions_of(r.file, p), "fixed[0]:right; symmetry[0]:left; symmetry[1]:bottom");
    EXPECT_NEAR(R.at(0, 0), P11 * kA, 1e-6 * P11 * kA) << "step " << p;
    EXPECT_NEAR(R.at(1, 0), -P11 * kA, 1e-6 * P11 * kA) << "step " << p;  // the symmetry plane
    EXPECT_NEAR(R.at(0, 1), 0, 1e-9 * P11 * kA);  // free to slide in y: no reaction
    EXPECT_NEAR(R.at(2, 1), 0, 1e-6 * P11 * kA);  // the top is free: sigma22 = 0
    // The support's displacement: the prescribed one, and the lateral contraction 1/lambda.
    EXPECT_NEAR(U.at(0, 0), factor * kDelta, 1e-12);
    EXPECT_NEAR(U.at(0, 1), kA / 2 * (1 / lambda - 1), 1e-7 * kA) << "step " << p;
  }
  // Homogeneous: u = ((lambda - 1) x, (1/lambda - 1) y) at every node (P2 is exact).
  const double lambda = 1 + kDelta / kA;
  const Array X = read_array(r.file, 0, "/mesh/X");
  ASSERT_EQ(X.dims.at(0), static_cast<hsize_t>(r.last.u.rows()));
  for (int a = 0; a < r.last.u.rows(); ++a) {
    EXPECT_NEAR(r.last.u(a, 0), (lambda - 1) * X.at(a, 0), 1e-7 * kA) << "node " << a;
    EXPECT_NEAR(r.last.u(a, 1), (1 / lambda - 1) * X.at(a, 1), 1e-7 * kA) << "node " << a;
  }
  fs::remove_all(r.dir);
}

TEST(Loads, Eq4_1_RampedPrescribedStretchSameStateWithAlg2AndNewton) {
  // The Newton phase reads the prescribed values through the same Solver (the state ALG2
  // leaves on the fixed degrees of freedom): both solvers reach the same state at every step.
  const LoadRun n = run_file("newton", kStretch, {"algorithm.solver=\"newton\""});
  const LoadRun a =
      run_file("alg2", kStretch, {"algorithm.solver=\"alg2\"", "algorithm.tol=1e-10"});
  ASSERT_EQ(n.steps, 3);
  ASSERT_EQ(a.steps, 3);
  for (int p = 1; p <= 3; ++p) {
    const Array un = read_array(n.file, p, "u"), ua = read_array(a.file, p, "u");
    ASSERT_EQ(un.data.size(), ua.data.size());
    double diff = 0;
    for (std::size_t i = 0; i < un.data.size(); ++i)
      diff = std::max(diff, std::abs(un.data[i] - ua.data[i]));
    EXPECT_LT(diff, 1e-7 * kA) << "step " << p;
    const Array Rn = read_array(n.file, p, "reactions"), Ra = read_array(a.file, p, "reactions");
    EXPECT_NEAR(Rn.at(2, 0), Ra.at(2, 0), 1e-5 * std::abs(Rn.at(2, 0))) << "step " << p;
  }
  fs::remove_all(n.dir);
  fs::remove_all(a.dir);
}

TEST(Loads, Eq1_2_ReactionsBalanceARampedTractionOnABar) {
  // A compressible bar fixed on its left face, loaded on its right face by a traction with a
  // shear part, ramped by a table: sum of the reactions + applied load = 0 at every step.
  const std::string config = block_config(R"(
[material]
model = "compressible"
C1 = "435 kPa"
C3 = "300 kPa"
[[fixed]]
group = "left"
[load]
ramp = "table"
factor = [0.5, 1.0]
[[load.traction]]
group = "right"
value = ["80 kPa", "-20 kPa"]
[time]
dt = "1 s"
steps = 2
)");
  const fs::path dir = ltl::testing::temp_dir("loads_bar_config");
  ltl::testing::write_file(dir / "bar.toml", config);
  const LoadRun r = run_file("bar", (dir / "bar.toml").string());
  fs::remove_all(dir);
  ASSERT_EQ(r.steps, 2);
  for (int p = 1; p <= 2; ++p) {
    const double factor = p == 1 ? 0.5 : 1.0;
    EXPECT_NEAR(measure_of(r.file, p, "load_factor"), factor, 1e-14);
    const Array R = read_array(r.file, p, "reactions");
    ASSERT_EQ(R.dims, (std::vector<hsize_t>{1, 2}));
    EXPECT_EQ(conditions_of(r.file, p), "fixed[0]:left");
    const double Fx = 80e3 * kA * factor, Fy = -20e3 * kA * factor;  // N/m of depth
    EXPECT_NEAR(R.at(0, 0), -Fx, 1e-6 * Fx) << "step " << p;
    EXPECT_NEAR(R.at(0, 1), -Fy, 1e-6 * Fx) << "step " << p;
    const Array U = read_array(r.file, p, "support_u");
    EXPECT_EQ(U.at(0, 0), 0.0);  // fixed: no displacement
  }
  fs::remove_all(r.dir);
}

TEST(Loads, FixedValueNeedsItsComponentsAndUnits) {
  // A per-component value with a wrong component, or a value in the wrong unit, is refused
  // naming the key.
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"fixed[0].component=\"z\"", "fixed[0].component"},
      {"fixed=[{group=\"right\", value=[\"1 kPa\", 0]}]", "fixed[0].value"}};
  for (const auto& [set, key] : cases) {
    try {
      load_problem(kStretch, {set});
      ADD_FAILURE() << "accepted: --set " << set;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}
