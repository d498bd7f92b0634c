#include "ttp/sim/battery.h"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>

#include "ttp/geometry/error.h"
#include "ttp/inspect/inspect.h"
#include "ttp/thermal/estimator.h"
#include "ttp/thermal/simulate.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::sim {

const char* ScenarioName(Scenario s) {
  switch (s) {
    case Scenario::kNone:
      return "none";
    case Scenario::kSingle:
      return "single";
    case Scenario::kPair:
      return "pair";
    case Scenario::kOutside:
      return "outside";
    case Scenario::kMismatched:
      return "mismatched";
  }
  return "?";
}

bool BatteryOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (runs < 0) return fail("runs: must be >= 0");
  if (!(rtest_interval_s >= 150 && rtest_interval_s <= 7200))
    return fail("rtest_interval_s: must be 150..7200 s");
  for (double s : {none_share, pair_share, outside_share, mismatched_share,
                   other_instrument_share})
    if (!(s >= 0 && s <= 1)) return fail("*_share: must be 0..1");
  if (none_share + pair_share + outside_share + mismatched_share > 1)
    return fail("none_share + pair_share + outside_share + "
                "mismatched_share: must be <= 1");
  if (3 * other_instrument_share > 1)
    return fail("other_instrument_share: must be <= 1/3");
  if (cloud_every < 0) return fail("cloud_every: must be >= 0");
  if (!(size_scale > 0)) return fail("size_scale: must be > 0");
  return diagnosis.IsValid(error);
}

SizeRange BatterySizeRange(const std::string& effect) {
  if (effect == "workpiece_expansion") return {0.3, 1.2};  // gain
  if (effect == "tool_wear") return {1.0, 5.0};            // um/m
  if (effect == "clamping_distortion") return {1.0, 5.0};  // um
  if (effect == "c_axis_indexing") return {50.0, 300.0};   // urad
  if (effect == "step") return {0.8, 3.0};                 // um
  if (effect == "two_lobe") return {2.0, 6.0};             // um
  return {0, 0};
}

BatteryCase DrawBatteryCase(const BatteryOptions& o, int index) {
  std::mt19937_64 rng(o.seed * 1000003ULL + static_cast<std::uint64_t>(index));
  auto uniform = [&](double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(rng);
  };
  auto size_of = [&](const std::string& effect) {
    const SizeRange r = BatterySizeRange(effect);
    return o.size_scale * std::exp(uniform(std::log(r.lo), std::log(r.hi)));
  };
  const char* catalogue[4] = {"workpiece_expansion", "tool_wear",
                              "clamping_distortion", "c_axis_indexing"};
  BatteryCase c;
  const double u = uniform(0, 1);
  double edge = o.none_share;
  if (u < edge) {
    c.scenario = Scenario::kNone;
  } else if (u < (edge += o.pair_share)) {
    c.scenario = Scenario::kPair;
  } else if (u < (edge += o.outside_share)) {
    c.scenario = Scenario::kOutside;
  } else if (u < (edge += o.mismatched_share)) {
    c.scenario = Scenario::kMismatched;
  } else {
    c.scenario = Scenario::kSingle;
  }
  TwinOptions& t = c.twin;
  t.seed = rng();
  t.rtest_interval_s = o.rtest_interval_s;
  t.compensation = uniform(0, 1) < 0.5;
  t.point_noise_um = uniform(0.2, 0.6);
  const int points[3] = {10000, 20000, 50000};
  t.cloud_points = points[std::uniform_int_distribution<int>(0, 2)(rng)];
  const int first = std::uniform_int_distribution<int>(0, 3)(rng);
  int second = std::uniform_int_distribution<int>(0, 2)(rng);
  if (second >= first) ++second;
  switch (c.scenario) {
    case Scenario::kNone:
    case Scenario::kMismatched:
      break;
    case Scenario::kSingle:
      SetEffect(&t, catalogue[first], size_of(catalogue[first]));
      break;
    case Scenario::kPair:
      SetEffect(&t, catalogue[first], size_of(catalogue[first]));
      SetEffect(&t, catalogue[second], size_of(catalogue[second]));
      break;
    case Scenario::kOutside:
      if (uniform(0, 1) < 0.5)
        t.step_um = size_of("step") * (uniform(0, 1) < 0.5 ? -1 : 1);
      else
        t.two_lobe_amplitude_um = size_of("two_lobe");
      break;
  }
  c.truncated_log = c.scenario == Scenario::kMismatched && uniform(0, 1) < 0.3;
  const double instrument = uniform(0, 1);
  c.instrument = instrument < o.other_instrument_share ? Instrument::kProbe
                 : instrument < 2 * o.other_instrument_share
                     ? Instrument::kDial
                 : instrument < 3 * o.other_instrument_share
                     ? Instrument::kDmis
                     : Instrument::kCloudFit;
  c.via_cloud = c.instrument == Instrument::kCloudFit && o.cloud_every > 0 &&
                index % o.cloud_every == o.cloud_every - 1;
  // What the instrument can show: a dial gauge reads no facet angles, and
  // a C stop error turns the facets without moving them (diagnosis.md
  // sections 1 and 4), so no diagnosis can name it from a dial's readings.
  TwinOptions shown = t;
  if (c.instrument == Instrument::kDial) shown.c_indexing_amplitude_urad = 0;
  c.expected = c.scenario == Scenario::kMismatched ? "refused"
                                                   : shown.ExpectedOutcome();
  return c;
}

