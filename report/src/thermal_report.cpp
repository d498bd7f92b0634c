#include "ttp/report/thermal_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/inspect/measurement.h"
#include "ttp/models/time_series.h"
#include "ttp/talc/replay.h"
#include "ttp/talc/strategy.h"

namespace ttp::report_assets {
extern const char* const kUplotJsPieces[];
extern const char* const kUplotCssPieces[];
}  // namespace ttp::report_assets

namespace ttp::report {
namespace {

using nlohmann::json;

std::string Joined(const char* const* pieces) {
  std::string out;
  for (; *pieces != nullptr; ++pieces) out += *pieces;
  return out;
}

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

json Finite(double v) { return std::isfinite(v) ? json(v) : json(); }

constexpr const char* kScript = R"js(
window.addEventListener("error", function(){ document.body.setAttribute("data-js-error", "1"); });
var D = JSON.parse(document.getElementById("data").textContent);
function width(div){ return Math.max(320, Math.min(div.clientWidth || 900, 1100)); }
D.outputs.forEach(function(o, k){
  var box = document.getElementById("out" + k);
  var a = document.createElement("div"); box.appendChild(a);
  new uPlot({ title: o.name + ": measured and predicted (um)", width: width(box), height: 260,
    scales: { x: { time: false } },
    axes: [{ label: "time (h)" }, { label: "um", size: 55 }],
    series: [{ label: "t (h)" },
      { label: "measured", stroke: "#0b4f8a", width: 1.5 },
      { label: "best: " + o.best, stroke: "#c2410c", width: 1.5 },
      { label: "simplest: static on all temperatures", stroke: "#7b8794", width: 1, dash: [4, 3] }],
    hooks: { draw: [function(u){
      var x = u.valToPos(D.holdout_from_h, "x", true), ctx = u.ctx;
      ctx.save(); ctx.strokeStyle = "#444"; ctx.setLineDash([3, 3]);
      ctx.beginPath(); ctx.moveTo(x, u.bbox.top); ctx.lineTo(x, u.bbox.top + u.bbox.height); ctx.stroke();
      ctx.restore(); }] }
  }, [D.t_h, o.measured, o.best_pred, o.simplest_pred], a);
  if (o.leading_input) {
    var b = document.createElement("div"); box.appendChild(b);
    var idx = o.leading.map(function(v, i){ return i; }).filter(function(i){ return D.t_h[i] >= D.holdout_from_h && o.leading[i] !== null; });
    idx.sort(function(p, q){ return o.leading[p] - o.leading[q]; });
    var xs = idx.map(function(i){ return o.leading[i]; });
    new uPlot({ title: o.name + ": residual on the holdout vs " + o.leading_input + " (loops = lag, pseudo-hysteresis)",
      width: width(box), height: 260, scales: { x: { time: false } },
      axes: [{ label: o.leading_input + " (degC)" }, { label: "residual (um)", size: 55 }],
      series: [{ label: o.leading_input },
        { label: "best", stroke: "#c2410c", width: 0, paths: function(){ return null; }, points: { show: true, size: 3, fill: "#c2410c" } },
        { label: "simplest", stroke: "#7b8794", width: 0, paths: function(){ return null; }, points: { show: true, size: 3, fill: "#7b8794" } }]
    }, [xs, idx.map(function(i){ return o.best_res[i]; }), idx.map(function(i){ return o.simplest_res[i]; })], b);
  }
});
if (D.replay && D.replay.outputs) {
  var R = D.replay, box = document.getElementById("replay_curve");
  var c = document.createElement("div"); box.appendChild(c);
  var colours = ["#0b4f8a", "#c2410c", "#15803d", "#7c3aed", "#b45309", "#0e7490", "#be123c"];
  var ser = [{ label: "interval (h)" }], cols = [R.curve.map(function(p){ return p.interval_s / 3600; })];
  R.output_names.forEach(function(name, k){
    ser.push({ label: name + " TALC", stroke: colours[k % colours.length], width: 1.5, points: { show: true, size: 5 } });
    cols.push(R.curve.map(function(p){ return p.outputs[name].talc_p99_um; }));
    ser.push({ label: name + " hold", stroke: colours[k % colours.length], width: 1, dash: [4, 3] });
    cols.push(R.curve.map(function(p){ return p.outputs[name].hold_p99_um; }));
  });
  new uPlot({ title: "P99 of |residual| against the measurement interval (um; dashed: the last measurement held)",
    width: width(box), height: 300, scales: { x: { time: false } },
    axes: [{ label: "interval (h)" }, { label: "P99 (um)", size: 55 }], series: ser }, cols, c);
  R.outputs.forEach(function(o, k){
    var b = document.getElementById("replay" + k), d = document.createElement("div"); b.appendChild(d);
    new uPlot({ title: o.name + ": measured, TALC's compensation and the last measurement held (um), every " + R.shown_interval_s / 3600 + " h",
      width: width(b), height: 260, scales: { x: { time: false } },
      axes: [{ label: "time (h)" }, { label: "um", size: 55 }],
      series: [{ label: "t (h)" },
        { label: "measured", stroke: "#0b4f8a", width: 1.5 },
        { label: "TALC", stroke: "#c2410c", width: 1.5 },
        { label: "hold", stroke: "#7b8794", width: 1, dash: [4, 3] },
        { label: "measurements", stroke: "#111", width: 0, paths: function(){ return null; }, points: { show: true, size: 5, fill: "#111" } }],
      hooks: { draw: [function(u){
        var x = u.valToPos(R.evaluated_from_h, "x", true), ctx = u.ctx;
        ctx.save(); ctx.strokeStyle = "#444"; ctx.setLineDash([3, 3]);
        ctx.beginPath(); ctx.moveTo(x, u.bbox.top); ctx.lineTo(x, u.bbox.top + u.bbox.height); ctx.stroke();
        ctx.restore(); }] }
    }, [R.t_h, o.measured, o.talc, o.hold, o.measurement], d);
  });
}
document.body.setAttribute("data-plots-done", "1");
)js";

// The replay the page shows (thesis chapter 6, docs/TALC.md): the default
// strategy (8.5 h of calibration, a measurement every 5 min, then a fixed
// interval), its P99 at intervals of 15 min to 4 h against holding the
// last measurement, and the compensation over time at one measurement per
// hour. A calibration that would leave less than a third of the log
// compensated is shortened to a third of the span (the page says so). A
// log the replay cannot run on (no output measured, say) gets the reason
// instead of the section.
json ReplayData(const models::TimeSeries& ts) {
  json out;
  const size_t n = ts.rows();
  if (n < 2 || ts.output_names.empty()) {
    out["unavailable"] = "the log has no output to replay";
    return out;
  }
  const double span_s = ts.t_s.back() - ts.t_s.front();
  talc::Strategy base;
  out["calibration_shortened"] = talc::FitDefaultCalibration(span_s, &base);
  constexpr double kShownIntervalS = 3600.0;
  try {
    json curve = json::array();
    // The shown interval's replay keeps its compensation at every sample
    // for the plots over time (its figures are the curve's point).
    talc::ReplayResult r;
    talc::Strategy shown = base;
    shown.interval_s = kShownIntervalS;
    for (double interval_s : {900.0, 1800.0, 3600.0, 7200.0, 14400.0}) {
      talc::Strategy s = base;
      s.interval_s = interval_s;
      talc::ReplayOptions options;
      options.keep_predictions = interval_s == kShownIntervalS;
      talc::ReplayResult point = talc::Replay(ts, s, options);
      if (options.keep_predictions) r = point;
      if (point.status != talc::ReplayStatus::kOk) continue;
      json per = json::object();
      for (const auto& o : point.outputs)
        per[o.name] = {{"talc_p99_um", Finite(o.talc.p99_um)},
                       {"talc_rms_um", Finite(o.talc.rms_um)},
                       {"hold_p99_um", Finite(o.hold.p99_um)},
                       {"static_p99_um", Finite(o.static_model.p99_um)},
                       {"none_p99_um", Finite(o.none.p99_um)}};
      curve.push_back({{"interval_s", interval_s},
                       {"measurements", point.measurements},
                       {"q_prod_percent", 100.0 * point.q_prod},
                       {"outputs", per}});
    }
    if (curve.empty() || r.status != talc::ReplayStatus::kOk) {
      out["unavailable"] =
          "no sample after the calibration phase has every output measured";
      return out;
    }
    // About 2000 rows per series, and every measurement's row.
    const size_t stride = std::max<size_t>(1, n / 2000);
    std::vector<char> measured_row(n, 0);
    {
      size_t i = 0;
      for (double tm : r.measurement_times_s) {
        while (i < n && ts.t_s[i] < tm) ++i;
        if (i < n && ts.t_s[i] == tm) measured_row[i] = 1;
      }
    }
    std::vector<size_t> rows;
    for (size_t i = 0; i < n; ++i)
      if (i % stride == 0 || measured_row[i]) rows.push_back(i);
    json t = json::array();
    for (size_t i : rows) t.push_back(ts.t_s[i] / 3600.0);
    json outs = json::array(), names = json::array();
    for (size_t k = 0; k < r.outputs.size(); ++k) {
      // The replay's outputs are the log's (Strategy::outputs empty).
      const int col = ts.OutputIndex(r.outputs[k].name);
      json m = json::array(), p = json::array(), h = json::array(),
           at = json::array();
      double held = std::numeric_limits<double>::quiet_NaN();
      size_t next = 0;
      for (size_t i : rows) {
        // The last measurement strictly before this sample (the
        // compensation at a sample is decided before its own measurement).
        for (; next < i; ++next)
          if (measured_row[next]) held = ts.outputs_um(Eigen::Index(next), col);
        const double y = ts.outputs_um(Eigen::Index(i), col);
        m.push_back(Finite(y));
        p.push_back(Finite(r.predictions_um(Eigen::Index(i), Eigen::Index(k))));
        h.push_back(Finite(held));
        at.push_back(measured_row[i] ? Finite(y) : json());
      }
      names.push_back(r.outputs[k].name);
      outs.push_back({{"name", r.outputs[k].name},
                      {"measured", m},
                      {"talc", p},
                      {"hold", h},
                      {"measurement", at}});
    }
    out["strategy"] = talc::StrategyToJson(shown);
    out["shown_interval_s"] = kShownIntervalS;
    out["evaluated_from_h"] = r.evaluated_from_s / 3600.0;
    out["curve"] = curve;
    out["output_names"] = names;
    out["t_h"] = t;
    out["outputs"] = outs;
  } catch (const InputError& e) {
    out = json{{"unavailable", e.what()}};
  }
  return out;
}

}  // namespace

