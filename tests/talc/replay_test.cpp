// Replay semantics (schedule, Q_Prod, causality) on constructed series,
// identification on outputs that are an exact linear function of lagged
// inputs, a two-node thermal plant, and the real FL thermal data.
#include "ttp/talc/replay.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <set>

#include "synthetic_series.h"
#include "ttp/geometry/error.h"
#include "ttp/models/time_series.h"

namespace ttp::talc {
namespace {

TEST(ResidualFigures, RmsP99AndPeakToValley) {
  std::vector<double> r;
  for (int i = 1; i <= 101; ++i) r.push_back(i % 2 ? -double(i) : double(i));
  const Figures f = ResidualFigures(r);
  // |r| = 1..101; P99 at rank 0.99*100 = 99 (0-based) -> 100.
  EXPECT_DOUBLE_EQ(f.p99_um, 100.0);
  EXPECT_DOUBLE_EQ(f.ptv_um, 100.0 + 101.0);
  double ss = 0;
  for (int i = 1; i <= 101; ++i) ss += double(i) * i;
  EXPECT_DOUBLE_EQ(f.rms_um, std::sqrt(ss / 101));
  EXPECT_EQ(f.samples, 101);
}

TEST(Replay, ExactLinearOutputsAreRecoveredAfterCalibration) {
  // Jittered sampling: the lags are discretised for every step length.
  const auto s = test::LaggedLinearSeries(30 * 3600, 15, 5, 21);
  Strategy st;
  st.calibration_s = 8 * 3600;
  st.interval_s = 3600;
  st.ridge = 1e-9;
  st.regressors.speed_lags_s = {1800, 7200};
  st.regressors.speed_squared = true;
  st.regressors.temperatures = {"T_env"};
  for (bool anchored : {true, false}) {
    st.anchored = anchored;
    const ReplayResult r = Replay(s, st);
    ASSERT_EQ(r.status, ReplayStatus::kOk);
    EXPECT_EQ(r.rank_at_start, 6);
    ASSERT_EQ(r.outputs.size(), 2u);
    for (const auto& o : r.outputs) {
      EXPECT_LT(o.talc.p99_um, 1e-3) << o.name << " anchored " << anchored;
      EXPECT_GT(o.hold.p99_um, 0.5) << o.name;
      EXPECT_GT(o.none.p99_um, 2.0) << o.name;
    }
    // The generator's own coefficients (1, n and n^2 at 1800 s and 7200 s,
    // dT_env).
    const Eigen::VectorXd& a = r.outputs[0].theta;
    const double expected_a[] = {1, 3, -1.5, 2, 0.5, 4};
    for (int j = 0; j < 6; ++j) EXPECT_NEAR(a(j), expected_a[j], 1e-3) << j;
    const double expected_b[] = {0, 0, 0, -6, 0, 2.5};
    for (int j = 0; j < 6; ++j)
      EXPECT_NEAR(r.outputs[1].theta(j), expected_b[j], 1e-3) << j;
  }
}

TEST(Replay, FixedScheduleMeasuringTimeAndQProd) {
  const auto s = test::LaggedLinearSeries(20 * 3600, 15, 0, 2);
  Strategy st;
  st.calibration_s = 4 * 3600;
  st.calibration_interval_s = 300;
  st.interval_s = 3600;
  st.measuring_time_s = 95;
  const ReplayResult r = Replay(s, st);
  // Calibration: 0, 300, ..., 14100 (48); then 17700 + k 3600 <= 72000 (16).
  ASSERT_EQ(r.calibration_measurements, 48);
  ASSERT_EQ(r.measurements, 64);
  EXPECT_EQ(r.measurement_times_s[47], 14100);
  EXPECT_EQ(r.measurement_times_s[48], 17700);
  EXPECT_EQ(r.measurement_times_s.back(), 17700 + 15 * 3600);
  EXPECT_DOUBLE_EQ(r.q_prod, 1.0 - 64 * 95.0 / 72000.0);
  EXPECT_EQ(r.evaluated_from_s, 14400);
  EXPECT_EQ(r.outputs[0].talc.samples, int((72000 - 14400) / 15) + 1);

  // A measurement longer than the calibration interval: the next one starts
  // when the previous one has ended (at the next sample).
  st.calibration_interval_s = 60;
  st.measuring_time_s = 200;
  const ReplayResult slow = Replay(s, st);
  for (int k = 1; k < slow.calibration_measurements; ++k)
    EXPECT_EQ(slow.measurement_times_s[size_t(k)] -
                  slow.measurement_times_s[size_t(k) - 1],
              210);
}

// An output the log never measures (a channel not connected) would stop
// every measurement, as the outputs are measured together: it is left out
// and said; the others replay exactly as without it. Named by the strategy,
// it is bad input.
TEST(Replay, AnOutputNeverMeasuredIsLeftOut) {
  const auto s = test::LaggedLinearSeries(20 * 3600, 15, 0, 2);
  auto with = s;
  with.output_names.push_back("d_unplugged");
  with.outputs_um.conservativeResize(Eigen::NoChange,
                                     with.outputs_um.cols() + 1);
  with.outputs_um.col(with.outputs_um.cols() - 1)
      .setConstant(std::numeric_limits<double>::quiet_NaN());
  Strategy st;
  st.calibration_s = 4 * 3600;
  const ReplayResult a = Replay(s, st);
  const ReplayResult b = Replay(with, st);
  ASSERT_EQ(b.outputs.size(), a.outputs.size());
  EXPECT_EQ(b.measurement_times_s, a.measurement_times_s);
  for (size_t o = 0; o < a.outputs.size(); ++o)
    EXPECT_EQ(b.outputs[o].talc.rms_um, a.outputs[o].talc.rms_um);
  bool said = false;
  for (const auto& w : b.warnings)
    said |= w.find("d_unplugged is never measured") != std::string::npos;
  EXPECT_TRUE(said);
  st.outputs = {s.output_names[0], "d_unplugged"};
  EXPECT_THROW(Replay(with, st), InputError);
}

// A measurement still running at the log's end counts up to the end:
// Q_Prod stays in 0..1 however long a measurement takes.
TEST(Replay, QProdCountsMeasuringTimeInsideTheLog) {
  const auto s = test::LaggedLinearSeries(20 * 3600, 15, 0, 2);
  Strategy st;
  st.calibration_s = 4 * 3600;
  st.calibration_interval_s = 300;
  st.interval_s = 600;
  st.measuring_time_s = 7200;
  const ReplayResult r = Replay(s, st);
  EXPECT_GE(r.q_prod, 0.0);
  EXPECT_NEAR(r.q_prod, 0.0, 1e-12);  // measuring back to back to the end
  st.measuring_time_s = 1e9;
  const ReplayResult one = Replay(s, st);
  EXPECT_EQ(one.measurements, 1);
  EXPECT_DOUBLE_EQ(one.q_prod, 0.0);
}

TEST(Replay, NeverReadsAnOutputItDidNotMeasure) {
  const auto s = test::TwoNodePlant{}.Make(36 * 3600, 15);
  Strategy st;
  st.mode = IntervalMode::kAdaptive;
  st.threshold_um = 2;
  st.min_interval_s = 600;
  st.max_interval_s = 3 * 3600;
  st.ng_measurements = 4;
  st.action_limit_um = 1.0;
  st.forgetting_per_h = 0.97;
  st.calibration_s = 6 * 3600;
  st.regressors.temperatures = {"T_air"};
  ReplayOptions opt;
  opt.keep_predictions = true;
  const ReplayResult a = Replay(s, st, opt);
  EXPECT_GT(a.ng_phases, 0);  // the No-Good path is exercised too
  std::set<double> measured(a.measurement_times_s.begin(),
                            a.measurement_times_s.end());
  auto perturbed = s;
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0, 50);
  int changed = 0;
  for (size_t i = 0; i < s.rows(); ++i) {
    if (measured.count(s.t_s[i])) continue;
    for (Eigen::Index o = 0; o < s.outputs_um.cols(); ++o)
      perturbed.outputs_um(Eigen::Index(i), o) += g(rng);
    ++changed;
  }
  ASSERT_GT(changed, int(s.rows()) - 200);
  const ReplayResult b = Replay(perturbed, st, opt);
  EXPECT_EQ(a.measurement_times_s, b.measurement_times_s);
  EXPECT_TRUE(a.predictions_um == b.predictions_um);  // bit for bit
  // ...while changing one measured value does change the predictions.
  auto one = s;
  const size_t k = size_t(
      std::lower_bound(s.t_s.begin(), s.t_s.end(), a.measurement_times_s[60]) -
      s.t_s.begin());
  one.outputs_um(Eigen::Index(k), 0) += 5.0;
  EXPECT_FALSE(Replay(one, st, opt).predictions_um == a.predictions_um);
}

TEST(Replay, AdaptiveIntervalsStayWithinTheirBounds) {
  const auto s = test::TwoNodePlant{}.Make(36 * 3600, 15);
  Strategy st;
  st.mode = IntervalMode::kAdaptive;
  st.threshold_um = 3;
  st.min_interval_s = 900;
  st.max_interval_s = 4 * 3600;
  st.calibration_s = 6 * 3600;
  const ReplayResult r = Replay(s, st);
  int short_ones = 0;
  for (size_t k = size_t(r.calibration_measurements) + 1;
       k < r.measurement_times_s.size(); ++k) {
    const double d = r.measurement_times_s[k] - r.measurement_times_s[k - 1];
    EXPECT_GE(d, 900);
    EXPECT_LE(d, 4 * 3600 + 15);
    if (d < 4 * 3600) ++short_ones;  // triggered by the threshold
  }
  EXPECT_GT(short_ones, 0);
}

TEST(Replay, AGapForcesAMeasurement) {
  auto s = test::LaggedLinearSeries(12 * 3600, 15, 0, 3);
  // Declare a gap at 10 h (the reader marks such rows).
  const size_t g = size_t(10 * 3600 / 15) + 7;
  s.gap_rows.push_back(g);
  Strategy st;
  st.calibration_s = 2 * 3600;
  st.interval_s = 6 * 3600;
  const ReplayResult r = Replay(s, st);
  EXPECT_NE(std::find(r.measurement_times_s.begin(),
                      r.measurement_times_s.end(), s.t_s[g]),
            r.measurement_times_s.end());
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("gap"), std::string::npos);
}

