// The diagnosis under production conditions. Prints:
//  - the time of one diagnosis of a 20k-point cloud (sample run-a: log,
//    cloud read and inspected, estimator, simulation, every candidate and
//    the held-out gain; target < 0.2 s without the inspection);
//  - per R-test spacing (300, 1800, 3600, 7200 s): the battery's confusion
//    matrix (expected outcome x outcome), right outcomes and causes named
//    in runs without one, and its time (100 runs: target < 60 s on 2 cores);
//  - the calibration of the decision rule: over runs without a cause, the
//    strongest evidence for any cause (delta BIC) and the goodness of fit
//    (chi2 per degree of freedom), as quantiles;
//  - the detection limit per cause: the share of runs named right against
//    the effect size, and the size named in 90 % of runs.
// Arguments: [runs per battery (100)] [runs per detection point (20)];
// `list SPACING [RUNS] [SEED]`, `calibrate RUNS [SCALE]` and `coverage
// SPACING [RUNS]` (the estimator's budget against its actual errors at
// the cut times) print one part each.
// Never fails.
#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <numeric>
#include <string>
#include <thread>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/point_io.h"
#include "ttp/sim/battery.h"
#include "ttp/sim/twin.h"
#include "ttp/thermal/estimator.h"
#include "ttp/thermal/simulate.h"
#include "ttp/thermal/talc_log.h"

#ifndef TTP_DATA_DIR
#define TTP_DATA_DIR "."
#endif

using namespace ttp;
using namespace ttp::diagnosis;
using namespace ttp::sim;

namespace {
double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0)
      .count();
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * v.size()))];
}

void OneDiagnosis(const Config& config) {
  const char* data = std::getenv("TTP_DATA_DIR");
  const std::filesystem::path run_a =
      std::filesystem::path(data ? data : TTP_DATA_DIR) / "samples/run-a";
  if (!std::filesystem::exists(run_a / "piece.ply")) {
    fmt::print("sample run-a not found: one-run timing skipped\n");
    return;
  }
  const inspect::PointCloud cloud =
      inspect::ReadPointCloud(run_a / "piece.ply");
  auto t0 = std::chrono::steady_clock::now();
  const MeasuredPiece m = MeasuredPieceFromInspection(
      config.part, inspect::InspectCloud(config.part, cloud));
  const double inspection = Since(t0);
  const int repeats = 5;
  DiagnosisReport report;
  t0 = std::chrono::steady_clock::now();
  for (int k = 0; k < repeats; ++k) {
    const thermal::TalcLog log =
        thermal::ReadTalcLog((run_a / "talc.csv").string());
    report = DiagnoseRun(log, config, m);
  }
  fmt::print(
      "one diagnosis of a {}-point cloud (sample run-a): {:.3f} s (target < "
      "0.2 s), the cloud's inspection {:.3f} s; status {}, cause {}\n",
      cloud.size(), Since(t0) / repeats, inspection, StatusName(report.status),
      report.cause);
}
}  // namespace

// `bench_diagnosis calibrate RUNS [SCALE]`: runs without a cause and runs
// with an effect outside the catalogue only, at every spacing, with the
// estimator's sigma scaled by SCALE: the distributions the decision rule
// is calibrated on.
int Calibrate(const Config& config, int runs, double scale) {
  const int threads =
      std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  for (double spacing : {300.0, 1800.0, 3600.0, 7200.0}) {
    BatteryOptions o;
    o.runs = runs;
    o.seed = 555;
    o.rtest_interval_s = spacing;
    o.none_share = 1.0;
    o.outside_share = 0;
    o.pair_share = o.mismatched_share = 0;
    o.other_instrument_share = 0.25;
    o.cloud_every = 10;
    o.threads = threads;
    if (scale > 0) o.diagnosis.estimator_sigma_scale = scale;
    const BatteryResult r = RunBattery(config, o);
    std::vector<double> bic, chi2, z, step, machine, pooled;
    for (const BatteryRun& run : r.runs) {
      if (run.c.expected != "none") continue;
      if (!run.correct)
        fmt::print("  none seed {} comp {} instrument {}{} -> {}: {}\n",
                   run.c.twin.seed, run.c.twin.compensation,
                   InstrumentName(run.c.instrument),
                   run.c.via_cloud ? " via cloud" : "", run.outcome,
                   run.reason);
      bic.push_back(run.best_evidence);
      chi2.push_back(run.chi2_per_dof);
      z.push_back(run.structure_z);
      step.push_back(run.step_chi2);
      machine.push_back(run.machine_z);
      pooled.push_back(run.machine_pooled_z);
    }
    auto line = [&](const char* name, const std::vector<double>& v) {
      fmt::print(
          "  {:<34} median {:7.2f}  95 % {:7.2f}  99 % {:7.2f}  max "
          "{:7.2f}\n",
          name, Quantile(v, 0.5), Quantile(v, 0.95), Quantile(v, 0.99),
          Quantile(v, 1.0));
    };
    const auto count = [&r](const char* outcome) {
      return std::count_if(
          r.runs.begin(), r.runs.end(),
          [outcome](const BatteryRun& x) { return x.outcome == outcome; });
    };
    fmt::print(
        "{:>5.0f} s: {} runs without a cause, {} named, {} unexplained, {} "
        "refused\n",
        spacing, bic.size(), r.false_names, count("unexplained"),
        count("refused"));
    line("evidence (-delta BIC, best cause)", bic);
    line("chi2 per degree of freedom", chi2);
    line("largest per-kind chi2 deviate", z);
    line("largest chi2 explained by a step", step);
    line("largest E_X/E_Y/E_Z chi2 deviate", machine);
    line("E_X, E_Y, E_Z pooled chi2 deviate", pooled);
    fmt::print("  pooled deviate above named_machine_z ({:g}): {} runs\n",
               o.diagnosis.named_machine_z,
               std::count_if(pooled.begin(), pooled.end(), [&](double v) {
                 return v > o.diagnosis.named_machine_z;
               }));
  }
  return 0;
}

