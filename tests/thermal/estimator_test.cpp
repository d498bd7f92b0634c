// Machine-error estimator: fits a lag model, beats the straight line at the
// load changes on a twin-like synthetic log, and refuses logs it cannot use.
#include "ttp/thermal/estimator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "synthetic_log.h"
#include "ttp/geometry/error.h"

namespace ttp::thermal {
namespace {

// Measured when the second-order test was written (about 1.5x margin).
constexpr double kDenseRmsUm = 0.15, kSparseRmsUm = 0.4;

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

// The JSON description holds numbers or null, never "inf": JSON has no
// infinity, and a reader expecting a number must not meet a string. Each
// error's smoother is named with its bandwidth.
TEST(Estimator, JsonBandwidthIsANumberOrNullWithTheSmootherNamed) {
  test::SyntheticRun run;
  const TalcLog log = Parse(run);
  EstimatorOptions mean_only;
  mean_only.bandwidth_grid_s = {std::numeric_limits<double>::infinity()};
  const nlohmann::json j = MachineErrorEstimator::Fit(log, mean_only).ToJson();
  ASSERT_FALSE(j["models"].empty());
  for (const auto& [name, m] : j["models"].items()) {
    EXPECT_TRUE(m["residual_bandwidth_s"].is_null()) << name;
    EXPECT_EQ(m["residual_smoother"], "mean") << name;
  }
  EstimatorOptions linear;
  linear.bandwidth_grid_s = {0};
  const nlohmann::json k = MachineErrorEstimator::Fit(log, linear).ToJson();
  for (const auto& [name, m] : k["models"].items()) {
    EXPECT_EQ(m["residual_bandwidth_s"], 0.0) << name;
    EXPECT_EQ(m["residual_smoother"], "linear") << name;
  }
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

// A compensated run whose controller updates its model with every R-test
// (thesis chapter 6: TALC re-anchors the prediction on each measurement),
// written here from that description: the prediction in force is the last
// R-test's machine error plus `follow` times the machine's change since,
// so pred_ jumps at every R-test; with `follow` applied to the whole
// change since the start instead, pred_ is continuous. The machine is the
// synthetic first-order lag of the C-axis speed.
std::string CompensatedLogText(const test::SyntheticRun& run, bool reanchor,
                               double follow) {
  std::vector<double> rtests;
  for (double t = 95; t <= run.end_s; t += run.rtest_interval_s)
    rtests.push_back(t);
  std::mt19937 rng(run.seed);
  std::normal_distribution<double> noise(0.0, run.rtest_noise_um);
  std::vector<std::array<double, 7>> measured;  // machine at each R-test
  for (double t : rtests) {
    auto e = run.TruthMicro(t - 47.5);
    for (double& v : e) v += noise(rng);
    measured.push_back(e);
  }
  auto pred = [&](double t) {
    std::array<double, 7> p{};
    const auto now = run.TruthMicro(t);
    if (!reanchor) {
      for (int i = 0; i < 7; ++i) p[i] = follow * now[i];
      return p;
    }
    int last = -1;
    for (size_t k = 0; k < rtests.size(); ++k)
      if (rtests[k] <= t) last = static_cast<int>(k);
    if (last < 0) return p;
    const auto base = run.TruthMicro(rtests[last] - 47.5);
    for (int i = 0; i < 7; ++i)
      p[i] = measured[last][i] + follow * (now[i] - base[i]);
    return p;
  };
  auto pred_cells = [&](double t) {
    std::string s;
    for (double v : pred(t)) s += fmt::format(",{:.5f}", v);
    return s;
  };
  std::vector<std::pair<double, std::string>> rows;
  for (double t = 0; t <= run.end_s; t += 60) {
    const int rpm = t > run.warmup_s && t <= run.cooldown_s ? 1200 : 0;
    rows.push_back(
        {t, fmt::format("{},sample,{},,,,,,,,{}", t, rpm, pred_cells(t))});
  }
  for (size_t k = 0; k < rtests.size(); ++k) {
    const double t = rtests[k];
    const auto p = pred(t - 47.5);
    std::string r = fmt::format("{},rtest,", t);
    for (int i = 0; i < 7; ++i)
      r += fmt::format(",{:.5f}", measured[k][i] - p[i]);
    rows.push_back({t, r + ",95" + pred_cells(t)});
  }
  std::stable_sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) {
    return a.first < b.first;
  });
  std::string text =
      "# talc-log: 1\n# start: 2026-03-02T06:00:00Z\n# compensation: on\n"
      "t_s,event,c_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,dur_s,pred_EX0C,"
      "pred_EY0C,pred_EZ0T,pred_ER0T,pred_EA0C,pred_EB0C,pred_EC0C\n";
  for (const auto& r : rows) text += r.second + "\n";
  return text;
}

// The synthetic run with R-tests half an hour apart under such a
// controller (following 75 % of the machine's change).
struct CompensatedRun {
  test::SyntheticRun run;
  TalcLog log;
  explicit CompensatedRun(bool reanchor) {
    run.rtest_interval_s = 1800;
    log = ParseTalcLog(CompensatedLogText(run, reanchor, 0.75), "c.csv");
  }
};

// Re-anchored at every R-test, the residual (machine - pred_) between two
// R-tests follows the machine's change since the last one, which a fit
// through the R-tests' residuals cannot see: the estimator fits the
// machine's own error instead and follows the truth between R-tests half
// an hour apart; fitting the residual is off by much more there.
TEST(Estimator, PredictionReanchoredAtRTestsFitsTheMachineError) {
  const CompensatedRun c(true);
  const test::SyntheticRun& run = c.run;
  const TalcLog& log = c.log;
  const auto est = MachineErrorEstimator::Fit(log);
  EXPECT_TRUE(est.fits_machine_error());
  EstimatorOptions residual_options;
  residual_options.compensation_fit =
      EstimatorOptions::CompensationFit::kResidual;
  const auto residual = MachineErrorEstimator::Fit(log, residual_options);
  EXPECT_FALSE(residual.fits_machine_error());
  const double t0 = est.FirstRTestS(), t1 = est.LastRTestS();
  const double machine_rms = RmsAgainstTruth(
      run, [&](double t) { return est.MachineErrorsAt(t); }, t0, t1);
  const double residual_rms = RmsAgainstTruth(
      run, [&](double t) { return residual.MachineErrorsAt(t); }, t0, t1);
  EXPECT_LT(machine_rms, 0.2);  // largest error 9.6 um, R-test noise 0.05
  EXPECT_LT(machine_rms, 0.5 * residual_rms)
      << machine_rms << " vs " << residual_rms;
}

// A prediction that follows the inputs continuously (no jump at the
// R-tests) leaves a smooth residual: that is what the fit takes.
TEST(Estimator, ContinuousPredictionFitsTheResidual) {
  const CompensatedRun c(false);
  const auto est = MachineErrorEstimator::Fit(c.log);
  EXPECT_FALSE(est.fits_machine_error());
  const double rms = RmsAgainstTruth(
      c.run, [&](double t) { return est.MachineErrorsAt(t); },
      est.FirstRTestS(), est.LastRTestS());
  EXPECT_LT(rms, 0.2);
}

// A plant outside the estimator's model class, written here with its own
// parameterisation: each error is a second-order response (two cascaded
// lags, 700 s and 4000 s) to the bearing heat (C speed squared), plus a
// slow heat source the log does not record (sun on the enclosure, 6 h
// period), plus the decay of a pre-machining state (the log does not start
// at rest). The C axis stops for every R-test and cut; R-tests with the
// noise of thesis table 5.4 (k = 1: 0.2, 0.25, 0.2, 0.3 um; 1.15, 1.25,
// 1.3 urad).
struct SecondOrderPlant {
  double rtest_interval_s = 300;
  // A production log may also end before an R-test follows the last cut.
  bool closing_rtest = true;
  unsigned seed = 11;
  static constexpr double kEnd = 8.5 * 3600, kStep = 1.0;
  std::array<double, 7> heat_gain = {1.2, -2.0, -9.0, 5.0, 3.0, -1.5, 4.0};
  std::array<double, 7> sun_gain = {0.3, 0.4, -0.6, 0.5, 0.8, -0.5, 0.6};
  std::array<double, 7> initial = {0.6, -0.4, -2.5, 1.5, 1.0, 0.5, -1.0};
  // A gross error (a chip on a sphere): R-test `gross_rtest` (its index in
  // the log, -1: none) reads `gross_amount` off in error `gross_error`.
  int gross_rtest = -1, gross_error = 0;
  double gross_amount = 0;
  // The R-tests' noise as a multiple of the table's (a lab whose R-test is
  // noisier than the thesis').
  double noise_scale = 1;
  std::vector<std::array<double, 7>> truth;  // per second

