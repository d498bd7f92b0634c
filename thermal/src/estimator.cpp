#include "ttp/thermal/estimator.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "ttp/geometry/error.h"
#include "ttp/geometry/series.h"

namespace ttp::thermal {
namespace {

struct InputSpec {
  const char* name;
  NumericColumn column;
  double scale;  // to the model's unit
  bool relative_to_start;
};
const InputSpec kInputs[] = {{"c_rpm/1000", kCRpm, 1e-3, false},
                             {"T_env-T_env(0)", kTEnv, 1.0, true},
                             {"T_ws-T_ws(0)", kTWs, 1.0, true},
                             {"dT_cool", kDTCool, 1.0, false}};

// Candidate input subsets of up to max_inputs of n inputs.
void Subsets(int n, int max_size, int first, std::vector<int>& current,
             std::vector<std::vector<int>>& out) {
  out.push_back(current);
  if (static_cast<int>(current.size()) == max_size) return;
  for (int i = first; i < n; ++i) {
    current.push_back(i);
    Subsets(n, max_size, i + 1, current, out);
    current.pop_back();
  }
}

}  // namespace

MachineErrorEstimator MachineErrorEstimator::Fit(
    const TalcLog& log, const EstimatorOptions& options) {
  return FitWithout(log, -1, options);
}

MachineErrorEstimator MachineErrorEstimator::FitWithout(
    const TalcLog& log, int skip, const EstimatorOptions& options) {
  MachineErrorEstimator est;
  est.options_ = options;
  est.compensation_ = log.compensation;
  if (log.rtests.size() < 2) {
    throw InputError(log.source, 0, "rtest",
                     "the log needs at least two R-tests to estimate the "
                     "machine's errors");
  }
  // Prediction in force, from every row giving all seven pred_ values.
  for (const auto& row : log.rows) {
    bool all = true;
    for (int i = 0; i < 7; ++i) all &= row.Has(NumericColumn(kPredEX0C + i));
    if (!all) continue;
    std::array<double, 7> micro;
    for (int i = 0; i < 7; ++i) micro[i] = row.values[kPredEX0C + i];
    if (!est.pred_t_.empty() && row.t_s == est.pred_t_.back()) continue;
    est.pred_t_.push_back(row.t_s);
    est.pred_.push_back(CAxisErrors::FromMicro(micro));
  }
  if (log.compensation && est.pred_t_.empty()) {
    throw InputError(log.source, 0, "pred_EX0C",
                     "compensation on but no row gives the pred_ values; "
                     "the machine's own error cannot be recovered");
  }

  // Machine errors at the R-tests (log units for the fit).
  for (int k = 0; k < static_cast<int>(log.rtests.size()); ++k) {
    if (k == skip) continue;
    const RTestRecord& r = log.rtests[k];
    CAxisErrors y = r.measured;
    if (log.compensation) y = y + est.PredictedAt(r.t_ref_s);
    if (!est.rtest_t_.empty() && r.t_ref_s <= est.rtest_t_.back()) {
      throw InputError(log.source, r.line, "dur_s",
                       "R-test refers to a time not after the previous one");
    }
    est.rtest_t_.push_back(r.t_ref_s);
    est.rtest_y_.push_back(y);
  }

  // Input signals, lag-filtered for every tau on a uniform grid.
  const double t0 = std::min(log.FirstTimeS(), est.rtest_t_.front());
  const double t1 = std::max(log.LastTimeS(), est.rtest_t_.back());
  const double dt = options.grid_step_s;
  const int steps = static_cast<int>(std::ceil((t1 - t0) / dt)) + 1;
  est.grid_t0_ = t0;
  for (const InputSpec& spec : kInputs) {
    std::vector<double> t, v;
    for (const auto& row : log.rows) {
      if (!row.Has(spec.column)) continue;
      if (!t.empty() && row.t_s == t.back()) continue;
      t.push_back(row.t_s);
      v.push_back(row.values[spec.column] * spec.scale);
    }
    if (t.size() < 2) continue;
    const double base = spec.relative_to_start ? v.front() : 0.0;
    const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
    if (*mx - *mn < 1e-9) continue;  // constant: carries no information
    Signal s;
    s.name = spec.name;
    for (double tau : options.tau_grid_s) {
      std::vector<double> f(steps);
      const double a = 1.0 - std::exp(-dt / tau);
      double x = Interpolate(t, v, t0) - base;  // start in steady state
      f[0] = x;
      for (int i = 1; i < steps; ++i) {
        const double u = Interpolate(t, v, t0 + (i - 0.5) * dt) - base;
        x += a * (u - x);
        f[i] = x;
      }
      s.filtered.push_back(std::move(f));
    }
    est.signals_.push_back(std::move(s));
  }

  // Per error: BIC over input subsets and time constants.
  const int n = static_cast<int>(est.rtest_t_.size());
  const int n_inputs = static_cast<int>(est.signals_.size());
  const int n_tau = static_cast<int>(options.tau_grid_s.size());
  std::vector<std::vector<int>> subsets;
  std::vector<int> current;
  Subsets(n_inputs, options.max_inputs, 0, current, subsets);
  // Input values at the R-tests: [input][tau][k].
  std::vector<std::vector<std::vector<double>>> at(n_inputs);
  for (int i = 0; i < n_inputs; ++i) {
    at[i].resize(n_tau);
    for (int j = 0; j < n_tau; ++j) {
      for (int k = 0; k < n; ++k) {
        at[i][j].push_back(est.InputAt(i, j, est.rtest_t_[k]));
      }
    }
  }
  est.models_.resize(7);
  est.model_input_index_.resize(7);
  est.model_tau_index_.resize(7);
  est.residual_.assign(n, {});
  for (int e = 0; e < 7; ++e) {
    double best_bandwidth = 0;
    // With compensation on the fit targets the R-test residual (machine minus
    // pred_): pred_ already follows the fast dynamics of the inputs (C-axis
    // stops for every R-test and cut), so what is left is smoother.
    Eigen::VectorXd y(n);
    for (int k = 0; k < n; ++k) {
      y[k] = (est.rtest_y_[k] - est.PredictedAt(est.rtest_t_[k])).ToMicro()[e];
    }
    double best_bic = std::numeric_limits<double>::infinity();
    for (const auto& subset : subsets) {
      const int m = static_cast<int>(subset.size());
      if (n <= 2 * m + 2) continue;  // keep the fit overdetermined
      std::vector<int> taus(m, 0);
      while (true) {
        Eigen::MatrixXd x(n, m + 1);
        x.col(0).setOnes();
        for (int c = 0; c < m; ++c) {
          for (int k = 0; k < n; ++k) x(k, c + 1) = at[subset[c]][taus[c]][k];
        }
        const Eigen::VectorXd beta = x.colPivHouseholderQr().solve(y);
        const double rss = std::max((y - x * beta).squaredNorm(), 1e-12);
        const double bic = n * std::log(rss / n) + (1 + 2 * m) * std::log(n);
        if (bic < best_bic - 1e-9) {
          best_bic = bic;
          ErrorModel model;
          model.offset = beta[0];
          model.bic = bic;
          model.rms_residual = std::sqrt(rss / n);
          for (int c = 0; c < m; ++c) {
            model.inputs.push_back(est.signals_[subset[c]].name);
            model.tau_s.push_back(options.tau_grid_s[taus[c]]);
            model.gains.push_back(beta[c + 1]);
          }
          est.models_[e] = model;
          est.model_input_index_[e] = subset;
          est.model_tau_index_[e] = taus;
        }
        int c = 0;  // next combination of time constants
        while (c < m && ++taus[c] == n_tau) taus[c++] = 0;
        if (c == m) break;
      }
    }
    for (int k = 0; k < n; ++k) {
      est.residual_[k][e] = y[k] - est.ModelAt(e, est.rtest_t_[k]);
    }
    // Residual smoother: the bandwidth with the least leave-one-out error.
    double best = std::numeric_limits<double>::infinity();
    for (double h : options.bandwidth_grid_s) {
      est.models_[e].bandwidth_s = h;
      double ss = 0;
      for (int k = 0; k < n; ++k) {
        const double r = est.ResidualAt(e, est.rtest_t_[k], k);
        ss += (r - est.residual_[k][e]) * (r - est.residual_[k][e]);
      }
      if (ss < best - 1e-12) {
        best = ss;
        est.models_[e].loo_rms = std::sqrt(ss / n);
        best_bandwidth = h;
      }
    }
    est.models_[e].bandwidth_s = best_bandwidth;
  }
  return est;
}

double MachineErrorEstimator::InputAt(int input, int tau, double t_s) const {
  return InterpolateUniform(signals_[input].filtered[tau], grid_t0_,
                            options_.grid_step_s, t_s);
}

double MachineErrorEstimator::ModelAt(int e, double t_s) const {
  const ErrorModel& m = models_[e];
  double y = m.offset;
  for (size_t c = 0; c < m.gains.size(); ++c) {
    y += m.gains[c] *
         InputAt(model_input_index_[e][c], model_tau_index_[e][c], t_s);
  }
  return y;
}

// Residual correction at t, R-test `skip` left out (-1: none).
double MachineErrorEstimator::ResidualAt(int e, double t_s, int skip) const {
  const int n = static_cast<int>(rtest_t_.size());
  const double h = models_[e].bandwidth_s;
  if (h == 0) {
    std::vector<double> t, r;
    for (int k = 0; k < n; ++k) {
      if (k == skip) continue;
      t.push_back(rtest_t_[k]);
      r.push_back(residual_[k][e]);
    }
    return Interpolate(t, r, t_s);
  }
  double sw = 0, swr = 0;
  for (int k = 0; k < n; ++k) {
    if (k == skip) continue;
    const double w =
        std::isinf(h) ? 1.0
                      : std::exp(-0.5 * std::pow((rtest_t_[k] - t_s) / h, 2));
    sw += w;
    swr += w * residual_[k][e];
  }
  return sw > 1e-300 ? swr / sw : 0.0;
}

CAxisErrors MachineErrorEstimator::MachineErrorsAt(double t_s) const {
  std::array<double, 7> micro;
  for (int e = 0; e < 7; ++e) {
    micro[e] = ModelAt(e, t_s) + ResidualAt(e, t_s, -1);
  }
  return PredictedAt(t_s) + CAxisErrors::FromMicro(micro);
}

CAxisErrors MachineErrorEstimator::LinearErrorsAt(double t_s) const {
  return Interpolate(rtest_t_, rtest_y_, t_s);
}

CAxisErrors MachineErrorEstimator::PredictedAt(double t_s) const {
  if (!compensation_ || pred_t_.empty()) return CAxisErrors{};
  return Interpolate(pred_t_, pred_, t_s);
}

std::string MachineErrorEstimator::Describe() const {
  std::string s = fmt::format(
      "ARX(1,1) smoother: per error c + sum g_i * lag_tau_i(u_i), least "
      "squares on {} R-tests, inputs and tau by BIC, plus R-test residuals "
      "smoothed (Gaussian kernel, bandwidth per error by leave-one-out; 0 = "
      "linear interpolation){}",
      rtest_t_.size(),
      compensation_ ? "; machine error = R-test residual + pred_" : "");
  return s;
}

nlohmann::json MachineErrorEstimator::ToJson() const {
  nlohmann::json j;
  j["name"] = "arx_smoother";
  j["description"] = Describe();
  j["rtests"] = rtest_t_.size();
  j["compensation"] = compensation_;
  nlohmann::json models = nlohmann::json::object();
  for (int e = 0; e < 7; ++e) {
    const ErrorModel& m = models_[e];
    nlohmann::json terms = nlohmann::json::array();
    for (size_t c = 0; c < m.inputs.size(); ++c) {
      terms.push_back({{"input", m.inputs[c]},
                       {"tau_s", m.tau_s[c]},
                       {"gain", m.gains[c]}});
    }
    models[kErrorNames[e]] = {
        {"offset", m.offset},
        {"terms", terms},
        {"bic", m.bic},
        {"rms_residual", m.rms_residual},
        {"residual_bandwidth_s", std::isinf(m.bandwidth_s)
                                     ? nlohmann::json("inf")
                                     : nlohmann::json(m.bandwidth_s)},
        {"loo_rms", m.loo_rms}};
  }
  j["models"] = models;
  return j;
}

LoadChangeComparison CompareAtLoadChanges(const TalcLog& log,
                                          const EstimatorOptions& options) {
  LoadChangeComparison out;
  double first_load = -1, last_load = -1;
  for (const auto& row : log.rows) {
    if (row.Has(kCRpm) && row.values[kCRpm] > 0) {
      if (first_load < 0) first_load = row.t_s;
      last_load = row.t_s;
    }
  }
  if (first_load >= 0) out.load_change_times_s = {first_load, last_load};
  const int n = static_cast<int>(log.rtests.size());
  std::array<double, 7> sum_arx{}, sum_lin{};
  double all_arx = 0, all_lin = 0;
  int near = 0, interior = 0;
  for (int k = 1; k + 1 < n; ++k) {
    const MachineErrorEstimator est =
        MachineErrorEstimator::FitWithout(log, k, options);
    const double t = log.rtests[k].t_ref_s;
    CAxisErrors truth = log.rtests[k].measured;
    if (log.compensation) truth = truth + est.PredictedAt(t);
    const auto y = truth.ToMicro();
    const auto a = est.MachineErrorsAt(t).ToMicro();
    const auto l = est.LinearErrorsAt(t).ToMicro();
    bool is_near = false;
    for (double c : out.load_change_times_s) {
      is_near |= log.rtests[k - 1].t_ref_s < c && c < log.rtests[k + 1].t_ref_s;
    }
    ++interior;
    for (int e = 0; e < 7; ++e) {
      const double da = (a[e] - y[e]) * (a[e] - y[e]);
      const double dl = (l[e] - y[e]) * (l[e] - y[e]);
      all_arx += da;
      all_lin += dl;
      if (is_near) {
        sum_arx[e] += da;
        sum_lin[e] += dl;
      }
    }
    if (is_near) {
      ++near;
      out.tested_rtest_times_s.push_back(t);
    }
  }
  if (near > 0) {
    double sa = 0, sl = 0;
    for (int e = 0; e < 7; ++e) {
      out.rms_arx[e] = std::sqrt(sum_arx[e] / near);
      out.rms_linear[e] = std::sqrt(sum_lin[e] / near);
      sa += sum_arx[e];
      sl += sum_lin[e];
    }
    out.rms_arx_all = std::sqrt(sa / (7.0 * near));
    out.rms_linear_all = std::sqrt(sl / (7.0 * near));
  }
  if (interior > 0) {
    out.rms_arx_everywhere = std::sqrt(all_arx / (7.0 * interior));
    out.rms_linear_everywhere = std::sqrt(all_lin / (7.0 * interior));
  }
  return out;
}

}  // namespace ttp::thermal

