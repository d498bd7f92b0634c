// The diagnosis battery: for fixed seeds, runs are drawn with no effect,
// one catalogue effect, a pair of them, an effect outside the catalogue or
// a measurement that belongs to another run (or a log that does not cover
// the cuts), with sizes between barely above noise and large, at a given
// R-test spacing, compensation on or off and a drawn instrument; the twin
// makes each run and the diagnosis must reach the expected outcome
// (diagnosis.md section 3). Shared by the tests and the benchmark.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/geometry/config.h"
#include "ttp/sim/twin.h"

namespace ttp::sim {

enum class Scenario { kNone, kSingle, kPair, kOutside, kMismatched };
const char* ScenarioName(Scenario scenario);

struct BatteryCase {
  Scenario scenario = Scenario::kNone;
  TwinOptions twin;
  Instrument instrument = Instrument::kCloudFit;
  // Measured as a user would: the twin's CMM cloud -> inspection.
  bool via_cloud = false;
  // Mismatched: the piece of another run, or the log cut short before
  // the last cycle.
  bool truncated_log = false;
  std::string expected;  // "none", "tool_wear", "a+b", "unexplained",
                         // "refused"
};

struct BatteryRun {
  BatteryCase c;
  std::string outcome;  // the cause when named, else the status
  diagnosis::DiagnosisStatus status = diagnosis::DiagnosisStatus::kNone;
  bool correct = false;
  // A cause named in a run whose expected outcome names none.
  bool false_name = false;
  double chi2_per_dof = 0;
  double best_delta_bic = 0;  // strongest evidence for any cause
  // The decision's statistics (DiagnosisReport): what the thresholds are
  // calibrated on.
  double best_evidence = 0, structure_z = 0, step_chi2 = 0, machine_z = 0;
  double machine_pooled_z = 0;  // E_X, E_Y, E_Z pooled
  std::string reason;  // the diagnosis' sentence
};

// The estimator's error budget against the estimator's actual errors at
// the cut times of one twin run: the noise-free cut piece minus the
// simulation from the log is the estimator's error in the figures. Per
// figure kind (E_X, E_Y, E_Z, E_TTP; kinds with fewer than three figures
// are left out), after the kind's offset, whitened by the budget.
struct BudgetCoverage {
  // chi2 per degree of freedom per kind: about 1 when the budget is right.
  std::vector<double> chi2_per_dof;
  // Per figure: its whitened error after the offset, and where its cut
  // sits between two R-tests (0 at one, 0.5 midway; 1 outside them).
  std::vector<double> z, gap_place;
};
BudgetCoverage MeasureBudgetCoverage(const Config& config,
                                     const TwinOptions& twin);

struct BatteryOptions {
  int runs = 100;
  std::uint64_t seed = 20261122;
  double rtest_interval_s = 300;
  // Shares of the scenarios (the rest: one catalogue effect).
  double none_share = 0.25, pair_share = 0.1, outside_share = 0.15,
         mismatched_share = 0.1;
  // Every cloud_every-th run goes through a synthetic CMM cloud and the
  // inspection; 0: none.
  int cloud_every = 0;
  // Of the others, this share is measured with a probe, dial or DMIS each.
  double other_instrument_share = 0.1;
  // Scale on the drawn effect sizes (detection-limit studies).
  double size_scale = 1.0;
  int threads = 0;  // 0: std::thread::hardware_concurrency()
  diagnosis::DiagnosisOptions diagnosis;
  bool IsValid(std::string* error) const;
};

struct BatteryResult {
  std::vector<BatteryRun> runs;
  // confusion[expected][outcome]
  std::map<std::string, std::map<std::string, int>> confusion;
  int correct = 0;
  int false_names = 0;
  int no_cause_runs = 0;  // runs whose expected outcome names no cause
  int errors = 0;
  double seconds = 0;
  int threads = 1;
};

// Size range drawn (log-uniform) per catalogue effect, in its unit.
struct SizeRange {
  double lo = 0, hi = 0;
};
SizeRange BatterySizeRange(const std::string& effect);
// The drawn case of run `index` (depends only on the options and index).
BatteryCase DrawBatteryCase(const BatteryOptions& options, int index);
// One run: twin, measurement, diagnosis (deterministic in its inputs).
BatteryRun RunBatteryCase(const Config& config, const BatteryCase& c,
                          const diagnosis::DiagnosisOptions& diagnosis = {});
// The runs in parallel over threads; the result does not depend on the
// number of threads.
BatteryResult RunBattery(const Config& config, const BatteryOptions& options);
std::string ConfusionText(const BatteryResult& result);

}  // namespace ttp::sim
