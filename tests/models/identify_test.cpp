// Identification against data the models did not make: a two-node thermal
// network (spindle node heated by n and n^2, structure node, drifting
// ambient) integrated with small-step RK4, whose displacement depends on an
// unmeasured node; and the real FL spindle test (chronological holdout).
#include "ttp/models/identify.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "ttp/geometry/error.h"
#include "ttp/models/compare.h"

namespace ttp::models {
namespace {

// Two thermal masses: C1 dT1/dt = Q - G12 (T1 - T2) - G1a (T1 - Ta),
// C2 dT2/dt = G12 (T1 - T2) - G2a (T2 - Ta); Q = 120 (n/1000) + 35
// (n/1000)^2 W. Displacement 9 (T1 - Ta) - 14 (T2 - Ta) um/K plus a slow
// ambient term. Measured: n, T_amb, T_spindle (= T1 + noise) and an
// unrelated sensor T_cabinet. T2 is not measured.
TimeSeries TwoNodeNetwork(unsigned seed) {
  const double c1 = 1.5e5, c2 = 9e5, g12 = 40, g1a = 15, g2a = 35;
  auto speed = [](double t) {
    const double block = std::floor(t / 7200.0);
    static const double levels[] = {1500, 0,    3000, 0,    2000, 0,    4000,
                                    0,    1000, 0,    3500, 0,    2500, 0};
    return levels[static_cast<int>(block) % 14];
  };
  auto ambient = [](double t) {
    return 21 + 1.2 * std::sin(2 * M_PI * t / 86400.0 - 1.0);
  };
  auto heat = [&](double t) {
    const double k = speed(t) / 1000.0;
    return 120 * k + 35 * k * k;
  };
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 1);
  double t1 = ambient(0), t2 = ambient(0);
  TimeSeries ts;
  ts.source = "two-node";
  ts.input_names = {"n_spindle", "T_amb", "T_spindle", "T_cabinet"};
  ts.output_names = {"d_z"};
  const double h = 2.0, sample = 30.0, end = 28 * 3600.0;
  std::vector<std::array<double, 5>> rows;
  double cabinet = 24;
  for (double t = 0; t <= end; t += sample) {
    cabinet += 0.01 * noise(rng);
    const double ta = ambient(t);
    rows.push_back({speed(t), ta + 0.02 * noise(rng), t1 + 0.02 * noise(rng),
                    cabinet,
                    9 * (t1 - ta) - 14 * (t2 - ta) + 0.05 * noise(rng)});
    ts.t_s.push_back(t);
    for (double s = 0; s < sample; s += h) {
      auto f = [&](double tt, double a, double b, double* da, double* db) {
        const double amb = ambient(tt);
        *da = (heat(tt) - g12 * (a - b) - g1a * (a - amb)) / c1;
        *db = (g12 * (a - b) - g2a * (b - amb)) / c2;
      };
      double a1, b1, a2, b2, a3, b3, a4, b4;
      const double tt = t + s;
      f(tt, t1, t2, &a1, &b1);
      f(tt + h / 2, t1 + h / 2 * a1, t2 + h / 2 * b1, &a2, &b2);
      f(tt + h / 2, t1 + h / 2 * a2, t2 + h / 2 * b2, &a3, &b3);
      f(tt + h, t1 + h * a3, t2 + h * b3, &a4, &b4);
      t1 += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
      t2 += h / 6 * (b1 + 2 * b2 + 2 * b3 + b4);
    }
  }
  const Eigen::Index n = static_cast<Eigen::Index>(rows.size());
  ts.inputs.resize(n, 4);
  ts.outputs_um.resize(n, 1);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (int k = 0; k < 4; ++k) ts.inputs(i, k) = rows[i][k];
    ts.outputs_um(i, 0) = rows[i][4] - rows[0][4];
  }
  return ts;
}

double HoldoutRms(const TimeSeries& ts, const Eigen::VectorXd& pred,
                  double from) {
  double s = 0;
  int n = 0;
  for (size_t i = 0; i < ts.rows(); ++i)
    if (ts.t_s[i] >= from) {
      const double r = ts.outputs_um(i, 0) - pred(i);
      s += r * r, ++n;
    }
  return std::sqrt(s / n);
}

const double kSplit = 18 * 3600.0;

TEST(Identify, DynamicModelBeatsStaticOnTwoNodeNetwork) {
  const TimeSeries ts = TwoNodeNetwork(7);
  FitOptions o;
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  ASSERT_EQ(m.outputs.size(), 1u);
  const double none = HoldoutRms(ts, Eigen::VectorXd::Zero(ts.rows()), kSplit);
  const double auto_rms =
      HoldoutRms(ts, PredictOutput(m.outputs[0], ts), kSplit);
  const double static_rms = HoldoutRms(
      ts,
      PredictOutput(FitOutput(HeadOf(ts, kSplit), 0, Structure::kStatic, o),
                    ts),
      kSplit);
  // auto chose a dynamic structure by CV inside the fitted span.
  EXPECT_NE(m.outputs[0].structure, Structure::kStatic) << m.outputs[0].label;
  EXPECT_FALSE(m.outputs[0].label.empty());
  EXPECT_LT(auto_rms, 0.5 * static_rms)
      << "auto " << auto_rms << " static " << static_rms;
  EXPECT_LT(auto_rms, 0.35 * none) << auto_rms << " vs none " << none;
  // The unrelated sensor is kept (no selection) but shrunk: its share of the
  // prediction over the holdout is small.
  const OutputModel& om = m.outputs[0];
  const int cab = ts.InputIndex("T_cabinet");
  Eigen::VectorXd cabinet = Eigen::VectorXd::Zero(ts.rows());
  for (size_t r = 0; r < om.regressors.size(); ++r)
    if (om.regressors[r].input == "T_cabinet")
      cabinet += om.coef(static_cast<Eigen::Index>(r)) *
                 ComputeFeatures(ts, {om.regressors[r]}).col(0);
  ASSERT_GE(cab, 0);
  const double spread =
      std::sqrt((cabinet.array() - cabinet.mean()).square().mean());
  EXPECT_LT(spread, 0.1 * none) << "T_cabinet contributes " << spread;
}

