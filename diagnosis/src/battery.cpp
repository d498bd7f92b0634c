#include "ttp/diagnosis/battery.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/inspect/inspect.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::diagnosis {

std::pair<double, double> BatterySizeRange(Cause cause) {
  switch (cause) {
    case Cause::kNone:
      return {0, 0};
    case Cause::kWorkpieceExpansion:
      return {0.2, 1.2};  // gain
    case Cause::kToolWear:
      return {0.4, 5.0};  // um/m
    case Cause::kClampingDistortion:
      return {0.4, 5.0};  // um
    case Cause::kCAxisIndexing:
      return {40.0, 400.0};  // urad
  }
  return {0, 0};
}

TwinOptions DrawBatteryRun(std::uint64_t seed, int index) {
  std::mt19937_64 rng(seed * 1000003ULL + static_cast<std::uint64_t>(index));
  auto uniform = [&](double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(rng);
  };
  TwinOptions o;
  o.effect = kAllCauses[std::uniform_int_distribution<int>(0, 4)(rng)];
  const auto [lo, hi] = BatterySizeRange(o.effect);
  o.size = lo > 0 ? std::exp(uniform(std::log(lo), std::log(hi))) : 0.0;
  o.seed = rng();
  o.compensation = uniform(0, 1) < 0.5;
  o.point_noise_um = uniform(0.2, 0.6);
  const int points[3] = {10000, 20000, 50000};
  o.cloud_points = points[std::uniform_int_distribution<int>(0, 2)(rng)];
  return o;
}

BatteryRun RunBatteryCase(const Config& config, const TwinOptions& options,
                          bool via_cloud, const DiagnosisOptions& diagnosis) {
  BatteryRun r;
  r.options = options;
  r.via_cloud = via_cloud;
  const TwinRun twin = RunTwin(config, options);
  const thermal::TalcLog log = thermal::ParseTalcLog(
      twin.log_text, fmt::format("twin seed {}", options.seed));
  MeasuredPiece measured;
  if (via_cloud) {
    const inspect::PointCloud cloud = TwinCloud(config, twin, options);
    const inspect::InspectionResult inspection =
        inspect::InspectCloud(config.part, cloud);
    measured = MeasuredPieceFromInspection(config.part, inspection);
  } else {
    measured = MeasuredPieceFromFeatures(config.part, twin.measured);
  }
  const DiagnosisReport report = DiagnoseRun(log, config, measured, diagnosis);
  r.diagnosed = CauseFromName(report.cause);
  r.best_delta_bic = std::numeric_limits<double>::infinity();
  for (const auto& c : report.candidates)
    if (c.cause != Cause::kNone && c.delta_bic < r.best_delta_bic) {
      r.best_delta_bic = c.delta_bic;
      r.best_cause = c.cause;
    }
  for (const auto& c : report.candidates)
    if (c.cause == r.diagnosed) {
      r.delta_bic = c.delta_bic;
      r.chi2_per_dof = c.chi2 / std::max(1, report.observations - c.parameters);
    }
  return r;
}

BatteryResult RunBattery(const Config& config, const BatteryOptions& options) {
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
      const bool cloud = options.cloud_every > 0 &&
                         k % options.cloud_every == options.cloud_every - 1;
      try {
        result.runs[k] = RunBatteryCase(config, DrawBatteryRun(options.seed, k),
                                        cloud, options.diagnosis);
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
    const int truth = static_cast<int>(r.options.effect);
    const int named = static_cast<int>(r.diagnosed);
    ++result.confusion[truth][named];
    if (truth == named) ++result.correct;
    if (r.options.effect == Cause::kNone && r.diagnosed != Cause::kNone)
      ++result.invented;
    if (r.via_cloud) {
      ++result.cloud_runs;
      if (truth == named) ++result.cloud_correct;
    }
  }
  result.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
          .count();
  return result;
}

std::string ConfusionText(const BatteryResult& result) {
  std::string s = fmt::format("{:<22}", "true \\ diagnosed");
  for (Cause c : kAllCauses) s += fmt::format(" {:>9.9}", CauseName(c));
  s += "\n";
  for (Cause t : kAllCauses) {
    s += fmt::format("{:<22}", CauseName(t));
    for (Cause d : kAllCauses)
      s += fmt::format(
          " {:>9}", result.confusion[static_cast<int>(t)][static_cast<int>(d)]);
    s += "\n";
  }
  double closest = std::numeric_limits<double>::infinity();
  for (const BatteryRun& r : result.runs)
    if (r.options.effect == Cause::kNone)
      closest = std::min(closest, r.best_delta_bic);
  if (std::isfinite(closest))
    s += fmt::format(
        "none-runs: the strongest evidence for any cause was delta BIC "
        "{:.1f} (a cause is named below -threshold)\n",
        closest);
  s += fmt::format(
      "correct {}/{} (through a CMM cloud and the inspection: {}/{}), causes "
      "invented in none-runs: {}, {:.1f} s on {} threads\n",
      result.correct, result.runs.size(), result.cloud_correct,
      result.cloud_runs, result.invented, result.seconds, result.threads);
  return s;
}

}  // namespace ttp::diagnosis
