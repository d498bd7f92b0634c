// Prints: the time of one diagnosis (sample run-a: log read, inspection
// JSON read, estimator, simulation, five causes fitted, leave-one-cycle-out
// gain; target < 1 s), the same from the raw cloud (inspection included),
// and the 100-run hidden-effect battery (twin, every run through a CMM
// cloud and the inspection; target < 2 min on 2 cores) with its confusion
// matrix, on 1 thread and on all cores. Never fails.
#include <fmt/format.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>

#include "ttp/diagnosis/battery.h"
#include "ttp/diagnosis/diagnose.h"
#include "ttp/geometry/file_io.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/point_io.h"
#include "ttp/thermal/talc_log.h"

#ifndef TTP_DATA_DIR
#define TTP_DATA_DIR "."
#endif

using namespace ttp;
using namespace ttp::diagnosis;

namespace {
double Since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0)
      .count();
}
}  // namespace

int main() {
  const Config config;
  const char* shared = std::getenv("TTP_DATA_DIR");
  const std::filesystem::path run_a =
      std::filesystem::path(shared ? shared : TTP_DATA_DIR) / "samples/run-a";
  if (std::filesystem::exists(run_a / "piece.ply")) {
    // The inspection JSON a user has after `ttp inspect --json`.
    const inspect::PointCloud cloud =
        inspect::ReadPointCloud(run_a / "piece.ply");
    const nlohmann::json inspection =
        inspect::InspectionToJson(inspect::InspectCloud(config.part, cloud));
    const auto json_path =
        std::filesystem::temp_directory_path() / "ttp_bench_diagnosis_a.json";
    WriteFileAtomic(json_path, inspection.dump());
    const int repeats = 5;
    DiagnosisReport report;
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < repeats; ++k) {
      const thermal::TalcLog log =
          thermal::ReadTalcLog((run_a / "talc.csv").string());
      report = DiagnoseRun(log, config,
                           LoadMeasuredPiece(config, json_path.string()));
    }
    const double one = Since(t0) / repeats;
    t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < repeats; ++k) {
      const thermal::TalcLog log =
          thermal::ReadTalcLog((run_a / "talc.csv").string());
      const inspect::PointCloud c =
          inspect::ReadPointCloud(run_a / "piece.ply");
      const MeasuredPiece m = MeasuredPieceFromInspection(
          config.part, inspect::InspectCloud(config.part, c));
      report = DiagnoseRun(log, config, m);
    }
    const double from_cloud = Since(t0) / repeats;
    fmt::print(
        "one diagnosis (sample run-a, log + inspection JSON): {:.3f} s "
        "(target < 1 s), from the raw cloud incl. inspection: {:.3f} s; "
        "cause {}\n",
        one, from_cloud, report.cause);
  } else {
    fmt::print("sample run-a not found ({}): one-run timing skipped\n",
               run_a.string());
  }

  // One twin run of each cause: twin + diagnosis.
  for (Cause c : kAllCauses) {
    TwinOptions o;
    o.effect = c;
    o.size = BatterySizeRange(c).second / 2;
    o.seed = 3;
    const auto t0 = std::chrono::steady_clock::now();
    const BatteryRun r = RunBatteryCase(config, o, false);
    const double feature_s = Since(t0);
    const auto t1 = std::chrono::steady_clock::now();
    const BatteryRun rc = RunBatteryCase(config, o, true);
    fmt::print(
        "twin + diagnosis, {:<20} -> {:<20} {:.3f} s; through a 20k-point "
        "cloud -> {:<20} {:.3f} s\n",
        CauseName(c), CauseName(r.diagnosed), feature_s,
        CauseName(rc.diagnosed), Since(t1));
  }

  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  for (int threads : {1, static_cast<int>(cores)}) {
    BatteryOptions options;  // 100 runs, seed of the test, all clouds
    options.threads = threads;
    const BatteryResult result = RunBattery(config, options);
    fmt::print(
        "\nbattery, {} runs on {} thread(s): {:.1f} s (target < 120 s "
        "on 2 cores)\n{}",
        result.runs.size(), result.threads, result.seconds,
        ConfusionText(result));
    if (threads == static_cast<int>(cores)) break;
  }
  return 0;
}