// The network's unmeasured node has a time constant of C2 / (G12 + G2a) =
// 12000 s; with the temperatures' lag near it the joint model follows it
// closely (the default 3600 s is what the real spindle test holds up with).
TEST(Identify, JointWithTemperatureLagNearTheHiddenNode) {
  const TimeSeries ts = TwoNodeNetwork(7);
  FitOptions o;
  o.model = "joint";
  o.temperature_lag_s = 14400;
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  const double none = HoldoutRms(ts, Eigen::VectorXd::Zero(ts.rows()), kSplit);
  EXPECT_LT(HoldoutRms(ts, PredictOutput(m.outputs[0], ts), kSplit),
            0.15 * none);
}

TEST(Identify, PredictIsCausalAndIgnoresOutputs) {
  const TimeSeries ts = TwoNodeNetwork(3);
  FitOptions o;
  o.model = "combined";
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  TimeSeries input_only = ts;
  input_only.outputs_um.setConstant(1e6);
  input_only.output_names = {"d_other"};
  const Prediction p = Predict(m, ts);
  const Prediction q = Predict(m, input_only);
  EXPECT_EQ((p.values_um - q.values_um).cwiseAbs().maxCoeff(), 0.0);
  // Changing the future changes nothing before it.
  TimeSeries changed = ts;
  const Eigen::Index k = 2000;
  changed.inputs.bottomRows(changed.inputs.rows() - k).array() += 5.0;
  PredictOptions keep;  // a step of 5 K would be repaired as a sensor jump
  keep.repair_jumps = false;
  const Prediction c = Predict(m, changed, keep);
  EXPECT_EQ(
      (c.values_um.topRows(k) - p.values_um.topRows(k)).cwiseAbs().maxCoeff(),
      0.0);
  EXPECT_GT((c.values_um.bottomRows(100) - p.values_um.bottomRows(100))
                .cwiseAbs()
                .maxCoeff(),
            0.1);
}

// The rows of `ts` from `first` on (a log that continues the one before).
TimeSeries RowsFrom(const TimeSeries& ts, size_t first) {
  TimeSeries tail = ts;
  const Eigen::Index nt = static_cast<Eigen::Index>(ts.rows() - first);
  tail.t_s.erase(tail.t_s.begin(), tail.t_s.begin() + first);
  tail.inputs = ts.inputs.bottomRows(nt).eval();
  tail.outputs_um = ts.outputs_um.bottomRows(nt).eval();
  return tail;
}

// Predicts the rows of `log` from `first` on as a log of their own, which
// continues the fitted one: the largest difference from the same rows of
// `full`, or -1 when that log is not taken as the continuation.
double ContinuationOffset(const ThermalModel& m, const TimeSeries& log,
                          size_t first, const Prediction& full) {
  const TimeSeries tail = RowsFrom(log, first);
  const Prediction cont = Predict(m, tail);
  if (!cont.continued) return -1;
  return (cont.values_um - full.values_um.bottomRows(tail.rows()))
      .cwiseAbs()
      .maxCoeff();
}

// A channel the fitted span never measures gets no model and a warning;
// the others are fitted as without it. Named with --outputs it is refused.
// compare leaves out an output not measured on both sides of the split,
// and refuses when none is.
TEST(Identify, AnOutputNeverMeasuredGetsNoModel) {
  const TimeSeries ts = TwoNodeNetwork(5);
  TimeSeries with = ts;
  with.output_names.push_back("d_unplugged");
  with.outputs_um.conservativeResize(Eigen::NoChange,
                                     with.outputs_um.cols() + 1);
  with.outputs_um.col(with.outputs_um.cols() - 1)
      .setConstant(std::numeric_limits<double>::quiet_NaN());
  FitOptions o;
  const ThermalModel a = FitThermalModel(ts, {}, o, kSplit);
  const ThermalModel b = FitThermalModel(with, {}, o, kSplit);
  ASSERT_EQ(b.outputs.size(), a.outputs.size());
  EXPECT_EQ(b.outputs[0].coef, a.outputs[0].coef);
  ASSERT_FALSE(b.fit_warnings.empty());
  EXPECT_NE(b.fit_warnings.back().find("d_unplugged is never measured"),
            std::string::npos);
  EXPECT_THROW(FitThermalModel(with, {"d_unplugged"}, o, kSplit), InputError);
  const CompareResult c = CompareModels(with, kSplit, o);
  EXPECT_EQ(c.outputs, ts.output_names);
  // Outputs measured only before the split: nothing to judge.
  TimeSeries early = ts;
  for (size_t i = 0; i < early.rows(); ++i)
    if (early.t_s[i] >= kSplit)
      early.outputs_um.row(static_cast<Eigen::Index>(i))
          .setConstant(std::numeric_limits<double>::quiet_NaN());
  EXPECT_THROW(CompareModels(early, kSplit, o), InputError);
}