namespace {
// The log cut short after the first R-test that follows the middle of the
// run: the last cycles' cuts are missing from it.
std::string TruncateLog(const std::string& text) {
  std::string out;
  size_t pos = 0;
  int rows = 0;
  std::vector<std::string> lines;
  while (pos < text.size()) {
    const size_t end = text.find('\n', pos);
    lines.push_back(text.substr(pos, end - pos));
    if (end == std::string::npos) break;
    pos = end + 1;
  }
  for (const auto& l : lines)
    if (!l.empty() && l[0] != '#') ++rows;
  int kept = 0;
  bool past_middle = false;
  for (const auto& l : lines) {
    if (l.empty()) continue;
    out += l + "\n";
    if (l[0] == '#') continue;
    ++kept;
    if (kept > rows * 2 / 3) past_middle = true;
    if (past_middle && l.find(",rtest,") != std::string::npos) break;
  }
  return out;
}
}  // namespace

BatteryRun RunBatteryCase(const Config& config, const BatteryCase& c,
                          const diagnosis::DiagnosisOptions& options) {
  BatteryRun r;
  r.c = c;
  const TwinRun twin = RunTwin(config, c.twin);
  std::string log_text = twin.log_text;
  const TwinRun* piece_run = &twin;
  TwinRun other;
  if (c.scenario == Scenario::kMismatched) {
    if (c.truncated_log) {
      log_text = TruncateLog(twin.log_text);
    } else {
      TwinOptions o = c.twin;
      o.seed = c.twin.seed ^ 0x9e3779b97f4a7c15ULL;
      other = RunTwin(config, o);
      piece_run = &other;
    }
  }
  const thermal::TalcLog log =
      thermal::ParseTalcLog(log_text, fmt::format("twin seed {}", c.twin.seed));
  diagnosis::MeasuredPiece measured;
  if (c.via_cloud) {
    const inspect::PointCloud cloud = TwinCloud(config, *piece_run, c.twin);
    measured = diagnosis::MeasuredPieceFromInspection(
        config.part, inspect::InspectCloud(config.part, cloud));
  } else if (c.instrument == Instrument::kCloudFit) {
    measured =
        diagnosis::MeasuredPieceFromFeatures(config.part, piece_run->measured);
  } else {
    measured = diagnosis::MeasuredPieceFromFeatures(
        config.part,
        MeasureWith(config.part, piece_run->true_results, c.instrument,
                    c.twin.point_noise_um, c.twin.seed));
  }
  measured.source = "twin piece";
  diagnosis::DiagnosisReport report;
  try {
    report = diagnosis::DiagnoseRun(log, config, measured, options);
  } catch (const InputError& e) {
    // A log cut short may not even be simulated: the log does not cover
    // the cut times, which `ttp diagnose` reports as refused.
    if (!c.truncated_log) throw;
    report.status = diagnosis::DiagnosisStatus::kRefused;
    report.reason = e.what();
  }
  r.status = report.status;
  r.outcome = report.status == diagnosis::DiagnosisStatus::kNamed
                  ? report.cause
                  : diagnosis::StatusName(report.status);
  r.correct = r.outcome == c.expected;
  const bool expects_cause = c.expected != "none" &&
                             c.expected != "unexplained" &&
                             c.expected != "refused";
  r.false_name =
      !expects_cause && report.status == diagnosis::DiagnosisStatus::kNamed;
  r.chi2_per_dof = report.chi2_per_dof;
  r.reason = report.reason;
  r.best_evidence = report.best_evidence;
  r.structure_z = report.structure_z;
  r.step_chi2 = report.step_chi2;
  r.machine_z = report.machine_z;
  r.machine_pooled_z = report.machine_pooled_z;
  r.best_delta_bic = std::numeric_limits<double>::infinity();
  for (const auto& cand : report.candidates)
    if (!cand.causes.empty() && cand.delta_bic < r.best_delta_bic)
      r.best_delta_bic = cand.delta_bic;
  return r;
}

