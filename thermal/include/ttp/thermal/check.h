// Checking a measured piece against its TALC log:
// measured and simulated figures side by side per cycle with their expanded
// uncertainties, and the temperature comparison of thesis 7.10 (piece vs
// table vs the log's temperatures). Also the log <-> program consistency
// check (cut names, order, times on the schedule, coverage, R-tests
// bracketing each cut), fed with the program's planned cuts as plain data so
// that this module does not depend on the CAM module.
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/figures.h"
#include "ttp/thermal/estimator.h"
#include "ttp/thermal/simulate.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::thermal {

struct CheckOptions {
  SimulationOptions simulation;
  // The table's alpha; the piece's alpha and radius (facet distance) come
  // from the config's part.
  double table_alpha_per_k = kTableAlphaPerK;
  // The log's temperatures are averaged over the cuts of a cycle widened by
  // this much on each side.
  double temperature_window_s = 300;
  // Propagate the estimator's error to the simulated figures.
  bool simulated_uncertainty = true;
  // The run's verdict: the chance that a piece whose figures all follow
  // the simulation within their uncertainties is judged to disagree (one
  // figure in twenty is outside its own k = 2 U by chance, so with forty
  // figures most such runs would have one). A figure disagrees for the run
  // beyond z(1 - p/(2m)) combined standard uncertainties, m the figures
  // compared (Bonferroni; at least k = 2).
  double run_false_alarm = 0.05;
};

constexpr int kFigureCount = 5;
extern const char* const kFigureNames[kFigureCount];  // E_X .. E_TTP
extern const char* const kFigureUnits[kFigureCount];  // um or um/m

// One figure of one cycle, in um (E_B in um/m). U are expanded (k = 2).
struct FigureCheck {
  bool available = false;  // both measured and simulated are finite
  double measured = 0, u_measured = 0;    // U (k = 2)
  double simulated = 0, u_simulated = 0;  // U (k = 2)
  double difference = 0;                  // measured - simulated
  double u_combined = 0;                  // 2 sqrt(u_m^2 + u_s^2), k = 2
  bool agree = true;                      // |difference| <= u_combined
  // |difference| > CheckResult::run_limit_k / 2 * u_combined: the run
  // disagrees.
  bool beyond_run_limit = false;
};

// Temperature changes (K) against the reference cycle, thesis 7.10.
struct TemperatureCheck {
  double piece_measured_k = 0, u_piece_measured_k = 0;  // E_TTP / (a R)
  double piece_simulated_k = 0;  // simulated E_TTP / (a R)
  double table_rtest_k = 0;      // E_R0T / (a_table d/2), estimator
  double ws_log_k = 0;           // T_ws around the cuts (NaN if absent)
  double env_log_k = 0;          // T_env around the cuts (NaN if absent)
};

struct CycleCheck {
  int cycle = 0;
  double t_s = 0;  // mean end time of the cycle's cuts (NaN if none)
  std::array<FigureCheck, kFigureCount> figures;
  TemperatureCheck temperature;
};

struct CheckResult {
  std::string log_source;
  std::string estimator;
  bool simulated_uncertainty = false;
  std::vector<CycleCheck> cycles;
  int compared = 0;       // figures with both values
  int disagreements = 0;  // of them outside the combined U
  // The coverage factor a figure's difference must exceed for the run to
  // disagree (CheckOptions::run_false_alarm), and how many do.
  double run_false_alarm = 0.05;
  double run_limit_k = 2;
  int beyond_run_limit = 0;
  // Measured figures the simulation lacks (the log does not cover their
  // cuts): a run that cannot be compared in full does not agree.
  int not_simulated = 0;
  bool agree() const {
    return compared > 0 && beyond_run_limit == 0 && not_simulated == 0;
  }
  double piece_alpha_per_k = 0, piece_radius_mm = 0;
  double table_alpha_per_k = 0, table_radius_mm = 0;
  // The simulation's (Simulation::warnings).
  std::vector<std::string> warnings;
};

// Standard uncertainties (k = 1, in the u_* fields, values zero) of the
// simulated figures from the estimator's error per machine error at each
// cycle's cut time (ErrorSigmaAt: the budget the diagnosis uses): taken as
// common to the cuts of one cycle (they lie within a minute) and
// independent between cycles, the reference cycle's included.
std::vector<CycleFigures> SimulatedFigureUncertainty(
    const TalcLog& log, const Config& config,
    const MachineErrorEstimator& estimator, const SimulationOptions& options);

// Measured figures (from any measurement) against the simulation from the
// log. Throws InputError for a log the simulation cannot use.
CheckResult CheckPiece(const TalcLog& log, const Config& config,
                       const std::vector<CycleFigures>& measured,
                       const CheckOptions& options = {});
CheckResult CheckPiece(const TalcLog& log, const Config& config,
                       const MachineErrorEstimator& estimator,
                       const Simulation& simulation,
                       const std::vector<CycleFigures>& measured,
                       const CheckOptions& options = {});

// Judges every figure of `r` from its difference and combined U (agree:
// within U; beyond_run_limit: beyond the run's Bonferroni limit for
// `run_false_alarm`) and counts them; CheckPiece ends with it.
void JudgeRun(double run_false_alarm, CheckResult* r);

nlohmann::json CheckToJson(const CheckResult& result);
std::string CheckTable(const CheckResult& result);

// ---- Log <-> program consistency ----------------------------------------

// One cut of the program's schedule (cam::Schedule as plain data): program
// time of the end of the cut (the report that makes the log's cut row).
struct PlannedCut {
  FeatureId feature;
  int cycle = 0;
  double start_s = 0, end_s = 0;  // program time
  double c_deg = 0;
};

struct ScheduleCheckOptions {
  // A logged cut may end this far from its planned time (after the offset
  // between program and log time is removed). The sample runs' machine cuts
  // a cycle up to 30 s faster than the program's time model; a cut in the
  // wrong hour is 3600 s off.
  double tolerance_s = 120;
  // The logged table angle may differ from the planned one by this much.
  double angle_tolerance_deg = 0.01;
};

struct ScheduleCheck {
  double offset_s = 0;  // log t_s = program time + offset (median)
  double max_deviation_s = 0;
  int matched = 0;
};

// Throws InputError(log, line, field, ...) for: a cut name that is not a
// feature of the program, a planned cut missing from a log that covers its
// time, cuts out of the program's order, a cut time off the schedule by more
// than the tolerance, a table angle that is not the planned one, a log that
// starts after the first planned cut or ends before the last, a cut without
// an R-test before it. A cut after the last R-test is no mismatch (a
// production log may end before the next R-test): the simulation
// extrapolates the machine's errors there and warns.
ScheduleCheck CheckLogAgainstSchedule(const TalcLog& log,
                                      const std::vector<PlannedCut>& planned,
                                      const ScheduleCheckOptions& options = {});

}  // namespace ttp::thermal