TEST(Identify, ModelFileRoundTripAndContinuation) {
  const TimeSeries ts = TwoNodeNetwork(5);
  FitOptions o;  // auto: the joint model
  const ThermalModel m = FitThermalModel(ts, {"d_z"}, o, kSplit);
  const ThermalModel back =
      ModelFromJson(nlohmann::json::parse(ModelToJson(m).dump()), "model.json");
  const Prediction full = Predict(back, ts);
  EXPECT_FALSE(full.continued);
  EXPECT_LT((full.values_um - Predict(m, ts).values_um).cwiseAbs().maxCoeff(),
            1e-9);
  // A log that continues the fitted one continues its filter state.
  size_t first = 0;
  while (ts.t_s[first] < kSplit) ++first;
  const double offset = ContinuationOffset(back, ts, first, full);
  EXPECT_GE(offset, 0) << "not taken as the continuation";
  EXPECT_LT(offset, 1e-9);
  // Without the end state it would start from steady state: different.
  TimeSeries shifted = RowsFrom(ts, first);
  for (double& t : shifted.t_s) t += 1e5;
  EXPECT_FALSE(Predict(back, shifted).continued);
}

// thermal-log.md: t_s counts from the log's own `start`. The second part of
// a test written as its own log (t_s from 0, start at the first part's
// start + the time it begins, in another UTC offset) continues the fitted
// log as the same rows with t_s counted on do; a log whose start puts it
// before the fitted end does not.
TEST(Identify, ContinuationIsJudgedInTheTimeOfTheStartHeaders) {
  TimeSeries ts = TwoNodeNetwork(5);
  ts.header["start"] = "2024-01-01T00:00:00+00:00";
  const ThermalModel m = ModelFromJson(
      nlohmann::json::parse(
          ModelToJson(FitThermalModel(ts, {"d_z"}, FitOptions{}, kSplit))
              .dump()),
      "model.json");
  EXPECT_EQ(m.fit_start, "2024-01-01T00:00:00+00:00");
  size_t first = 0;
  while (ts.t_s[first] < kSplit) ++first;
  const Eigen::Index nt = static_cast<Eigen::Index>(ts.rows() - first);
  TimeSeries tail = ts;
  tail.t_s.erase(tail.t_s.begin(), tail.t_s.begin() + first);
  tail.inputs = ts.inputs.bottomRows(nt).eval();
  tail.outputs_um = ts.outputs_um.bottomRows(nt).eval();
  const Prediction counted_on = Predict(m, tail);
  ASSERT_TRUE(counted_on.continued);

  TimeSeries own = tail;
  const double t0 = own.t_s.front();
  for (double& t : own.t_s) t -= t0;
  // t0 = kSplit rounded up to the sampling: 2024-01-01T00:00 + t0 in +02:00
  const long whole = static_cast<long>(t0);
  ASSERT_EQ(static_cast<double>(whole), t0);
  const long local = whole + 2 * 3600;
  own.header["start"] = fmt::format("2024-01-01T{:02d}:{:02d}:{:02d}+02:00",
                                    local / 3600, local / 60 % 60, local % 60);
  ASSERT_LT(local, 24 * 3600);
  const Prediction restarted = Predict(m, own);
  EXPECT_TRUE(restarted.continued);
  EXPECT_LT((restarted.values_um - counted_on.values_um).cwiseAbs().maxCoeff(),
            1e-9);

  TimeSeries before = own;
  before.header["start"] = "2024-01-01T00:00:00+00:00";  // t_s 0 = fit start
  EXPECT_FALSE(Predict(m, before).continued);
  // A model file whose start is not a time is refused naming the field.
  nlohmann::json j = ModelToJson(m);
  j["fit_start"] = "yesterday";
  try {
    ModelFromJson(j, "model.json");
    ADD_FAILURE() << "a bad fit_start was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("fit_start"), std::string::npos);
  }
}

// The model file of one structure fitted on the two-node network.
nlohmann::json FittedModelFile(const char* structure) {
  FitOptions o;
  o.model = structure;
  return ModelToJson(FitThermalModel(TwoNodeNetwork(5), {"d_z"}, o, kSplit));
}

// A model file whose filter state is cut short (a delayed input's history
// entry without its time or value): refused as a bad file, not read past
// its end (the fuzzer's model file).
TEST(Identify, RefusesAModelFileWithAShortFilterHistory) {
  const nlohmann::json good = FittedModelFile("fir");
  int delayed = 0;
  for (const nlohmann::json& cut :
       {nlohmann::json::array(), nlohmann::json::array({1.0})}) {
    nlohmann::json bad = good;
    bool changed = false;
    for (auto& out : bad["outputs"])
      for (auto& chan : out["end_state"]["regressors"])
        if (!changed && !chan["history"].empty()) {
          chan["history"][0] = cut;
          changed = true;
        }
    ASSERT_TRUE(changed) << "no delayed regressor in the fir model";
    ++delayed;
    EXPECT_THROW(ModelFromJson(bad, "model.json"), InputError) << cut.dump();
  }
  EXPECT_EQ(delayed, 2);
  EXPECT_NO_THROW(ModelFromJson(good, "model.json"));
}