// `bench_diagnosis list SPACING RUNS [SEED]`: the battery at one spacing,
// every run that misses its expected outcome with the diagnosis' reason.
int List(const Config& config, double spacing, int runs, std::uint64_t seed) {
  BatteryOptions o;
  o.runs = runs;
  o.seed = seed;
  o.rtest_interval_s = spacing;
  o.cloud_every = 10;
  o.threads =
      std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const BatteryResult r = RunBattery(config, o);
  for (size_t k = 0; k < r.runs.size(); ++k) {
    const BatteryRun& run = r.runs[k];
    if (run.correct) continue;
    fmt::print(
        "#{} {} expected {} -> {} ({}{}, comp {}, step {:.2f} um from {}, "
        "two-lobe {:.2f} um, seed {}): {}\n",
        k, ScenarioName(run.c.scenario), run.c.expected, run.outcome,
        InstrumentName(run.c.instrument), run.c.via_cloud ? " via cloud" : "",
        run.c.twin.compensation, run.c.twin.step_um, run.c.twin.step_from_cycle,
        run.c.twin.two_lobe_amplitude_um, run.c.twin.seed, run.reason);
  }
  fmt::print("{}", ConfusionText(r));
  return 0;
}

// `bench_diagnosis coverage SPACING RUNS`: the estimator part of the
// error budget against the estimator's actual errors at the cut times. Per
// run without an effect, the noise-free cut piece (the twin's true
// geometry) minus the simulation from the log is the estimator's error in
// the figures; per figure kind, after its offset, whitened by the budget:
// chi2 per degree of freedom near 1 (and its tail as chi2's) when the
// budget is right. Also each figure's own z (after the offset) by the
// cut's place between its R-tests (fraction of the gap to the nearest).
int Coverage(const Config& config, double spacing, int runs) {
  const int threads =
      std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  std::vector<std::vector<double>> chi2(runs), zin(runs), place(runs);
  std::atomic<int> next{0};
  auto work = [&] {
    for (int k = next++; k < runs; k = next++) {
      TwinOptions t;
      t.seed = 90001 + 7919ULL * k;
      t.rtest_interval_s = spacing;
      t.compensation = k % 2 == 1;
      const sim::BudgetCoverage cover = sim::MeasureBudgetCoverage(config, t);
      chi2[k] = cover.chi2_per_dof;
      zin[k] = cover.z;
      place[k] = cover.gap_place;
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t) pool.emplace_back(work);
  for (auto& t : pool) t.join();
  std::vector<double> all, near_z, far_z;
  for (int k = 0; k < runs; ++k) {
    all.insert(all.end(), chi2[k].begin(), chi2[k].end());
    for (size_t i = 0; i < zin[k].size(); ++i)
      (place[k][i] < 0.15 ? near_z : far_z).push_back(std::abs(zin[k][i]));
  }
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return v.empty() ? 0.0 : std::sqrt(s / v.size());
  };
  fmt::print(
      "{:>5.0f} s: {} runs, per-kind chi2/dof of the estimator's error "
      "against its budget: mean {:.2f} median {:.2f} 95 % {:.2f} 99 % "
      "{:.2f} max {:.2f}\n  |z| of a figure: next to an R-test (< 0.15 gap) "
      "rms {:.2f} 99 % {:.2f} (n {}), in the gap rms {:.2f} 99 % {:.2f} (n "
      "{})\n",
      spacing, runs,
      std::accumulate(all.begin(), all.end(), 0.0) /
          std::max<size_t>(1, all.size()),
      Quantile(all, 0.5), Quantile(all, 0.95), Quantile(all, 0.99),
      Quantile(all, 1.0), rms(near_z), Quantile(near_z, 0.99), near_z.size(),
      rms(far_z), Quantile(far_z, 0.99), far_z.size());
  return 0;
}

