#include "ttp/models/compare.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"

namespace ttp::models {
namespace {

// The median sampling step; 1 s for a single row (a step to divide by).
double MedianStepOrOne(const TimeSeries& ts) {
  return ts.rows() < 2 ? 1.0 : MedianStepS(ts);
}

double Corr(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = std::min(a.size(), b.size());
  if (n < 3) return 0;
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) ma += a[i], mb += b[i];
  ma /= n, mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return saa > 0 && sbb > 0 ? sab / std::sqrt(saa * sbb) : 0;
}

TimeSeries WithoutInput(const TimeSeries& ts, const std::string& name) {
  TimeSeries out = ts;
  const int j = ts.InputIndex(name);
  if (j < 0) return out;
  out.input_names.erase(out.input_names.begin() + j);
  Eigen::MatrixXd in(ts.inputs.rows(), ts.inputs.cols() - 1);
  in << ts.inputs.leftCols(j), ts.inputs.rightCols(ts.inputs.cols() - j - 1);
  out.inputs = in;
  return out;
}

}  // namespace

double Percentile(std::vector<double> v, double x) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double n = static_cast<double>(v.size());
  // Thesis eq. 4.30-4.32: k = N X + 1/2 (1-based), clamped to [1, N].
  const double k = std::clamp(n * x + 0.5, 1.0, n);
  const size_t lo = static_cast<size_t>(std::floor(k)) - 1;
  const double frac = k - std::floor(k);
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + frac * (v[hi] - v[lo]);
}

ResidualStats ComputeStats(const Eigen::VectorXd& measured,
                           const Eigen::VectorXd& predicted,
                           double none_rms_um) {
  ResidualStats s;
  std::vector<double> abs_r;
  double sse = 0, lo = 1e300, hi = -1e300;
  for (Eigen::Index i = 0; i < measured.size(); ++i) {
    if (!std::isfinite(measured(i))) continue;
    const double r = measured(i) - predicted(i);
    sse += r * r;
    abs_r.push_back(std::abs(r));
    lo = std::min(lo, r);
    hi = std::max(hi, r);
  }
  s.n = static_cast<int>(abs_r.size());
  if (s.n == 0) return s;
  s.rms_um = std::sqrt(sse / s.n);
  s.p99_um = Percentile(abs_r, 0.99);
  s.pv_um = hi - lo;
  s.reduction_pct =
      none_rms_um > 0 ? 100.0 * (1.0 - s.rms_um / none_rms_um) : 0.0;
  return s;
}

const char* ErrorKindName(ErrorKind k) {
  switch (k) {
    case ErrorKind::kNone:
      return "none";
    case ErrorKind::kJump:
      return "sensor_jump";
    case ErrorKind::kLag:
      return "lag";
    case ErrorKind::kDrift:
      return "drift";
  }
  return "?";
}

