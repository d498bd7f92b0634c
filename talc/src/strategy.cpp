#include "ttp/talc/strategy.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <cmath>
#include <set>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"

namespace ttp::talc {

bool FitDefaultCalibration(double span_s, Strategy* s) {
  if (!(s->calibration_s > span_s * 2.0 / 3.0)) return false;
  s->calibration_s = span_s / 3.0;
  return true;
}

bool Strategy::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!std::isfinite(measuring_time_s) || measuring_time_s < 0)
    return fail("measuring_time_s: must be >= 0");
  if (!std::isfinite(calibration_s) || calibration_s < 0)
    return fail("calibration_s: must be >= 0");
  if (!positive(calibration_interval_s))
    return fail("calibration_interval_s: must be > 0");
  if (!positive(interval_s)) return fail("interval_s: must be > 0");
  if (!positive(threshold_um)) return fail("threshold_um: must be > 0");
  if (!std::isfinite(min_interval_s) || min_interval_s < 0)
    return fail("min_interval_s: must be >= 0");
  if (!positive(max_interval_s) || max_interval_s < min_interval_s)
    return fail("max_interval_s: must be > 0 and >= min_interval_s");
  if (!positive(action_limit_um)) return fail("action_limit_um: must be > 0");
  if (ng_measurements < 0) return fail("ng_measurements: must be >= 0");
  if (!positive(ng_interval_s)) return fail("ng_interval_s: must be > 0");
  if (!(forgetting_per_h > 0 && forgetting_per_h <= 1))
    return fail("forgetting_per_h: must be in (0, 1]");
  if (!std::isfinite(ridge) || ridge < 0) return fail("ridge: must be >= 0");
  return regressors.IsValid(error);
}

namespace {

double Number(const nlohmann::json& v, const std::string& src,
              const std::string& field) {
  if (!v.is_number())
    throw InputError(src, 0, field, "expected a number, got " + v.dump());
  return v.get<double>();
}

}  // namespace

Strategy StrategyFromJson(const nlohmann::json& j, const std::string& source,
                          const std::string& prefix) {
  if (!j.is_object())
    throw InputError(source, 0, prefix.empty() ? "strategy" : prefix,
                     "expected a table/object");
  Strategy s;
  // One length of the calibration: two would leave one silently unused.
  if (j.contains("calibration_s") && j.contains("calibration_h"))
    throw InputError(source, 0, prefix + "calibration_h",
                     "give calibration_s or calibration_h, not both");
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& k = it.key();
    const nlohmann::json& v = it.value();
    const std::string f = prefix + k;
    auto num = [&] { return Number(v, source, f); };
    if (k == "measuring_time_s")
      s.measuring_time_s = num();
    else if (k == "calibration_s")
      s.calibration_s = num();
    else if (k == "calibration_h")
      s.calibration_s = num() * 3600.0;
    else if (k == "calibration_interval_s")
      s.calibration_interval_s = num();
    else if (k == "interval_s")
      s.interval_s = num();
    else if (k == "threshold_um")
      s.threshold_um = num();
    else if (k == "min_interval_s")
      s.min_interval_s = num();
    else if (k == "max_interval_s")
      s.max_interval_s = num();
    else if (k == "action_limit_um")
      s.action_limit_um = num();
    else if (k == "ng_interval_s")
      s.ng_interval_s = num();
    else if (k == "forgetting_per_h")
      s.forgetting_per_h = num();
    else if (k == "ridge")
      s.ridge = num();
    else if (k == "temperature_lag_s")
      s.regressors.temperature_lag_s = num();
    else if (k == "ng_measurements") {
      const double d = num();
      if (d != std::floor(d) || d < 0 || d > 1e6)
        throw InputError(source, 0, f, "expected a whole number >= 0");
      s.ng_measurements = int(d);
    } else if (k == "mode") {
      if (v == "fixed")
        s.mode = IntervalMode::kFixed;
      else if (v == "adaptive")
        s.mode = IntervalMode::kAdaptive;
      else
        throw InputError(source, 0, f,
                         "expected \"fixed\" or \"adaptive\", got " + v.dump());
    } else if (k == "anchored" || k == "speed_squared") {
      if (!v.is_boolean())
        throw InputError(source, 0, f, "expected true or false");
      (k == "anchored" ? s.anchored : s.regressors.speed_squared) =
          v.get<bool>();
    } else if (k == "speed_lags_s") {
      if (!v.is_array())
        throw InputError(source, 0, f, "expected a list of time constants");
      s.regressors.speed_lags_s.clear();
      for (size_t i = 0; i < v.size(); ++i)
        s.regressors.speed_lags_s.push_back(
            Number(v[i], source, fmt::format("{}[{}]", f, i)));
    } else if (k == "temperatures" || k == "outputs") {
      std::vector<std::string> names;
      if (v.is_string()) {
        names.push_back(v.get<std::string>());
      } else if (v.is_array()) {
        for (size_t i = 0; i < v.size(); ++i) {
          if (!v[i].is_string())
            throw InputError(source, 0, fmt::format("{}[{}]", f, i),
                             "expected a column name");
          names.push_back(v[i].get<std::string>());
        }
      } else {
        throw InputError(source, 0, f, "expected a list of column names");
      }
      (k == "outputs" ? s.outputs : s.regressors.temperatures) = names;
    } else {
      throw InputError(source, 0, f, "unknown field");
    }
  }
  std::string why;
  if (!s.IsValid(&why)) {
    const auto colon = why.find(':');
    throw InputError(source, 0, prefix + why.substr(0, colon),
                     colon == std::string::npos ? why : why.substr(colon + 2));
  }
  return s;
}

