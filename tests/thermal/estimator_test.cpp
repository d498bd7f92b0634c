// Machine-error estimator: fits a lag model, beats the straight line at the
// load changes on a twin-like synthetic log, and refuses logs it cannot use.
#include "ttp/thermal/estimator.h"

#include <gtest/gtest.h>

#include <cmath>

#include "synthetic_log.h"
#include "ttp/geometry/error.h"

namespace ttp::thermal {
namespace {

TalcLog Parse(const test::SyntheticRun& run) {
  return ParseTalcLog(run.Text(Config{}), "synthetic.csv");
}

// RMS over the four linear errors (um) of estimate - truth on [t0, t1].
// Largest |estimate - truth| over the four linear errors (um) on [t0, t1].
template <typename F>
double MaxAgainstTruth(const test::SyntheticRun& run, F estimate, double t0,
                       double t1) {
  double m = 0;
  for (double t = t0; t <= t1; t += 60) {
    const auto e = estimate(t).ToMicro();
    const auto y = run.TruthMicro(t);
    for (int i = 0; i < 4; ++i) m = std::max(m, std::abs(e[i] - y[i]));
  }
  return m;
}

template <typename F>
double RmsAgainstTruth(const test::SyntheticRun& run, F estimate, double t0,
                       double t1) {
  double ss = 0;
  int n = 0;
  for (double t = t0; t <= t1; t += 60) {
    const auto e = estimate(t).ToMicro();
    const auto y = run.TruthMicro(t);
    for (int i = 0; i < 4; ++i) ss += (e[i] - y[i]) * (e[i] - y[i]);
    n += 4;
  }
  return std::sqrt(ss / n);
}

TEST(Estimator, FollowsTheTruthWithDenseRTests) {
  test::SyntheticRun run;
  const TalcLog log = Parse(run);
  const auto est = MachineErrorEstimator::Fit(log);
  EXPECT_EQ(est.models().size(), 7u);
  const double rms = RmsAgainstTruth(
      run, [&](double t) { return est.MachineErrorsAt(t); }, est.FirstRTestS(),
      est.LastRTestS());
  EXPECT_LT(rms, 0.1);  // R-test noise 0.05 um, largest error 9.6 um
  // The C-axis speed is the input the errors follow.
  EXPECT_EQ(est.models()[2].inputs.at(0), "c_rpm/1000");
  EXPECT_NEAR(est.models()[2].tau_s.at(0), run.tau_s, 900);
}

// With R-tests an hour apart, a straight line across the
// start of the warm-up and of the cool-down is off by a micrometre or more;
// the dynamic model is not.
TEST(Estimator, DynamicModelBeatsTheLineAtLoadChanges) {
  test::SyntheticRun run;
  run.rtest_interval_s = 3600;
  const TalcLog log = Parse(run);
  const auto est = MachineErrorEstimator::Fit(log);
  for (double change : {run.warmup_s, run.cooldown_s}) {
    const double model = RmsAgainstTruth(
        run, [&](double t) { return est.MachineErrorsAt(t); }, change,
        change + 3600);
    const double line = RmsAgainstTruth(
        run, [&](double t) { return est.LinearErrorsAt(t); }, change,
        change + 3600);
    EXPECT_GT(MaxAgainstTruth(
                  run, [&](double t) { return est.LinearErrorsAt(t); }, change,
                  change + 3600),
              1.0)
        << change;
    EXPECT_LT(model, 0.5 * line) << change;
  }
}

TEST(Estimator, LoadChangeTimesAreTheWarmUpAndCoolDownStarts) {
  test::SyntheticRun run;
  const auto times = LoadChangeTimes(Parse(run));
  ASSERT_EQ(times.size(), 2u);
  EXPECT_NEAR(times[0], run.warmup_s, 60);
  EXPECT_NEAR(times[1], run.cooldown_s, 60);
}

TEST(Estimator, CompareInterpolationShowsTheLineErrorOnThinnedRTests) {
  test::SyntheticRun run;
  const auto c = CompareInterpolation(Parse(run), 3600);
  ASSERT_EQ(c.windows.size(), 2u);
  EXPECT_LE(c.kept_rtests, 11);
  for (const auto& w : c.windows) {
    EXPECT_GE(w.held_out, 5);
    EXPECT_GT(w.max_line_um, 1.0) << w.label;
    EXPECT_LT(w.rms_model_um, 0.5 * w.rms_line_um) << w.label;
  }
}

TEST(Estimator, LeaveOneOutIsHonest) {
  test::SyntheticRun run;
  const TalcLog log = Parse(run);
  const auto cmp = CompareAtLoadChanges(log);
  EXPECT_FALSE(cmp.tested_rtest_times_s.empty());
  EXPECT_GT(cmp.rms_arx_everywhere, 0.0);  // left-out R-test noise remains
  EXPECT_LT(cmp.rms_arx_everywhere, 0.5);
}

TEST(Estimator, CompensationOnAddsThePredictionBack) {
  // The R-tests see machine - pred_ (thesis 6.4.2); the estimator works on
  // the machine's own error.
  std::string text =
      "# talc-log: 1\n# start: 2026-03-02T06:00:00Z\n# compensation: on\n"
      "t_s,event,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,dur_s,pred_EX0C,"
      "pred_EY0C,pred_EZ0T,pred_ER0T,pred_EA0C,pred_EB0C,pred_EC0C\n";
  for (int k = 0; k < 6; ++k) {
    const double t = 95 + 300 * k;
    text +=
        fmt::format("{},sample,,,,,,,,,{},0,{},0,0,0,0\n", t - 60, k, -2.0 * k);
    text += fmt::format("{},rtest,{},0,{},0,0,0,0,95,,,,,,,\n", t, 0.1 * k,
                        -0.2 * k);
  }
  text += "1835,sample,,,,,,,,,6,0,-12,0,0,0,0\n";
  const TalcLog log = ParseTalcLog(text, "comp.csv");
  const auto est = MachineErrorEstimator::Fit(log);
  ASSERT_EQ(est.rtest_errors().size(), 6u);
  for (int k = 0; k < 6; ++k) {
    const double t = est.rtest_times_s()[k];
    // pred_ is linear in time: k at t_k - 60 -> at t_ref = t_k - 47.5.
    const double pred = (t - 35) / 300.0;
    const auto y = est.rtest_errors()[k].ToMicro();
    EXPECT_NEAR(y[0], 0.1 * k + pred, 1e-9) << k;
    EXPECT_NEAR(y[2], -0.2 * k - 2 * pred, 1e-9) << k;
    EXPECT_NEAR(est.PredictedAt(t).ToMicro()[0], pred, 1e-9);
  }
}

TEST(Estimator, RefusesLogsItCannotUse) {
  const std::string head =
      "# talc-log: 1\n# start: 2026-03-02T06:00:00Z\n# compensation: off\n"
      "t_s,event,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,dur_s,pred_EX0C,"
      "pred_EY0C,pred_EZ0T,pred_ER0T,pred_EA0C,pred_EB0C,pred_EC0C\n";
  const std::string one =
      head + "95,rtest,0,0,0,0,0,0,0,95,,,,,,,\n200,sample,,,,,,,,,,,,,,,\n";
  EXPECT_THROW(MachineErrorEstimator::Fit(ParseTalcLog(one, "one")),
               InputError);
  std::string two = one + "395,rtest,1,1,1,1,1,1,1,95,,,,,,,\n";
  EXPECT_NO_THROW(MachineErrorEstimator::Fit(ParseTalcLog(two, "two")));
  two.replace(two.find("compensation: off"), 17, "compensation: on");
  EXPECT_THROW(MachineErrorEstimator::Fit(ParseTalcLog(two, "two")),
               InputError);
}

}  // namespace
}  // namespace ttp::thermal