  static bool Stopped(double t, double interval) {
    const double in_cycle = std::fmod(t, 3600.0);
    if (in_cycle >= 300 && in_cycle < 420) return true;  // cuts
    const double to_rtest = std::fmod(t - 95 + interval, interval);
    return to_rtest >= interval - 95;  // R-test window
  }
  double CRpm(double t) const {
    const bool warm = t > 600 && t < 4.5 * 3600;
    return warm && !Stopped(t, rtest_interval_s) ? 1500.0 : 0.0;
  }
  void Simulate() {
    truth.assign(static_cast<size_t>(kEnd / kStep) + 2, {});
    std::array<double, 7> x1{}, x2{};
    for (size_t i = 0; i < truth.size(); ++i) {
      const double t = i * kStep;
      const double heat = std::pow(CRpm(t) / 1500.0, 2);
      const double sun = 1 - std::cos(2 * M_PI * t / (6 * 3600));
      for (int e = 0; e < 7; ++e) {
        x1[e] += (heat - x1[e]) * kStep / 700;
        x2[e] += (x1[e] - x2[e]) * kStep / 4000;
        truth[i][e] = heat_gain[e] * x2[e] + sun_gain[e] * sun +
                      initial[e] * std::exp(-t / 2500);
      }
    }
  }
  std::array<double, 7> At(double t) const {
    return truth[std::min(truth.size() - 1, static_cast<size_t>(t / kStep))];
  }
  std::string Text() const {
    constexpr std::array<double, 7> noise = {0.2, 0.25, 0.2, 0.3,
                                             1.15, 1.25, 1.3};
    std::mt19937 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    std::vector<std::pair<double, std::string>> rows;
    for (double t = 0; t <= kEnd; t += 60)
      rows.push_back({t, fmt::format("{},sample,20.0000,20.5000,{:.0f},,,,,,,,,,",
                                     t, CRpm(t))});
    std::vector<double> rtest_t;
    for (double t = 95; t <= kEnd; t += rtest_interval_s) rtest_t.push_back(t);
    // A production log closes with an R-test after the last cut.
    if (closing_rtest && rtest_t.back() < kEnd - 60) rtest_t.push_back(kEnd);
    for (size_t k = 0; k < rtest_t.size(); ++k) {
      const double t = rtest_t[k];
      auto e = At(t - 47.5);
      if (static_cast<int>(k) == gross_rtest) e[gross_error] += gross_amount;
      std::string r = fmt::format("{},rtest,,,", t);
      for (int i = 0; i < 7; ++i)
        r += fmt::format(",{:.5f}", e[i] + noise_scale * noise[i] * gauss(rng));
      rows.push_back({t, r + ",,,95"});
    }
    const PartSpec part;
    for (int cycle = 0; cycle <= part.cycles(); ++cycle) {
      const int j = IndexForCycle(part, cycle);
      const double t0 = 300 + 3600.0 * cycle;
      rows.push_back({t0 + 20, fmt::format("{},cut,,,,,,,,,,,{},0,", t0 + 20,
                                           StripId(j))});
      int k = 0;
      for (Segment s : kSegments) {
        const double t = t0 + 30 + 10 * k++;
        rows.push_back({t, fmt::format("{},cut,,,,,,,,,,,{},{},", t,
                                       FacetId(s, j), FacetPhiDeg(part, s, j))});
      }
    }
    std::stable_sort(rows.begin(), rows.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    std::string text =
        "# talc-log: 1\n# start: 2026-03-02T06:00:00+01:00\n"
        "# compensation: off\n"
        "t_s,event,T_env,T_ws,c_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,"
        "feature,c_deg,dur_s\n";
    for (const auto& r : rows) text += r.second + "\n";
    return text;
  }
};

// Estimate - truth at the cut times, over the four linear errors (um), as
// RMS and as deviates of the stated uncertainty (ErrorSigmaAt).
struct CutTimeErrors {
  double rms_um = 0, rms_z = 0, largest_z = 0;
};
CutTimeErrors AtTheCuts(const SecondOrderPlant& plant,
                        const EstimatorOptions& options = {}) {
  const TalcLog log = ParseTalcLog(plant.Text(), "second-order.csv");
  const auto est = MachineErrorEstimator::Fit(log, options);
  CutTimeErrors out;
  int n = 0;
  for (const CutRecord& cut : log.cuts) {
    const auto e = est.MachineErrorsAt(cut.t_s).ToMicro();
    const auto y = plant.At(cut.t_s);
    for (int i = 0; i < 4; ++i) {
      const double d = e[i] - y[i], z = d / est.ErrorSigmaAt(i, cut.t_s);
      out.rms_um += d * d;
      out.rms_z += z * z;
      out.largest_z = std::max(out.largest_z, std::abs(z));
      ++n;
    }
  }
  out.rms_um = std::sqrt(out.rms_um / n);
  out.rms_z = std::sqrt(out.rms_z / n);
  return out;
}

// Dense R-tests: the estimate follows a plant it does not model to about
// the R-tests' noise; sparse ones (production): larger errors, and the
// stated uncertainty covers them (not overconfident, not vacuous).
TEST(Estimator, SecondOrderPlantWithAnUnloggedInput) {
  SecondOrderPlant plant;
  plant.Simulate();
  double lo = 0, hi = 0;  // E_Z0T over the run: the plant does move
  for (const auto& e : plant.truth) {
    lo = std::min(lo, e[2]);
    hi = std::max(hi, e[2]);
  }
  EXPECT_GT(hi - lo, 5.0);
  const CutTimeErrors dense = AtTheCuts(plant);
  EXPECT_LT(dense.rms_um, kDenseRmsUm) << dense.rms_z;
  EXPECT_LT(dense.rms_z, 1.5);
  plant.rtest_interval_s = 1800;
  plant.Simulate();
  const CutTimeErrors sparse = AtTheCuts(plant);
  EXPECT_LT(sparse.rms_um, kSparseRmsUm);
  EXPECT_LT(sparse.rms_z, 1.5) << sparse.largest_z;
  EXPECT_GT(sparse.rms_z, 0.3);
  EXPECT_LT(sparse.largest_z, 4.0);
  // R-tests 2 h apart (six in the run): the cross-validation's folds
  // choose among the structures the whole log affords. Folds of five
  // R-tests choosing as five R-tests afford could take only a constant,
  // whose error across 2 h gaps is not the chosen model's: the budget was
  // then wider than the error (rms z 0.63 here, 0.16-0.41 on the outside
  // generator: a budget that hides effects).
  plant.rtest_interval_s = 7200;
  plant.Simulate();
  const CutTimeErrors two_hours = AtTheCuts(plant);
  EXPECT_LT(two_hours.rms_z, 1.5) << two_hours.largest_z;
  EXPECT_GT(two_hours.rms_z, 0.8) << two_hours.rms_um;
  EXPECT_LT(two_hours.largest_z, 4.0);
  // The same without the closing R-test: five R-tests, the last cuts past
  // the last one. One lag through five still follows the plant, and the
  // budget still describes the error.
  plant.closing_rtest = false;
  const CutTimeErrors open = AtTheCuts(plant);
  EXPECT_EQ(ParseTalcLog(plant.Text(), "open.csv").rtests.size(), 5u);
  EXPECT_LT(open.rms_z, 1.5) << open.largest_z;
  EXPECT_GT(open.rms_z, 0.5) << open.rms_um;
  EXPECT_LT(open.largest_z, 4.0);
  plant.closing_rtest = true;
  plant.rtest_interval_s = 1800;
  plant.Simulate();
  // The stated uncertainty grows with the distance to the nearest R-test:
  // next to one it is smaller than in the middle of the gap that follows.
  {
    const TalcLog log = ParseTalcLog(plant.Text(), "second-order.csv");
    const auto est = MachineErrorEstimator::Fit(log);
    ASSERT_GE(log.rtests.size(), 8u);
    const double t0 = log.rtests[3].t_ref_s, t1 = log.rtests[4].t_ref_s;
    EXPECT_LT(est.ErrorSigmaAt(2, t0 + 60), est.ErrorSigmaAt(2, (t0 + t1) / 2));  // E_Z0T moves most
  }
  std::cout << "dense " << dense.rms_um << " um z " << dense.rms_z << " max "
            << dense.largest_z << "; sparse " << sparse.rms_um << " um z "
            << sparse.rms_z << " max " << sparse.largest_z << "; 2 h "
            << two_hours.rms_um << " um z " << two_hours.rms_z << " max "
            << two_hours.largest_z << "; 2 h, five R-tests " << open.rms_um
            << " um z " << open.rms_z << " max " << open.largest_z << "\n";
}

// A gross error in one R-test (a chip on a sphere: 3-4 um on E_X0C or
// E_R0T, 10-15 times their noise) is found against the estimate from the
// other R-tests, named with its line, and left out: the estimate at its
// time follows the machine, not the gross error. A clean log loses no R-test,
// and the first R-test (every value's reference) is never left out.
TEST(Estimator, LeavesOutAGrossErrorInOneRTest) {
  SecondOrderPlant plant;
  plant.Simulate();
  for (double interval : {300.0, 1800.0}) {
    plant.rtest_interval_s = interval;
    plant.Simulate();
    const TalcLog clean = ParseTalcLog(plant.Text(), "clean.csv");
    EXPECT_TRUE(MachineErrorEstimator::Fit(clean).left_out_rtests().empty())
        << interval;
  }
  struct Case {
    double interval_s;
    int rtest, error;
    double amount;
  };
  for (const Case& c :
       {Case{300, 40, 0, 3.0}, Case{300, 70, 3, -3.0}, Case{1800, 8, 0, 4.0}}) {
    SCOPED_TRACE(fmt::format("interval {} s, R-test {}, error {}", c.interval_s,
                             c.rtest, c.error));
    plant.rtest_interval_s = c.interval_s;
    plant.gross_rtest = c.rtest;
    plant.gross_error = c.error;
    plant.gross_amount = c.amount;
    plant.Simulate();
    const TalcLog log = ParseTalcLog(plant.Text(), "gross.csv");
    const auto est = MachineErrorEstimator::Fit(log);
    ASSERT_EQ(est.left_out_rtests().size(), 1u);
    const LeftOutRTest& r = est.left_out_rtests()[0];
    EXPECT_EQ(r.line, log.rtests[c.rtest].line);
    EXPECT_EQ(r.error, c.error);
    EXPECT_NEAR(r.deviation_um_or_urad, c.amount, 1.0);
    EXPECT_GT(r.z, 6.0);
    ASSERT_EQ(est.Warnings().size(), 1u);
    EXPECT_NE(est.Warnings()[0].find(fmt::format("line {}", r.line)),
              std::string::npos);
    EXPECT_NE(est.ToJson().dump().find("rtests_left_out"), std::string::npos);
    // At the R-test's time the estimate follows the truth, not the gross
    // error it would have passed through; the cuts keep their budget.
    EstimatorOptions keep_all;
    keep_all.rtest_gross_error_z = 0;
    const auto kept = MachineErrorEstimator::Fit(log, keep_all);
    const double t = log.rtests[c.rtest].t_ref_s;
    const double truth = plant.At(t)[c.error];
    const double off_screened =
        std::abs(est.MachineErrorsAt(t).ToMicro()[c.error] - truth);
    const double off_kept =
        std::abs(kept.MachineErrorsAt(t).ToMicro()[c.error] - truth);
    std::cout << "off the truth at the R-test: screened " << off_screened
              << " kept " << off_kept << " um\n";
    EXPECT_LT(off_screened, 0.1 * std::abs(c.amount));
    EXPECT_GT(off_kept, 3 * off_screened);
    EXPECT_LT(AtTheCuts(plant).rms_z, 1.5);
  }
  // The reference R-test: every value is relative to it; a gross error
  // there moves all others alike and is not left out.
  plant.rtest_interval_s = 300;
  plant.gross_rtest = 0;
  plant.gross_error = 0;
  plant.gross_amount = 3.0;
  plant.Simulate();
  const TalcLog first = ParseTalcLog(plant.Text(), "first.csv");
  const auto est = MachineErrorEstimator::Fit(first);
  for (const LeftOutRTest& r : est.left_out_rtests())
    EXPECT_NE(r.line, first.rtests[0].line);
}

// R-tests four times as noisy as thesis table 5.4 (diagnosis.md section 4
// allows up to 1.3 um and 6 urad): read from a log of R-tests every 5 min
// (within a quarter of the truth on every error), named in a warning, and
// no R-test left out as a gross error for the lab's noise. A log as noisy
// as the table keeps the table's values; R-tests every 30 min (fewer than
// rtest_noise_from_log_min_rtests) are not read.
TEST(Estimator, ReadsTheRTestNoiseFromTheLog) {
  constexpr std::array<double, 7> table = {0.2,  0.25, 0.2, 0.3,
                                           1.15, 1.25, 1.3};
  SecondOrderPlant plant;
  plant.Simulate();
  {
    const auto est = MachineErrorEstimator::Fit(
        ParseTalcLog(plant.Text(), "as-the-table.csv"));
    for (int e = 0; e < 7; ++e) {
      EXPECT_EQ(est.RTestNoise(e), table[e]) << e;
      EXPECT_NEAR(est.ToJson()["models"][std::string(kErrorNames[e])].value(
                      "rtest_noise_from_log_" + est.models()[e].unit, 0.0),
                  table[e], 0.35 * table[e])
          << e;
    }
    EXPECT_TRUE(est.Warnings().empty());
  }
  plant.noise_scale = 4;
  const TalcLog noisy = ParseTalcLog(plant.Text(), "noisy.csv");
  const auto est = MachineErrorEstimator::Fit(noisy);
  for (int e = 0; e < 7; ++e) {
    const double from_log =
        est.ToJson()["models"][std::string(kErrorNames[e])]
                    ["rtest_noise_from_log_" + est.models()[e].unit];
    EXPECT_NEAR(from_log, 4 * table[e], table[e]) << e;
    EXPECT_GT(est.RTestNoise(e), 2 * table[e]) << e;
    EXPECT_LE(est.RTestNoise(e), from_log) << e;
  }
  ASSERT_FALSE(est.Warnings().empty());
  EXPECT_NE(est.Warnings()[0].find("scatter more than the R-test's stated "
                                   "uncertainty"),
            std::string::npos);
  EXPECT_NE(est.Warnings()[0].find("EZ0T"), std::string::npos);
  EXPECT_TRUE(est.left_out_rtests().empty());
  EstimatorOptions table_only;
  table_only.rtest_noise_from_log_min_rtests = 0;
  const auto assumed = MachineErrorEstimator::Fit(noisy, table_only);
  for (int e = 0; e < 7; ++e) EXPECT_EQ(assumed.RTestNoise(e), table[e]);
  EXPECT_TRUE(assumed.Warnings().empty());
  plant.rtest_interval_s = 1800;
  plant.Simulate();
  const auto sparse =
      MachineErrorEstimator::Fit(ParseTalcLog(plant.Text(), "sparse.csv"));
  for (int e = 0; e < 7; ++e) {
    EXPECT_EQ(sparse.RTestNoise(e), table[e]) << e;
    EXPECT_TRUE(sparse
                    .ToJson()["models"][std::string(kErrorNames[e])]
                             ["rtest_noise_from_log_" + sparse.models()[e].unit]
                    .is_null());
  }
  std::string error;
  EstimatorOptions o;
  o.rtest_noise_from_log_min_rtests = 2;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("rtest_noise_from_log_min_rtests"), std::string::npos);
  o = EstimatorOptions{};
  o.rtest_noise_lower_bound_sd = -1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("rtest_noise_lower_bound_sd"), std::string::npos);
}

