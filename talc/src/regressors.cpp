#include "ttp/talc/regressors.h"

#include <fmt/format.h>

#include <cmath>

#include "ttp/geometry/error.h"

namespace ttp::talc {

bool RegressorSpec::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  for (double tau : speed_lags_s)
    if (!std::isfinite(tau) || tau < 0)
      return fail("speed_lags_s: each lag must be >= 0 s");
  if (!std::isfinite(temperature_lag_s) || temperature_lag_s < 0)
    return fail("temperature_lag_s: must be >= 0 s");
  return true;
}

std::vector<double> FirstOrderLag(const std::vector<double>& t_s,
                                  const std::vector<double>& u, double tau_s) {
  std::vector<double> x(u.size());
  if (u.empty()) return x;
  if (tau_s <= 0) return u;
  x[0] = u[0];
  for (size_t k = 1; k < u.size(); ++k) {
    const double a = std::exp(-(t_s[k] - t_s[k - 1]) / tau_s);
    x[k] = a * x[k - 1] + (1.0 - a) * u[k - 1];
  }
  return x;
}

namespace {
bool StartsWith(const std::string& s, const char* p) {
  return s.rfind(p, 0) == 0;
}
}  // namespace

Regressors BuildRegressors(const models::TimeSeries& series,
                           const RegressorSpec& spec) {
  const size_t n = series.rows();
  std::vector<std::pair<std::string, std::vector<double>>> cols;
  cols.emplace_back("1", std::vector<double>(n, 1.0));
  std::vector<int> speeds, temps;
  for (size_t c = 0; c < series.input_names.size(); ++c) {
    if (StartsWith(series.input_names[c], "n_")) speeds.push_back(int(c));
  }
  const bool all_temps =
      spec.temperatures.size() == 1 && spec.temperatures[0] == "all";
  if (all_temps) {
    for (size_t c = 0; c < series.input_names.size(); ++c)
      if (StartsWith(series.input_names[c], "T_")) temps.push_back(int(c));
  } else {
    for (const auto& name : spec.temperatures) {
      int found = -1;
      for (size_t c = 0; c < series.input_names.size(); ++c)
        if (series.input_names[c] == name) found = int(c);
      if (found < 0)
        throw InputError(series.source, 0, name,
                         "temperature named by the strategy is not a column "
                         "of the log");
      temps.push_back(found);
    }
  }
  auto column = [&](int c) {
    std::vector<double> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = series.inputs(Eigen::Index(i), c);
    return v;
  };
  for (int c : speeds) {
    std::vector<double> u = column(c), u2(n);
    for (size_t i = 0; i < n; ++i) {
      u[i] /= 1000.0;
      u2[i] = u[i] * u[i];
    }
    const std::string& name = series.input_names[size_t(c)];
    for (double tau : spec.speed_lags_s) {
      cols.emplace_back(fmt::format("lag({},{:g}s)", name, tau),
                        FirstOrderLag(series.t_s, u, tau));
      if (spec.speed_squared)
        cols.emplace_back(fmt::format("lag({}^2,{:g}s)", name, tau),
                          FirstOrderLag(series.t_s, u2, tau));
    }
  }
  for (int c : temps) {
    std::vector<double> u = column(c);
    const double u0 = n ? u[0] : 0.0;
    for (double& v : u) v -= u0;
    const std::string& name = series.input_names[size_t(c)];
    cols.emplace_back(
        spec.temperature_lag_s > 0
            ? fmt::format("lag(d{},{:g}s)", name, spec.temperature_lag_s)
            : "d" + name,
        FirstOrderLag(series.t_s, u, spec.temperature_lag_s));
  }
  Regressors r;
  r.values.resize(Eigen::Index(n), Eigen::Index(cols.size()));
  for (size_t j = 0; j < cols.size(); ++j) {
    r.names.push_back(cols[j].first);
    for (size_t i = 0; i < n; ++i)
      r.values(Eigen::Index(i), Eigen::Index(j)) = cols[j].second[i];
  }
  r.rows = r.values;
  return r;
}

}  // namespace ttp::talc
