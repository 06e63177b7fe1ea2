// Adhesion and time stepping [LTL87 sec. 1-2, 6] on the Fig 3 bar (the first steps, before the
// peel runs away): the discrete energy principle, the behaviour of beta, and restart.
#include <gtest/gtest.h>

#include "alg2.hpp"
#include "config.hpp"
#include "error.hpp"
#include "results.hpp"
#include "simulation.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::source_path;

namespace {
// The Fig 3 bar under the literal reading R1 (pulled up), whose glue yields from the first step.
Problem fig3(int steps, std::vector<std::string> extra = {}) {
  extra.push_back("time.steps=" + std::to_string(steps));
  return load_problem(source_path("experiments/fig3/fig3_literal.toml"), extra);
}
}  // namespace

TEST(Adhesion, Eq2_2_EnergyDecreasesWithinEachTimeStep) {
  // (1.4) in discrete form: the converged state of step p is no worse for J_p (2.2) than the
  // state of step p-1 (where the dissipation term vanishes).
  const Problem p = fig3(6);
  Solver solver(p);
  State s = solver.initial_state();
  for (int step = 1; step <= 6; ++step) {
    const Eigen::VectorXd beta_prev = s.beta;
    const State old = s;
    const StepReport r = solver.solve_step(s, beta_prev);
    ASSERT_TRUE(r.converged) << r.status;
    const double J_old = solver.energy(old, beta_prev), J_new = solver.energy(s, beta_prev);
    EXPECT_LE(J_new, J_old + 1e-9 * std::abs(J_old)) << "step " << step;
    if (step > 1) {
      EXPECT_LT(J_new, J_old) << "step " << step << ": nothing happened";
    }
  }
}

TEST(Adhesion, BetaStaysInUnitIntervalDecreasesAndStaysOneWhereUnloaded) {
  const Problem p = fig3(6);
  Solver solver(p);
  State s = solver.initial_state();
  const Eigen::MatrixXd& centre = solver.discretization().points()->centre;
  for (int step = 1; step <= 6; ++step) {
    const Eigen::VectorXd beta_prev = s.beta;
    ASSERT_TRUE(solver.solve_step(s, beta_prev).converged);
    for (int f = 0; f < s.beta.size(); ++f) {
      EXPECT_GE(s.beta(f), 0.0);
      EXPECT_LE(s.beta(f), 1.0);
      EXPECT_LE(s.beta(f), beta_prev(f) + 1e-9) << "step " << step << " facet " << f;
      // Near the fixed end x1 = 1 the load vanishes and the glue is not stretched.
      if (centre(0, f) > 0.75) {
        EXPECT_NEAR(s.beta(f), 1.0, 1e-12) << "facet " << f;
      }
    }
    // ...while the free end x1 = 0, where the peeling traction is largest, debonds.
    EXPECT_LT(s.beta(0), 1.0 - 0.03 * step);
    // No penetration of the support: e2 >= 0 (N = (0, -1), gap 0).
    EXPECT_GE(s.e.col(1).minCoeff(), -1e-12);
  }
}

TEST(Adhesion, RestartGivesTheUninterruptedAnswer) {
  const auto dir = ltl::testing::temp_dir("restart");
  const std::string a = (dir / "a.h5").string(), b = (dir / "b.h5").string();
  const Problem p = fig3(5);
  RunOptions full{a, false, 0, 0, ""};
  const RunSummary sa = run(p, full);
  RunOptions first{b, false, 0, 2, ""};  // stopped after 2 steps, as if killed
  const RunSummary s1 = run(p, first);
  EXPECT_EQ(s1.last_step, 2);
  EXPECT_EQ(ResultsFile::read_last_step(b)->p, 2);
  RunOptions rest{b, true, 0, 0, ""};
  const RunSummary sb = run(p, rest);
  EXPECT_EQ(sb.first_step, 3);
  EXPECT_EQ(sb.last_step, 5);
  const auto last = ResultsFile::read_last_step(b);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->p, 5);
  const double scale = sa.state.u.cwiseAbs().maxCoeff();
  EXPECT_LE((last->state.u - sa.state.u).cwiseAbs().maxCoeff(), 1e-12 * scale);
  EXPECT_LE((last->state.beta - sa.state.beta).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LE((last->state.lambda - sa.state.lambda).cwiseAbs().maxCoeff(),
            1e-12 * sa.state.lambda.cwiseAbs().maxCoeff());
  // Resuming with another physics is refused; other [algorithm] settings are not (the file is
  // complete: nothing to do).
  const Problem other = fig3(5, {"material.C1=200000"});
  EXPECT_THROW(run(other, rest), Error);
  EXPECT_NO_THROW(run(fig3(5, {"algorithm.R=4"}), rest));
  std::filesystem::remove_all(dir);
}
