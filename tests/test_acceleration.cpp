// Anderson acceleration of the ALG2 fixed-point map (4.1)-(4.3) (lib/anderson.hpp): the
// accelerator on a linear contraction, and the safeguard of Solver::solve_step, which keeps an
// accelerated iterate only when its merit r_G + r_B does not exceed the previous one (a test that
// counts), on the Fig 5 problem. The same fixed point as the plain iteration on the closed forms:
// test_verification.cpp (planar tension, cantilever) and test_contact_problems.cpp (pressed
// block, Fig 5).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "alg2.hpp"
#include "anderson.hpp"
#include "config.hpp"
#include "error.hpp"
#include "testing.hpp"

using namespace ltl;
using ltl::testing::source_path;

TEST(Anderson, LinearContractionReachesTheFixedPointInFewerStepsThanPicard) {
  // x -> A x + b with A symmetric, spectrum in [0, 0.99]: Picard needs ~ 2000 steps for 1e-9;
  // Anderson(10), a GMRES-like method on a linear map, far fewer.
  const int n = 50;
  Eigen::VectorXd d = Eigen::VectorXd::LinSpaced(n, 0.0, 0.99), b = Eigen::VectorXd::Ones(n);
  const Eigen::VectorXd x_exact = (1 - d.array()).inverse().matrix().cwiseProduct(b);
  auto G = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd { return d.cwiseProduct(x) + b; };
  auto steps = [&](int depth) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(n), g(n);
    Anderson aa(n, std::max(depth, 1), 1e6);
    for (int k = 1; k <= 100000; ++k) {
      g = G(x);
      if ((g - x).norm() < 1e-9 * b.norm()) {
        EXPECT_LT((x - x_exact).norm(), 1e-6 * x_exact.norm());
        return k;
      }
      if (depth > 0) aa.step(x, g);
      x = g;
    }
    return 100000;
  };
  const int picard = steps(0), anderson = steps(10);
  std::printf("  Picard %d steps, Anderson(10) %d steps\n", picard, anderson);
  EXPECT_GT(picard, 1500);
  EXPECT_LT(anderson, picard / 10);
}

TEST(Anderson, NoAllocationAfterConstructionAndPlainIterateWhileTheHistoryFills) {
  Anderson aa(4, 3);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(4), g = Eigen::VectorXd::Ones(4);
  // 3 differences are needed: the first 3 calls (1 pair, then 2 differences) return g as is.
  for (int k = 0; k < 3; ++k) {
    const Eigen::VectorXd g0 = g;
    EXPECT_EQ(aa.step(x, g), 0);
    EXPECT_EQ(g, g0);
    x = g;
    g = 0.5 * x + Eigen::VectorXd::Ones(4);
  }
  EXPECT_EQ(aa.columns(), 2);
  aa.restart();
  EXPECT_EQ(aa.columns(), 0);
}

namespace {
Problem fig5(const std::vector<std::string>& extra = {}) {
  // The default mean-det incompressibility: the map also depends on u (the lagged fluctuation
  // terms), so u is part of the accelerated vector (paper_notes/discretization.md).
  std::vector<std::string> o = {"algorithm.tol=1e-9"};
  o.insert(o.end(), extra.begin(), extra.end());
  return load_problem(source_path("experiments/fig5/fig5.toml"), o);
}
}  // namespace

TEST(AndersonSafeguard, Eq4_1to4_3_Fig5_NeverKeepsAnIterateThatIncreasesTheMerit) {
  // Depth 3 and R = 20 (a slower plain iteration, K = 7): both verdicts occur.
  for (const int depth : {3, 10}) {
    const Problem p = fig5({"algorithm.acceleration=anderson", "algorithm.R=20",
                            "algorithm.depth=" + std::to_string(depth)});
    Solver solver(p);
    State s = solver.initial_state();
    const StepReport r = solver.solve_step(s, s.beta);
    ASSERT_TRUE(r.converged) << r.status;
    int kept = 0, rejected = 0, increases_kept = 0;
    for (size_t i = 1; i < r.history.size(); ++i) {
      const IterationRecord &h = r.history[i], &prev = r.history[i - 1];
      if (h.accelerated == 1) {
        ++kept;
        if (h.r_G + h.r_B > prev.r_G + prev.r_B) ++increases_kept;
      } else if (h.accelerated == -1) {
        ++rejected;
        EXPECT_GT(h.r_G + h.r_B, prev.r_G + prev.r_B);
        // After a rejection the next iterate is the plain one.
        if (i + 1 < r.history.size()) {
          EXPECT_EQ(r.history[i + 1].accelerated, 0);
        }
      }
    }
    std::printf("  depth %d: %d iterations, %d accelerated iterates kept, %d rejected\n", depth,
                r.iterations, kept, rejected);
    EXPECT_EQ(increases_kept, 0);
    EXPECT_EQ(kept, r.accepted);
    EXPECT_EQ(rejected, r.rejected);
    EXPECT_GT(kept, 0);
    EXPECT_EQ(r.strain_failures, 0);
  }
}

