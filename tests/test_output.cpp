// The complete output of a run: the true plane-strain out-of-plane
// stress [LTL87 (1.5), (1.1)] against closed forms and through a whole run, units and
// descriptions on every dataset, the format version, the equilibrium measure per step, the
// resolved configuration, cell volumes from the discretization, the unconverged iterate of a
// failed step kept apart from the results, and every XDMF file read by Debian's meshio.
// The measures (lib/measures.hpp): the peel measures of a constructed state, and the measures
// stored per step equal to the in-memory ones.
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "admissibility.hpp"
#include "config.hpp"
#include "error.hpp"
#include "fe.hpp"
#include "measures.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::test_path;
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// A dataset of doubles (row-major) from an HDF5 file.
std::vector<double> read_doubles(const std::string& file, const std::string& path) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_GE(f, 0) << file;
  const hid_t d = H5Dopen2(f, path.c_str(), H5P_DEFAULT);
  EXPECT_GE(d, 0) << path;
  const hid_t sp = H5Dget_space(d);
  std::vector<double> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(sp)));
  if (!v.empty()) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
  H5Sclose(sp);
  H5Dclose(d);
  H5Fclose(f);
  return v;
}

bool has(const std::string& file, const std::string& path) {
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  bool found = true;
  std::size_t start = 1;
  while (found && start <= path.size()) {
    std::size_t end = path.find('/', start);
    if (end == std::string::npos) end = path.size();
    found = H5Lexists(f, path.substr(0, end).c_str(), H5P_DEFAULT) > 0;
    start = end + 1;
  }
  H5Fclose(f);
  return found;
}

// Plane strain planar tension of an incompressible Mooney-Rivlin block (test_verification.cpp):
// u1 = 0 on x1 = 0, u2 = 0 on x2 = 0, a dead nominal traction on x1 = 1, x2 = 1 free, so
// F = diag(l, 1/l, 1), sigma22 = 0, sigma11 = 2 (C1 + C2)(l^2 - l^-2), and (B = F F^T,
// sigma = 2 C1 B - 2 C2 B^-1 - q I with q from sigma22 = 0)
//   sigma33 = 2 C1 (1 - l^-2) + 2 C2 (l^2 - 1).
constexpr double kC1 = 100e3, kC2 = 30e3;
double planar_sigma33(double l) {
  return 2 * kC1 * (1 - 1 / (l * l)) + 2 * kC2 * (l * l - 1);
}

}  // namespace

TEST(Sigma33, Eq1_5_PlanarTensionClosedForm) {
  const Material m = Material::mooney_rivlin(kC1, kC2);
  for (const double l : {0.7, 1.0, 1.5, 2.0}) {
    Eigen::Matrix2d F, P;
    F << l, 0, 0, 1 / l;
    P << 2 * (kC1 + kC2) * (l * l - 1 / (l * l)) / l, 0, 0, 0;  // P = sigma F^-T, J = 1
    const double s33 = m.plane_strain_sigma33(F, P);
    EXPECT_NEAR(s33, planar_sigma33(l), 1e-10 * (kC1 + kC2)) << "l = " << l;
    // Any stress state with the same F differs only by the pressure: a hydrostatic shift p
    // (P -> P - p cof F) moves sigma33 by -p too.
    Eigen::Matrix2d cof;
    cof << F(1, 1), 0, 0, F(0, 0);
    EXPECT_NEAR(m.plane_strain_sigma33(F, P - 5e3 * cof), planar_sigma33(l) - 5e3, 1e-6);
  }
  // The split of the solver (C2 moved into C1, an identity on det F = 1 in plane strain) is not
  // the 3-D law: its sigma33 differs, which is why the law itself is used.
  const Material split = Material::mooney_rivlin(kC1 + kC2, 0);
  Eigen::Matrix2d F, P;
  F << 2, 0, 0, 0.5;
  P << 2 * (kC1 + kC2) * (4 - 0.25) / 2, 0, 0, 0;
  EXPECT_GT(std::abs(split.plane_strain_sigma33(F, P) - planar_sigma33(2)), 1e3);
}