int main(int argc, char** argv) {
  const Config config;
  if (argc > 2 && std::string(argv[1]) == "list")
    return List(config, std::atof(argv[2]), argc > 3 ? std::atoi(argv[3]) : 100,
                argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 20261122);
  if (argc > 2 && std::string(argv[1]) == "coverage")
    return Coverage(config, std::atof(argv[2]),
                    argc > 3 ? std::atoi(argv[3]) : 100);
  if (argc > 1 && std::string(argv[1]) == "calibrate")
    return Calibrate(config, argc > 2 ? std::atoi(argv[2]) : 50,
                     argc > 3 ? std::atof(argv[3]) : 0.0);
  const int runs = argc > 1 ? std::atoi(argv[1]) : 100;
  const int per_point = argc > 2 ? std::atoi(argv[2]) : 20;
  const int threads =
      std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  OneDiagnosis(config);

  std::vector<double> none_bic, none_chi2;
  for (double spacing : {300.0, 1800.0, 3600.0, 7200.0}) {
    BatteryOptions o;
    o.runs = runs;
    o.rtest_interval_s = spacing;
    o.cloud_every = 10;
    o.threads = threads;
    const BatteryResult r = RunBattery(config, o);
    fmt::print("\n== R-tests every {:.0f} s: {} runs ==\n{}", spacing, runs,
               ConfusionText(r));
    for (const BatteryRun& run : r.runs)
      if (run.c.expected == "none") {
        none_bic.push_back(-run.best_delta_bic);
        none_chi2.push_back(run.chi2_per_dof);
      }
  }
  fmt::print(
      "\ncalibration over {} runs without a cause: strongest evidence for a "
      "cause (-delta BIC) median {:.1f}, 95 % {:.1f}, 99 % {:.1f}, max {:.1f} "
      "(threshold {:g}); chi2/dof median {:.2f}, 99 % {:.2f}, max {:.2f} "
      "(limit {:g})\n",
      none_bic.size(), Quantile(none_bic, 0.5), Quantile(none_bic, 0.95),
      Quantile(none_bic, 0.99), Quantile(none_bic, 1.0),
      DiagnosisOptions{}.evidence_threshold, Quantile(none_chi2, 0.5),
      Quantile(none_chi2, 0.99), Quantile(none_chi2, 1.0),
      DiagnosisOptions{}.max_chi2_per_dof);

  // Detection limit: one catalogue cause, its size scaled down from the
  // battery's range (not measured with 0 runs per point).
  if (per_point <= 0) return 0;
  fmt::print(
      "\ndetection (share named right; {} runs per point; R-tests "
      "every 300 s and 3600 s)\n",
      per_point);
  const char* causes[4] = {"workpiece_expansion", "tool_wear",
                           "clamping_distortion", "c_axis_indexing"};
  for (const char* cause : causes) {
    const SizeRange range = BatterySizeRange(cause);
    for (double spacing : {300.0, 3600.0}) {
      std::string line = fmt::format("{:<20} {:>5.0f} s:", cause, spacing);
      double limit = -1;
      // The battery's range first; past it (x 1.5 .. 5) until two sizes in
      // a row are named in 90 % of runs, so that every curve ends in a
      // confirmed limit or shows where it levels off.
      int at_90_in_a_row = 0;
      for (double f : {0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.5, 5.0}) {
        if (f > 1.0 && at_90_in_a_row >= 2) break;
        const double size = range.lo * f * 2;
        BatteryOptions o;
        o.runs = per_point;
        o.rtest_interval_s = spacing;
        o.none_share = o.pair_share = o.outside_share = o.mismatched_share = 0;
        o.other_instrument_share = 0;
        o.threads = threads;
        o.seed = 7000 + static_cast<int>(f * 100);
        int right = 0;
        std::vector<BatteryCase> cases;
        for (int k = 0; k < per_point; ++k) {
          BatteryCase c = DrawBatteryCase(o, k);
          c.twin = TwinOptions{};
          c.twin.seed = o.seed * 31 + k;
          c.twin.rtest_interval_s = spacing;
          c.twin.compensation = k % 2 == 1;
          SetEffect(&c.twin, cause, size);
          c.expected = cause;
          cases.push_back(c);
        }
        std::vector<int> ok(cases.size(), 0);
        std::vector<std::thread> pool;
        std::atomic<int> next{0};
        auto work = [&] {
          for (int k = next++; k < static_cast<int>(cases.size()); k = next++)
            ok[k] = RunBatteryCase(config, cases[k]).correct;
        };
        for (int t = 0; t < threads; ++t) pool.emplace_back(work);
        for (auto& t : pool) t.join();
        for (int v : ok) right += v;
        const double share = static_cast<double>(right) / per_point;
        line += fmt::format("  {:.3g}:{:.0f}%", size, 100 * share);
        // The smallest size from which every larger one is named in 90 %.
        at_90_in_a_row = share < 0.9 ? 0 : at_90_in_a_row + 1;
        if (share < 0.9)
          limit = -1;
        else if (limit < 0)
          limit = size;
      }
      fmt::print(
          "{}  -> 90 % at {}\n", line,
          limit < 0 ? std::string("> tested") : fmt::format("{:.3g}", limit));
    }
  }
  return 0;
}
