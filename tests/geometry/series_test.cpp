#include "ttp/geometry/series.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>

namespace ttp {
namespace {

TEST(Interpolate, LinearBetweenHeldOutside) {
  const std::vector<double> t = {0, 10, 30};
  const std::vector<double> v = {1, 3, -1};
  EXPECT_DOUBLE_EQ(Interpolate(t, v, -5.0), 1);
  EXPECT_DOUBLE_EQ(Interpolate(t, v, 0.0), 1);
  EXPECT_DOUBLE_EQ(Interpolate(t, v, 5.0), 2);
  EXPECT_DOUBLE_EQ(Interpolate(t, v, 10.0), 3);
  EXPECT_DOUBLE_EQ(Interpolate(t, v, 20.0), 1);
  EXPECT_DOUBLE_EQ(Interpolate(t, v, 99.0), -1);
  const std::vector<Eigen::Vector2d> p = {{0, 0}, {2, -4}, {2, 0}};
  EXPECT_TRUE(Interpolate(t, p, 5.0).isApprox(Eigen::Vector2d(1, -2)));
}

TEST(InterpolateUniform, SameAsOnTheExplicitGrid) {
  const std::vector<double> v = {4, -2, 7, 7, 1};
  const std::vector<double> t = {10, 12.5, 15, 17.5, 20};
  for (double x = 5; x < 25; x += 0.37)
    EXPECT_NEAR(InterpolateUniform(v, 10, 2.5, x), Interpolate(t, v, x), 1e-12)
        << x;
  EXPECT_EQ(InterpolateUniform({}, 0, 1, 3), 0);
}

// The response to a step and to a ramp against the closed forms
// y = 1 - exp(-t / tau) and y = t - tau (1 - exp(-t / tau)).
TEST(LagFilter, StepAndRampMatchTheClosedForm) {
  const double tau = 120, step = 7;
  std::vector<double> ones(200, 1.0), ramp(200);
  ones[0] = 0;
  for (size_t i = 0; i < ramp.size(); ++i) ramp[i] = i * step;
  const std::vector<double> y = LagFilter(ramp, step, tau);
  for (size_t i = 0; i < y.size(); ++i) {
    const double t = i * step;
    EXPECT_NEAR(y[i], t - tau * (1 - std::exp(-t / tau)), 1e-9) << i;
  }
  // A step between samples 0 and 1 is a ramp over the first step; after it
  // the output relaxes as exp(-(t - step) / tau).
  const std::vector<double> s = LagFilter(ones, step, tau);
  const double y1 = 1 - tau / step * (1 - std::exp(-step / tau));
  EXPECT_NEAR(s[1], y1, 1e-12);
  EXPECT_NEAR(s[50], 1 - (1 - y1) * std::exp(-49 * step / tau), 1e-12);
  EXPECT_TRUE(LagFilter({}, step, tau).empty());
  EXPECT_DOUBLE_EQ(LagFilter({2, 5}, step, 0)[1], 5);  // no lag
}

}  // namespace
}  // namespace ttp
