// Hidden-effect battery (issue 4): for fixed seeds a cause is drawn at
// random with a size between barely above noise and large, noise, point
// count and compensation are drawn too; the twin makes the run and the
// diagnosis has to name the cause. Shared by the test and the bench.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/diagnosis/effects.h"
#include "ttp/diagnosis/twin.h"
#include "ttp/geometry/config.h"

namespace ttp::diagnosis {

struct BatteryRun {
  TwinOptions options;
  // Measured as a user would: the twin's CMM cloud -> inspect::InspectCloud
  // -> MeasuredPieceFromInspection (as `ttp diagnose`). Otherwise the twin's
  // per-feature results with cloud-fit noise.
  bool via_cloud = false;
  Cause diagnosed = Cause::kNone;
  double delta_bic = 0;     // of the named cause (0 for none)
  double chi2_per_dof = 0;  // of the named model
  // The best cause other than none and its delta BIC, whether named or not
  // (how close a none-run came to inventing a cause).
  Cause best_cause = Cause::kNone;
  double best_delta_bic = 0;
};

struct BatteryResult {
  std::vector<BatteryRun> runs;
  // confusion[true][diagnosed], in kAllCauses order.
  std::array<std::array<int, 5>, 5> confusion{};
  int correct = 0;
  int invented = 0;  // none-runs given a cause
  int cloud_runs = 0, cloud_correct = 0;
  double seconds = 0;
  int threads = 1;
};

struct BatteryOptions {
  int runs = 100;
  std::uint64_t seed = 20261122;
  // Every cloud_every-th run (index % cloud_every == cloud_every - 1) goes
  // through a synthetic CMM cloud and the inspection; 0: none, 1: all (the
  // default: every measured piece is made the way a user's is).
  int cloud_every = 1;
  int threads = 0;  // 0: std::thread::hardware_concurrency()
  DiagnosisOptions diagnosis;
};

// Size range drawn (log-uniform) per cause, in the twin's size units.
std::pair<double, double> BatterySizeRange(Cause cause);
// The drawn options of run `index` (depends only on seed and index).
TwinOptions DrawBatteryRun(std::uint64_t seed, int index);
// One run: twin, measurement, diagnosis (deterministic in its inputs).
BatteryRun RunBatteryCase(const Config& config, const TwinOptions& options,
                          bool via_cloud,
                          const DiagnosisOptions& diagnosis = {});
// The runs in parallel over threads; the result does not depend on the
// number of threads.
BatteryResult RunBattery(const Config& config, const BatteryOptions& options);
std::string ConfusionText(const BatteryResult& result);

}  // namespace ttp::diagnosis
