// The package against the independent Newton solver (experiments/peer/peer.py, dolfinx,
// Taylor-Hood): its converged values are stored in tests/reference/peer.toml (value, and as tol
// the peer's change between its two finest meshes; `make verify && make peer-reference`
// regenerates them). Here the package's refined answers must approach them, at the mesh levels
// and within the allowances stated below (measured: paper_notes/discretization.md).
#include <gtest/gtest.h>
#include <toml++/toml.h>

#include "alg2.hpp"
#include "config.hpp"
#include "measures.hpp"
#include "testing.hpp"

namespace {

using ltl::testing::source_path;
using ltl::testing::test_path;

struct Answer {
  double drop = 0, a_moment = 0, p_max = 0, force_ratio = 0;
  bool converged = false;
};

Answer solve(const std::string& figure, std::vector<std::string> overrides) {
  const ltl::Problem problem =
      ltl::load_problem(source_path("experiments/" + figure + "/" + figure + ".toml"), overrides);
  ltl::Solver solver(problem);
  ltl::State s = solver.initial_state();
  const ltl::StepReport report = solver.solve_step(s, s.beta);
  Answer a;
  a.converged = report.converged;
  const ltl::ContactMeasures m = ltl::contact_measures(solver.discretization(), s, 0);
  a.a_moment = m.a_moment;
  a.p_max = m.p_max;
  a.force_ratio = m.force / ltl::load_along_normal(solver.problem(), solver.external_load());
  a.drop = figure == "fig5" ? -s.u(ltl::node_at(problem.mesh, Eigen::Vector2d(0, 1)), 1)
                            : (-s.u.col(1)).maxCoeff();
  return a;
}

struct Reference {
  double value, tol;
};
Reference reference(const std::string& figure, const std::string& key) {
  static const toml::table ref = toml::parse_file(test_path("reference/peer.toml"));
  const auto* t = ref[figure][key].as_table();
  if (!t) throw std::runtime_error("tests/reference/peer.toml: no [" + figure + "] " + key);
  return {(*t)["value"].value<double>().value(), (*t)["tol"].value<double>().value()};
}

std::vector<std::string> fig5_mesh(int K) {
  return {"mesh.parameters.n=" + std::to_string(K), "mesh.parameters.nd=" + std::to_string(K),
          "algorithm.R=20"};
}

// (2.7), (4.1)-(4.4), (6.6)-(6.7): Fig 5 at K = 14 and 28. The drop and the contact half-width
// come closer to the peer's converged values from K = 14 to K = 28, and at K = 28 lie within
// 5e-4 (drop) and 2.5e-3 (half-width) relative of them, plus the peer's own tolerance (measured:
// drop 0.26570 / 0.26560 against 0.26553, a_moment 0.5979 / 0.5952 against 0.5945). The peak
// nodal pressure converges slowly in both codes (the pressure is singular at the contact edge):
// within 1.5 % (measured 0.7 %).
TEST(Peer, Eq2_7_Eq4_1to4_4_Fig5ConvergesToTheNewtonPeer) {
  const Answer a14 = solve("fig5", fig5_mesh(14)), a28 = solve("fig5", fig5_mesh(28));
  ASSERT_TRUE(a14.converged && a28.converged);
  const Reference drop = reference("fig5", "drop"), am = reference("fig5", "a_moment"),
                  pm = reference("fig5", "p_max");
  EXPECT_LT(std::abs(a28.drop - drop.value), std::abs(a14.drop - drop.value));
  EXPECT_LT(std::abs(a28.a_moment - am.value), std::abs(a14.a_moment - am.value));
  EXPECT_NEAR(a28.drop, drop.value, 5e-4 * drop.value + drop.tol);
  EXPECT_NEAR(a28.a_moment, am.value, 2.5e-3 * am.value + am.tol);
  EXPECT_NEAR(a28.p_max, pm.value, 1.5e-2 * pm.value + pm.tol);
  EXPECT_NEAR(a28.force_ratio, 1.0, 1e-6);  // the plane carries the whole weight
}

// The paper's discretization (det-mean incompressibility, C2 on cell means, facet-mean contact)
// stays reproducible and stays away from the peer: its K = 28 drop is more than 2 % above.
TEST(Peer, Fig5PaperDiscretizationMissesTheNewtonPeer) {
  auto o = fig5_mesh(28);
  o.insert(o.end(), {"discretization.incompressibility=det-mean", "discretization.c2=cell-mean",
                     "discretization.contact=facet-mean", "algorithm.tol=1e-6"});
  const Answer a = solve("fig5", o);
  ASSERT_TRUE(a.converged);
  EXPECT_GT(a.drop, 1.02 * reference("fig5", "drop").value);
}

// The peer's Q1/P0 (mean dilatation, nodal penalty contact at the H8 vertices) at one level:
// the same discrete problem as the package's mean-det H8, solved by Newton.
double q1p0_value(const std::string& key, int level) {
  static const toml::table ref = toml::parse_file(test_path("reference/peer.toml"));
  const auto* levels = ref["fig6_q1p0"]["levels"].as_array();
  const auto* values = ref["fig6_q1p0"][key].as_array();
  if (!levels || !values) throw std::runtime_error("tests/reference/peer.toml: no [fig6_q1p0]");
  for (size_t i = 0; i < levels->size(); ++i)
    if ((*levels)[i].value<int>() == level) return (*values)[i].value<double>().value();
  throw std::runtime_error("tests/reference/peer.toml: [fig6_q1p0] has no level " +
                           std::to_string(level));
}

// (2.7), (4.1)-(4.4): Fig 6 on the paper's mesh (270 H8, level 1), Anderson-accelerated. With
// mean-det the package solves the peer's Q1/P0 discrete problem: the sag and the share of the
// load carried by the plane agree with the peer's Newton solution on the same mesh to 1e-5
// relative (measured: 2.711468 against 2.711470). Against the peer's converged value (level 3)
// the paper's mesh is within 0.5 % plus the peer's own tolerance (measured 0.27 %); the paper's
// det-mean H8, which locks in bending, is more than 2 % short (measured 2.5 %).
TEST(Peer, Eq2_7_Eq4_1to4_4_Fig6MeanDetIsThePeersQ1P0AndApproachesItsConvergedSag) {
  const std::vector<std::string> accel = {"algorithm.acceleration=anderson"};
  const Answer a = solve("fig6", accel);
  ASSERT_TRUE(a.converged);
  EXPECT_NEAR(a.drop, q1p0_value("sag", 1), 1e-5 * a.drop);
  EXPECT_NEAR(a.force_ratio, q1p0_value("force_ratio", 1), 1e-5);
  const Reference sag = reference("fig6", "sag"), ratio = reference("fig6", "force_ratio");
  EXPECT_NEAR(a.drop, sag.value, 5e-3 * sag.value + sag.tol);
  EXPECT_NEAR(a.force_ratio, ratio.value, 2e-2 * ratio.value + ratio.tol);

  auto o = accel;
  o.push_back("discretization.incompressibility=det-mean");
  const Answer paper = solve("fig6", o);
  ASSERT_TRUE(paper.converged);
  EXPECT_LT(paper.drop, 0.98 * sag.value);
}

}  // namespace
