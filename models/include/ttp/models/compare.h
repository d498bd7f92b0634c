// Every structure side by side on a chronological holdout (fit on the rows
// before holdout_from_s, predict the rest from the inputs alone), quality
// figures per output (thesis 4.2.3, 6.1.3), and for the best and the
// simplest structure what they get wrong, named, with the extension that
// addresses it refitted and measured on the same holdout.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/models/identify.h"
#include "ttp/models/time_series.h"

namespace ttp::models {

struct ResidualStats {
  int n = 0;
  double rms_um = 0;
  double p99_um = 0;         // 99th percentile of |residual| (thesis eq. 4.30)
  double pv_um = 0;          // peak-to-valley of the residual
  double reduction_pct = 0;  // RMS against no compensation
};

// Over the rows where `measured` is finite; `none_rms_um` is the RMS of the
// measured values themselves (no compensation) for the reduction.
ResidualStats ComputeStats(const Eigen::VectorXd& measured,
                           const Eigen::VectorXd& predicted,
                           double none_rms_um);
double Percentile(std::vector<double> values, double fraction);

// The error a diagnosis names, in the order it is looked for.
enum class ErrorKind { kNone, kJump, kLag, kDrift };
const char* ErrorKindName(ErrorKind k);

// What a model gets wrong on the holdout.
struct Diagnosis {
  ErrorKind kind = ErrorKind::kNone;
  std::string model;
  std::string leading_input;  // temperature most correlated with the output
  double loop_area_um_k = 0;  // residual vs leading temperature
  double loop_ratio = 0;      // area over the bounding box of the loop
  double lag_s = 0;           // measured lags the prediction by this (xcorr)
  double drift_um_per_h = 0;  // slope of the residual over time
  std::string jump_input;     // an input that jumps (empty: none)
  double jump_t_s = 0, jump_size = 0;
  std::string problem;    // named: "lag (pseudo-hysteresis)", ...
  std::string extension;  // what fixes it
  double rms_um = 0, extended_rms_um = 0;  // holdout before / after
};

Diagnosis Diagnose(const TimeSeries& ts, size_t first_holdout_row, int output,
                   const Eigen::VectorXd& predicted, const std::string& model);

struct CompareEntry {
  std::string name;  // none, static_all_T, lag_speed, static, ..., select, auto
  std::string kind;  // "baseline", "reference", "structure", "auto"
  std::vector<ResidualStats> stats;     // per output
  std::vector<std::string> structures;  // per output (auto: its choice)
  std::vector<int> terms;               // regressors per output
};

struct CompareResult {
  std::string source;
  double holdout_from_s = 0;
  size_t first_holdout_row = 0;
  std::vector<std::string> outputs;
  std::vector<CompareEntry> entries;
  std::vector<std::string> best, simplest;  // per output
  std::vector<Diagnosis> best_diag, simplest_diag;
  // For plots: prediction of the best entry per output at every row.
  std::vector<double> t_s;
  Eigen::MatrixXd measured_um, best_um, simplest_um;
  std::vector<std::string> leading_inputs;
  Eigen::MatrixXd leading_values;  // rows x outputs
  std::vector<std::string> warnings;
  // Per output: select's candidates with their CV scores (FitAuto's log).
  std::vector<std::vector<std::string>> select_candidates;
};

CompareResult CompareModels(const TimeSeries& ts, double holdout_from_s,
                            const FitOptions& options);
nlohmann::json CompareToJson(const CompareResult& r);
std::string CompareText(const CompareResult& r);

}  // namespace ttp::models