TEST(AndersonSafeguard, Eq4_1to4_3_NoneReproducesThePlainIteration) {
  // "none" is the paper's iteration: no accelerated iterate, the same history as the default.
  Solver a(fig5()), b(fig5({"algorithm.acceleration=none", "algorithm.depth=7"}));
  State sa = a.initial_state(), sb = b.initial_state();
  const StepReport ra = a.solve_step(sa, sa.beta), rb = b.solve_step(sb, sb.beta);
  EXPECT_EQ(ra.iterations, rb.iterations);
  EXPECT_EQ(rb.accepted + rb.rejected, 0);
  EXPECT_EQ((sa.u - sb.u).cwiseAbs().maxCoeff(), 0.0);
}

// Adaptive R (AlgorithmParams::adaptive_R, residual balancing, paper_notes/performance.md): R
// changes the path of ALG2, not its fixed point [LTL87 sec. 3], so a run that re-factorizes K with
// a new R along the way reaches the answer of the plain run at the configuration's R.
TEST(AdaptiveR, Eq4_1to4_3_Fig5_FromR20ItLowersRToItsFloorAndReachesTheSameFixedPoint) {
  auto solve = [](const Problem& p) {
    Solver solver(p);
    State s = solver.initial_state();
    const StepReport r = solver.solve_step(s, s.beta);
    EXPECT_TRUE(r.converged) << r.status;
    EXPECT_EQ(solver.factorizations(), 1 + r.R_changes);
    return std::make_pair(r, s);
  };
  const auto [plain, s_plain] = solve(fig5({"algorithm.R=20"}));
  const Problem p = fig5({"algorithm.R=20", "algorithm.adaptive_R=true"});
  // The floor: the default rule's R q = 6 (C1 + C2) in plane strain, R_min = 3 with q = 1000 kPa.
  EXPECT_NEAR(p.algorithm.R_min, 6 * (435e3 + 65e3) / 1000e3, 1e-12);
  const auto [adapted, s_adapted] = solve(p);
  std::printf("  R = 20: %d iterations; adaptive: %d iterations, R = %g after %d changes\n",
              plain.iterations, adapted.iterations, adapted.R, adapted.R_changes);
  EXPECT_GE(adapted.R_changes, 1);
  EXPECT_LE(adapted.R_changes, p.algorithm.max_refactorizations);
  EXPECT_LT(adapted.R, 20);
  EXPECT_GE(adapted.R, p.algorithm.R_min);
  EXPECT_LT(adapted.iterations, plain.iterations);
  // The same fixed point: u to the stopping tolerance's scale (tol 1e-9 on a 1 m cylinder).
  EXPECT_LT((s_adapted.u - s_plain.u).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(adapted.force_residual, 1e-5);
}

TEST(AdaptiveR, NeverBelowItsFloorNorMoreRefactorizationsThanAllowed) {
  const Problem p = fig5({"algorithm.R=20", "algorithm.adaptive_R=true", "algorithm.R_min=12",
                          "algorithm.adapt_every=5", "algorithm.max_refactorizations=1"});
  Solver solver(p);
  State s = solver.initial_state();
  std::vector<double> Rs;
  const StepReport r =
      solver.solve_step(s, s.beta, [&](const IterationRecord&) { Rs.push_back(solver.R()); });
  EXPECT_TRUE(r.converged) << r.status;
  EXPECT_EQ(r.R_changes, 1);
  EXPECT_EQ(solver.factorizations(), 2);
  EXPECT_GE(*std::min_element(Rs.begin(), Rs.end()), 12.0);
  EXPECT_EQ(r.R, 12.0);
}

TEST(AdaptiveR, BadKeysAreClearErrors) {
  for (const std::string bad : {"algorithm.R_min=0", "algorithm.adapt_every=0",
                                "algorithm.max_refactorizations=-1", "algorithm.adaptive_R=1"}) {
    try {
      fig5({bad});
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      const std::string key = bad.substr(10, bad.find('=') - 10);
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}