Diagnosis Diagnose(const TimeSeries& ts, size_t first, int output,
                   const Eigen::VectorXd& predicted, const std::string& model) {
  Diagnosis d;
  d.model = model;
  std::vector<double> t, y, p, r;
  std::vector<size_t> rows;
  for (size_t i = first; i < ts.rows(); ++i) {
    const double m = ts.outputs_um(static_cast<Eigen::Index>(i), output);
    if (!std::isfinite(m)) continue;
    rows.push_back(i);
    t.push_back(ts.t_s[i]);
    y.push_back(m);
    p.push_back(predicted(static_cast<Eigen::Index>(i)));
    r.push_back(m - p.back());
  }
  if (rows.size() < 10) return d;
  double sse = 0;
  for (double v : r) sse += v * v;
  d.rms_um = std::sqrt(sse / r.size());
  // Leading temperature: the one most correlated with the measured output.
  double best = -1;
  int lead = -1;
  for (size_t j = 0; j < ts.input_names.size(); ++j) {
    if (ts.input_names[j].rfind("T_", 0) != 0) continue;
    std::vector<double> x;
    for (size_t i : rows)
      x.push_back(ts.inputs(static_cast<Eigen::Index>(i), j));
    const double c = std::abs(Corr(x, y));
    if (c > best) best = c, lead = static_cast<int>(j);
  }
  if (lead >= 0) {
    d.leading_input = ts.input_names[lead];
    double area = 0, tlo = 1e300, thi = -1e300, rlo = 1e300, rhi = -1e300;
    for (size_t k = 0; k < rows.size(); ++k) {
      const double temp = ts.inputs(static_cast<Eigen::Index>(rows[k]), lead);
      tlo = std::min(tlo, temp), thi = std::max(thi, temp);
      rlo = std::min(rlo, r[k]), rhi = std::max(rhi, r[k]);
      if (k > 0) {
        const double prev =
            ts.inputs(static_cast<Eigen::Index>(rows[k - 1]), lead);
        area += 0.5 * (r[k] + r[k - 1]) * (temp - prev);
      }
    }
    d.loop_area_um_k = std::abs(area);
    const double box = (thi - tlo) * (rhi - rlo);
    d.loop_ratio = box > 0 ? d.loop_area_um_k / box : 0;
  }
  // Lag: shift of the prediction that best matches the measurement.
  const double step = MedianStepOrOne(ts);
  const int max_shift =
      static_cast<int>(std::min(7200.0 / step, y.size() / 4.0));
  const int stride = std::max(1, static_cast<int>(60.0 / step));
  double best_c = -2;
  for (int s = -max_shift; s <= max_shift; s += stride) {
    std::vector<double> a, b;
    for (size_t k = 0; k < y.size(); ++k) {
      const long q = static_cast<long>(k) - s;
      if (q < 0 || q >= static_cast<long>(p.size())) continue;
      a.push_back(y[k]);
      b.push_back(p[q]);
    }
    const double c = Corr(a, b);
    if (c > best_c) best_c = c, d.lag_s = s * step;
  }
  // Drift: least-squares slope of the residual over time.
  double mt = 0, mr = 0;
  for (size_t k = 0; k < t.size(); ++k) mt += t[k], mr += r[k];
  mt /= t.size(), mr /= r.size();
  double stt = 0, str = 0;
  for (size_t k = 0; k < t.size(); ++k)
    stt += (t[k] - mt) * (t[k] - mt), str += (t[k] - mt) * (r[k] - mr);
  d.drift_um_per_h = stt > 0 ? str / stt * 3600.0 : 0;
  // Sensor jumps: a step of an input far outside its own step scatter.
  double worst = 0;
  for (size_t j = 0; j < ts.input_names.size(); ++j) {
    if (ts.input_names[j].rfind("T_", 0) != 0) continue;
    std::vector<double> diffs;
    for (size_t i = std::max<size_t>(1, first); i < ts.rows(); ++i)
      diffs.push_back(std::abs(ts.inputs(i, j) - ts.inputs(i - 1, j)));
    if (diffs.size() < 10) continue;
    const double mad = Percentile(diffs, 0.5);
    for (size_t k = 0; k < diffs.size(); ++k) {
      const double ratio = diffs[k] / std::max(mad, 1e-3);
      if (diffs[k] > 0.5 && ratio > 30 && ratio > worst) {
        worst = ratio;
        const size_t i = std::max<size_t>(1, first) + k;
        d.jump_input = ts.input_names[j];
        d.jump_t_s = ts.t_s[i];
        d.jump_size = ts.inputs(i, j) - ts.inputs(i - 1, j);
      }
    }
  }
  const double span_h = (t.back() - t.front()) / 3600.0;
  if (!d.jump_input.empty()) {
    d.kind = ErrorKind::kJump;
    d.problem = fmt::format("sensor jump: {} steps by {:+.2f} K at t = {:g} s",
                            d.jump_input, d.jump_size, d.jump_t_s);
  } else if (std::abs(d.lag_s) >= 600 || d.loop_ratio >= 0.1) {
    d.kind = ErrorKind::kLag;
    d.problem = fmt::format(
        "lag (pseudo-hysteresis): the measurement lags the prediction by "
        "{:+.0f} s; residual vs {} encloses {:.1f} um K ({:.0f}% of its box)",
        d.lag_s, d.leading_input, d.loop_area_um_k, 100 * d.loop_ratio);
  } else if (std::abs(d.drift_um_per_h) * span_h > d.rms_um) {
    d.kind = ErrorKind::kDrift;
    d.problem = fmt::format("slow drift of the residual: {:+.2f} um/h",
                            d.drift_um_per_h);
  } else {
    d.problem = fmt::format(
        "no dominant systematic error (lag {:+.0f} s, loop {:.0f}%, drift "
        "{:+.2f} um/h): the residual is mostly what the inputs do not carry",
        d.lag_s, 100 * d.loop_ratio, d.drift_um_per_h);
  }
  return d;
}

