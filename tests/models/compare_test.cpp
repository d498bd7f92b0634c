// Quality figures (thesis 4.2.3) and the diagnosis of a residual on
// constructed cases whose answer is known by construction.
#include "ttp/models/compare.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <cmath>

namespace ttp::models {
namespace {

TEST(Compare, PercentileFollowsThesisDefinition) {
  // N = 4, X = 0.5: k = 2.5 -> halfway between the 2nd and 3rd values.
  EXPECT_DOUBLE_EQ(Percentile({4, 1, 3, 2}, 0.5), 2.5);
  // X = 0.99: k = 4.46 > N -> the largest.
  EXPECT_DOUBLE_EQ(Percentile({4, 1, 3, 2}, 0.99), 4.0);
  std::vector<double> v;
  for (int i = 1; i <= 100; ++i) v.push_back(i);
  // k = 99.5 -> 99.5.
  EXPECT_DOUBLE_EQ(Percentile(v, 0.99), 99.5);
}

TEST(Compare, StatsOfAKnownResidual) {
  Eigen::VectorXd m(4), p(4);
  m << 1, 2, std::nan(""), 4;
  p << 0, 0, 5, 6;
  const ResidualStats s = ComputeStats(m, p, 4.0);
  EXPECT_EQ(s.n, 3);
  EXPECT_NEAR(s.rms_um, std::sqrt((1 + 4 + 4) / 3.0), 1e-12);
  EXPECT_NEAR(s.pv_um, 2 - (-2), 1e-12);
  EXPECT_NEAR(s.reduction_pct, 100 * (1 - std::sqrt(3.0) / 4.0), 1e-9);
}

// A first-order system seen through a static prediction: the measurement
// lags; a jump in one sensor is found and named.
TEST(Compare, DiagnosesLagAndSensorJump) {
  TimeSeries ts;
  ts.source = "synthetic";
  ts.input_names = {"T_a", "T_b"};
  ts.output_names = {"d_x"};
  const int n = 2000;
  ts.inputs.resize(n, 2);
  ts.outputs_um.resize(n, 1);
  Eigen::VectorXd pred(n);
  double y = 0;
  for (int i = 0; i < n; ++i) {
    const double t = 30.0 * i;
    ts.t_s.push_back(t);
    const double temp = 20 + 3 * std::sin(2 * M_PI * t / 20000.0);
    y += (temp - 20 - y) * (1 - std::exp(-30.0 / 1800.0));
    ts.inputs(i, 0) = temp;
    ts.inputs(i, 1) = 25 + (i >= 1500 ? 2.0 : 0.0) + 1e-3 * std::sin(i);
    ts.outputs_um(i, 0) = 5 * y;
    pred(i) = 5 * (temp - 20);
  }
  const Diagnosis lag = Diagnose(ts, 1000, 0, pred, "static");
  EXPECT_NEAR(lag.lag_s, 1800, 400);
  EXPECT_GT(lag.loop_ratio, 0.1);
  EXPECT_EQ(lag.jump_input, "T_b");
  EXPECT_DOUBLE_EQ(lag.jump_t_s, 1500 * 30.0);
  EXPECT_NEAR(lag.jump_size, 2.0, 0.01);
  // Without the jump the lag is what is named.
  ts.inputs.col(1).setConstant(25);
  const Diagnosis d = Diagnose(ts, 1000, 0, pred, "static");
  EXPECT_TRUE(d.jump_input.empty());
  EXPECT_EQ(d.problem.rfind("lag", 0), 0u) << d.problem;
}

// A spindle heated by a n + b n^2 (first-order node, 1200 s), measured by
// two redundant sensors T_s1, T_s2; the displacement follows the spindle
// temperature through a slower structure (5400 s). Speed blocks of 3 h.
TimeSeries LaggingStructure(bool jump, double jump_h = 30) {
  TimeSeries ts;
  ts.source = "lagging-structure";
  ts.input_names = {"n_spindle", "T_s1", "T_s2"};
  ts.output_names = {"d_x"};
  const int n = 2400;  // 40 h at 60 s
  ts.inputs.resize(n, 3);
  ts.outputs_um.resize(n, 1);
  const double levels[] = {2000, 0,    4000, 0,    1000, 0,    3000,
                           0,    2500, 0,    3500, 0,    1500, 0};
  double temp = 20, structure = 20;
  for (int i = 0; i < n; ++i) {
    const double t = 60.0 * i;
    ts.t_s.push_back(t);
    const double rpm = levels[static_cast<int>(t / 10800.0) % 14];
    const double k = rpm / 1000.0;
    const double target = 20 + 0.8 * k + 0.15 * k * k;
    temp += (target - temp) * (1 - std::exp(-60.0 / 1200.0));
    structure += (temp - structure) * (1 - std::exp(-60.0 / 5400.0));
    ts.inputs(i, 0) = rpm;
    ts.inputs(i, 1) = temp + 0.01 * std::sin(1.7 * i);
    ts.inputs(i, 2) = temp + 0.01 * std::cos(1.3 * i) +
                      (jump && t >= jump_h * 3600.0 ? 3.0 : 0.0);
    ts.outputs_um(i, 0) = 6 * (structure - 20);
  }
  return ts;
}

// The static model on all temperatures misses the structure's delay: the
// comparison names the lag and its extension gains on the holdout; with a
// jump of one redundant sensor in the holdout, the jump is named and leaving
// the sensor out gains.
TEST(Compare, NamesTheErrorAndMeasuresTheExtension) {
  const double from = 26 * 3600.0;
  const CompareResult r = CompareModels(LaggingStructure(false), from, {});
  ASSERT_EQ(r.simplest.size(), 1u);
  EXPECT_EQ(r.simplest[0], "static_all_T");
  const Diagnosis& d = r.simplest_diag[0];
  EXPECT_EQ(d.kind, ErrorKind::kLag) << d.problem;
  EXPECT_LT(d.extended_rms_um, 0.5 * d.rms_um) << d.extension;
  const CompareResult j = CompareModels(LaggingStructure(true), from, {});
  const Diagnosis& e = j.simplest_diag[0];
  EXPECT_EQ(e.kind, ErrorKind::kJump) << e.problem;
  EXPECT_EQ(e.jump_input, "T_s2");
  EXPECT_NE(e.extension.find("T_s2"), std::string::npos);
  EXPECT_LT(e.extended_rms_um, e.rms_um) << e.extension;
  // The text states the measured difference, not a canned line.
  const std::string text = CompareText(j);
  EXPECT_NE(
      text.find(fmt::format("{:.2f} -> {:.2f}", e.rms_um, e.extended_rms_um)),
      std::string::npos)
      << text;
}

// A jump of one redundant sensor inside the fitted span (in the middle of a
// speed block) is shifted out of it and of the holdout, as `thermal fit`
// and `predict` do: the comparison says so, and the models on every
// temperature are nearly what they are without the jump.
TEST(Compare, ShiftsOutAJumpInsideTheFittedSpan) {
  const double from = 34 * 3600.0;
  const CompareResult clean = CompareModels(LaggingStructure(false), from, {});
  const CompareResult r = CompareModels(LaggingStructure(true, 31.5), from, {});
  bool said = false;
  for (const auto& w : r.warnings)
    said |= w.rfind("T_s2 jumps by +3.0", 0) == 0 ||
            w.rfind("T_s2 jumps by +2.9", 0) == 0;
  EXPECT_TRUE(said) << CompareText(r);
  EXPECT_NE(r.simplest_diag[0].kind, ErrorKind::kJump);
  // Kept (--keep-jumps): the models on every temperature learn the step.
  FitOptions keep;
  keep.repair_jumps = false;
  const CompareResult k =
      CompareModels(LaggingStructure(true, 31.5), from, keep);
  EXPECT_NE(k.warnings.back().find("not repaired"), std::string::npos);
  // The entries that use every temperature (a forward selection may choose
  // differently on a series that differs by the step's estimate, 0.01 K).
  ASSERT_EQ(r.entries.size(), clean.entries.size());
  ASSERT_EQ(k.entries.size(), clean.entries.size());
  int checked = 0;
  for (size_t e = 0; e < r.entries.size(); ++e) {
    const std::string& name = r.entries[e].name;
    if (name != "static_all_T" && name != "joint" && name != "auto" &&
        name != "static_T_ols")
      continue;
    ++checked;
    const double want = clean.entries[e].stats[0].rms_um;
    EXPECT_NEAR(r.entries[e].stats[0].rms_um, want, 0.05 + 0.02 * want) << name;
    EXPECT_GT(k.entries[e].stats[0].rms_um, want + 1.0) << name;
  }
  EXPECT_EQ(checked, 4);
}

// The README's simple models are shown fitted its way: the static entry is
// the ordinary least-squares fit on all temperatures (checked against an
// independent QR solve), both are marked "readme" and never named best.
TEST(Compare, ShowsTheReadmeModelsFittedByOrdinaryLeastSquares) {
  const double from = 26 * 3600.0;
  const TimeSeries ts = LaggingStructure(false);
  const CompareResult r = CompareModels(ts, from, {});
  const CompareEntry* ols = nullptr;
  const CompareEntry* lag = nullptr;
  for (const auto& e : r.entries) {
    if (e.name == "static_T_ols") ols = &e;
    if (e.name == "lag_speed_ols") lag = &e;
  }
  ASSERT_NE(ols, nullptr);
  ASSERT_NE(lag, nullptr);
  EXPECT_EQ(ols->kind, "readme");
  EXPECT_EQ(lag->kind, "readme");
  EXPECT_NE(r.best[0], "static_T_ols");
  EXPECT_NE(r.best[0], "lag_speed_ols");
  // Independent OLS: [1, T_s1, T_s2] on the rows before `from`.
  int n_fit = 0;
  while (ts.t_s[n_fit] < from) ++n_fit;
  Eigen::MatrixXd x(n_fit, 3);
  x.col(0).setOnes();
  x.rightCols(2) = ts.inputs.block(0, 1, n_fit, 2);
  const Eigen::VectorXd beta =
      x.colPivHouseholderQr().solve(ts.outputs_um.col(0).head(n_fit));
  double sse = 0;
  int n = 0;
  for (Eigen::Index i = n_fit; i < ts.inputs.rows(); ++i) {
    const double p =
        beta(0) + beta(1) * ts.inputs(i, 1) + beta(2) * ts.inputs(i, 2);
    sse += std::pow(ts.outputs_um(i, 0) - p, 2), ++n;
  }
  // Tight: the ridge version (static_all_T) differs here by 0.25 %.
  EXPECT_NEAR(ols->stats[0].rms_um, std::sqrt(sse / n),
              1e-4 * std::sqrt(sse / n));
  EXPECT_TRUE(std::isfinite(lag->stats[0].rms_um));
  EXPECT_NE(CompareText(r).find("lag_speed_ols"), std::string::npos);
}

}  // namespace
}  // namespace ttp::models