// Numbers of a model file beyond an int where the file has an integer (its
// version, a regressor's power): refused, not converted (the fuzzer's
// thermal_model of 3.3e106).
TEST(Identify, RefusesAModelFileWithNumbersBeyondAnInt) {
  const nlohmann::json good = FittedModelFile("static");
  nlohmann::json version = good;
  version["thermal_model"] = 3.3e106;
  EXPECT_THROW(ModelFromJson(version, "model.json"), InputError);
  nlohmann::json power = good;
  power["outputs"][0]["regressors"][0]["power"] = 1e100;
  EXPECT_THROW(ModelFromJson(power, "model.json"), InputError);
  EXPECT_NO_THROW(ModelFromJson(good, "model.json"));
}

TEST(Identify, RefusesModelWhoseInputIsMissing) {
  const TimeSeries ts = TwoNodeNetwork(9);
  FitOptions o;
  o.model = "static";
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  ASSERT_FALSE(m.inputs.empty());
  const std::string needed = m.inputs.front();
  TimeSeries other = ts;
  other.input_names[other.InputIndex(needed)] = "T_renamed";
  try {
    Predict(m, other);
    FAIL() << "accepted a log without " << needed;
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), needed);
  }
}

TEST(Identify, OptionsValidateThemselves) {
  FitOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.model = "neural";
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("model"), std::string::npos);
  o = FitOptions();
  o.cv_first_validation_block = o.cv_blocks;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("cv_first_validation_block"), std::string::npos);
  o = FitOptions();
  o.criterion = "aic";
  EXPECT_FALSE(o.IsValid(&error));
}

TEST(Identify, MdlCriterionAndWlseRun) {
  const TimeSeries ts = TwoNodeNetwork(11);
  FitOptions o;
  o.model = "lag";
  o.criterion = "mdl";
  o.weight_half_life_s = 6 * 3600.0;
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  EXPECT_FALSE(m.outputs[0].regressors.empty());
  const double none = HoldoutRms(ts, Eigen::VectorXd::Zero(ts.rows()), kSplit);
  EXPECT_LT(HoldoutRms(ts, PredictOutput(m.outputs[0], ts), kSplit), none);
}

// A half-life short against the span weights all but the newest samples
// to nothing: refused naming the option, not a failed solve.
TEST(Identify, WlseHalfLifeLeavingTooFewSamplesIsBadInput) {
  const TimeSeries ts = TwoNodeNetwork(11);
  FitOptions o;
  o.weight_half_life_s = 1e-3;
  try {
    FitThermalModel(ts, {}, o, kSplit);
    ADD_FAILURE() << "a half-life of 1 ms was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "--weight-half-life-s");
    EXPECT_NE(std::string(e.what()).find("effective samples"),
              std::string::npos)
        << e.what();
  }
}

// --outputs names d_ columns: an input given there is said to be one.
TEST(Identify, AnInputAskedForAsAnOutputIsNamedAsAnInput) {
  const TimeSeries ts = TwoNodeNetwork(11);
  ASSERT_FALSE(ts.input_names.empty());
  try {
    FitThermalModel(ts, {ts.input_names[0]}, FitOptions{}, kSplit);
    ADD_FAILURE() << "an input was fitted as an output";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("is an input of the log"),
              std::string::npos)
        << e.what();
  }
}

TEST(Identify, AnOutputAskedForTwiceIsBadInput) {
  const TimeSeries ts = TwoNodeNetwork(11);
  try {
    FitThermalModel(ts, {"d_z", "d_z"}, FitOptions{}, kSplit);
    ADD_FAILURE() << "d_z was fitted twice";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("asked for more than once"),
              std::string::npos)
        << e.what();
  }
}

TEST(Identify, AutoNeverSeesTheHoldout) {
  const TimeSeries ts = TwoNodeNetwork(5);
  FitOptions o;
  o.auto_selected = false;  // the fixed candidates suffice here (cheap)
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  TimeSeries changed = ts;
  for (size_t i = 0; i < ts.rows(); ++i)
    if (ts.t_s[i] >= kSplit) {
      changed.outputs_um.row(static_cast<Eigen::Index>(i)).setConstant(1e3);
      changed.inputs.row(static_cast<Eigen::Index>(i)).array() += 7.0;
    }
  const ThermalModel c = FitThermalModel(changed, {}, o, kSplit);
  ASSERT_EQ(m.outputs.size(), c.outputs.size());
  EXPECT_EQ(m.outputs[0].label, c.outputs[0].label);
  EXPECT_EQ(m.outputs[0].coef, c.outputs[0].coef);
  EXPECT_EQ(m.outputs[0].intercept_um, c.outputs[0].intercept_um);
}