CompareResult CompareModels(const TimeSeries& log, double holdout_from_s,
                            const FitOptions& o) {
  TimeSeries ts = log;  // with the fitted span's sensor jumps shifted out
  CompareResult res;
  res.source = ts.source;
  res.holdout_from_s = holdout_from_s;
  res.outputs = ts.output_names;
  res.t_s = ts.t_s;
  while (res.first_holdout_row < ts.rows() &&
         ts.t_s[res.first_holdout_row] < holdout_from_s)
    ++res.first_holdout_row;
  const size_t first = res.first_holdout_row;
  if (first < 10 || ts.rows() - first < 10) {
    throw InputError(
        ts.source, 0, "--holdout-from",
        fmt::format("{:g} s leaves fewer than 10 rows on one side "
                    "(log spans {:g}..{:g} s)",
                    holdout_from_s, ts.t_s.front(), ts.t_s.back()));
  }
  if (ts.output_names.empty())
    throw InputError(ts.source, 0, "d_*", "the log has no output column");
  // An output is compared only where it is measured on both sides of the
  // split: fitted without values it has no model, judged without values
  // every model would score 0 um.
  std::vector<std::string> left_out;
  {
    std::vector<Eigen::Index> keep;
    const Eigen::Index f = static_cast<Eigen::Index>(first);
    for (Eigen::Index j = 0; j < ts.outputs_um.cols(); ++j) {
      const auto col = ts.outputs_um.col(j).array();
      const bool before = col.head(f).isFinite().any();
      const bool after = col.tail(col.size() - f).isFinite().any();
      if (before && after) {
        keep.push_back(j);
        continue;
      }
      left_out.push_back(fmt::format(
          "{} has no measured value {} --holdout-from {:g} s: left out of "
          "the comparison",
          ts.output_names[static_cast<size_t>(j)], before ? "after" : "before",
          holdout_from_s));
    }
    if (keep.empty())
      throw InputError(ts.source, 0, "--holdout-from",
                       fmt::format("no output is measured both before and "
                                   "after {:g} s: nothing to fit and judge",
                                   holdout_from_s));
    if (static_cast<Eigen::Index>(keep.size()) != ts.outputs_um.cols()) {
      Eigen::MatrixXd kept(ts.outputs_um.rows(),
                           static_cast<Eigen::Index>(keep.size()));
      std::vector<std::string> names;
      for (size_t k = 0; k < keep.size(); ++k) {
        kept.col(static_cast<Eigen::Index>(k)) = ts.outputs_um.col(keep[k]);
        names.push_back(ts.output_names[static_cast<size_t>(keep[k])]);
      }
      ts.outputs_um = std::move(kept);
      ts.output_names = std::move(names);
      res.outputs = ts.output_names;
    }
  }
  // As `thermal fit` on the fitted span: a sensor that jumps there is
  // shifted back from the jump on, in the holdout too.
  const SensorFaults faults =
      RepairSensorFaults(HeadOf(ts, holdout_from_s), o.repair_jumps, &ts);
  const TimeSeries fit = HeadOf(ts, holdout_from_s);
  const Eigen::Index n_rows = static_cast<Eigen::Index>(ts.rows());
  const int n_out = static_cast<int>(ts.output_names.size());
  const Eigen::Index nh = n_rows - static_cast<Eigen::Index>(first);
  res.measured_um = ts.outputs_um;
  res.best_um.resize(n_rows, n_out);
  res.simplest_um.resize(n_rows, n_out);
  res.leading_values.resize(n_rows, n_out);
  res.warnings = ts.warnings;
  res.warnings.insert(res.warnings.end(), faults.warnings.begin(),
                      faults.warnings.end());
  res.warnings.insert(res.warnings.end(), left_out.begin(), left_out.end());

  std::vector<std::string> names = {"none", "static_all_T", "lag_speed"};
  for (Structure s : AllStructures()) names.push_back(StructureName(s));
  names.push_back("select");
  names.push_back("auto");
  // The README's simple models fitted its way (ordinary least squares, no
  // ridge): the customer's bar, shown beside our ridge versions. Not
  // candidates for "best" (no extension is refitted for them).
  names.push_back("static_T_ols");
  names.push_back("lag_speed_ols");
  for (const auto& name : names) {
    CompareEntry e;
    e.name = name;
    e.kind = name == "none"                                    ? "baseline"
             : (name == "auto" || name == "select")            ? "auto"
             : (name == "static_all_T" || name == "lag_speed") ? "reference"
             : (name == "static_T_ols" || name == "lag_speed_ols")
                 ? "readme"
                 : "structure";
    res.entries.push_back(e);
  }
  for (int j = 0; j < n_out; ++j) {
    const Eigen::VectorXd meas = ts.outputs_um.col(j).tail(nh);
    double none_sq = 0;
    int none_n = 0;
    for (Eigen::Index i = 0; i < nh; ++i)
      if (std::isfinite(meas(i))) none_sq += meas(i) * meas(i), ++none_n;
    const double none_rms = none_n > 0 ? std::sqrt(none_sq / none_n) : 0;
    auto record = [&](size_t entry, const Eigen::VectorXd& pred,
                      const std::string& structure, int terms) {
      res.entries[entry].stats.push_back(
          ComputeStats(meas, pred.tail(nh), none_rms));
      res.entries[entry].structures.push_back(structure);
      res.entries[entry].terms.push_back(terms);
    };
    record(0, Eigen::VectorXd::Zero(n_rows), "none", 0);
    // The reference simple models: static on every temperature; lags of n
    // and n^2 with the time constant chosen by CV.
    std::vector<Regressor> all_t, lag_best;
    for (const auto& name : ts.input_names)
      if (name.rfind("T_", 0) == 0) all_t.push_back({name, 1, 0, {}});
    OutputModel ref_static;
    if (!all_t.empty()) {
      ref_static = FitFixed(fit, j, all_t, Structure::kStatic, o);
      record(1, PredictOutput(ref_static, ts), "static", int(all_t.size()));
    } else {
      record(1, Eigen::VectorXd::Zero(n_rows), "none", 0);
    }
    OutputModel lag_model;
    double lag_score = std::numeric_limits<double>::infinity();
    for (double tau : o.taus_s) {
      std::vector<Regressor> regs;
      for (const auto& name : ts.input_names)
        if (name.rfind("n_", 0) == 0) {
          regs.push_back({name, 1, 0, {tau}});
          regs.push_back({name, 2, 0, {tau}});
        }
      if (regs.empty()) break;
      OutputModel m = FitFixed(fit, j, regs, Structure::kLag, o);
      if (m.cv_score < lag_score) lag_score = m.cv_score, lag_model = m;
    }
    record(2,
           lag_model.regressors.empty() ? Eigen::VectorXd::Zero(n_rows)
                                        : PredictOutput(lag_model, ts),
           "lag", int(lag_model.regressors.size()));
    // Every structure, select (chosen per output by CV inside the fitted
    // span) and auto (joint with its default temperature lag).
    size_t entry = 3;
    for (Structure s : AllStructures()) {
      OutputModel m = FitOutput(fit, j, s, o);
      record(entry, PredictOutput(m, ts), StructureName(s),
             int(m.regressors.size()));
      ++entry;
    }
    {
      const OutputModel sm = FitAuto(fit, j, o);
      record(entry, PredictOutput(sm, ts), sm.label, int(sm.regressors.size()));
      res.select_candidates.push_back(sm.selection_log);
      ++entry;
      FitOptions ao = o;
      ao.model = "auto";
      const OutputModel am =
          FitThermalModel(fit, {fit.output_names[j]}, ao).outputs.front();
      record(entry, PredictOutput(am, ts), am.label, int(am.regressors.size()));
      ++entry;
    }
    {
      FitOptions ols = o;
      ols.ridge = {0};
      // Without a ridge, a chronological fold needs more measured values
      // before it than the model has parameters; with sparse outputs (one
      // every 30 min) the folds have fewer. The OLS fit of the whole
      // fitted span is still determined: then the lag's time constant is
      // chosen by the in-sample criterion (MDL) instead of the CV.
      auto fit_ols = [&](const std::vector<Regressor>& regs, Structure s) {
        try {
          return FitFixed(fit, j, regs, s, ols);
        } catch (const InputError&) {
          FitOptions in_sample = ols;
          in_sample.criterion = "mdl";
          return FitFixed(fit, j, regs, s, in_sample);
        }
      };
      if (!all_t.empty()) {
        const OutputModel m = fit_ols(all_t, Structure::kStatic);
        record(entry, PredictOutput(m, ts), "static", int(all_t.size()));
      } else {
        record(entry, Eigen::VectorXd::Zero(n_rows), "none", 0);
      }
      ++entry;
      // One time constant, chosen by the CV inside the fitted span.
      OutputModel best_lag;
      double score = std::numeric_limits<double>::infinity();
      for (double tau : o.taus_s) {
        const std::vector<Regressor> regs = SpeedLagRegressors(fit, {tau});
        if (regs.empty()) break;
        const OutputModel m = fit_ols(regs, Structure::kLag);
        if (m.cv_score < score) score = m.cv_score, best_lag = m;
      }
      record(entry,
             best_lag.regressors.empty() ? Eigen::VectorXd::Zero(n_rows)
                                         : PredictOutput(best_lag, ts),
             "lag", int(best_lag.regressors.size()));
    }
    // Best on this holdout (a diagnostic chosen after the fact, not a model
    // choice) and the simplest: the static model on every temperature.
    size_t best_entry = 1;
    for (size_t e = 1; e < res.entries.size(); ++e)
      if (res.entries[e].kind != "readme" &&
          res.entries[e].stats.back().rms_um <
              res.entries[best_entry].stats.back().rms_um)
        best_entry = e;
    const std::string best_name = res.entries[best_entry].name;
    const std::string simplest_name = "static_all_T";

    // Refits a named entry on `series` (the same holdout split) with
    // `opt`, optionally with extra regressors (a fixed set), and returns
    // its prediction at every row.
    auto refit = [&](const std::string& name, const TimeSeries& series,
                     const FitOptions& opt,
                     const std::vector<Regressor>& extra) -> Eigen::VectorXd {
      const TimeSeries head = HeadOf(series, holdout_from_s);
      OutputModel m;
      Structure s;
      if (name == "static_all_T") {
        std::vector<Regressor> regs = AllTemperatureRegressors(series);
        regs.insert(regs.end(), extra.begin(), extra.end());
        m = FitFixed(head, j, regs, Structure::kStatic, opt);
      } else if (name == "lag_speed") {
        std::vector<Regressor> regs = SpeedLagRegressors(series, opt.taus_s);
        regs.insert(regs.end(), extra.begin(), extra.end());
        m = FitFixed(head, j, regs, Structure::kLag, opt);
      } else if (name == "select") {
        m = FitAuto(head, j, opt);
      } else if (name == "auto") {
        FitOptions ao = opt;
        ao.model = "auto";
        m = FitThermalModel(head, {head.output_names[j]}, ao).outputs.front();
      } else if (ParseStructure(name, &s)) {
        m = FitOutput(head, j, s, opt);
      } else {
        return Eigen::VectorXd::Zero(static_cast<Eigen::Index>(series.rows()));
      }
      return PredictOutput(m, series);
    };
    auto entry_pred = [&](const std::string& name) {
      return refit(name, ts, o, {});
    };
    const Eigen::VectorXd best_pred = entry_pred(best_name);
    const Eigen::VectorXd static_pred = entry_pred(simplest_name);
    res.best.push_back(best_name);
    res.simplest.push_back(simplest_name);
    res.best_um.col(j) = best_pred;
    res.simplest_um.col(j) = static_pred;

    // What the best and the simplest get wrong, and the extension that
    // addresses that named error, refitted and measured on the holdout.
    auto diagnose = [&](const std::string& name, const Eigen::VectorXd& pred) {
      Diagnosis d = Diagnose(ts, first, j, pred, name);
      const bool is_static = name == "static_all_T" || name == "static";
      const double longest =
          *std::max_element(o.taus_s.begin(), o.taus_s.end());
      Eigen::VectorXd fixed;
      if (d.kind == ErrorKind::kJump) {
        d.extension = "leave out " + d.jump_input;
        fixed = refit(name, WithoutInput(ts, d.jump_input), o, {});
      } else if (d.kind == ErrorKind::kLag && is_static) {
        // The structure lags its sensors: each temperature also through a
        // first-order lag near the measured delay.
        double tau = o.taus_s.front();
        for (double t : o.taus_s)
          if (std::abs(std::log(t / std::max(std::abs(d.lag_s), 300.0))) <
              std::abs(std::log(tau / std::max(std::abs(d.lag_s), 300.0))))
            tau = t;
        // Two physical extensions for a model that reacts too early or
        // late: the structure lags its sensors (each temperature also
        // through a lag near the measured delay), or the heat source acts
        // before the sensors see it (lags of n and n^2). Chosen by the CV
        // score inside the fitted span, then measured on the holdout.
        std::vector<Regressor> lagged;
        for (const auto& r : AllTemperatureRegressors(ts))
          lagged.push_back({r.input, 1, 0, {tau}});
        const std::vector<Regressor> speed = SpeedLagRegressors(ts, o.taus_s);
        const TimeSeries head = HeadOf(ts, holdout_from_s);
        double score_t = std::numeric_limits<double>::infinity();
        double score_n = score_t;
        std::vector<Regressor> regs_t = AllTemperatureRegressors(ts);
        std::vector<Regressor> regs_n = regs_t;
        regs_t.insert(regs_t.end(), lagged.begin(), lagged.end());
        regs_n.insert(regs_n.end(), speed.begin(), speed.end());
        score_t = FitFixed(head, j, regs_t, Structure::kStatic, o).cv_score;
        if (!speed.empty())
          score_n = FitFixed(head, j, regs_n, Structure::kStatic, o).cv_score;
        if (score_t <= score_n) {
          d.extension = fmt::format(
              "each temperature also through a first-order lag of {:g} s "
              "(chosen over lags of n and n^2 by CV in the fitted span: "
              "{:.2f} vs {:.2f})",
              tau, score_t, score_n);
          fixed = refit("static_all_T", ts, o, lagged);
        } else {
          d.extension = fmt::format(
              "lags of n and n^2 at every time constant (chosen over "
              "temperature lags of {:g} s by CV in the fitted span: {:.2f} "
              "vs {:.2f})",
              tau, score_n, score_t);
          fixed = refit("static_all_T", ts, o, speed);
        }
      } else if (d.kind == ErrorKind::kLag) {
        FitOptions ext = o;
        if (d.lag_s > 0) {  // the measurement is slower than the model
          ext.taus_s.push_back(2 * longest);
          ext.taus_s.push_back(4 * longest);
          d.extension = fmt::format(
              "slower dynamics: time constants {:g} and {:g} s added",
              2 * longest, 4 * longest);
        } else {  // faster than the model
          const double shortest =
              *std::min_element(o.taus_s.begin(), o.taus_s.end());
          ext.taus_s.insert(ext.taus_s.begin(), shortest / 2);
          ext.taus_s.insert(ext.taus_s.begin(), shortest / 4);
          d.extension = fmt::format(
              "faster dynamics: time constants {:g} and {:g} s added",
              shortest / 4, shortest / 2);
        }
        fixed = refit(name, ts, ext, {});
      } else if (d.kind == ErrorKind::kDrift) {
        FitOptions ext = o;
        ext.taus_s.push_back(2 * longest);
        ext.taus_s.push_back(4 * longest);
        if (is_static) {
          std::vector<Regressor> slow =
              SpeedLagRegressors(ts, {2 * longest, 4 * longest});
          d.extension = fmt::format(
              "a slow state: lags of n and n^2 at {:g} and {:g} s added",
              2 * longest, 4 * longest);
          fixed = refit("static_all_T", ts, o, slow);
        } else {
          d.extension =
              fmt::format("a slow state: time constants {:g} and {:g} s added",
                          2 * longest, 4 * longest);
          fixed = refit(name, ts, ext, {});
        }
      }
      if (fixed.size() > 0) {
        d.extended_rms_um = ComputeStats(meas, fixed.tail(nh), none_rms).rms_um;
      } else {
        d.extension = "none indicated";
        d.extended_rms_um = d.rms_um;
      }
      return d;
    };
    res.best_diag.push_back(diagnose(best_name, best_pred));
    res.simplest_diag.push_back(diagnose(simplest_name, static_pred));
    const int lead = ts.InputIndex(res.best_diag.back().leading_input);
    res.leading_inputs.push_back(res.best_diag.back().leading_input);
    if (lead >= 0)
      res.leading_values.col(j) = ts.inputs.col(lead);
    else
      res.leading_values.col(j).setConstant(kNaN);
  }
  return res;
}

