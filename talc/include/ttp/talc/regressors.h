// Regressors of the TALC model, built from a time series' inputs alone:
// an intercept, first-order lags of every speed and of its square (one
// lag per time constant), and selected temperatures as their change since
// the first sample (optionally lagged too). The lags are discretised
// exactly for any step (zero-order hold of the input over the step), so
// irregular sampling needs no resampling.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ttp/models/time_series.h"

namespace ttp::talc {

struct RegressorSpec {
  // One first-order lag per time constant for each speed input (and its
  // square when speed_squared); 0 s = the value itself.
  std::vector<double> speed_lags_s = {1800.0, 7200.0};
  bool speed_squared = false;
  // Temperature inputs used: names of T_ columns, {"all"} or {} (none).
  std::vector<std::string> temperatures = {"all"};
  double temperature_lag_s = 0.0;  // 0 = the temperature change itself

  // Names the bad field ("speed_lags_s", ...).
  bool IsValid(std::string* error) const;
};

struct Regressors {
  std::vector<std::string> names;  // column names, "1" first (intercept)
  Eigen::MatrixXd values;          // rows: samples; cols: names
  // Row-major copy (one regressor vector per sample, contiguous) for the
  // replay's inner loop.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows;
};

// Speeds are scaled to 1000/min (their squares to (1000/min)^2) so that all
// columns have comparable magnitudes. Throws InputError naming a
// temperature that the series lacks.
Regressors BuildRegressors(const models::TimeSeries& series,
                           const RegressorSpec& spec);

// x_k = a x_{k-1} + (1 - a) u_{k-1}, a = exp(-(t_k - t_{k-1}) / tau),
// x_0 = u_0 (steady state at the start); tau = 0 gives x = u.
std::vector<double> FirstOrderLag(const std::vector<double>& t_s,
                                  const std::vector<double>& u, double tau_s);

}  // namespace ttp::talc