TEST(Identify, AutoTakesTheLowestCvScoreOfItsCandidates) {
  const TimeSeries ts = TwoNodeNetwork(7);
  const TimeSeries fit = HeadOf(ts, kSplit);
  FitOptions o;
  o.auto_selected = false;
  const OutputModel a = FitAuto(fit, 0, o);
  const OutputModel st =
      FitFixed(fit, 0, AllTemperatureRegressors(fit), Structure::kStatic, o);
  const OutputModel lag =
      FitFixed(fit, 0, SpeedLagRegressors(fit, o.taus_s), Structure::kLag, o);
  EXPECT_LE(a.cv_score, st.cv_score);
  EXPECT_LE(a.cv_score, lag.cv_score);
  // Every candidate is listed with its score, the chosen one marked.
  int marked = 0;
  for (const auto& line : a.selection_log)
    if (line.rfind("* ", 0) == 0) ++marked;
  EXPECT_EQ(marked, 1);
  // More candidates (the forward-selected ones, nested CV): the minimum
  // can only go down.
  FitOptions with = o;
  with.auto_selected = true;
  with.model = "select";
  const OutputModel b = FitAuto(fit, 0, with);
  EXPECT_LE(b.cv_score, a.cv_score);
}

TEST(Identify, PredictWarnsAndRepairsAJumpingSensor) {
  const TimeSeries ts = TwoNodeNetwork(3);
  FitOptions o;
  o.model = "joint";
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  TimeSeries jumped = ts;
  const int j = ts.InputIndex("T_spindle");
  ASSERT_GE(j, 0);
  const Eigen::Index k = 2500;
  jumped.inputs.col(j).tail(ts.rows() - k).array() += 5.0;
  const Prediction clean = Predict(m, ts);
  const Prediction repaired = Predict(m, jumped);
  ASSERT_EQ(repaired.jumps.size(), 1u);
  EXPECT_EQ(repaired.jumps[0].input, "T_spindle");
  EXPECT_EQ(repaired.jumps[0].t_s, ts.t_s[k]);
  bool named = false;
  for (const auto& w : repaired.warnings)
    if (w.find("T_spindle jumps") != std::string::npos) named = true;
  EXPECT_TRUE(named);
  // Repaired: the machine's own step at that row is also removed, so the
  // prediction is close to the clean one, not equal; followed: off by
  // several um.
  PredictOptions keep;
  keep.repair_jumps = false;
  const Prediction followed = Predict(m, jumped, keep);
  const double off_followed =
      (followed.values_um - clean.values_um).cwiseAbs().maxCoeff();
  const double off_repaired =
      (repaired.values_um - clean.values_um).cwiseAbs().maxCoeff();
  EXPECT_GT(off_followed, 1.0);
  EXPECT_LT(off_repaired, 0.1 * off_followed);
}

TEST(Identify, PredictNamesInputsOutsideTheFittedRange) {
  const TimeSeries ts = TwoNodeNetwork(3);
  FitOptions o;
  o.model = "lag";
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  const Prediction inside = Predict(m, HeadOf(ts, kSplit));
  EXPECT_TRUE(inside.extrapolations.empty());
  TimeSeries fast = ts;
  const int n = ts.InputIndex("n_spindle");
  fast.inputs.col(n) *= 1.5;
  const Prediction p = Predict(m, fast);
  ASSERT_FALSE(p.extrapolations.empty());
  EXPECT_EQ(p.extrapolations[0].input, "n_spindle");
  EXPECT_TRUE(p.extrapolations[0].severe);
  ASSERT_EQ(p.cv_rms_um.size(), 1u);
  EXPECT_TRUE(std::isfinite(p.cv_rms_um[0]));
}

TEST(Identify, PredictsALogWithoutOutputColumns) {
  const TimeSeries ts = TwoNodeNetwork(3);
  FitOptions o;
  o.model = "static";
  const ThermalModel m = FitThermalModel(ts, {}, o, kSplit);
  TimeSeries inputs_only = ts;
  inputs_only.output_names.clear();
  inputs_only.outputs_um.resize(static_cast<Eigen::Index>(ts.rows()), 0);
  const Prediction p = Predict(m, inputs_only);
  EXPECT_EQ(p.values_um.rows(), static_cast<Eigen::Index>(ts.rows()));
  EXPECT_EQ(p.outputs, std::vector<std::string>{"d_z"});
  EXPECT_LT((p.values_um - Predict(m, ts).values_um).cwiseAbs().maxCoeff(),
            1e-12);
}

