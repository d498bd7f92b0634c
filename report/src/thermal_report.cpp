#include "ttp/report/thermal_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "ttp/geometry/file_io.h"
#include "ttp/models/time_series.h"

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
)js";

}  // namespace

bool LooksLikeThermalLog(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    if (line.empty() || line[0] != '#') return false;
    if (line.find("thermal-log:") != std::string::npos) return true;
  }
  return false;
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
  std::string payload = data.dump();
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
         table + "<h2>What the best and the simplest get wrong</h2>\n" + diag +
         "<h2>Per output</h2>\n" + plots +
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
  const models::CompareResult r =
      models::CompareModels(ts, from, models::FitOptions());
  const json data = ThermalReportData(r);
  WriteFileAtomic(html_out,
                  ThermalReportHtml(data, "Thermal error models: " + log_path));
  if (!json_out.empty()) WriteFileAtomic(json_out, data.dump(1) + "\n");
  return data;
}

}  // namespace ttp::report
