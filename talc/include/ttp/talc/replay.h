// The thesis' virtual experiment (chapter 6): a TALC strategy replayed on a
// log whose outputs were measured densely. The replay measures only at the
// strategy's times; between measurements the compensation is the model's
// prediction from the inputs; at each measurement the model is updated
// recursively. An output value is read only at a measurement (causal), and
// the figures compare the compensated residual with three baselines.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "ttp/models/time_series.h"
#include "ttp/talc/regressors.h"
#include "ttp/talc/strategy.h"

namespace ttp::talc {

// Residual figures over the evaluated span (from the end of calibration,
// samples where the output is known): RMS, P99 of |residual| (linear
// interpolation between order statistics), peak-to-valley.
struct Figures {
  double rms_um = 0.0;
  double p99_um = 0.0;
  double ptv_um = 0.0;
  int samples = 0;
};

struct OutputReplay {
  std::string name;
  Figures talc;  // the strategy's compensation
  Figures none;  // no compensation (outputs are relative to start)
  Figures hold;  // the last measurement held (same times)
  // Linear on all temperatures (their change since the start), updated
  // exactly as TALC is: the same measurement times, calibration phase,
  // recursive least squares (ridge, forgetting) and anchoring. The fair
  // static baseline: only the structure differs from TALC's.
  Figures static_model;
  // The same static model fitted once on the calibration measurements,
  // then frozen (extrapolates to speeds the calibration did not see).
  Figures static_frozen;
  // The same static model fitted once, by least squares, on every sample
  // with all outputs measured in ReplayResult's static window (default:
  // the whole log, i.e. in-sample: an optimistic bound for a static model).
  Figures static_window;
  Eigen::VectorXd theta;  // model parameters at the end
};

enum class ReplayStatus { kOk, kNoEvaluatedSamples };

struct ReplayResult {
  ReplayStatus status = ReplayStatus::kOk;
  std::vector<std::string> regressor_names;
  std::vector<double> measurement_times_s;
  int measurements = 0;
  int calibration_measurements = 0;
  int ng_phases = 0;
  int rank_at_start = 0;  // numerical rank of the calibration data
  double total_s = 0.0;
  double evaluated_from_s = 0.0;  // end of the calibration phase
  double q_prod = 1.0;            // 1 - N t_M / t_total (fraction)
  // The window OutputReplay::static_window was fitted on (s) and the
  // samples used.
  double static_window_from_s = 0.0, static_window_to_s = 0.0;
  int static_window_samples = 0;
  bool static_window_in_sample = false;  // overlaps the evaluated span
  std::vector<OutputReplay> outputs;
  // Compensation value at every sample (rows x outputs), when kept.
  Eigen::MatrixXd predictions_um;
  std::vector<std::string> warnings;
};

struct ReplayOptions {
  bool keep_predictions = false;
  bool baselines = true;  // hold / static / none figures
  // The window the `static_window` baseline is fitted on (s; clipped to
  // the log).
  double static_window_from_s = -std::numeric_limits<double>::infinity();
  double static_window_to_s = std::numeric_limits<double>::infinity();
};

ReplayResult Replay(const models::TimeSeries& series, const Strategy& strategy,
                    const ReplayOptions& options = {});
// The same with the regressors built already (a sweep shares them between
// strategies with the same regressor spec).
ReplayResult Replay(const models::TimeSeries& series,
                    const Regressors& regressors, const Strategy& strategy,
                    const ReplayOptions& options = {});

Figures ResidualFigures(std::vector<double> residuals_um);

nlohmann::json ReplayToJson(const ReplayResult& r, const Strategy& s);
std::string ReplayText(const ReplayResult& r, const Strategy& s);

}  // namespace ttp::talc