namespace ttp::thermal {

std::vector<double> LoadChangeTimes(const TalcLog& log) {
  double first = -1;
  int last = -1;
  for (int i = 0; i < static_cast<int>(log.rows.size()); ++i) {
    const LogRow& row = log.rows[i];
    if (row.Has(kCRpm) && row.values[kCRpm] > 0) {
      if (first < 0) first = row.t_s;
      last = i;
    }
  }
  if (first < 0) return {};
  double cool = log.rows[last].t_s;
  for (size_t i = last + 1; i < log.rows.size(); ++i) {
    if (log.rows[i].Has(kCRpm)) {
      cool = log.rows[i].t_s;
      break;
    }
  }
  return {first, cool};
}

InterpolationComparison CompareInterpolation(const TalcLog& log,
                                             double interval_s,
                                             const EstimatorOptions& options) {
  InterpolationComparison out;
  out.interval_s = interval_s;
  const int n = static_cast<int>(log.rtests.size());
  if (n < 2) {
    throw InputError(log.source, 0, "rtest",
                     "the log needs at least two R-tests");
  }
  // Keep every stride-th R-test (plus the first and the last), for every
  // phase of that grid, so that each load change is seen at every position
  // between two kept R-tests.
  const double spacing =
      (log.rtests.back().t_ref_s - log.rtests.front().t_ref_s) / (n - 1);
  const int stride =
      std::max(1, static_cast<int>(std::lround(interval_s / spacing)));
  const std::vector<double> changes = LoadChangeTimes(log);
  std::vector<InterpolationWindow> windows(changes.size());
  std::vector<std::array<double, 7>> sm(changes.size()), sl(changes.size());
  for (size_t c = 0; c < changes.size(); ++c) {
    windows[c].label = c == 0 ? "warm-up start" : "cool-down start";
    windows[c].load_change_s = changes[c];
    windows[c].bracket_from_s = 0;
    sm[c].fill(0);
    sl[c].fill(0);
  }
  for (int phase = 0; phase < stride; ++phase) {
    std::vector<bool> kept(n, false);
    for (int k = 0; k < n; ++k) kept[k] = k % stride == phase;
    kept[0] = kept[n - 1] = true;
    TalcLog sparse = log;
    sparse.rtests.clear();
    for (int k = 0; k < n; ++k) {
      if (kept[k]) sparse.rtests.push_back(log.rtests[k]);
    }
    if (phase == 0) out.kept_rtests = static_cast<int>(sparse.rtests.size());
    ++out.phases;
    const MachineErrorEstimator est =
        MachineErrorEstimator::Fit(sparse, options);
    for (size_t c = 0; c < changes.size(); ++c) {
      InterpolationWindow& w = windows[c];
      int a = -1, b = -1;
      for (int k = 0; k < n; ++k) {
        if (!kept[k]) continue;
        if (log.rtests[k].t_ref_s <= changes[c]) a = k;
        if (log.rtests[k].t_ref_s > changes[c] && b < 0) b = k;
      }
      if (a < 0 || b < 0) continue;
      w.bracket_from_s += log.rtests[b].t_ref_s - log.rtests[a].t_ref_s;
      for (int k = a + 1; k < b; ++k) {
        const double t = log.rtests[k].t_ref_s;
        CAxisErrors y = log.rtests[k].measured;
        if (log.compensation) y = y + est.PredictedAt(t);
        const auto yv = y.ToMicro();
        const auto m = est.MachineErrorsAt(t).ToMicro();
        const auto l = est.LinearErrorsAt(t).ToMicro();
        for (int e = 0; e < 7; ++e) {
          sm[c][e] += (m[e] - yv[e]) * (m[e] - yv[e]);
          sl[c][e] += (l[e] - yv[e]) * (l[e] - yv[e]);
          if (e < 4) {
            w.max_model_um = std::max(w.max_model_um, std::abs(m[e] - yv[e]));
            w.max_line_um = std::max(w.max_line_um, std::abs(l[e] - yv[e]));
          }
        }
        ++w.held_out;
      }
    }
  }
  for (size_t c = 0; c < changes.size(); ++c) {
    InterpolationWindow& w = windows[c];
    if (w.held_out == 0) continue;
    w.mean_bracket_s = w.bracket_from_s / out.phases;
    w.bracket_from_s = 0;
    double am = 0, al = 0;
    for (int e = 0; e < 7; ++e) {
      w.rms_model[e] = std::sqrt(sm[c][e] / w.held_out);
      w.rms_line[e] = std::sqrt(sl[c][e] / w.held_out);
      if (e < 4) {
        am += sm[c][e];
        al += sl[c][e];
      }
    }
    w.rms_model_um = std::sqrt(am / (4.0 * w.held_out));
    w.rms_line_um = std::sqrt(al / (4.0 * w.held_out));
    out.windows.push_back(w);
  }
  return out;
}

nlohmann::json InterpolationToJson(const InterpolationComparison& c) {
  nlohmann::json j;
  j["rtest_interval_s"] = c.interval_s;
  j["kept_rtests"] = c.kept_rtests;
  nlohmann::json windows = nlohmann::json::array();
  for (const InterpolationWindow& w : c.windows) {
    nlohmann::json model, line;
    for (int e = 0; e < 7; ++e) {
      model[kErrorNames[e]] = w.rms_model[e];
      line[kErrorNames[e]] = w.rms_line[e];
    }
    windows.push_back({{"load_change", w.label},
                       {"t_s", w.load_change_s},
                       {"mean_bracket_s", w.mean_bracket_s},
                       {"held_out_rtests", w.held_out},
                       {"rms_model", model},
                       {"rms_line", line},
                       {"rms_model_linear_errors_um", w.rms_model_um},
                       {"rms_line_linear_errors_um", w.rms_line_um},
                       {"max_model_um", w.max_model_um},
                       {"max_line_um", w.max_line_um}});
  }
  j["windows"] = windows;
  return j;
}

std::string InterpolationText(const InterpolationComparison& c) {
  std::string s = fmt::format(
      "machine error at the load changes: dynamic model vs straight line, "
      "R-tests thinned to one every {:.0f} s ({} kept; all {} phases of that "
      "grid), checked against the held-out R-tests between the two kept ones "
      "that bracket each load change\n",
      c.interval_s, c.kept_rtests, c.phases);
  for (const InterpolationWindow& w : c.windows) {
    s += fmt::format(
        "  {} at t_s {:.0f} (kept R-tests {:.0f} s apart around it on "
        "average, {} held-out R-tests)\n",
        w.label, w.load_change_s, w.mean_bracket_s, w.held_out);
    s += "     error   model    line   (RMS, um or um/m)\n";
    for (int e = 0; e < 7; ++e) {
      s += fmt::format("    {:>6} {:7.3f} {:7.3f}\n", kErrorNames[e],
                       w.rms_model[e], w.rms_line[e]);
    }
    s += fmt::format(
        "    EX..ER  {:7.3f} {:7.3f}   largest {:.2f} vs {:.2f} um\n",
        w.rms_model_um, w.rms_line_um, w.max_model_um, w.max_line_um);
  }
  return s;
}

}  // namespace ttp::thermal