bool LooksLikeThermalLog(const std::string& text) {
  return inspect::SniffLogFormat(text) == "thermal-log";
}

json ThermalReportData(const models::CompareResult& r) {
  json d = models::CompareToJson(r);
  // Every row up to ~2000 points per series: enough for the page, small file.
  const size_t n = r.t_s.size();
  const size_t stride = std::max<size_t>(1, n / 2000);
  std::vector<size_t> rows;
  for (size_t i = 0; i < n; i += stride) rows.push_back(i);
  json t = json::array();
  for (size_t i : rows) t.push_back(r.t_s[i] / 3600.0);
  d["t_h"] = t;
  d["holdout_from_h"] = r.holdout_from_s / 3600.0;
  json outs = json::array();
  for (size_t k = 0; k < r.outputs.size(); ++k) {
    const Eigen::Index c = static_cast<Eigen::Index>(k);
    json m = json::array(), b = json::array(), s = json::array(),
         br = json::array(), sr = json::array(), lead = json::array();
    for (size_t i : rows) {
      const Eigen::Index ii = static_cast<Eigen::Index>(i);
      const double y = r.measured_um(ii, c);
      m.push_back(Finite(y));
      b.push_back(Finite(r.best_um(ii, c)));
      s.push_back(Finite(r.simplest_um(ii, c)));
      br.push_back(Finite(y - r.best_um(ii, c)));
      sr.push_back(Finite(y - r.simplest_um(ii, c)));
      lead.push_back(Finite(r.leading_values(ii, c)));
    }
    outs.push_back({{"name", r.outputs[k]},
                    {"best", r.best[k]},
                    {"leading_input", r.leading_inputs[k]},
                    {"measured", m},
                    {"best_pred", b},
                    {"simplest_pred", s},
                    {"best_res", br},
                    {"simplest_res", sr},
                    {"leading", lead}});
  }
  d["outputs"] = outs;
  d["output_names"] = r.outputs;
  return d;
}

