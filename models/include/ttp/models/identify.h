// Identification of thermal error models from a thermal log, one model per
// output (MISO submodels, thesis 4.1.3). Every structure is linear in its
// parameters once its regressors are fixed, so each is a (weighted, ridge)
// least-squares fit. `joint` takes every regressor at once and lets the ridge
// penalty (chosen by chronological cross-validation) do the shrinking; the
// others choose a regressor set by forward selection:
//   static    inputs as they are (temperatures, n, n^2)
//   fir       taps of the inputs at 0, dt, 2 dt, ... (thesis eq. 3.35)
//   lag       first-order lags of n and n^2 (spindle heat through the
//             structure)
//   arx       ARX simulated as an output-error model y = B(q)/A(q) u: the
//             poles of A (one or two, as time constants, exact for any step)
//             are shared by every input; B by least squares
//   combined  temperatures, lagged temperatures and lagged n, n^2 together
//   joint     every temperature directly and through one lag, n and n^2
//             through a lag at every time constant, all in one ridge fit
// `auto` is `joint` with its default temperature lag: the one method that
// did best on both chronological validation splits inside the real data
// (docs/THERMAL.md), the same choices for every output. `select` chooses a
// structure per output by CV inside the fitted span (FitAuto); on the real
// data its inner CV ranks candidates by noise, so it is not the default.
// The prediction uses the inputs only (never a measured output).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/models/features.h"
#include "ttp/models/time_series.h"

namespace ttp::models {

enum class Structure { kStatic, kFir, kLag, kArx, kCombined, kJoint };
const char* StructureName(Structure s);
// "static", "fir", "lag", "arx", "combined", "joint"; false when unknown.
bool ParseStructure(const std::string& name, Structure* s);
std::vector<Structure> AllStructures();

struct FitOptions {
  // auto (= joint), select (per output by CV) or a structure name
  std::string model = "auto";
  // Lag time constants searched (s) and FIR taps (step and count).
  std::vector<double> taus_s = {900, 1800, 3600, 7200, 14400};
  // `joint`: the one lag each temperature passes through besides its direct
  // path (s).
  double temperature_lag_s = 3600;
  double fir_step_s = 1800;
  int fir_taps = 6;
  int max_terms = 8;  // regressors per output, intercept not counted
  // Chronological cross-validation: the fitted span is cut into cv_blocks
  // blocks of equal time; fold k trains on blocks [0, k) and validates on
  // every block from k to the end (the horizon of a real prediction: hours
  // ahead), for k = cv_first_validation_block .. cv_blocks - 1; the score is
  // the RMS over every validated sample.
  int cv_blocks = 8;
  int cv_first_validation_block = 4;
  // Ridge factors (relative, on standardised regressors) tried by CV.
  std::vector<double> ridge = {0, 1e-4, 1e-3, 1e-2, 1e-1, 1};
  // "cv": CV RMS times the MDL factor (1 + p ln N / N); "mdl": the thesis'
  // in-sample MDL-like criterion alone (RMS (1 + p ln N / N)), no CV.
  std::string criterion = "cv";
  double min_gain = 0.05;  // a new term must improve the score by this share
  // WLSE: weight 2^(-(t_end - t) / half_life) on each sample (0 = ordinary
  // least squares; thesis eq. 4.20).
  double weight_half_life_s = 0;
  // `select`: also the forward-selected structures among the candidates
  // (each scored by nested CV, which refits the selection in every fold:
  // about a hundred times the cost of the fixed candidates).
  bool auto_selected = false;
  // Shift a temperature sensor that jumps inside the fitted span back by
  // its step (FindFittedJumps); false: warn only, the model learns the step.
  bool repair_jumps = true;

