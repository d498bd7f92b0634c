// A TALC strategy: when to measure (calibration phase, then a fixed or an
// adaptive interval, No-Good phases after a residual above the action
// limit), what a measurement costs, and the model updated at each
// measurement. Read from TOML or JSON; every field has a default.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/talc/regressors.h"

namespace ttp::talc {

enum class IntervalMode { kFixed, kAdaptive };

struct Strategy {
  // Time one on-machine measurement takes; production stops meanwhile
  // (the thesis' measuring cycle: 95 s).
  double measuring_time_s = 95.0;
  // Calibration phase: measurements every calibration_interval_s from the
  // start; the model compensates from calibration_s on.
  double calibration_s = 8.5 * 3600.0;
  double calibration_interval_s = 300.0;

  IntervalMode mode = IntervalMode::kFixed;
  double interval_s = 3600.0;  // fixed mode
  // Adaptive mode: measure when the predicted change of any output since
  // its last measurement reaches threshold_um, but not sooner than
  // min_interval_s and at the latest after max_interval_s.
  double threshold_um = 5.0;
  double min_interval_s = 900.0;
  double max_interval_s = 4.0 * 3600.0;

  // No-Good phase: a measured residual above action_limit_um (any output)
  // makes the next ng_measurements measurements ng_interval_s apart.
  // ng_measurements = 0 switches it off.
  double action_limit_um = 5.0;
  int ng_measurements = 0;
  double ng_interval_s = 600.0;

  // Model: forgetting per hour of elapsed time (1 = none), ridge weight,
  // regressors; anchored = the prediction is the last measurement plus the
  // model's change since then (the offset re-anchored at each measurement).
  double forgetting_per_h = 1.0;
  double ridge = 0.1;
  bool anchored = true;
  RegressorSpec regressors;

  // Outputs replayed (d_ names); empty = every output of the log.
  std::vector<std::string> outputs;

  bool IsValid(std::string* error) const;  // names the bad field
};

// The default calibration phase fitted to a log of `span_s` seconds: left
// as it is while it leaves at least a third of the log compensated, else
// shortened to a third of the span (true returned). For replays whose
// calibration nobody chose (the report's page, `talc replay --interval-s`
// without --calibration-s); a strategy that sets it keeps it.
bool FitDefaultCalibration(double span_s, Strategy* s);

// JSON object with any subset of the fields above (names as in the struct;
// "mode": "fixed" | "adaptive"; regressor fields at top level:
// speed_lags_s, speed_squared, temperatures, temperature_lag_s). Unknown
// fields and wrong types throw InputError(source, 0, field, ...).
Strategy StrategyFromJson(const nlohmann::json& j, const std::string& source,
                          const std::string& field_prefix = "");
nlohmann::json StrategyToJson(const Strategy& s);

// A TOML or JSON file (JSON when the text starts with '{').
Strategy ReadStrategy(const std::filesystem::path& path);

// TOML text as JSON (tables -> objects, arrays -> arrays); syntax errors
// throw InputError with the line.
nlohmann::json TomlToJson(const std::string& text, const std::string& source);
// A TOML or JSON document as JSON.
nlohmann::json ReadTomlOrJson(const std::filesystem::path& path);

}  // namespace ttp::talc