std::string ThermalReportHtml(const json& data, const std::string& title) {
  std::string table = "<table><tr><th>model</th>";
  const auto& names = data.at("output_names");
  for (const auto& o : names)
    table += "<th>" + Escape(o.get<std::string>()) + "</th>";
  table += "</tr>\n";
  for (const auto& m : data.at("models")) {
    table += "<tr><td>" + Escape(m.at("model").get<std::string>()) + "</td>";
    for (const auto& o : names) {
      const auto& e = m.at("outputs").at(o.get<std::string>());
      table += fmt::format(
          "<td title=\"P99 {:.2f} um, peak-to-valley {:.2f} um, reduction "
          "{:.0f}%, {}\">{:.2f}</td>",
          e.at("p99_um").get<double>(), e.at("pv_um").get<double>(),
          e.at("reduction_pct").get<double>(),
          Escape(e.at("structure").get<std::string>()),
          e.at("rms_um").get<double>());
    }
    table += "</tr>\n";
  }
  table += "</table>\n";
  std::string diag = "<ul>";
  for (const auto& o : names) {
    const auto& dj = data.at("diagnosis").at(o.get<std::string>());
    for (const char* which : {"best", "simplest"}) {
      const auto& d = dj.at(which);
      const double before = d.at("rms_um").get<double>();
      const double after = d.at("extended_rms_um").get<double>();
      const bool none = d.value("kind", "") == "none";
      diag += fmt::format(
          "<li><b>{} {} ({})</b>: {}. {}</li>\n", Escape(o.get<std::string>()),
          which, Escape(d.at("model").get<std::string>()),
          Escape(d.at("problem").get<std::string>()),
          none
              ? std::string("No extension indicated.")
              : fmt::format(
                    "Extension: {} &rarr; holdout RMS {:.2f} &rarr; {:.2f} "
                    "um ({}).",
                    Escape(d.at("extension").get<std::string>()), before, after,
                    before - after > 0.005 * before
                        ? fmt::format("gain {:.2f} um", before - after)
                        : std::string("does not help")));
    }
  }
  diag += "</ul>";
  std::string plots;
  for (size_t k = 0; k < names.size(); ++k)
    plots += fmt::format("<div class=\"out\" id=\"out{}\"></div>\n", k);
  std::string replay;
  if (data.contains("replay")) {
    const json& rp = data.at("replay");
    replay = "<h2>TALC replayed (thesis chapter 6)</h2>\n";
    if (rp.contains("unavailable")) {
      replay +=
          "<p>No replay: " + Escape(rp.at("unavailable").get<std::string>()) +
          ".</p>\n";
    } else {
      const json& st = rp.at("strategy");
      replay += fmt::format(
          "<p>The outputs measured only at the strategy's times, the model "
          "(speed lags and temperatures) updated by recursive least squares "
          "at each, its prediction the compensation (<code>ttp talc "
          "replay</code>, docs/TALC.md). Calibration: {:g} h, a measurement "
          "every {:g} min{}; then a fixed interval. P99 of |residual| (um) "
          "from the end of calibration ({:.2f} h), TALC / the last "
          "measurement held; Q_Prod: the share of time not spent "
          "measuring.</p>\n",
          st.at("calibration_s").get<double>() / 3600.0,
          st.at("calibration_interval_s").get<double>() / 60.0,
          rp.at("calibration_shortened").get<bool>()
              ? " (shortened to a third of the log)"
              : "",
          rp.at("evaluated_from_h").get<double>());
      replay +=
          "<table><tr><th>interval</th><th>measurements</th>"
          "<th>Q_Prod</th>";
      for (const auto& o : rp.at("output_names"))
        replay += "<th>" + Escape(o.get<std::string>()) + "</th>";
      replay += "</tr>\n";
      auto cell = [](const json& v) {
        return v.is_number() ? fmt::format("{:.2f}", v.get<double>())
                             : std::string("-");
      };
      for (const auto& p : rp.at("curve")) {
        replay +=
            fmt::format("<tr><td>{:g} min</td><td>{}</td><td>{:.1f} %</td>",
                        p.at("interval_s").get<double>() / 60.0,
                        p.at("measurements").get<int>(),
                        p.at("q_prod_percent").get<double>());
        for (const auto& o : rp.at("output_names")) {
          const json& e = p.at("outputs").at(o.get<std::string>());
          replay += "<td>" + cell(e.at("talc_p99_um")) + " / " +
                    cell(e.at("hold_p99_um")) + "</td>";
        }
        replay += "</tr>\n";
      }
      replay += "</table>\n<div class=\"out\" id=\"replay_curve\"></div>\n";
      for (size_t k = 0; k < rp.at("outputs").size(); ++k)
        replay += fmt::format("<div class=\"out\" id=\"replay{}\"></div>\n", k);
    }
  }
  // What the log's reading and the fitted span's sensor faults gave.
  std::string warnings;
  if (data.contains("warnings"))
    for (const auto& w : data.at("warnings"))
      warnings += "<li>" + Escape(w.get<std::string>()) + "</li>\n";
  if (!warnings.empty())
    warnings =
        "<p>Warnings:</p>\n<ul class=\"warnings\">\n" + warnings + "</ul>\n";
  std::string payload = JsonText(data);
  // Keep "</script>" out of the embedded JSON.
  for (size_t p = 0; (p = payload.find("</", p)) != std::string::npos; p += 3)
    payload.replace(p, 2, "<\\/");
  return "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" +
         Escape(title) + "</title>\n<style>" +
         Joined(report_assets::kUplotCssPieces) +
         "\nbody{font-family:system-ui,sans-serif;margin:24px;max-width:1150px}"
         "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:"
         "3px 8px;text-align:right}td:first-child{text-align:left}.out{margin:"
         "18px 0}</style></head><body>\n<h1>" +
         Escape(title) + "</h1>\n" +
         fmt::format(
             "<p>{}: fit on t_s &lt; {:g} s, predicted from the "
             "inputs alone after it. RMS of the residual (um); hover "
             "a cell for P99, peak-to-valley and the reduction.</p>\n",
             Escape(data.at("log").get<std::string>()),
             data.at("holdout_from_s").get<double>()) +
         warnings + table +
         "<h2>What the best and the simplest get wrong</h2>\n" + diag +
         "<h2>Per output</h2>\n" + plots + replay +
         "<script type=\"application/json\" id=\"data\">" + payload +
         "</script>\n<script>" + Joined(report_assets::kUplotJsPieces) +
         "\n</script>\n<script>" + kScript +
         "</script>\n<footer>ttp thermal report. Plots: uPlot (MIT).</footer>"
         "</body></html>\n";
}

json WriteThermalReport(const std::string& log_path,
                        const std::string& html_out,
                        const std::string& json_out) {
  const models::TimeSeries ts = models::ReadThermalLog(log_path);
  const double from =
      ts.t_s.front() + (ts.t_s.back() - ts.t_s.front()) * 2.0 / 3.0;
  models::CompareResult r;
  try {
    r = models::CompareModels(ts, from, models::FitOptions());
  } catch (const InputError& e) {
    // The page holds out its last third itself: say so, not an option the
    // user did not give.
    if (e.field() != "--holdout-from") throw;
    throw InputError(e.source(), e.line(), "holdout",
                     fmt::format("the page fits the first two thirds of the "
                                 "log and judges the last (from t_s {:g}): {}",
                                 from, e.problem()));
  }
  json data = ThermalReportData(r);
  data["replay"] = ReplayData(ts);
  OutputBatch outputs;  // the page and its data, or neither
  outputs.Add(html_out,
              ThermalReportHtml(data, "Thermal error models: " + log_path));
  if (!json_out.empty()) outputs.Add(json_out, JsonText(data, 1) + "\n");
  outputs.Commit();
  return data;
}

}  // namespace ttp::report
