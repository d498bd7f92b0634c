#include "ttp/models/features.h"

#include <fmt/format.h>

#include <cmath>

#include "ttp/geometry/error.h"

namespace ttp::models {

double Regressor::InputScale() const {
  return input.rfind("n_", 0) == 0 ? 1e-3 : 1.0;
}

std::string Regressor::Name() const {
  std::string s = input;
  if (power == 2) s += "^2";
  if (delay_s > 0) s = fmt::format("{}(t-{:g}s)", s, delay_s);
  for (double tau : taus_s) s = fmt::format("lag{:g}({})", tau, s);
  return s;
}

nlohmann::json Regressor::ToJson() const {
  return {{"input", input},
          {"power", power},
          {"delay_s", delay_s},
          {"taus_s", taus_s},
          {"name", Name()}};
}

Regressor Regressor::FromJson(const nlohmann::json& j,
                              const std::string& source) {
  Regressor r;
  try {
    r.input = j.at("input").get<std::string>();
    // Read as a number first: 1e100 does not fit an int.
    const double power = j.value("power", 1.0);
    if (power != 1 && power != 2)
      throw InputError(source, 0, "regressors.power", "must be 1 or 2");
    r.power = static_cast<int>(power);
    r.delay_s = j.value("delay_s", 0.0);
    r.taus_s = j.value("taus_s", std::vector<double>{});
  } catch (const nlohmann::json::exception& e) {
    throw InputError(source, 0, "regressors", e.what());
  }
  if (!(r.delay_s >= 0))
    throw InputError(source, 0, "regressors.delay_s", "must be >= 0");
  if (r.taus_s.size() > 2)
    throw InputError(source, 0, "regressors.taus_s", "at most two lags");
  for (double tau : r.taus_s)
    if (!(tau > 0))
      throw InputError(source, 0, "regressors.taus_s", "must be > 0");
  return r;
}

bool Regressor::operator==(const Regressor& o) const {
  return input == o.input && power == o.power && delay_s == o.delay_s &&
         taus_s == o.taus_s;
}

FeatureBank::FeatureBank(std::vector<Regressor> regressors,
                         const std::vector<std::string>& input_names,
                         const std::string& source)
    : regs_(std::move(regressors)) {
  channels_.resize(regs_.size());
  for (size_t k = 0; k < regs_.size(); ++k) {
    for (size_t i = 0; i < input_names.size(); ++i)
      if (input_names[i] == regs_[k].input) channels_[k].column = int(i);
    if (channels_[k].column < 0) {
      throw InputError(source, 0, regs_[k].input,
                       "column needed by the model is missing from the log");
    }
    channels_[k].scale = regs_[k].InputScale();
    channels_[k].u_prev.assign(regs_[k].taus_s.size(), 0.0);
    channels_[k].y.assign(regs_[k].taus_s.size(), 0.0);
  }
}

double FeatureBank::Transformed(
    const Regressor& r, const Channel& c,
    const Eigen::Ref<const Eigen::RowVectorXd>& row) const {
  const double x = row(c.column) * c.scale;
  return r.power == 2 ? x * x : x;
}

double FeatureBank::Delayed(const Regressor& r, Channel& c, double t_s,
                            double u) {
  if (r.delay_s <= 0) return u;
  c.history.emplace_back(t_s, u);
  // Keep the newest sample at or before t - delay at the front (zero-order
  // hold); before the restart row there is nothing older: hold its value.
  const double t_past = t_s - r.delay_s;
  while (c.history.size() > 1 && c.history[1].first <= t_past)
    c.history.pop_front();
  return c.history.front().second;
}

void FeatureBank::Reset(double t_s,
                        const Eigen::Ref<const Eigen::RowVectorXd>& row) {
  for (size_t k = 0; k < regs_.size(); ++k) {
    Channel& c = channels_[k];
    const double u = Transformed(regs_[k], c, row);
    c.history.clear();
    if (regs_[k].delay_s > 0) c.history.emplace_back(t_s, u);
    std::fill(c.u_prev.begin(), c.u_prev.end(), u);
    std::fill(c.y.begin(), c.y.end(), u);
  }
  last_t_ = t_s;
  started_ = true;
}

void FeatureBank::Step(double t_s,
                       const Eigen::Ref<const Eigen::RowVectorXd>& row,
                       double* out) {
  if (!started_) Reset(t_s, row);
  const double dt = t_s - last_t_;
  for (size_t k = 0; k < regs_.size(); ++k) {
    const Regressor& r = regs_[k];
    Channel& c = channels_[k];
    double u = Transformed(r, c, row);
    if (dt > 0 || (r.delay_s > 0 && c.history.empty()))
      u = Delayed(r, c, t_s, u);
    else if (r.delay_s > 0)
      u = c.history.front().second;
    if (dt > 0 && !r.taus_s.empty()) {
      // Exact response of tau1 y1' = u - y1, tau2 y2' = y1 - y2 to an input
      // linear between the two samples (first-order hold).
      const double u0 = c.u_prev[0];
      const double slope = (u - u0) / dt;
      const double t1 = r.taus_s[0];
      const double a1 = std::exp(-dt / t1);
      const double c1 = c.y[0] - u0 + slope * t1;  // free part of y1
      if (r.taus_s.size() == 2) {
        double t2 = r.taus_s[1];
        if (std::abs(t2 - t1) < 1e-9 * t1) t2 = t1 * (1 + 1e-6);
        const double a2 = std::exp(-dt / t2);
        const double k = c1 * t1 / (t1 - t2);
        const double forced0 = u0 - slope * (t1 + t2);
        const double c2 = c.y[1] - forced0 - k;
        c.y[1] = forced0 + slope * dt + k * a1 + c2 * a2;
      }
      c.y[0] = u - slope * t1 + c1 * a1;
      c.u_prev[0] = u;
    }
    out[k] = r.taus_s.empty() ? u : c.y.back();
  }
  last_t_ = t_s;
}

nlohmann::json FeatureBank::State() const {
  nlohmann::json j;
  j["t_s"] = last_t_;
  nlohmann::json chans = nlohmann::json::array();
  for (const Channel& c : channels_) {
    nlohmann::json h = nlohmann::json::array();
    for (const auto& [t, u] : c.history) h.push_back({t, u});
    chans.push_back({{"history", h}, {"u_prev", c.u_prev}, {"y", c.y}});
  }
  j["regressors"] = chans;
  return j;
}

void FeatureBank::SetState(const nlohmann::json& state) {
  last_t_ = state.at("t_s").get<double>();
  const auto& chans = state.at("regressors");
  if (chans.size() != channels_.size())
    throw InputError("model", 0, "state",
                     "filter state does not match the regressors");
  for (size_t k = 0; k < channels_.size(); ++k) {
    Channel& c = channels_[k];
    c.history.clear();
    for (const auto& p : chans[k].at("history"))
      c.history.emplace_back(p.at(0).get<double>(), p.at(1).get<double>());
    c.u_prev = chans[k].at("u_prev").get<std::vector<double>>();
    c.y = chans[k].at("y").get<std::vector<double>>();
    if (c.y.size() != regs_[k].taus_s.size() || c.u_prev.size() != c.y.size())
      throw InputError("model", 0, "state",
                       "filter state does not match the regressors");
  }
  started_ = true;
}

Eigen::MatrixXd ComputeFeatures(const TimeSeries& ts,
                                const std::vector<Regressor>& regressors,
                                const nlohmann::json* state,
                                nlohmann::json* end_state) {
  FeatureBank bank(regressors, ts.input_names, ts.source);
  // Row-major scratch so that Step can write one row at a time.
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> f(
      static_cast<Eigen::Index>(ts.rows()),
      static_cast<Eigen::Index>(regressors.size()));
  size_t next_gap = 0;
  if (state != nullptr) bank.SetState(*state);
  for (size_t i = 0; i < ts.rows(); ++i) {
    const bool gap =
        next_gap < ts.gap_rows.size() && ts.gap_rows[next_gap] == i;
    if (gap) ++next_gap;
    if ((i == 0 && state == nullptr) || gap)
      bank.Reset(ts.t_s[i], ts.inputs.row(i));
    bank.Step(ts.t_s[i], ts.inputs.row(i),
              f.row(static_cast<Eigen::Index>(i)).data());
  }
  if (end_state != nullptr) *end_state = bank.State();
  return f;
}

}  // namespace ttp::models