BatteryResult RunBattery(const Config& config, const BatteryOptions& options) {
  std::string invalid;
  if (!options.IsValid(&invalid))
    throw std::invalid_argument("BatteryOptions." + invalid);
  const auto start = std::chrono::steady_clock::now();
  BatteryResult result;
  const int runs = options.runs;
  result.runs.resize(runs);
  std::vector<std::string> errors(runs);
  int threads = options.threads > 0
                    ? options.threads
                    : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::clamp(threads, 1, std::max(1, runs));
  result.threads = threads;
  std::atomic<int> next{0};
  auto worker = [&] {
    for (int k = next++; k < runs; k = next++) {
      try {
        result.runs[k] = RunBatteryCase(
            config, DrawBatteryCase(options, k), options.diagnosis);
      } catch (const std::exception& e) {
        errors[k] = e.what();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  for (int k = 0; k < runs; ++k)
    if (!errors[k].empty())
      throw std::runtime_error(fmt::format("battery run {}: {}", k, errors[k]));
  for (const BatteryRun& r : result.runs) {
    ++result.confusion[r.c.expected][r.outcome];
    result.correct += r.correct;
    result.false_names += r.false_name;
    const bool no_cause = r.c.expected == "none" ||
                          r.c.expected == "unexplained" ||
                          r.c.expected == "refused";
    result.no_cause_runs += no_cause;
  }
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return result;
}

std::string ConfusionText(const BatteryResult& result) {
  std::vector<std::string> outcomes;
  for (const auto& [expected, row] : result.confusion)
    for (const auto& [outcome, n] : row)
      if (std::find(outcomes.begin(), outcomes.end(), outcome) ==
          outcomes.end())
        outcomes.push_back(outcome);
  std::sort(outcomes.begin(), outcomes.end());
  std::string s = "expected \\ outcome\n";
  for (size_t k = 0; k < outcomes.size(); ++k)
    s += fmt::format("  [{}] {}\n", k, outcomes[k]);
  s += fmt::format("{:<44}", "");
  for (size_t k = 0; k < outcomes.size(); ++k) s += fmt::format(" {:>4}", k);
  s += "\n";
  for (const auto& [expected, row] : result.confusion) {
    s += fmt::format("{:<44}", expected);
    for (const auto& o : outcomes) {
      auto it = row.find(o);
      s += fmt::format(" {:>4}", it == row.end() ? 0 : it->second);
    }
    s += "\n";
  }
  s += fmt::format(
      "right outcome {}/{}, causes named in runs without one (none, outside "
      "the catalogue, mismatched): {}/{}, {:.1f} s on {} threads\n",
      result.correct, result.runs.size(), result.false_names,
      result.no_cause_runs, result.seconds, result.threads);
  return s;
}

BudgetCoverage MeasureBudgetCoverage(const Config& config,
                                     const TwinOptions& twin_options) {
  const TwinRun twin = RunTwin(config, twin_options);
  const thermal::TalcLog log = thermal::ParseTalcLog(twin.log_text, "twin");
  const auto est = thermal::MachineErrorEstimator::Fit(
      log, thermal::EstimatorOptionsFor(config.machine));
  const diagnosis::PreparedRun run = diagnosis::PrepareRun(
      log, config, est, thermal::SimulatePiece(log, config, est, {}),
      diagnosis::MeasuredPieceFromFeatures(config.part, twin.true_results));
  const diagnosis::Observations& o = run.observations;
  const auto& rt = est.rtest_times_s();
  BudgetCoverage out;
  for (int g = 0; g < 4; ++g) {
    std::vector<size_t> idx;
    for (size_t i = 0; i < o.figures(); ++i)
      if (o.figure_kind[i] == g) idx.push_back(i);
    const int n = static_cast<int>(idx.size());
    if (n < 3) continue;
    Eigen::MatrixXd c(n, n);
    Eigen::VectorXd r(n), one = Eigen::VectorXd::Ones(n);
    for (int a = 0; a < n; ++a) {
      r[a] = o.figure_value_um[idx[a]];
      for (int b = 0; b < n; ++b)
        c(a, b) = o.figure_covariance_um2(idx[a], idx[b]);
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(c);
    const Eigen::VectorXd cr = llt.solve(r), c1 = llt.solve(one);
    const double offset = one.dot(cr) / one.dot(c1);
    out.chi2_per_dof.push_back((r.dot(cr) - offset * one.dot(cr)) / (n - 1));
    for (int a = 0; a < n; ++a) {
      const double ti = o.figure_t_s[idx[a]];
      const auto hi = std::upper_bound(rt.begin(), rt.end(), ti);
      double place = 1;
      if (hi != rt.begin() && hi != rt.end())
        place = std::min(ti - *(hi - 1), *hi - ti) / (*hi - *(hi - 1));
      out.z.push_back((r[a] - offset) / std::sqrt(c(a, a)));
      out.gap_place.push_back(place);
    }
  }
  return out;
}

}  // namespace ttp::sim