// A lab that states its R-test's uncertainty (machine.rtest_u95_um,
// rtest_u95_urad) gets half of it as the R-tests' noise, and with R-tests
// four times as noisy as thesis table 5.4 and two hours apart (too few to
// read the noise from the log) the budget at the cuts describes the
// estimator's error against the plant's truth: neither overconfident nor
// vacuous (on the outside generator the stated noise keeps such pieces
// from being refused with their own log: bench/outside, NOISY_LAB_CASES).
TEST(Estimator, TakesTheLabsStatedRTestUncertainty) {
  MachineProfile lab;
  lab.rtest_u95_um = {1.6, 2.0, 1.6, 2.4};
  lab.rtest_u95_urad = {9.2, 10.0, 10.4};
  const EstimatorOptions stated = EstimatorOptionsFor(lab);
  const std::array<double, 7> half = {0.8, 1.0, 0.8, 1.2, 4.6, 5.0, 5.2};
  for (int e = 0; e < 7; ++e)
    EXPECT_DOUBLE_EQ(stated.rtest_noise_um_or_urad[e], half[e]) << e;
  EXPECT_EQ(EstimatorOptionsFor(MachineProfile{}).rtest_noise_um_or_urad,
            EstimatorOptions{}.rtest_noise_um_or_urad);
  SecondOrderPlant plant;
  plant.noise_scale = 4;
  plant.rtest_interval_s = 7200;
  double mean_z2 = 0;
  const std::vector<unsigned> seeds = {11, 12, 13, 14, 15, 16, 17, 18};
  for (unsigned seed : seeds) {
    plant.seed = seed;
    plant.Simulate();
    const CutTimeErrors at = AtTheCuts(plant, stated);
    std::cout << "seed " << seed << ": " << at.rms_um << " um, RMS z "
              << at.rms_z << ", largest " << at.largest_z << "\n";
    EXPECT_LT(at.largest_z, 4.0) << seed;
    mean_z2 += at.rms_z * at.rms_z / seeds.size();
  }
  EXPECT_GT(std::sqrt(mean_z2), 0.6);
  EXPECT_LT(std::sqrt(mean_z2), 1.4);
}

