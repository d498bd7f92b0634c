// Regressor bank against an independent integration: tau y' = u - y solved
// by small-step RK4 with the input linear between samples, irregular steps.
#include "ttp/models/features.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "ttp/geometry/error.h"

namespace ttp::models {
namespace {

TimeSeries Series(const std::vector<double>& t,
                  const std::function<double(double)>& temp) {
  TimeSeries ts;
  ts.source = "synthetic";
  ts.t_s = t;
  ts.input_names = {"n_s", "T_a"};
  ts.inputs.resize(static_cast<Eigen::Index>(t.size()), 2);
  for (size_t i = 0; i < t.size(); ++i) {
    ts.inputs(i, 0) = 1000.0 * (1 + std::sin(t[i] / 700.0));
    ts.inputs(i, 1) = temp(t[i]);
  }
  ts.outputs_um.resize(static_cast<Eigen::Index>(t.size()), 0);
  return ts;
}

// Input linear between samples; RK4 with step h of one or two lags.
std::vector<double> Rk4Lags(const TimeSeries& ts, int col, double scale,
                            int power, const std::vector<double>& taus) {
  auto u_at = [&](double t) {
    size_t k = 1;
    while (k < ts.rows() - 1 && ts.t_s[k] < t) ++k;
    const double f = (t - ts.t_s[k - 1]) / (ts.t_s[k] - ts.t_s[k - 1]);
    auto tr = [&](size_t i) {
      const double x = ts.inputs(i, col) * scale;
      return power == 2 ? x * x : x;
    };
    return tr(k - 1) + f * (tr(k) - tr(k - 1));
  };
  std::vector<double> y(taus.size(), u_at(ts.t_s[0]));
  std::vector<double> out = {y.back()};
  auto deriv = [&](double t, const std::vector<double>& s) {
    std::vector<double> d(s.size());
    double in = u_at(t);
    for (size_t j = 0; j < s.size(); ++j) {
      d[j] = (in - s[j]) / taus[j];
      in = s[j];
    }
    return d;
  };
  const double h = 0.5;
  for (size_t i = 1; i < ts.rows(); ++i) {
    double t = ts.t_s[i - 1];
    while (t < ts.t_s[i] - 1e-9) {
      const double step = std::min(h, ts.t_s[i] - t);
      auto add = [&](const std::vector<double>& a, const std::vector<double>& b,
                     double f) {
        std::vector<double> r(a.size());
        for (size_t j = 0; j < a.size(); ++j) r[j] = a[j] + f * b[j];
        return r;
      };
      const auto k1 = deriv(t, y);
      const auto k2 = deriv(t + step / 2, add(y, k1, step / 2));
      const auto k3 = deriv(t + step / 2, add(y, k2, step / 2));
      const auto k4 = deriv(t + step, add(y, k3, step));
      for (size_t j = 0; j < y.size(); ++j)
        y[j] += step / 6 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
      t += step;
    }
    out.push_back(y.back());
  }
  return out;
}

std::vector<double> IrregularTimes() {
  std::vector<double> t = {0};
  for (int i = 1; i < 300; ++i) t.push_back(t.back() + 10 + 37 * ((i * 7) % 5));
  return t;
}

TEST(FeatureBank, LagIsExactForIrregularSteps) {
  const TimeSeries ts = Series(
      IrregularTimes(), [](double t) { return 20 + 3 * std::cos(t / 1500.0); });
  const std::vector<Regressor> regs = {
      {"n_s", 1, 0, {600}}, {"n_s", 2, 0, {1800}}, {"T_a", 1, 0, {900, 300}}};
  const Eigen::MatrixXd f = ComputeFeatures(ts, regs);
  const auto r0 = Rk4Lags(ts, 0, 1e-3, 1, {600});
  const auto r1 = Rk4Lags(ts, 0, 1e-3, 2, {1800});
  const auto r2 = Rk4Lags(ts, 1, 1.0, 1, {900, 300});
  for (size_t i = 0; i < ts.rows(); ++i) {
    EXPECT_NEAR(f(i, 0), r0[i], 1e-7) << i;
    EXPECT_NEAR(f(i, 1), r1[i], 1e-7) << i;
    EXPECT_NEAR(f(i, 2), r2[i], 1e-7) << i;
  }
  // The lag really lags: not equal to its input.
  EXPECT_GT((f.col(0) - ts.inputs.col(0) * 1e-3).cwiseAbs().maxCoeff(), 0.05);
  EXPECT_GT((f.col(2) - ts.inputs.col(1)).cwiseAbs().maxCoeff(), 0.05);
}

TEST(FeatureBank, DelayHoldsThePastValue) {
  std::vector<double> t;
  for (int i = 0; i < 50; ++i) t.push_back(15.0 * i);
  const TimeSeries ts = Series(t, [](double x) { return x; });
  const Eigen::MatrixXd f = ComputeFeatures(ts, {{"T_a", 1, 60, {}}});
  for (size_t i = 0; i < ts.rows(); ++i)
    EXPECT_DOUBLE_EQ(f(i, 0), std::max(0.0, t[i] - 60)) << i;
}

TEST(FeatureBank, RestartsAtGapAndContinuesFromState) {
  std::vector<double> t;
  for (int i = 0; i < 100; ++i) t.push_back(15.0 * i + (i >= 60 ? 5000 : 0));
  TimeSeries ts = Series(t, [](double x) { return 20 + x / 1000; });
  ts.gap_rows = {60};
  const std::vector<Regressor> regs = {{"T_a", 1, 0, {3600}},
                                       {"n_s", 2, 120, {600}}};
  const Eigen::MatrixXd f = ComputeFeatures(ts, regs);
  // After the gap the lag starts from the steady state of the restart row.
  EXPECT_DOUBLE_EQ(f(60, 0), ts.inputs(60, 1));
  EXPECT_NE(f(59, 0), ts.inputs(59, 1));
  // Computing in two parts with the state in between gives the same.
  TimeSeries head = ts, tail = ts;
  head.t_s.resize(40);
  head.inputs = ts.inputs.topRows(40).eval();
  // No output columns: a block of an empty matrix offsets a null pointer
  // inside Eigen (undefined behaviour), so the empty halves are made anew.
  head.outputs_um.resize(40, ts.outputs_um.cols());
  head.gap_rows.clear();
  tail.t_s.erase(tail.t_s.begin(), tail.t_s.begin() + 40);
  tail.inputs = ts.inputs.bottomRows(60).eval();
  tail.outputs_um.resize(60, ts.outputs_um.cols());
  tail.gap_rows = {20};
  nlohmann::json state;
  ComputeFeatures(head, regs, nullptr, &state);
  const nlohmann::json roundtrip = nlohmann::json::parse(state.dump());
  const Eigen::MatrixXd g = ComputeFeatures(tail, regs, &roundtrip);
  for (Eigen::Index i = 0; i < 60; ++i)
    for (Eigen::Index k = 0; k < 2; ++k)
      EXPECT_NEAR(g(i, k), f(i + 40, k), 1e-12);
}

TEST(FeatureBank, MissingColumnNamed) {
  try {
    FeatureBank bank({{"T_missing", 1, 0, {}}}, {"T_a"}, "log.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "T_missing");
    EXPECT_EQ(e.source(), "log.csv");
  }
}

}  // namespace
}  // namespace ttp::models