nlohmann::json CompareToJson(const CompareResult& r) {
  nlohmann::json j;
  j["log"] = r.source;
  j["holdout_from_s"] = r.holdout_from_s;
  j["outputs"] = r.outputs;
  nlohmann::json entries = nlohmann::json::array();
  nlohmann::json readme = nlohmann::json::array();
  for (const auto& e : r.entries) {
    nlohmann::json per = nlohmann::json::object();
    for (size_t k = 0; k < e.stats.size(); ++k) {
      const auto& s = e.stats[k];
      per[r.outputs[k]] = {
          {"rms_um", s.rms_um}, {"p99_um", s.p99_um},
          {"pv_um", s.pv_um},   {"reduction_pct", s.reduction_pct},
          {"n", s.n},           {"structure", e.structures[k]},
          {"terms", e.terms[k]}};
    }
    (e.kind == "readme" ? readme : entries)
        .push_back({{"model", e.name}, {"kind", e.kind}, {"outputs", per}});
  }
  j["models"] = entries;
  j["readme_models"] = readme;
  auto diag_json = [](const Diagnosis& d) {
    return nlohmann::json{{"model", d.model},
                          {"leading_input", d.leading_input},
                          {"loop_area_um_k", d.loop_area_um_k},
                          {"loop_ratio", d.loop_ratio},
                          {"lag_s", d.lag_s},
                          {"drift_um_per_h", d.drift_um_per_h},
                          {"jump_input", d.jump_input},
                          {"jump_t_s", d.jump_t_s},
                          {"problem", d.problem},
                          {"kind", ErrorKindName(d.kind)},
                          {"extension", d.extension},
                          {"rms_um", d.rms_um},
                          {"extended_rms_um", d.extended_rms_um},
                          {"gain_um", d.rms_um - d.extended_rms_um}};
  };
  nlohmann::json diag = nlohmann::json::object();
  for (size_t k = 0; k < r.outputs.size(); ++k) {
    diag[r.outputs[k]] = {{"best", diag_json(r.best_diag[k])},
                          {"simplest", diag_json(r.simplest_diag[k])}};
  }
  j["diagnosis"] = diag;
  nlohmann::json sel = nlohmann::json::object();
  for (size_t k = 0; k < r.select_candidates.size(); ++k)
    sel[r.outputs[k]] = r.select_candidates[k];
  j["select_candidates"] = sel;
  j["warnings"] = r.warnings;
  return j;
}

