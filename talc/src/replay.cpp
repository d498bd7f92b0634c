#include "ttp/talc/replay.h"

#include <fmt/format.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>

#include "ttp/geometry/error.h"
#include "ttp/talc/rls.h"

namespace ttp::talc {

Figures ResidualFigures(std::vector<double> r) {
  Figures f;
  f.samples = int(r.size());
  if (r.empty()) return f;
  double ss = 0.0, lo = r[0], hi = r[0];
  for (double v : r) {
    ss += v * v;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  f.rms_um = std::sqrt(ss / double(r.size()));
  f.ptv_um = hi - lo;
  for (double& v : r) v = std::abs(v);
  const double pos = 0.99 * double(r.size() - 1);
  const size_t k = size_t(std::floor(pos));
  std::nth_element(r.begin(), r.begin() + long(k), r.end());
  const double a = r[k];
  double b = a;
  if (k + 1 < r.size()) b = *std::min_element(r.begin() + long(k) + 1, r.end());
  f.p99_um = a + (pos - double(k)) * (b - a);
  return f;
}

namespace {

std::vector<int> OutputColumns(const models::TimeSeries& s,
                               const Strategy& st) {
  std::vector<int> cols;
  if (st.outputs.empty()) {
    for (size_t c = 0; c < s.output_names.size(); ++c) cols.push_back(int(c));
  } else {
    for (const auto& name : st.outputs) {
      int found = -1;
      for (size_t c = 0; c < s.output_names.size(); ++c)
        if (s.output_names[c] == name) found = int(c);
      if (found < 0)
        throw InputError(s.source, 0, name,
                         "output named by the strategy is not a column of "
                         "the log");
      cols.push_back(found);
    }
  }
  if (cols.empty())
    throw InputError(s.source, 0, "d_", "the log has no output column");
  return cols;
}

// Static baseline: y = c + sum_j b_j (T_j - T_j(0)) over the calibration
// measurements, tiny ridge so that a short calibration still solves.
Eigen::MatrixXd FitStatic(const models::TimeSeries& s,
                          const std::vector<int>& temps,
                          const std::vector<size_t>& rows,
                          const std::vector<int>& outs) {
  const Eigen::Index p = Eigen::Index(temps.size()) + 1;
  Eigen::MatrixXd a(Eigen::Index(rows.size()) + p, p);
  Eigen::MatrixXd b(Eigen::Index(rows.size()) + p, Eigen::Index(outs.size()));
  a.setZero();
  b.setZero();
  for (size_t k = 0; k < rows.size(); ++k) {
    a(Eigen::Index(k), 0) = 1.0;
    for (size_t j = 0; j < temps.size(); ++j)
      a(Eigen::Index(k), Eigen::Index(j) + 1) =
          s.inputs(Eigen::Index(rows[k]), temps[j]) - s.inputs(0, temps[j]);
    for (size_t o = 0; o < outs.size(); ++o)
      b(Eigen::Index(k), Eigen::Index(o)) =
          s.outputs_um(Eigen::Index(rows[k]), outs[o]);
  }
  a.bottomRows(p) = 1e-3 * Eigen::MatrixXd::Identity(p, p);
  return a.householderQr().solve(b);
}

// One TALC measurement: the recursive fit forgets by the time since the
// last update (forgetting_per_h per hour) and takes the new row; after the
// calibration the estimate is refreshed and, when anchored, offset so that
// the prediction passes through the measurement.
void MeasurementUpdate(const Strategy& st, double t,
                       const Eigen::Ref<const Eigen::RowVectorXd>& phi,
                       const Eigen::VectorXd& y, bool started,
                       RecursiveLeastSquares* rls, double* last_update_t,
                       Eigen::MatrixXd* theta, Eigen::VectorXd* base) {
  const double lambda =
      st.forgetting_per_h == 1.0
          ? 1.0
          : std::pow(st.forgetting_per_h, (t - *last_update_t) / 3600.0);
  rls->Update(phi.transpose(), y, 1.0, lambda);
  *last_update_t = t;
  if (!started) return;
  *theta = rls->Solve();
  *base = st.anchored ? Eigen::VectorXd(y - (phi * *theta).transpose())
                      : Eigen::VectorXd::Zero(y.size());
}

// The static baseline updated like TALC (OutputReplay::static_model): the
// main loop's semantics with temperature regressors only and the
// measurement rows TALC chose.
std::vector<std::vector<double>> StaticUpdatedResiduals(
    const models::TimeSeries& s, const std::vector<int>& outs,
    const Strategy& st, const std::vector<size_t>& meas_rows, double cal_end) {
  RegressorSpec spec;
  spec.speed_lags_s.clear();
  spec.speed_squared = false;
  spec.temperatures = {"all"};
  spec.temperature_lag_s = 0.0;
  const Regressors reg = BuildRegressors(s, spec);
  const int m = int(outs.size());
  const int p = int(reg.rows.cols());
  RecursiveLeastSquares rls(p, m, st.ridge);
  Eigen::MatrixXd theta = Eigen::MatrixXd::Zero(p, m);
  Eigen::VectorXd base = Eigen::VectorXd::Zero(m), last_y = base, y(m), pred(m);
  bool started = false, any = false;
  double last_update_t = s.t_s.front();
  size_t next = 0, last_cal = 0;
  std::vector<std::vector<double>> r(static_cast<size_t>(m));
  for (size_t i = 0; i < s.rows(); ++i) {
    const double t = s.t_s[i];
    const auto phi = reg.rows.row(Eigen::Index(i));
    if (!started && t >= cal_end) {
      started = true;
      theta = rls.Solve();
      if (any && st.anchored)
        base =
            last_y - (reg.rows.row(Eigen::Index(last_cal)) * theta).transpose();
    }
    pred = started ? Eigen::VectorXd((phi * theta).transpose() + base) : last_y;
    if (t >= cal_end)
      for (int o = 0; o < m; ++o) {
        const double yo = s.outputs_um(Eigen::Index(i), outs[size_t(o)]);
        if (!std::isnan(yo)) r[size_t(o)].push_back(yo - pred(o));
      }
    if (next >= meas_rows.size() || meas_rows[next] != i) continue;
    ++next;
    for (int o = 0; o < m; ++o)
      y(o) = s.outputs_um(Eigen::Index(i), outs[size_t(o)]);
    MeasurementUpdate(st, t, phi, y, started, &rls, &last_update_t, &theta,
                      &base);
    if (!started) last_cal = i;
    last_y = y;
    any = true;
  }
  return r;
}

}  // namespace

ReplayResult Replay(const models::TimeSeries& series, const Strategy& strategy,
                    const ReplayOptions& options) {
  return Replay(series, BuildRegressors(series, strategy.regressors), strategy,
                options);
}

ReplayResult Replay(const models::TimeSeries& s, const Regressors& reg,
                    const Strategy& st, const ReplayOptions& opt) {
  std::string why;
  if (!st.IsValid(&why)) throw InputError("strategy", 0, "", why);
  ReplayResult res;
  res.regressor_names = reg.names;
  // TALC measures the outputs it compensates together: an output the log
  // never measures would leave it without a single measurement. Left out
  // (said) when the strategy does not name it; bad input when it does.
  std::vector<int> outs;
  for (int c : OutputColumns(s, st)) {
    if (s.outputs_um.col(c).array().isFinite().any()) {
      outs.push_back(c);
      continue;
    }
    const std::string& name = s.output_names[size_t(c)];
    if (!st.outputs.empty())
      throw InputError(s.source, 0, name,
                       "the strategy compensates it, but the log never "
                       "measures it");
    res.warnings.push_back(fmt::format(
        "{} is never measured in the log: left out of the replay (the "
        "outputs are measured together)",
        name));
  }
  if (outs.empty())
    throw InputError(s.source, 0, "d_",
                     "no output column holds a measured value");
  const int m = int(outs.size());
  const size_t n = s.rows();
  const int p = int(reg.rows.cols());
  if (n == 0) {
    res.status = ReplayStatus::kNoEvaluatedSamples;
    return res;
  }
  const double t0 = s.t_s.front();
  const double cal_end = t0 + st.calibration_s;
  res.total_s = s.t_s.back() - t0;
  res.evaluated_from_s = cal_end;

  std::vector<char> gap(n, 0);
  for (size_t g : s.gap_rows)
    if (g > 0 && g < n) gap[g] = 1;

  RecursiveLeastSquares rls(p, m, st.ridge);
  Eigen::MatrixXd theta = Eigen::MatrixXd::Zero(p, m);
  // Anchored prediction: y_m + (phi_i - phi_m)' theta = phi_i' theta + base.
  Eigen::VectorXd base = Eigen::VectorXd::Zero(m);
  Eigen::VectorXd last_y = Eigen::VectorXd::Zero(m);
  Eigen::VectorXd pred(m), y(m);
  bool started = false, any_measurement = false;
  double last_t = -std::numeric_limits<double>::infinity();
  double last_update_t = t0;
  int ng_left = 0;
  std::vector<size_t> cal_rows, meas_rows;

  std::vector<std::vector<double>> r_talc(static_cast<size_t>(m)),
      r_hold(static_cast<size_t>(m)), r_none(static_cast<size_t>(m));
  if (opt.keep_predictions)
    res.predictions_um.resize(Eigen::Index(n), Eigen::Index(m));

  auto all_measured = [&](size_t i) {
    for (int o = 0; o < m; ++o)
      if (std::isnan(s.outputs_um(Eigen::Index(i), outs[size_t(o)])))
        return false;
    return true;
  };

  for (size_t i = 0; i < n; ++i) {
    const double t = s.t_s[i];
    const auto phi = reg.rows.row(Eigen::Index(i));
    if (!started && t >= cal_end) {
      started = true;
      res.rank_at_start = rls.Rank();
      theta = rls.Solve();
      if (any_measurement) {
        for (int o = 0; o < m; ++o) base(o) = last_y(o);
        // Re-anchor to the last calibration measurement.
        base -=
            (reg.rows.row(Eigen::Index(cal_rows.back())) * theta).transpose();
      }
      if (!st.anchored) base.setZero();
      if (res.rank_at_start < p)
        res.warnings.push_back(fmt::format(
            "calibration data determine {} of {} parameters (rank); the "
            "ridge holds the rest",
            res.rank_at_start, p));
    }
    // The compensation in effect at t, decided before any measurement at t.
    if (started) {
      pred = (phi * theta).transpose() + base;
    } else {
      pred = last_y;
    }
    // Is a measurement due at t?
    bool due = false;
    const double since = t - last_t;
    if (!any_measurement || gap[i]) {
      due = true;
      if (gap[i])
        res.warnings.push_back(fmt::format(
            "gap of {:g} s before t = {:g} s: measured again there instead "
            "of predicting across it",
            t - s.t_s[i - 1], t));
    } else if (since >= st.measuring_time_s) {
      if (!started || t < cal_end) {
        due = since >= st.calibration_interval_s;
      } else if (ng_left > 0) {
        due = since >= st.ng_interval_s;
      } else if (st.mode == IntervalMode::kFixed) {
        due = since >= st.interval_s;
      } else {
        if (since >= st.max_interval_s) {
          due = true;
        } else if (since >= st.min_interval_s) {
          for (int o = 0; o < m; ++o)
            if (std::abs(pred(o) - last_y(o)) >= st.threshold_um) due = true;
        }
      }
    }
    if (due && !all_measured(i)) due = false;  // taken at the next sample
    if (opt.keep_predictions) res.predictions_um.row(Eigen::Index(i)) = pred;
    if (t >= cal_end && opt.baselines) {
      for (int o = 0; o < m; ++o) {
        const double yo = s.outputs_um(Eigen::Index(i), outs[size_t(o)]);
        if (std::isnan(yo)) continue;
        r_talc[size_t(o)].push_back(yo - pred(o));
        r_none[size_t(o)].push_back(yo);
        r_hold[size_t(o)].push_back(yo - last_y(o));
      }
    } else if (t >= cal_end) {
      for (int o = 0; o < m; ++o) {
        const double yo = s.outputs_um(Eigen::Index(i), outs[size_t(o)]);
        if (!std::isnan(yo)) r_talc[size_t(o)].push_back(yo - pred(o));
      }
    }
    if (!due) continue;

    // Measurement: the only place an output value is read for the model.
    for (int o = 0; o < m; ++o)
      y(o) = s.outputs_um(Eigen::Index(i), outs[size_t(o)]);
    if (started) {
      bool over = false;
      for (int o = 0; o < m; ++o)
        if (std::abs(y(o) - pred(o)) > st.action_limit_um) over = true;
      if (ng_left > 0)
        --ng_left;
      else if (over && st.ng_measurements > 0) {
        ng_left = st.ng_measurements;
        ++res.ng_phases;
      }
    } else {
      cal_rows.push_back(i);
      ++res.calibration_measurements;
    }
    MeasurementUpdate(st, t, phi, y, started, &rls, &last_update_t, &theta,
                      &base);
    last_y = y;
    last_t = t;
    any_measurement = true;
    res.measurement_times_s.push_back(t);
    meas_rows.push_back(i);
  }
  res.measurements = int(res.measurement_times_s.size());
  // Production time lost to measuring, within the log: a measurement still
  // running at the log's end counts up to the end (Q_Prod stays in 0..1).
  double measuring_s = 0;
  for (double tm : res.measurement_times_s)
    measuring_s += std::clamp(s.t_s.back() - tm, 0.0, st.measuring_time_s);
  res.q_prod = res.total_s > 0 ? 1.0 - measuring_s / res.total_s : 1.0;

  // Static baselines: frozen after calibration, updated like TALC, and
  // fitted once on the stated window.
  Eigen::MatrixXd b_static, b_window;
  std::vector<int> temps;
  std::vector<std::vector<double>> r_updated;
  if (opt.baselines) {
    for (size_t c = 0; c < s.input_names.size(); ++c)
      if (s.input_names[c].rfind("T_", 0) == 0) temps.push_back(int(c));
    b_static = FitStatic(s, temps, cal_rows, outs);
    std::vector<size_t> window_rows;
    for (size_t i = 0; i < n; ++i)
      if (s.t_s[i] >= opt.static_window_from_s &&
          s.t_s[i] <= opt.static_window_to_s && all_measured(i))
        window_rows.push_back(i);
    res.static_window_samples = int(window_rows.size());
    if (!window_rows.empty()) {
      res.static_window_from_s = s.t_s[window_rows.front()];
      res.static_window_to_s = s.t_s[window_rows.back()];
      b_window = FitStatic(s, temps, window_rows, outs);
      res.static_window_in_sample = res.static_window_to_s >= cal_end;
    } else {
      res.warnings.push_back(
          "the static window holds no sample with every output measured");
    }
    r_updated = StaticUpdatedResiduals(s, outs, st, meas_rows, cal_end);
  }
  res.outputs.resize(size_t(m));
  for (int o = 0; o < m; ++o) {
    OutputReplay& out = res.outputs[size_t(o)];
    out.name = s.output_names[size_t(outs[size_t(o)])];
    out.theta = theta.col(o);
    out.talc = ResidualFigures(std::move(r_talc[size_t(o)]));
    if (!opt.baselines) continue;
    out.none = ResidualFigures(std::move(r_none[size_t(o)]));
    out.hold = ResidualFigures(std::move(r_hold[size_t(o)]));
    auto frozen = [&](const Eigen::MatrixXd& b) {
      std::vector<double> r;
      if (b.size() == 0) return r;
      for (size_t i = 0; i < n; ++i) {
        if (s.t_s[i] < cal_end) continue;
        const double yo = s.outputs_um(Eigen::Index(i), outs[size_t(o)]);
        if (std::isnan(yo)) continue;
        double v = b(0, o);
        for (size_t j = 0; j < temps.size(); ++j)
          v += b(Eigen::Index(j) + 1, o) *
               (s.inputs(Eigen::Index(i), temps[j]) - s.inputs(0, temps[j]));
        r.push_back(yo - v);
      }
      return r;
    };
    out.static_frozen = ResidualFigures(frozen(b_static));
    out.static_window = ResidualFigures(frozen(b_window));
    out.static_model = ResidualFigures(std::move(r_updated[size_t(o)]));
  }
  if (res.outputs.front().talc.samples == 0)
    res.status = ReplayStatus::kNoEvaluatedSamples;
  return res;
}

namespace {
nlohmann::json FiguresJson(const Figures& f) {
  return {{"rms_um", f.rms_um},
          {"p99_um", f.p99_um},
          {"ptv_um", f.ptv_um},
          {"samples", f.samples}};
}
}  // namespace

nlohmann::json ReplayToJson(const ReplayResult& r, const Strategy& s) {
  nlohmann::json j;
  j["status"] = r.status == ReplayStatus::kOk ? "ok" : "no evaluated samples";
  j["strategy"] = StrategyToJson(s);
  j["regressors"] = r.regressor_names;
  j["measurements"] = r.measurements;
  j["calibration_measurements"] = r.calibration_measurements;
  j["ng_phases"] = r.ng_phases;
  j["rank_at_start"] = r.rank_at_start;
  j["total_s"] = r.total_s;
  j["evaluated_from_s"] = r.evaluated_from_s;
  j["q_prod_percent"] = 100.0 * r.q_prod;
  j["measurement_times_s"] = r.measurement_times_s;
  j["static_window_s"] = {r.static_window_from_s, r.static_window_to_s};
  j["static_window_samples"] = r.static_window_samples;
  j["static_window_in_sample"] = r.static_window_in_sample;
  j["warnings"] = r.warnings;
  nlohmann::json outs = nlohmann::json::array();
  for (const auto& o : r.outputs) {
    outs.push_back(
        {{"name", o.name},
         {"talc", FiguresJson(o.talc)},
         {"none", FiguresJson(o.none)},
         {"hold", FiguresJson(o.hold)},
         {"static", FiguresJson(o.static_model)},
         {"static_frozen", FiguresJson(o.static_frozen)},
         {"static_window", FiguresJson(o.static_window)},
         {"theta", std::vector<double>(o.theta.data(),
                                       o.theta.data() + o.theta.size())}});
  }
  j["outputs"] = outs;
  return j;
}

std::string ReplayText(const ReplayResult& r, const Strategy& s) {
  std::string t = fmt::format(
      "TALC replay: {} measurements ({} in calibration, {} NG phases), "
      "Q_Prod {:.2f} %, evaluated from {:.1f} h over {:.1f} h\n",
      r.measurements, r.calibration_measurements, r.ng_phases, 100.0 * r.q_prod,
      r.evaluated_from_s / 3600.0, r.total_s / 3600.0);
  t += fmt::format("model: {} regressors, rank {} at the end of calibration\n",
                   r.regressor_names.size(), r.rank_at_start);
  t += fmt::format(
      "static: on all temperatures, updated at TALC's measurements like "
      "TALC; frozen: fitted on the calibration measurements only; window: "
      "fitted once on every sample in {:.0f}..{:.0f} s ({} samples{})\n",
      r.static_window_from_s, r.static_window_to_s, r.static_window_samples,
      r.static_window_in_sample
          ? ": it overlaps the evaluated span, in-sample, an optimistic bound"
          : "");
  t += fmt::format("{:<10} {:>20} {:>20} {:>20} {:>20} {:>20} {:>20}\n",
                   "rms/P99/PtV", "TALC", "none", "hold last", "static",
                   "static frozen", "static window");
  auto cell = [](const Figures& f) {
    return fmt::format("{:6.2f} {:6.2f} {:6.2f}", f.rms_um, f.p99_um, f.ptv_um);
  };
  for (const auto& o : r.outputs)
    t += fmt::format("{:<10} {:>20} {:>20} {:>20} {:>20} {:>20} {:>20}\n",
                     o.name, cell(o.talc), cell(o.none), cell(o.hold),
                     cell(o.static_model), cell(o.static_frozen),
                     cell(o.static_window));
  for (const auto& w : r.warnings) t += "warning: " + w + "\n";
  return t;
}

}  // namespace ttp::talc
