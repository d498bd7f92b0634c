#include "ttp/talc/regressors.h"

#include <gtest/gtest.h>

#include <cmath>

#include "synthetic_series.h"
#include "ttp/geometry/error.h"

namespace ttp::talc {
namespace {

TEST(FirstOrderLag, IsTheExactStepResponseOnIrregularSteps) {
  const std::vector<double> t = {0, 7, 30, 31, 400, 401.5, 2000, 9000};
  std::vector<double> u(t.size(), 2.0);
  u[0] = 0.0;  // step to 2 held from t[1] on
  const auto x = FirstOrderLag(t, u, 600.0);
  EXPECT_EQ(x[0], 0.0);
  EXPECT_EQ(x[1], 0.0);  // the step starts at t[1] (input held from there)
  for (size_t k = 1; k < t.size(); ++k)
    EXPECT_NEAR(x[k], 2.0 * (1 - std::exp(-(t[k] - t[1]) / 600.0)), 1e-12);
}

TEST(FirstOrderLag, MatchesAnRk4IntegrationOfTheHeldInput) {
  const auto t = test::Times(20000, 15, 5, 4);
  const auto n = test::SpeedBlocks(t, 5);
  const auto x = FirstOrderLag(t, n, 2500);
  const auto ref = test::Rk4Lag(t, n, 2500);
  for (size_t k = 0; k < t.size(); ++k) EXPECT_NEAR(x[k], ref[k], 1e-6);
}

TEST(BuildRegressors, NamesColumnsAndScalesSpeeds) {
  const auto s = test::LaggedLinearSeries(8 * 3600, 60, 0, 1);
  RegressorSpec spec;
  spec.speed_lags_s = {0, 1800};
  spec.speed_squared = true;
  spec.temperatures = {"T_env"};
  const Regressors r = BuildRegressors(s, spec);
  ASSERT_EQ(r.names.size(), 6u);
  EXPECT_EQ(r.names[0], "1");
  EXPECT_EQ(r.names[1], "lag(n_spindle,0s)");
  EXPECT_EQ(r.names[5], "dT_env");
  for (Eigen::Index i = 0; i < r.values.rows(); ++i) {
    EXPECT_DOUBLE_EQ(r.values(i, 1), s.inputs(i, 0) / 1000);
    EXPECT_DOUBLE_EQ(r.values(i, 2), std::pow(s.inputs(i, 0) / 1000, 2));
    EXPECT_DOUBLE_EQ(r.values(i, 5), s.inputs(i, 1) - s.inputs(0, 1));
    EXPECT_EQ(r.rows(i, 3), r.values(i, 3));
  }
  spec.temperatures = {"all"};
  EXPECT_EQ(BuildRegressors(s, spec).names.back(), "dT_env");
}

TEST(BuildRegressors, AnUnknownTemperatureIsNamed) {
  const auto s = test::LaggedLinearSeries(3600, 60, 0, 1);
  RegressorSpec spec;
  spec.temperatures = {"T_nowhere"};
  try {
    BuildRegressors(s, spec);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "T_nowhere");
  }
}

}  // namespace
}  // namespace ttp::talc