// Real data: the FL spindle test, fitted on the first part and predicted
// from the inputs alone, against the simple models of the README on the
// same split. Fitted the README's way (ordinary least squares): static on
// all 16 temperatures; lags of n and n^2 at one time constant, chosen by
// the CV inside the fitted span (`lag_ols_cv`) and, the strictest reading,
// the one best on the holdout itself (`lag_ols_best`). Our ridge versions
// (ridge by CV) of both: `static_all_t`, `lag_speed`. `auto` (joint) and
// `select` (per output by CV, its fixed candidates).
struct Rms {
  double none, static_all_t, lag_speed, mine, select;
  double static_ols, lag_ols_cv, lag_ols_best;
  double simple() const { return std::min(static_all_t, lag_speed); }
  // The best of the README's simple models, its time constant chosen on the
  // holdout: the bar the customer sets, read as strictly as possible.
  double readme_best() const { return std::min(static_ols, lag_ols_best); }
  // The same with the time constant chosen inside the fitted span.
  double readme_cv() const { return std::min(static_ols, lag_ols_cv); }
};
double RmsFrom(const TimeSeries& ts, int j, double from,
               const Eigen::VectorXd& pred) {
  double s = 0;
  int n = 0;
  for (size_t i = 0; i < ts.rows(); ++i)
    if (ts.t_s[i] >= from && std::isfinite(ts.outputs_um(i, j))) {
      const double r = ts.outputs_um(i, j) - pred(static_cast<Eigen::Index>(i));
      s += r * r, ++n;
    }
  return std::sqrt(s / n);
}
std::vector<Rms> RealSplit(const TimeSeries& ts, double holdout_from_s) {
  const TimeSeries fit = HeadOf(ts, holdout_from_s);
  FitOptions o;
  o.auto_selected = false;
  FitOptions ols = o;
  ols.ridge = {0};
  std::vector<Rms> out;
  for (int j = 0; j < static_cast<int>(ts.output_names.size()); ++j) {
    Rms r;
    r.none = RmsFrom(ts, j, holdout_from_s, Eigen::VectorXd::Zero(ts.rows()));
    const std::vector<Regressor> temps = AllTemperatureRegressors(fit);
    r.static_all_t = RmsFrom(
        ts, j, holdout_from_s,
        PredictOutput(FitFixed(fit, j, temps, Structure::kStatic, o), ts));
    r.static_ols = RmsFrom(
        ts, j, holdout_from_s,
        PredictOutput(FitFixed(fit, j, temps, Structure::kStatic, ols), ts));
    OutputModel lag, lag_ols;
    lag.cv_score = lag_ols.cv_score = std::numeric_limits<double>::infinity();
    r.lag_ols_best = std::numeric_limits<double>::infinity();
    for (double tau : o.taus_s) {
      const std::vector<Regressor> regs = SpeedLagRegressors(fit, {tau});
      OutputModel m = FitFixed(fit, j, regs, Structure::kLag, o);
      if (m.cv_score < lag.cv_score) lag = m;
      m = FitFixed(fit, j, regs, Structure::kLag, ols);
      if (m.cv_score < lag_ols.cv_score) lag_ols = m;
      r.lag_ols_best = std::min(
          r.lag_ols_best, RmsFrom(ts, j, holdout_from_s, PredictOutput(m, ts)));
    }
    r.lag_speed = RmsFrom(ts, j, holdout_from_s, PredictOutput(lag, ts));
    r.lag_ols_cv = RmsFrom(ts, j, holdout_from_s, PredictOutput(lag_ols, ts));
    FitOptions ao = o;
    ao.model = "auto";
    r.mine = RmsFrom(
        ts, j, holdout_from_s,
        PredictOutput(
            FitThermalModel(fit, {fit.output_names[j]}, ao).outputs.front(),
            ts));
    r.select =
        RmsFrom(ts, j, holdout_from_s, PredictOutput(FitAuto(fit, j, o), ts));
    out.push_back(r);
  }
  return out;
}

// Sensors that jump in the fitted span, on the real log: its 16 sensors have
// none (T_t16 has bursts of up to 2.9 K between two rows that come back
// within minutes: an air sensor, not a fault), and a fault put into one
// sensor is found where it was put.
TimeSeries RealFirstHalf(double until_s) {
  return HeadOf(ReadThermalLog(std::string(TTP_DATA_DIR) +
                               "/reference/fl-thermal/train.csv"),
                until_s);
}

size_t RowAt(const TimeSeries& ts, double t_s) {
  size_t i = 0;
  while (i < ts.rows() && ts.t_s[i] < t_s) ++i;
  return i;
}

TEST(Identify, FindsNoSensorFaultInTheRealLog) {
  const TimeSeries ts = RealFirstHalf(1e9);
  EXPECT_TRUE(FindFittedJumps(ts).empty());
  // The largest step of T_t16 is far above the jump limits: only its
  // coming back keeps it from being a jump.
  const int j = ts.InputIndex("T_t16");
  ASSERT_GE(j, 0);
  double largest = 0;
  for (size_t i = 1; i < ts.rows(); ++i)
    largest =
        std::max(largest, std::abs(ts.inputs(i, j) - ts.inputs(i - 1, j)));
  EXPECT_GT(largest, 2.0);
}