std::string CompareText(const CompareResult& r) {
  std::string s = fmt::format(
      "{}: fit on t_s < {:g} s, predicted {:g}..{:g} s from the inputs alone\n"
      "RMS of the residual (um), per output; P99 / peak-to-valley / reduction "
      "in --json\n",
      r.source, r.holdout_from_s, r.t_s[r.first_holdout_row], r.t_s.back());
  s += fmt::format("{:<14}", "model");
  for (const auto& o : r.outputs) s += fmt::format("{:>10}", o);
  s += "\n";
  for (const auto& e : r.entries) {
    s += fmt::format("{:<14}", e.name);
    for (const auto& st : e.stats) s += fmt::format("{:>10.2f}", st.rms_um);
    s += "\n";
  }
  for (const auto& e : r.entries)
    if (e.name == "select")
      for (size_t k = 0; k < e.structures.size(); ++k)
        s +=
            fmt::format("select {}: {} (chosen by CV inside the fitted span)\n",
                        r.outputs[k], e.structures[k]);
  for (size_t k = 0; k < r.outputs.size(); ++k) {
    for (const Diagnosis* d : {&r.best_diag[k], &r.simplest_diag[k]}) {
      const double gain = d->rms_um - d->extended_rms_um;
      s += fmt::format("{} {} ({}): {}\n", r.outputs[k],
                       d == &r.best_diag[k] ? "best" : "simplest", d->model,
                       d->problem);
      if (d->kind == ErrorKind::kNone)
        s += "    extension: none indicated\n";
      else
        s += fmt::format(
            "    extension: {} -> holdout RMS {:.2f} -> {:.2f} um ({})\n",
            d->extension, d->rms_um, d->extended_rms_um,
            gain > 0.005 * d->rms_um
                ? fmt::format("gain {:.2f} um", gain)
                : fmt::format("does not help: {:+.2f} um", -gain));
    }
  }
  for (const auto& w : r.warnings) s += "warning: " + w + "\n";
  return s;
}

}  // namespace ttp::models