TEST(Replay, TwoNodePlantHourlyBeatsHoldingTheLastMeasurement) {
  const auto s = test::TwoNodePlant{}.Make(46 * 3600, 15);
  Strategy st;
  st.interval_s = 3600;
  st.forgetting_per_h = 0.98;
  const ReplayResult r = Replay(s, st);
  for (const auto& o : r.outputs) {
    EXPECT_LT(o.talc.p99_um, 0.5 * o.hold.p99_um) << o.name;
    EXPECT_LT(o.talc.p99_um, 0.2 * o.none.p99_um) << o.name;
    // The plant's outputs are linear in its measured node temperatures:
    // the static model updated at the same measurements has the true
    // structure and does not lose to TALC's speed lags (within 10 %); the
    // static model frozen after calibration does.
    EXPECT_LT(o.static_model.p99_um, 1.1 * o.talc.p99_um) << o.name;
    EXPECT_LT(o.static_model.p99_um, o.static_frozen.p99_um) << o.name;
  }
}

TEST(Replay, RealFlDataHourlyIsFarBelowHoldingTheLastMeasurement) {
  const auto s = models::ReadThermalLog(std::string(TTP_DATA_DIR) +
                                        "/reference/fl-thermal/train.csv");
  Strategy st;  // the defaults: 8.5 h calibration, then one per hour
  st.interval_s = 3600;
  const ReplayResult r = Replay(s, st);
  ASSERT_EQ(r.outputs.size(), 5u);
  for (const auto& o : r.outputs) {
    EXPECT_LT(o.talc.p99_um, 0.5 * o.hold.p99_um) << o.name;
    // Against the fair static baseline (updated at the same measurements).
    EXPECT_LT(o.talc.p99_um, o.static_model.p99_um) << o.name;
    // Updating makes the static model far better than freezing it after a
    // calibration that saw one speed only.
    EXPECT_LT(o.static_model.p99_um, 0.5 * o.static_frozen.p99_um) << o.name;
  }
  // The window baseline is fitted on the whole log by default: in-sample,
  // and said so.
  EXPECT_TRUE(r.static_window_in_sample);
  EXPECT_EQ(r.static_window_samples, int(s.rows()));
  ReplayOptions first_half;
  first_half.static_window_to_s = 40000;
  const ReplayResult h = Replay(s, st, first_half);
  EXPECT_TRUE(h.static_window_in_sample);  // overlaps 8.5 h .. 40000 s
  EXPECT_LE(h.static_window_to_s, 40000);
  EXPECT_GT(h.outputs[0].static_window.rms_um,
            r.outputs[0].static_window.rms_um);
}

}  // namespace
}  // namespace ttp::talc