TEST(Identify, FitShiftsOutASensorThatJumpsInTheFittedSpan) {
  const TimeSeries clean = RealFirstHalf(60000);
  TimeSeries jumped = clean;
  const int j = clean.InputIndex("T_t7");
  ASSERT_GE(j, 0);
  const size_t k = RowAt(clean, 30000);
  jumped.inputs.col(j).tail(clean.rows() - k).array() += 3.0;
  const std::vector<FittedJump> found = FindFittedJumps(HeadOf(jumped, 54000));
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].input, "T_t7");
  EXPECT_EQ(found[0].t_s, clean.t_s[k]);
  // The row's step less the sensor's own change there (median step around).
  EXPECT_NEAR(found[0].step, 3.0, 0.03);

  FitOptions o;  // auto
  const ThermalModel ref = FitThermalModel(clean, {"d_ch3"}, o, 54000);
  EXPECT_TRUE(ref.fitted_jumps.empty());
  EXPECT_TRUE(ref.fit_warnings.empty());
  const ThermalModel m = ModelFromJson(
      nlohmann::json::parse(
          ModelToJson(FitThermalModel(jumped, {"d_ch3"}, o, 54000)).dump()),
      "model.json");
  ASSERT_EQ(m.fitted_jumps.size(), 1u);
  ASSERT_EQ(m.fit_warnings.size(), 1u);
  EXPECT_NE(m.fit_warnings[0].find(
                fmt::format("T_t7 jumps by {:+.2f} K at t = {:g} s",
                            m.fitted_jumps[0].step, clean.t_s[k])),
            std::string::npos)
      << m.fit_warnings[0];
  // Nearly the model without the fault (the step's estimate is off by the
  // sensor's own change in that row), and nearly the same prediction of the
  // jumped log: over the fitted span and the rows after it, and for a log
  // that continues the fitted one.
  const Prediction want = Predict(ref, clean);
  const Prediction got = Predict(m, jumped);
  EXPECT_LT((got.values_um - want.values_um).cwiseAbs().maxCoeff(), 0.05);
  EXPECT_TRUE(got.jumps.empty());  // nothing left for Predict's own rule
  bool said = false;
  for (const auto& w : got.warnings)
    said |= w.find(fmt::format("T_t7: shifted back by {:+.2f} K",
                               m.fitted_jumps[0].step)) != std::string::npos;
  EXPECT_TRUE(said);
  const size_t first = RowAt(clean, 54000);
  const double offset = ContinuationOffset(m, jumped, first, got);
  EXPECT_GE(offset, 0) << "not taken as the continuation";
  EXPECT_LT(offset, 1e-6);
  const Eigen::Index nt = static_cast<Eigen::Index>(clean.rows() - first);
  // Kept (--keep-jumps): warned about, learnt, and the prediction after the
  // fitted span differs.
  FitOptions keep = o;
  keep.repair_jumps = false;
  const ThermalModel learnt = FitThermalModel(jumped, {"d_ch3"}, keep, 54000);
  EXPECT_TRUE(learnt.fitted_jumps.empty());
  ASSERT_EQ(learnt.fit_warnings.size(), 1u);
  EXPECT_NE(learnt.fit_warnings[0].find("not repaired"), std::string::npos);
  EXPECT_GT((Predict(learnt, jumped).values_um - want.values_um)
                .bottomRows(nt)
                .cwiseAbs()
                .maxCoeff(),
            0.5);
}

// What is not a jump: a burst that comes back within a minute, a step at a
// change of the spindle speed (the machine's), a step too close to the end
// of the span to tell whether it stays.
TEST(Identify, BurstsSpeedStepsAndTheSpansEdgeAreNotJumps) {
  const TimeSeries clean = RealFirstHalf(54000);
  const int j = clean.InputIndex("T_t7");
  const int n = clean.InputIndex("n_spindle");
  ASSERT_GE(j, 0);
  ASSERT_GE(n, 0);
  TimeSeries burst = clean;
  const size_t k = RowAt(clean, 30000);
  burst.inputs.col(j).segment(k, 4).array() += 3.0;
  EXPECT_TRUE(FindFittedJumps(burst).empty());
  size_t change = 1;
  while (change < clean.rows() &&
         clean.inputs(change, n) == clean.inputs(change - 1, n))
    ++change;
  ASSERT_LT(change, clean.rows() - 100);
  TimeSeries at_speed = clean;
  at_speed.inputs.col(j).tail(clean.rows() - change).array() += 1.0;
  EXPECT_TRUE(FindFittedJumps(at_speed).empty());
  // The same step 100 rows later is found.
  TimeSeries later = clean;
  later.inputs.col(j).tail(clean.rows() - change - 100).array() += 1.0;
  ASSERT_EQ(FindFittedJumps(later).size(), 1u);
  TimeSeries edge = clean;
  edge.inputs.col(j).tail(5).array() += 3.0;
  EXPECT_TRUE(FindFittedJumps(edge).empty());
}

// Fit on the first 15 h (1250 and 2500 1/min), predict the next 8 h (3750
// 1/min, never seen in the fit). Measured (docs/THERMAL.md): auto 1.42 /
// 1.74 / 2.91 / 3.07 / 5.30 um; the README's simple models fitted its way,
// the best of them per output 13.96 / 11.70 / 10.61 / 11.55 / 13.91 (2.6 to
// 9.8 times auto). Our ridge versions are stronger: 8.96 / 10.06 / 2.01 /
// 2.80 / 12.25 (the static model on all temperatures): auto far ahead on
// d_ch1, d_ch2, d_ch5, behind it on d_ch3 (1.45 times) and d_ch4 (1.10).
TEST(Identify, RealSpindleTestUnseenSpeed) {
  const TimeSeries ts = ReadThermalLog(std::string(TTP_DATA_DIR) +
                                       "/reference/fl-thermal/train.csv");
  const std::vector<Rms> r = RealSplit(ts, 54000);
  ASSERT_EQ(r.size(), 5u);
  for (int k = 0; k < 5; ++k)
    EXPECT_LT(r[k].mine, 0.45 * r[k].readme_best())
        << "d_ch" << k + 1 << ": auto " << r[k].mine << " README's best "
        << r[k].readme_best();
  for (int k : {0, 1, 4})
    EXPECT_LT(r[k].mine, 0.5 * r[k].simple())
        << "d_ch" << k + 1 << ": auto " << r[k].mine << " simple "
        << r[k].simple();
  for (int k : {2, 3}) {
    EXPECT_LT(r[k].mine, 0.15 * r[k].none) << "d_ch" << k + 1;
    EXPECT_LT(r[k].mine, 1.6 * r[k].static_all_t) << "d_ch" << k + 1;
  }
  // auto is the better method on this split: ahead of select everywhere.
  for (int k = 0; k < 5; ++k)
    EXPECT_LT(r[k].mine, r[k].select) << "d_ch" << k + 1;
}

