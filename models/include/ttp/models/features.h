// Regressors of the thermal error models: an input (speed or temperature),
// optionally squared, delayed (FIR tap) and passed through up to two
// first-order lags (cascaded). The bank is evaluated causally, row by row:
// a lag is discretised exactly for each step (first-order hold of the input
// between samples), so irregular steps are right, and every filter restarts
// from the steady state of the restart row (the first row, or the row after
// a gap) instead of bridging a gap.
#pragma once

#include <Eigen/Core>
#include <deque>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/models/time_series.h"

namespace ttp::models {

struct Regressor {
  std::string input;           // n_* or T_* column
  int power = 1;               // 1: value, 2: squared (spindle heat ~ n, n^2)
  double delay_s = 0;          // FIR tap: the value delay_s earlier (held)
  std::vector<double> taus_s;  // cascaded first-order lags, 0..2 of them

  // Speeds enter in 1000/min (so that n and n^2 are of order 1), temperatures
  // in degC.
  double InputScale() const;
  std::string Name() const;  // e.g. "lag3600(n_spindle^2)"
  nlohmann::json ToJson() const;
  static Regressor FromJson(const nlohmann::json& j, const std::string& source);
  bool operator==(const Regressor& o) const;
};

// Streams rows through a set of regressors.
class FeatureBank {
 public:
  // Maps each regressor to its column in `input_names`; a missing column
  // throws InputError(source, 0, column, ...).
  FeatureBank(std::vector<Regressor> regressors,
              const std::vector<std::string>& input_names,
              const std::string& source);

  // Steady state at this row: every lag equals its input, every delay line
  // holds the row's value.
  void Reset(double t_s, const Eigen::Ref<const Eigen::RowVectorXd>& row);
  // Advances to t_s (> last time) and returns the regressors at t_s.
  void Step(double t_s, const Eigen::Ref<const Eigen::RowVectorXd>& row,
            double* out);
  bool started() const { return started_; }
  double last_t_s() const { return last_t_; }

  nlohmann::json State() const;
  void SetState(const nlohmann::json& state);

  const std::vector<Regressor>& regressors() const { return regs_; }

 private:
  struct Channel {
    int column = -1;
    double scale = 1;
    std::deque<std::pair<double, double>> history;  // delay line (t, u)
    std::vector<double> u_prev, y;  // per lag stage: its input and output
  };
  double Transformed(const Regressor& r, const Channel& c,
                     const Eigen::Ref<const Eigen::RowVectorXd>& row) const;
  double Delayed(const Regressor& r, Channel& c, double t_s, double u);
  std::vector<Regressor> regs_;
  std::vector<Channel> channels_;
  double last_t_ = 0;
  bool started_ = false;
};

// Regressor matrix over a whole series (rows x regressors): Reset at the
// first row and at every gap row. With `state` (a FeatureBank::State() of a
// previous log that this one continues), the first row continues from it.
Eigen::MatrixXd ComputeFeatures(const TimeSeries& ts,
                                const std::vector<Regressor>& regressors,
                                const nlohmann::json* state = nullptr,
                                nlohmann::json* end_state = nullptr);

}  // namespace ttp::models