TEST(Estimator, GrossErrorOptionsAreChecked) {
  std::string error;
  EstimatorOptions o;
  EXPECT_TRUE(o.IsValid(&error));
  o.rtest_gross_error_z = -1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("rtest_gross_error_z"), std::string::npos);
  o = EstimatorOptions{};
  o.rtest_gross_error_max_fraction = 1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("rtest_gross_error_max_fraction"), std::string::npos);
  o = EstimatorOptions{};
  o.rtest_gross_error_min_rtests = 2;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("rtest_gross_error_min_rtests"), std::string::npos);
}

// R-tests an hour apart resolve no lag of a minute: such a lag's gain
// would rest on the few phases of the cycle the R-tests are taken at. The
// machine's lag (1500 s) lies between the two time constants offered: the
// minute fits it better, and is what the fit takes without the rule.
TEST(Estimator, LagsFasterThanTheRTestsResolveAreNotTried) {
  test::SyntheticRun run;
  run.rtest_interval_s = 3600;
  EstimatorOptions options;
  options.tau_grid_s = {60, 19200};
  auto shortest_tau_s = [&](const EstimatorOptions& o) {
    const auto est = MachineErrorEstimator::Fit(Parse(run), o);
    double shortest = std::numeric_limits<double>::infinity();
    for (const ErrorModel& m : est.models())
      for (double tau : m.tau_s) shortest = std::min(shortest, tau);
    return shortest;
  };
  EXPECT_EQ(shortest_tau_s(options), 19200);
  EstimatorOptions all_taus = options;
  all_taus.min_tau_fraction_of_rtest_spacing = 0;
  EXPECT_EQ(shortest_tau_s(all_taus), 60);
  EstimatorOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error)) << error;
  o.min_tau_fraction_of_rtest_spacing = -0.1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("min_tau_fraction_of_rtest_spacing"), std::string::npos)
      << error;
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
  // Usable, but two R-tests cannot be cross-validated: it says so.
  const auto est = MachineErrorEstimator::Fit(ParseTalcLog(two, "two"));
  ASSERT_EQ(est.Warnings().size(), 1u);
  EXPECT_NE(est.Warnings()[0].find("too few to cross-validate"),
            std::string::npos);
  EXPECT_NE(est.Describe().find("too few to cross-validate"),
            std::string::npos);
  const std::string three = one + "395,rtest,1,1,1,1,1,1,1,95,,,,,,,\n" +
                            "695,rtest,2,2,2,2,2,2,2,95,,,,,,,\n";
  EXPECT_TRUE(MachineErrorEstimator::Fit(ParseTalcLog(three, "three"))
                  .Warnings()
                  .empty());
  two.replace(two.find("compensation: off"), 17, "compensation: on");
  EXPECT_THROW(MachineErrorEstimator::Fit(ParseTalcLog(two, "two")),
               InputError);
}

}  // namespace
}  // namespace ttp::thermal