  bool IsValid(std::string* error) const;
};

struct OutputModel {
  std::string output;  // d_* column
  Structure structure = Structure::kStatic;
  std::string label;  // `select`: the candidate chosen, e.g. "joint, ..."
  std::vector<Regressor> regressors;
  Eigen::VectorXd coef;  // um per regressor unit
  double intercept_um = 0;
  Eigen::VectorXd mean, scale;  // standardisation used while fitting
  double ridge = 0;
  double cv_score = 0;  // selection score (criterion)
  double cv_rms_um = std::numeric_limits<double>::quiet_NaN();
  double fit_rms_um = 0;
  int n_fit = 0;
  std::vector<std::string> selection_log;  // one line per forward step
  nlohmann::json end_state;  // filter state at the end of the fitted log
};

// What the fitted span saw of one input: its range and the largest step
// between neighbouring rows (gaps excluded). Predict compares a new log
// with it (extrapolation, a sensor that jumps).
struct InputRange {
  std::string input;
  double min = 0, max = 0;
  double max_step = 0;
};

// A temperature sensor that jumps inside a fitted span: one row-to-row step
// of at least 0.3 K and 20 times the sensor's median step, after which the
// sensor stays shifted (the median over the 10 min after the step differs
// from the median over the 10 min before by 0.5 to 2 times the step, same
// sign), not within 10 min of a gap or of a speed change (a step of a speed
// by more than 5 % of its range: the program's, and a sensor near the heat
// may step with it). A re-seated or re-connected
// sensor, not the machine: a structure does not step by degrees in one
// sample, and a burst that comes back (an air sensor in a draught) does not
// stay shifted.
struct FittedJump {
  std::string input;
  double t_s = 0;  // the first row after the step, in the fitted log's t_s
  // K: the row's step less the sensor's own change over a row there (the
  // median step around it)
  double step = 0;
};
// The jumps of a fitted span, one after the other (each found on the
// series with the earlier ones shifted out).
std::vector<FittedJump> FindFittedJumps(const TimeSeries& span);
// Shifts each jump's sensor back by its step at every row of `ts` whose
// t_s + t_offset_s is at or after the jump's t_s (t_offset_s maps ts's
// t_s into the fitted log's; a sensor ts does not have is skipped).
// Returns the number of values shifted.
size_t ShiftJumps(const std::vector<FittedJump>& jumps, double t_offset_s,
                  TimeSeries* ts);
struct SensorFaults {
  std::vector<FittedJump> jumps;      // shifted out with `repair`
  std::vector<std::string> warnings;  // one line per fault
};
// The jumps of `span` (the fitted rows), and with `repair` the jumps
// shifted out of `series` from each jump on (the rows after the span too:
// the sensor stays shifted). `series` may be `span` itself.
SensorFaults RepairSensorFaults(const TimeSeries& span, bool repair,
                                TimeSeries* series);

struct ThermalModel {
  std::string source;
  std::vector<InputRange> input_ranges;       // every input of the fitted span
  double fit_t_begin_s = 0, fit_t_end_s = 0;  // last fitted row
  // The fitted log's `start` (ISO 8601 with offset; empty when it had
  // none): a log continues the fitted one when its start + t_s follows
  // this start + fit_t_end_s, whatever its own t_s.
  std::string fit_start;
  double median_step_s = 0;
  std::vector<std::string> inputs;  // columns the model needs
  FitOptions options;
  std::vector<OutputModel> outputs;
  // Jumps shifted out of the fitted span; Predict shifts them out of every
  // later row too (in the time of the two logs' start headers).
  std::vector<FittedJump> fitted_jumps;
  std::vector<std::string> fit_warnings;  // jumps of the fitted span
};

// Fits every output in `outputs` (empty: every d_ column) on the rows with
// t_s < fit_until_s, after looking there for sensors that jump: a jump is
// shifted out (options.repair_jumps) and kept in `fitted_jumps`; each is
// said in `fit_warnings`.
ThermalModel FitThermalModel(
    const TimeSeries& ts, const std::vector<std::string>& outputs,
    const FitOptions& options,
    double fit_until_s = std::numeric_limits<double>::infinity());

// Fits one output on the given structure (neither `auto` nor `select`).
OutputModel FitOutput(const TimeSeries& fit, int output, Structure structure,
                      const FitOptions& options);

// `select`: every candidate structure scored by the same chronological CV
// inside `fit`, the lowest score wins (see FitAuto in identify.cpp and
// docs/THERMAL.md). Candidates: static on all temperatures; lags of n and
// n^2 at every time constant; both together; `joint` at each temperature
// lag in taus_s; and (auto_selected) the forward-selected static, fir, lag,
// arx and combined structures, whose score is a nested CV.
OutputModel FitAuto(const TimeSeries& fit, int output,
                    const FitOptions& options);

// The reference regressor sets: every temperature as it is; n and n^2
// through a lag at each time constant.
std::vector<Regressor> AllTemperatureRegressors(const TimeSeries& ts);
std::vector<Regressor> SpeedLagRegressors(const TimeSeries& ts,
                                          const std::vector<double>& taus_s);

// Fixed regressors (no selection; ridge still by CV), e.g. the reference
// models "static on all temperatures", "lags of n and n^2".
OutputModel FitFixed(const TimeSeries& fit, int output,
                     const std::vector<Regressor>& regressors,
                     Structure structure, const FitOptions& options);

// An input of the predicted log outside what the fit saw.
struct Extrapolation {
  std::string input;
  double fitted_min = 0, fitted_max = 0;
  double seen_min = 0, seen_max = 0;
  double share_outside = 0;  // of the rows
  double excess = 0;         // largest distance outside, in input units
  // Beyond the fitted range by more than a tenth of that range: the
  // model's CV RMS does not describe these rows.
  bool severe = false;
};

// A temperature that steps between two rows by more than both
// PredictOptions::jump_factor times the largest step of the fitted span and
// jump_min: a sensor that jumps, not the machine's temperature.
struct SensorJump {
  std::string input;
  double t_s = 0;
  double step = 0;
  bool repaired = false;  // later values shifted back by the step
};

struct PredictOptions {
  double jump_factor = 10;
  double jump_min = 0.3;     // degC
  bool repair_jumps = true;  // shift a jumping sensor back by its step
  bool IsValid(std::string* error) const;
};

struct Prediction {
  std::vector<double> t_s;
  std::vector<std::string> outputs;
  Eigen::MatrixXd values_um;  // rows x outputs
  // The chronological CV RMS inside the fitted span, per output: the
  // expected error where the inputs stay inside the fitted range (NaN when
  // the model was not cross-validated).
  std::vector<double> cv_rms_um;
  bool continued = false;  // started from the model's end state
  std::vector<Extrapolation> extrapolations;
  std::vector<SensorJump> jumps;
  std::vector<std::string> warnings;
};
nlohmann::json PredictionSummaryJson(const Prediction& p);

// Causal prediction of every modelled output at every row of `ts` from its
// inputs alone (outputs in `ts` are ignored). When ts starts after the
// fitted log's end (within ten sampling periods; in the time of the two
// logs' `start` headers when both have one, else in t_s) the filters
// continue from the model's end state; otherwise they start from the
// first row.
Prediction Predict(const ThermalModel& model, const TimeSeries& ts,
                   const PredictOptions& options = {});
// One output over a whole series, filters from its first row.
Eigen::VectorXd PredictOutput(const OutputModel& m, const TimeSeries& ts);

nlohmann::json ModelToJson(const ThermalModel& model);
ThermalModel ModelFromJson(const nlohmann::json& j, const std::string& source);

// Rows with t_s < t_end_s, gaps kept.
TimeSeries HeadOf(const TimeSeries& ts, double t_end_s);

}  // namespace ttp::models