nlohmann::json StrategyToJson(const Strategy& s) {
  nlohmann::json j;
  j["measuring_time_s"] = s.measuring_time_s;
  j["calibration_s"] = s.calibration_s;
  j["calibration_interval_s"] = s.calibration_interval_s;
  j["mode"] = s.mode == IntervalMode::kFixed ? "fixed" : "adaptive";
  j["interval_s"] = s.interval_s;
  j["threshold_um"] = s.threshold_um;
  j["min_interval_s"] = s.min_interval_s;
  j["max_interval_s"] = s.max_interval_s;
  j["action_limit_um"] = s.action_limit_um;
  j["ng_measurements"] = s.ng_measurements;
  j["ng_interval_s"] = s.ng_interval_s;
  j["forgetting_per_h"] = s.forgetting_per_h;
  j["ridge"] = s.ridge;
  j["anchored"] = s.anchored;
  j["speed_lags_s"] = s.regressors.speed_lags_s;
  j["speed_squared"] = s.regressors.speed_squared;
  j["temperatures"] = s.regressors.temperatures;
  j["temperature_lag_s"] = s.regressors.temperature_lag_s;
  j["outputs"] = s.outputs;
  return j;
}

namespace {

nlohmann::json NodeToJson(const toml::node& node) {
  if (const auto* t = node.as_table()) {
    nlohmann::json o = nlohmann::json::object();
    for (const auto& [k, v] : *t) o[std::string(k.str())] = NodeToJson(v);
    return o;
  }
  if (const auto* a = node.as_array()) {
    nlohmann::json o = nlohmann::json::array();
    for (const auto& v : *a) o.push_back(NodeToJson(v));
    return o;
  }
  if (const auto* v = node.as_integer()) return double(v->get());
  if (const auto* v = node.as_floating_point()) return v->get();
  if (const auto* v = node.as_boolean()) return v->get();
  if (const auto* v = node.as_string()) return v->get();
  return nlohmann::json();  // dates: not used by any field
}

}  // namespace

nlohmann::json TomlToJson(const std::string& text, const std::string& source) {
  try {
    const toml::table t = toml::parse(text, source);
    return NodeToJson(t);
  } catch (const toml::parse_error& e) {
    throw InputError(source, int(e.source().begin.line), "",
                     std::string(e.description()));
  }
}

nlohmann::json ReadTomlOrJson(const std::filesystem::path& path) {
  const std::string text = ReadTextFile(path);
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && text[first] == '{') {
    return ParseJsonText(text, path.string());
  }
  return TomlToJson(text, path.string());
}

Strategy ReadStrategy(const std::filesystem::path& path) {
  return StrategyFromJson(ReadTomlOrJson(path), path.string());
}

}  // namespace ttp::talc
