// Regression against stored reference data (tests/reference/regression.toml): reduced versions
// of Figs 3-6 summarized by norms, extremes, positions and iteration counts, each compared with
// its stored value within its stored tolerance. Regenerate with `make reference`.
#include <gtest/gtest.h>
#include <toml++/toml.h>

#include "regression.hpp"
#include "testing.hpp"

namespace {

class Regression : public ::testing::TestWithParam<ltl::regression::Case> {};

TEST_P(Regression, MatchesStoredReference) {
  const auto& c = GetParam();
  const toml::table ref = toml::parse_file(ltl::testing::test_path("reference/regression.toml"));
  const toml::table* stored = ref[c.name].as_table();
  ASSERT_NE(stored, nullptr) << "no reference data for " << c.name << ": run `make reference`";
  const auto metrics = ltl::regression::evaluate(c, ltl::testing::source_path(""));
  EXPECT_EQ(metrics.size(), stored->size()) << "metrics changed: run `make reference`";
  for (const auto& m : metrics) {
    const auto* entry = (*stored)[m.name].as_table();
    ASSERT_NE(entry, nullptr) << c.name << "." << m.name << " missing in the reference";
    const double value = (*entry)["value"].value_or(std::nan("")),
                 tol = (*entry)["tol"].value_or(0.0);
    EXPECT_NEAR(m.value, value, tol) << c.name << "." << m.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Figures, Regression, ::testing::ValuesIn(ltl::regression::cases()),
                         [](const auto& info) { return info.param.name; });

}  // namespace