TEST(Sigma33, Fig3LawUniaxialStrainClosedForm) {
  // Compressible law W = C1 (|F|^2 - 3) + C3 J^2 - C3 - 2 (C1 + C3) ln J under F = diag(l, 1, 1):
  // sigma = (2 C1 B + (2 C3 J^2 - 2 (C1 + C3)) I) / J, so sigma33 = 2 C3 (l^2 - 1) / l.
  const double C1 = 187.5e3, C3 = 60e3;
  const Material m = Material::compressible(C1, C3);
  for (const double l : {0.8, 1.0, 1.3}) {
    Eigen::Matrix2d F;
    F << l, 0, 0, 1;
    const double s33 = m.plane_strain_sigma33(F, m.dW(F));
    EXPECT_NEAR(s33, 2 * C3 * (l * l - 1) / l, 1e-9 * C1) << "l = " << l;
  }
}

TEST(Output, PlanarTensionRunWritesTheTrueSigma33UnitsAndMeasures) {
  const fs::path dir = ltl::testing::temp_dir("output_planar");
  const std::string out = (dir / "planar.h5").string();
  const double l = 1.5;
  const Problem p = ltl::testing::planar_tension(l, kC1, kC2);
  RunOptions o;
  o.output = out;
  o.verbosity = 0;
  run(p, o);
  const int nc = p.mesh.num_cells();
  const std::vector<double> s33 = read_doubles(out, "/steps/000001/sigma33");
  const std::vector<double> sigma = read_doubles(out, "/steps/000001/sigma");
  const std::vector<double> pressure = read_doubles(out, "/steps/000001/pressure");
  const std::vector<double> s3 = read_doubles(out, "/steps/000001/xdmf/sigma");
  const std::vector<double> E3 = read_doubles(out, "/steps/000001/xdmf/E");
  ASSERT_EQ(static_cast<int>(s33.size()), nc);
  double worst = 0;
  for (int c = 0; c < nc; ++c) {
    worst = std::max(worst, std::abs(s33[c] - planar_sigma33(l)));
    EXPECT_NEAR(pressure[c], -(sigma[4 * c] + sigma[4 * c + 3] + s33[c]) / 3, 1e-6);
    EXPECT_EQ(s3[9 * c + 8], s33[c]);  // the ParaView tensor has the true sigma33
    EXPECT_EQ(E3[9 * c + 8], 1.0);     // F33 = 1
  }
  std::printf("  planar tension l = %g: sigma33 closed form %.6f Pa, worst cell error %.3e Pa\n", l,
              planar_sigma33(l), worst);
  EXPECT_LT(worst, 1e-5 * planar_sigma33(l));
  // Units, descriptions, version, equilibrium measure, resolved configuration.
  EXPECT_EQ(ResultsFile::read_attribute(out, "config_resolved").find("C2 = 30000.0  # Pa"),
            ResultsFile::read_attribute(out, "config_resolved").find("C2 = "));
  const hid_t f = H5Fopen(out.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  int version = 0;
  const hid_t a = H5Aopen(f, "format_version", H5P_DEFAULT);
  H5Aread(a, H5T_NATIVE_INT, &version);
  H5Aclose(a);
  EXPECT_EQ(version, kFormatVersion);
  double force_residual = -1;
  const hid_t g = H5Gopen2(f, "/steps/000001", H5P_DEFAULT);
  const hid_t fr = H5Aopen(g, "force_residual", H5P_DEFAULT);
  H5Aread(fr, H5T_NATIVE_DOUBLE, &force_residual);
  H5Aclose(fr);
  H5Gclose(g);
  H5Fclose(f);
  EXPECT_GE(force_residual, 0);
  EXPECT_LT(force_residual, 1e-6);
  // The cell volumes are the discretization's: they add up to the unit square.
  const std::vector<double> vol = read_doubles(out, "/mesh/cell_volume");
  double total = 0;
  for (double v : vol) total += v;
  EXPECT_NEAR(total, 1.0, 1e-13);
  fs::remove_all(dir);
}

// [LTL87 (1.5)] One set of stresses and one pressure (Discretization::stresses): planar tension
// F = diag(l, 1/l, 1) with sigma22 = 0 has sigma11 = P11 l = 2 (l^2 - l^-2)(C1 + C2) and the
// closed-form sigma33, so the pressure is -(sigma11 + sigma33) / 3, the mean of the
// three-dimensional stress (not the in-plane mean); in 3-D the pressure is -tr(sigma) / 3 and
// there is no sigma33.
TEST(Stresses, Eq1_5_OnePressureTheMeanOfTheThreeDimensionalStress) {
  const double l = 1.5;
  const auto r = ltl::testing::solve_one_step(ltl::testing::planar_tension(l, kC1, kC2));
  const Discretization::Stresses st = r.solver->discretization().stresses(r.s);
  const double sigma11 = 2 * (l * l - 1 / (l * l)) * (kC1 + kC2);
  const double p = -(sigma11 + planar_sigma33(l)) / 3;
  const int nc = r.solver->discretization().num_cells();
  ASSERT_EQ(st.pressure.size(), nc);
  ASSERT_EQ(st.sigma33.size(), nc);
  EXPECT_EQ((st.P - r.solver->discretization().piola(r.s)).norm(), 0.0);
  for (int c = 0; c < nc; ++c) {
    EXPECT_NEAR(st.sigma(2 * c, 0), sigma11, 1e-5 * sigma11) << "cell " << c;
    EXPECT_NEAR(st.sigma33(c), planar_sigma33(l), 1e-5 * sigma11) << "cell " << c;
    EXPECT_NEAR(st.pressure(c), p, 1e-5 * sigma11) << "cell " << c;
  }
  const Mesh box = ltl::testing::distorted_box(2);
  const auto b = ltl::testing::homogeneous_3d(box, Material::mooney_rivlin(kC1, kC2),
                                              Eigen::Vector3d(1.2, 1 / 1.2, 1.0).asDiagonal());
  const Discretization::Stresses st3 = b.solver->discretization().stresses(b.s);
  EXPECT_EQ(st3.sigma33.size(), 0);
  for (int c = 0; c < box.num_cells(); ++c) {
    const double trace = st3.sigma.block(3 * c, 0, 3, 3).trace();
    EXPECT_NEAR(st3.pressure(c), -trace / 3, 1e-12 * st3.sigma.norm());
  }
}

TEST(Output, ADivergedStepIsSavedApartAsUnconverged) {
  const fs::path dir = ltl::testing::temp_dir("output_unconverged");
  const std::string out = (dir / "cap.h5").string();
  Problem p = ltl::testing::planar_tension(1.5, kC1, kC2);
  p.algorithm.max_iter = 7;  // the iteration cap: a failed step
  RunOptions o;
  o.output = out;
  o.verbosity = 0;
  std::string msg;
  try {
    run(p, o);
  } catch (const Error& e) {
    msg = e.what();
  }
  EXPECT_NE(msg.find("diverged at step 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find("saved in " + out + ", group /unconverged/000001 (not a result)"),
            std::string::npos)
      << msg;
  ASSERT_TRUE(fs::exists(out));
  EXPECT_FALSE(ResultsFile::read_last_step(out));  // no result
  EXPECT_EQ(read_doubles(out, "/unconverged/000001/history").size(), 7u * 8u);
  EXPECT_EQ(read_doubles(out, "/unconverged/000001/u").size(), 2u * p.mesh.num_nodes());
  EXPECT_FALSE(has(out, "/unconverged/000001/xdmf"));
  EXPECT_NE(ResultsFile::read_attribute(out, "status").find("diverged at step 1"),
            std::string::npos);
  EXPECT_EQ(read_text(dir / "cap.xdmf").find("unconverged"), std::string::npos);
  // A run that does converge supersedes it (resume of the same configuration with a later cap
  // is refused, so run afresh into the same file).
  p.algorithm.max_iter = 20000;
  run(p, o);
  EXPECT_FALSE(has(out, "/unconverged/000001"));
  EXPECT_EQ(ResultsFile::read_last_step(out)->p, 1);
  fs::remove_all(dir);
}

// meshio (Debian's python3-meshio) reads every XDMF file: the single-step body and contact
// files with meshio.read(), the multi-step ones with its time-series reader, with the contact
// fields; h5py sees a unit and a description on every dataset; ltl_results shows the
// equilibrium measure and the resolved configuration, and ignores the unconverged group.
TEST(Output, MeshioReadsEveryFileWithTheContactFields) {
  const fs::path dir = ltl::testing::temp_dir("output_meshio");
  ltl::testing::write_file(dir / "case.toml",
                           ltl::testing::coarse_fig5_config(
                               ltl::testing::source_path("experiments/fig5/half_disc.geo")));
  for (const auto& [name, steps, contact] :
       {std::tuple{"one", 1, "nodal"}, std::tuple{"two", 2, "nodal"},
        std::tuple{"facets", 1, "facet-mean"}}) {
    const Problem p =
        load_problem((dir / "case.toml").string(),
                     {cat("time.steps=", steps), cat("discretization.contact=\"", contact, "\"")});
    RunOptions o;
    o.output = (dir / (std::string(name) + ".h5")).string();
    o.verbosity = 0;
    run(p, o);
  }
  const fs::path script = dir / "read.py";
  ltl::testing::write_file(script, "import sys\nsys.path.insert(0, " +
                                       ("'" + ltl::testing::source_path("figures") + "'") + ")\n" +
                                       R"(import h5py, meshio, numpy as np
import ltl_results
d = sys.argv[1]
# Single-step files: meshio.read() on the body and the contact surface.
for name, nodal in (("one", True), ("facets", False)):
    m = meshio.read(f"{d}/{name}.xdmf")
    assert m.points.shape[1] == 2 and m.cells[0].type == "triangle6", m
    cd = {k: v[0] for k, v in m.cell_data.items()}
    for k in ("u",):
        assert m.point_data[k].shape[1] == 3, k
    for k in ("E", "P", "sigma"):
        assert cd[k].shape[1:] == (3, 3), (k, cd[k].shape)
    assert np.all(cd["E"][:, 2, 2] == 1.0)
    assert np.array_equal(cd["sigma"][:, 2, 2], cd["sigma33"])
    assert np.allclose(cd["pressure"], -np.trace(cd["sigma"], axis1=1, axis2=2) / 3)
    print(name, "body: %d points, %d cells, sigma33 in [%.4g, %.4g] Pa"
          % (len(m.points), len(cd["E"]), cd["sigma33"].min(), cd["sigma33"].max()))
    c = meshio.read(f"{d}/{name}_contact.xdmf")
    assert c.cells[0].type == "line3", c.cells[0].type
    data = c.point_data if nodal else {k: v[0] for k, v in c.cell_data.items()}
    for k in ("beta", "contact_pressure", "gap", "e", "lambda_c"):
        assert k in data, (name, k, list(data))
    assert data["e"].shape[1] == 3 and data["lambda_c"].shape[1] == 3
    assert data["contact_pressure"].max() > 0 and data["gap"].min() >= -1e-9
    print(name, "contact: %d points, %d facets, peak contact pressure %.6g Pa"
          % (len(c.points), len(c.cells[0].data), data["contact_pressure"].max()))
# The two-step files: the time-series reader.
for file, key in (("two.xdmf", "u"), ("two_contact.xdmf", "beta")):
    with meshio.xdmf.TimeSeriesReader(f"{d}/{file}") as r:
        points, cells = r.read_points_cells()
        assert r.num_steps == 2, r.num_steps
        for k in range(r.num_steps):
            t, pd, cd = r.read_data(k)
            assert key in pd, (file, list(pd))
    print(file, "time series: 2 steps")
# Every dataset has a unit and a description; the file has a format version.
with h5py.File(f"{d}/two.h5", "r") as f:
    assert f.attrs["format_version"] == 2
    missing = []
    f.visititems(lambda n, o: missing.append(n) if isinstance(o, h5py.Dataset) and
                 ("unit" not in o.attrs or "description" not in o.attrs) else None)
    assert not missing, missing
r = ltl_results.load(f"{d}/two.h5")
assert r.format_version == 2
for s in r.steps:
    eq = s.equilibrium
    assert set(eq) == {"force_residual", "det_error", "penetration", "det_min"}, eq
    assert 0 < eq["det_min"] < 1.5, eq
    assert 0 <= eq["force_residual"] < 0.1, eq
    # The measures of lib/measures.hpp, with units; the contact set per contact point.
    ms = s.measures
    assert ms["contact_force"] > 0 and ms["a_edge"] > 0, ms
    assert s.measure_units["contact_force"] == "N/m", s.measure_units
    assert s.in_contact is not None and s.in_contact.sum() == ms["in_contact_count"]
    assert len(s.in_contact) == ms["contact_points"] == len(r.mesh.contact_area)
cfg = ltl_results.resolved_config(r)
assert cfg["material"]["C1"] == 435e3 and cfg["algorithm"]["q"] == 1e6, cfg["material"]
assert cfg["time"]["steps"] == 2 and cfg["discretization"]["contact"] == "nodal"
print("MESHIO-OK")
)");
  const fs::path log = dir / "read.log";
  const int rc = std::system(("/usr/bin/python3 '" + script.string() + "' '" + dir.string() +
                              "' > '" + log.string() + "' 2>&1")
                                 .c_str());
  const std::string text = read_text(log);
  std::printf("%s", text.c_str());
  EXPECT_EQ(rc, 0) << text;
  EXPECT_NE(text.find("MESHIO-OK"), std::string::npos) << text;
  fs::remove_all(dir);
}

// ---------------------------------------------------------------------------------------------
// The measures (lib/measures.hpp): closed forms and what the results file stores.

namespace {

// The bottom of tests/geometry/square.geo (n = 4 equal segments on [0, 1]) as the glued contact
// surface on the plane x2 = 0 (N = -e2, into the support): contact points = the 4 facets, with
// centres x1 = 0.125, 0.375, 0.625, 0.875 and weights h = 0.25.
Problem glued_square() {
  Problem p;
  p.mesh = load_mesh(test_path("geometry/square.geo"));
  ContactCondition cc;
  cc.group = "bottom";
  cc.plane_point.setZero();
  cc.plane_normal = Eigen::Vector3d(0, -1, 0);
  cc.adhesion.kappa = 1e9;
  cc.origin = "test";
  p.contacts = {cc};
  return p;
}

}  // namespace

// [LTL87 (1.2)-(1.3), (4.11)] A constructed state with beta(x1) = x1 + 0.3 and opening
// -e . N = e2 = 0.01 (1 - x1)^2 on the 4 facets: the glue is broken (beta < kDebondedBeta) where
// x1 < 0.2, damaged (beta < kDamagedBeta) where x1 < 0.6, so the front is the centre 0.125 and the
// damage front the centre 0.375; the largest opening is 0.01 (0.875)^2 at x1 = 0.125; and the
// weighted mean square of beta is the midpoint rule of int_0^1 (x + 0.3)^2 dx, exact minus h^2/12
// (f'' = 2).
TEST(Measures, Eq4_11_PeelFrontAndOpeningOfAConstructedState) {
  const Problem p = glued_square();
  const ContactPoints points = facet_mean_points(p.mesh, p.mesh.boundary("bottom"));
  ASSERT_EQ(points.size(), 4);
  State s;
  s.u = Eigen::MatrixXd::Zero(p.mesh.num_nodes(), 2);
  s.beta.resize(4);
  s.e.resize(4, 2);
  s.lambda_c = Eigen::MatrixXd::Zero(4, 2);
  for (int i = 0; i < 4; ++i) {
    const double x = points.centre(0, i);
    s.beta(i) = x + 0.3;
    s.e.row(i) = Eigen::RowVector2d(0.1, 0.01 * (1 - x) * (1 - x));
  }
  const PeelMeasures m = peel_measures(p, points, s);
  EXPECT_EQ(m.points, 4);
  EXPECT_EQ(m.broken, 1);
  EXPECT_NEAR(m.front, 0.125, 1e-12);
  EXPECT_NEAR(m.damage_front, 0.375, 1e-12);
  EXPECT_NEAR(m.beta_min, 0.425, 1e-12);
  EXPECT_NEAR(m.beta_max, 1.175, 1e-12);
  const double h = 0.25, exact = (std::pow(1.3, 3) - std::pow(0.3, 3)) / 3;
  EXPECT_NEAR(m.beta_l2, std::sqrt(exact - h * h / 12), 1e-12);
  EXPECT_NEAR(m.max_opening, 0.01 * 0.875 * 0.875, 1e-13);  // centres from gmsh, to ~1e-13 m
  EXPECT_NEAR(m.max_opening_x, 0.125, 1e-12);
  // Intact glue: no front (NaN), nothing broken.
  s.beta.setOnes();
  const PeelMeasures intact = peel_measures(p, points, s);
  EXPECT_EQ(intact.broken, 0);
  EXPECT_TRUE(std::isnan(intact.front));
  EXPECT_TRUE(std::isnan(intact.damage_front));
}

// The measures stored per step (/steps/N/measures) are the in-memory ones, bit for bit: a short
// run of Fig 3's literal reading (peel and contact measures) and of a coarse Fig 5 (contact).
TEST(Output, StoredMeasuresEqualTheInMemoryOnes) {
  const fs::path dir = ltl::testing::temp_dir("output_measures");
  ltl::testing::write_file(dir / "fig5.toml",
                           ltl::testing::coarse_fig5_config(
                               ltl::testing::source_path("experiments/fig5/half_disc.geo")));
  for (const auto& [config, overrides] :
       {std::pair{ltl::testing::source_path("experiments/fig3/fig3_literal.toml"),
                  std::vector<std::string>{"time.steps=2"}},
        std::pair{(dir / "fig5.toml").string(), std::vector<std::string>{}}}) {
    const Problem p = load_problem(config, overrides);
    RunOptions o;
    o.output = (dir / "out.h5").string();
    o.verbosity = 0;
    StepMeasures last;
    AdmissibilityReport admissibility;
    run(p, o, [&](const Solver& solver, int, const State& s) {
      last = step_measures(solver.discretization(), s);
      admissibility = check_admissibility(solver.discretization(), s);
    });
    ASSERT_TRUE(last.contact) << config;
    EXPECT_EQ(last.peel.has_value(), p.contacts[0].adhesion.kappa > 0) << config;
    const auto stored = ResultsFile::read_last_step(o.output);
    ASSERT_TRUE(stored);
    std::vector<StoredMeasure> expected = stored_measures(last, p.mesh.dim);
    // ... and the admissibility of the step (lib/admissibility.hpp).
    for (const StoredMeasure& m : stored_measures(admissibility)) expected.push_back(m);
    // ... and the load subdivision of the step (lib/simulation.cpp): the full increment.
    expected.push_back({"substeps", 1.0, "1", ""});
    expected.push_back({"failed_attempts", 0.0, "1", ""});
    // ... and the load factor of the step ([load] ramp).
    expected.push_back({"load_factor", p.ramp.factor(stored->p, p.time.dt), "1", ""});
    EXPECT_TRUE(stored->measures.count("det_F_min") && stored->measures.count("rotation_jump"));
    EXPECT_EQ(stored->measures.size(), expected.size());
    for (const StoredMeasure& m : expected) {
      ASSERT_TRUE(stored->measures.count(m.name)) << m.name;
      const double v = stored->measures.at(m.name);
      if (std::isnan(m.value))
        EXPECT_TRUE(std::isnan(v)) << m.name;
      else
        EXPECT_EQ(v, m.value) << m.name;
    }
    const std::vector<double> mask = read_doubles(o.output, "/steps/000001/measures/in_contact");
    EXPECT_EQ(static_cast<int>(mask.size()), last.contact->points);
    std::printf("  %s: %zu measures stored, contact force %.6g, %d of %d points in contact\n",
                p.name.c_str(), expected.size(), last.contact->force, last.contact->in_contact,
                last.contact->points);
  }
  fs::remove_all(dir);
}