// Outputs measured every 30 min while the inputs are logged every 15 s
// (thermal-log.md: displacements may be sparse): before a CV fold there are
// then fewer values (7 to 26 of them in the 15 h fitted) than the joint
// model's 42 regressors. Only a ridge determines such a fit: the fit must
// choose one, the model file must read back, and its prediction of the
// unseen 3750 1/min block must still be far better than no compensation.
// Measured: RMS 1.48 / 3.26 / 5.53 / 5.49 / 4.15 um against none 11.43 /
// 11.00 / 27.16 / 25.63 / 19.33 um (dense outputs: 1.42 / 1.74 / 2.91 /
// 3.07 / 5.30 um).
TEST(Identify, OutputsMeasuredEveryHalfHour) {
  TimeSeries ts = ReadThermalLog(std::string(TTP_DATA_DIR) +
                                 "/reference/fl-thermal/train.csv");
  for (Eigen::Index i = 0; i < ts.outputs_um.rows(); ++i)
    if (i % 120 != 0)
      ts.outputs_um.row(i).setConstant(
          std::numeric_limits<double>::quiet_NaN());
  const TimeSeries fit = HeadOf(ts, 54000);
  const ThermalModel m = FitThermalModel(fit, {}, FitOptions{});
  const ThermalModel back =
      ModelFromJson(nlohmann::json::parse(ModelToJson(m).dump()), "model.json");
  ASSERT_EQ(back.outputs.size(), 5u);
  const Prediction p = Predict(back, ts);
  for (int j = 0; j < 5; ++j) {
    const OutputModel& o = back.outputs[j];
    EXPECT_GT(o.ridge, 0) << o.output << ": 42 regressors, about 25 values";
    EXPECT_TRUE(std::isfinite(o.cv_rms_um)) << o.output;
    EXPECT_TRUE(std::isfinite(o.fit_rms_um)) << o.output;
    const double none = RmsFrom(ts, j, 54000, Eigen::VectorXd::Zero(ts.rows()));
    const double mine = RmsFrom(ts, j, 54000, p.values_um.col(j));
    EXPECT_LT(mine, 0.35 * none) << o.output << ": " << mine << " um";
  }
  // Ordinary least squares cannot be scored by the CV there: compare fits
  // the README's models on the whole span and chooses the lag in-sample.
  const CompareResult c = CompareModels(ts, 54000, FitOptions{});
  for (const CompareEntry& e : c.entries)
    for (const ResidualStats& s : e.stats)
      EXPECT_TRUE(std::isfinite(s.rms_um)) << e.name;
  // With ridge 0 alone nothing can be scored: bad input that says why.
  FitOptions ols;
  ols.ridge = {0};
  try {
    FitThermalModel(fit, {"d_ch1"}, ols);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ridge values above 0"),
              std::string::npos)
        << e.what();
  }
}

// Inside the first 15 h: fit on 10 h (1250 1/min, rest, 2 h of 2500),
// predict 36000..54000 s. Measured: auto 1.54 / 2.31 / 4.04 / 4.13 / 1.16
// um; the README's models fitted its way with the lag's time constant by CV
// 4.07 / 3.26 / 7.81 / 7.64 / 1.47 (1.3 to 2.6 times auto); with the time
// constant best on the holdout 1.73 / 2.10 / 5.95 / 6.00 / 1.47 (auto 1.12,
// 0.91, 1.47, 1.45, 1.27 times ahead: behind on d_ch2); our ridge versions
// 4.38 / 3.53 / 8.94 / 8.70 / 4.02; none 11.04 / 12.11 / 8.21 / 9.00 / 29.09.
TEST(Identify, RealSpindleTestInsideTheFirstHalf) {
  const TimeSeries ts =
      HeadOf(ReadThermalLog(std::string(TTP_DATA_DIR) +
                            "/reference/fl-thermal/train.csv"),
             54000);
  const std::vector<Rms> r = RealSplit(ts, 36000);
  ASSERT_EQ(r.size(), 5u);
  for (int k = 0; k < 5; ++k) {
    EXPECT_LT(r[k].mine, 0.8 * r[k].simple())
        << "d_ch" << k + 1 << ": auto " << r[k].mine;
    EXPECT_LT(r[k].mine, 0.85 * r[k].readme_cv())
        << "d_ch" << k + 1 << ": auto " << r[k].mine << " README's (tau by CV) "
        << r[k].readme_cv();
    EXPECT_LT(r[k].mine, 0.6 * r[k].none) << "d_ch" << k + 1;
    EXPECT_LT(r[k].mine, r[k].select) << "d_ch" << k + 1;
  }
  for (int k : {0, 2, 3, 4})
    EXPECT_LT(r[k].mine, 0.95 * r[k].readme_best())
        << "d_ch" << k + 1 << ": auto " << r[k].mine << " README's best "
        << r[k].readme_best();
  // The one cell behind: speed lags at the time constant best on the
  // holdout (3600 s) on d_ch2; auto stays within 1.2 times.
  EXPECT_LT(r[1].mine, 1.2 * r[1].readme_best());
}

}  // namespace
}  // namespace ttp::models
