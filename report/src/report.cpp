// Renders the report HTML. Tables, the verdict and the piece drawing are
// built here in C++; the plots are drawn in the page by uPlot from the data
// embedded as JSON. uPlot was chosen over Chart.js: ~50 kB minified, no
// dependencies, canvas-based and fast for a day of 1-row-a-minute logs, and
// actively maintained (github.com/leeoniya/uPlot).
#include "ttp/report/report.h"

#include <fmt/format.h>

#include <cmath>
#include <map>
#include <string>

#include "piece_drawing.h"
#include "report_schema.h"
#include "ttp/geometry/features.h"
#include "ttp/inspect/grade.h"

namespace ttp::report_assets {
extern const char* const kUplotJsPieces[];
extern const char* const kUplotCssPieces[];
}  // namespace ttp::report_assets

namespace ttp {
namespace {

using nlohmann::json;
using report_internal::kFigureKeys;

std::string Joined(const char* const* pieces) {
  std::string out;
  for (; *pieces != nullptr; ++pieces) out += *pieces;
  return out;
}

std::string Escape(const std::string& text) {
  std::string out;
  for (char ch : text) {
    switch (ch) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += ch;
    }
  }
  return out;
}

// JSON inside <script>: "</" would end the element, so escape the slash.
std::string ScriptSafeJson(const json& doc) {
  std::string text = doc.dump();
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '<') {
      out += "\\u003c";
    } else {
      out += text[i];
    }
  }
  return out;
}

std::string NotAvailable(const std::string& what) {
  return "<p class=\"na\">Not available: " + Escape(what) + "</p>\n";
}

const char* FigureUnit(const std::string& key) {
  return key == "E_B" ? "um/m" : "um";
}

std::string Num(double v, int decimals = 2) {
  return fmt::format("{:.{}f}", v, decimals);
}

// The section's input sub-document, or null when absent.
const json* Find(const json& doc, const char* key) {
  auto it = doc.find(key);
  return it == doc.end() ? nullptr : &*it;
}

struct Limits {
  double linear_um = 5.0;
  double angular_um_per_m = 15.0;
  double For(const std::string& key) const {
    return key == "E_B" ? angular_um_per_m : linear_um;
  }
};

std::string PieceSection(const json& data, const PartSpec& part) {
  std::string html =
      "<section id=\"piece\"><h2>1. The piece and where each figure comes "
      "from</h2>\n<div class=\"two\"><div>" +
      report_internal::PieceSvg(part) + "</div><div>\n";
  html += fmt::format(
      "<p>Disc of {} ({} mm x {} mm blank, top face at z = 0, piece {} mm "
      "high). Four segments X1, Y1, X2, Y2 carry {} facets each (normal "
      "steps of {} deg, finished at {} mm from the axis); {} strips Z1..Z{} "
      "lie on the floor of the big notch (pitch {} mm, {} mm wide). Facet "
      "and strip {} are cut in the reference cycle 0; each test cycle i = "
      "1..{} then cuts one facet in every segment and one strip.</p>\n",
      Escape(part.material), part.blank_diameter_mm, part.blank_height_mm,
      part.height_mm(), part.facets_per_segment, part.facet_step_deg,
      part.facet_final_distance_mm, part.facets_per_segment,
      part.facets_per_segment, part.strip_pitch_mm, part.strip_width_mm,
      part.reference_index, part.cycles());
  html +=
      "<table class=\"def\"><tr><th>figure</th><th>from</th><th>unit</th></tr>"
      "<tr><td>E_X</td><td>[(dX2(i) - dX2(0)) - (dX1(i) - dX1(0))] / 2</td>"
      "<td>um</td></tr>"
      "<tr><td>E_Y</td><td>[(dY2(i) - dY2(0)) - (dY1(i) - dY1(0))] / 2</td>"
      "<td>um</td></tr>"
      "<tr><td>E_Z</td><td>dZ(i) - dZ(0), strip depth</td><td>um</td></tr>"
      "<tr><td>E_B</td><td>beta(i) - beta(0), strip slope along X</td>"
      "<td>um/m</td></tr>"
      "<tr><td>E_TTP</td><td>-[(lX(i) - lX(0)) + (lY(i) - lY(0))] / 4, "
      "radial growth</td><td>um</td></tr></table>\n"
      "<p class=\"note\">d: facet plane distance to the axis (strips: depth "
      "below the top face); lX = dX1 + dX2, lY = dY1 + dY2 "
      "(test-piece.md section 4).</p>\n<div class=\"legend\">";
  for (int cycle = 0; cycle <= part.cycles(); ++cycle) {
    const int index = IndexForCycle(part, cycle);
    html += fmt::format(
        "<span><i style=\"background:{}\"></i>cycle {}{}: facets -{} , "
        "Z{}</span>",
        report_internal::CycleColour(cycle), cycle,
        cycle == 0 ? " (reference)" : "", index, index);
  }
  html += "</div></div></div>\n";
  if (const json* facets = Find(data, "facets")) {
    html +=
        "<details><summary>Per-facet results</summary><table class=\"num\">"
        "<tr><th>facet</th><th>distance (mm)</th>"
        "<th>normal angle error (urad)</th></tr>";
    for (const auto& [id, facet] : facets->items()) {
      auto cell = [&](const char* key, int decimals) {
        return facet.contains(key) && !facet[key].is_null()
                   ? Num(facet[key].get<double>(), decimals)
                   : std::string("-");
      };
      html += "<tr><td>" + Escape(id) + "</td><td>" + cell("distance_mm", 4) +
              "</td><td>" + cell("angle_error_urad", 1) + "</td></tr>";
    }
    html += "</table></details>\n";
  }
  return html + "</section>\n";
}

std::string FiguresSection(const json& data, const Limits& limits) {
  std::string html =
      "<section id=\"figures\"><h2>2. Thermal figures per cycle</h2>\n";
  const json* figures = Find(data, "figures");
  if (figures == nullptr ||
      (!figures->contains("measured") && !figures->contains("simulated"))) {
    return html + NotAvailable("no measured or simulated figures") +
           "</section>\n";
  }
  if (!figures->contains("measured")) html += NotAvailable("measured figures");
  if (!figures->contains("simulated")) {
    html += NotAvailable("simulated figures");
  }
  html += fmt::format(
      "<p>Measured (points, bars: expanded uncertainty U, k = 2) and "
      "simulated (line) figures; the red dashed lines are the limits "
      "(+-{} um, E_B +-{} um/m). The simulation takes the machine's errors "
      "at each cut time from the R-tests through a dynamic model driven by "
      "the log; the grey dotted line, where given, takes them from a "
      "straight line between the R-tests around the cut instead.</p>\n"
      "<div class=\"grid\">",
      limits.linear_um, limits.angular_um_per_m);
  for (const auto& key : kFigureKeys) {
    html += "<div class=\"plot\" id=\"plot-" + key + "\" data-plot=\"" + key +
            "\"></div>";
  }
  return html + "</div></section>\n";
}

std::string VerdictSection(const json& data, const Limits& limits) {
  const json* grade = Find(data, "grade");
  std::string html =
      "<section id=\"verdict\"><h2>3. Verdict</h2>\n<p class=\"rule\">Decision "
      "rule ISO 14253-1: conformance is proven when |E| &le; limit - U (the "
      "conformance zone reduced by the expanded uncertainty U, k = 2), "
      "non-conformance when |E| &gt; limit + U; in between the result is "
      "undecidable. A figure passes when every cycle passes; a missing value "
      "leaves conformance unproven.</p>\n";
  const json* figures = Find(data, "figures");
  if (figures == nullptr || !figures->contains("measured") ||
      (*figures)["measured"].empty()) {
    return html + NotAvailable("no measured figures to grade") + "</section>\n";
  }
  std::map<int, const json*> by_cycle;
  for (const json& entry : (*figures)["measured"]) {
    by_cycle[entry["cycle"].get<int>()] = &entry;
  }
  std::string table = "<table class=\"verdict\"><tr><th>figure</th>";
  for (const auto& [cycle, entry] : by_cycle) {
    table += fmt::format("<th>cycle {}</th>", cycle);
  }
  table += "<th>limit</th><th>figure</th></tr>\n";
  int fails = 0, undecidable = 0, missing = 0;
  for (const auto& key : kFigureKeys) {
    const double limit = limits.For(key);
    table += "<tr><th>" + key + "</th>";
    int key_fails = 0, key_undecidable = 0, key_missing = 0;
    for (const auto& [cycle, entry] : by_cycle) {
      if ((*entry)[key].is_null()) {
        table += "<td class=\"missing\">missing</td>";
        ++key_missing;
        continue;
      }
      const double value = (*entry)[key].get<double>();
      const double u = (*entry)["U"][key].get<double>();
      // The rule of `ttp grade` (inspect::Decide).
      const inspect::Verdict d = inspect::Decide(value, u, limit);
      key_fails += d == inspect::Verdict::kFail;
      key_undecidable += d == inspect::Verdict::kUndecidable;
      table += fmt::format("<td class=\"{}\">{} &plusmn; {}</td>",
                           inspect::VerdictName(d), Num(value), Num(u));
    }
    const char* key_result = key_fails         ? "fail"
                             : key_undecidable ? "undecidable"
                             : key_missing     ? "missing"
                                               : "pass";
    fails += key_fails;
    undecidable += key_undecidable;
    missing += key_missing;
    table +=
        fmt::format("<td>&plusmn;{} {}</td><td class=\"{}\">{}</td></tr>\n",
                    limit, FigureUnit(key), key_result, key_result);
  }
  table += "</table>\n";
  // Same rule as `ttp grade`: any fail fails; pass only if every value
  // passes; otherwise (undecidable or missing values) undecidable.
  std::string overall = fails                    ? "fail"
                        : undecidable || missing ? "undecidable"
                                                 : "pass";
  if (grade != nullptr) overall = (*grade)["verdict"].get<std::string>();
  const std::string text =
      overall == "fail"   ? "FAIL - non-conformance proven"
      : overall == "pass" ? "PASS - conformance proven"
                          : "UNDECIDABLE - conformance not proven (within "
                            "the uncertainty at a limit, or values missing)";
  html += fmt::format(
      "<div class=\"stamp {}\" id=\"overall-verdict\" "
      "data-verdict=\"{}\">{}</div>\n",
      overall, overall, text);
  html += fmt::format(
      "<p class=\"note\">{} value(s) fail, {} undecidable, {} missing{}.</p>\n",
      fails, undecidable, missing,
      grade != nullptr ? "; overall verdict from the grading (ttp grade)" : "");
  return html + table + "</section>\n";
}

std::string LogSection(const json& data, const PartSpec& part) {
  std::string html =
      "<section id=\"log\"><h2>4. The machine over the test (TALC "
      "log)</h2>\n";
  const json* log = Find(data, "log");
  if (log == nullptr)
    return html + NotAvailable("no TALC log") + "</section>\n";
  if (log->contains("start")) {
    html += "<p>Log start: " + Escape((*log)["start"].get<std::string>()) +
            ". Vertical lines mark the cut times, coloured by cycle.</p>\n";
  }
  html += "<div class=\"grid\">";
  if (log->contains("samples")) {
    html +=
        "<div class=\"plot wide\" id=\"plot-temperatures\" "
        "data-plot=\"temperatures\"></div>"
        "<div class=\"plot wide\" id=\"plot-c-speed\" "
        "data-plot=\"c-speed\"></div>";
  } else {
    html += NotAvailable("temperature and C-speed samples");
  }
  if (log->contains("rtests")) {
    html +=
        "<div class=\"plot wide\" id=\"plot-rtest-linear\" "
        "data-plot=\"rtest-linear\"></div>"
        "<div class=\"plot wide\" id=\"plot-rtest-angular\" "
        "data-plot=\"rtest-angular\"></div>";
  } else {
    html += NotAvailable("R-test results");
  }
  html += "</div>\n";
  if (!log->contains("cuts") || (*log)["cuts"].empty()) {
    return html + NotAvailable("cut times") + "</section>\n";
  }
  // Cut times grouped by the cycle their feature belongs to.
  std::map<int, std::pair<double, double>> span;
  std::map<int, std::string> names;
  for (const json& cut : (*log)["cuts"]) {
    FeatureKind kind;
    Segment segment;
    int index = 0;
    ParseFeatureId(cut["feature"].get<std::string>(), &kind, &segment, &index);
    const int cycle = CycleForIndex(part, index);
    const double t_h = cut["t_s"].get<double>() / 3600.0;
    auto [it, fresh] = span.emplace(cycle, std::make_pair(t_h, t_h));
    it->second.first = std::min(it->second.first, t_h);
    it->second.second = std::max(it->second.second, t_h);
    names[cycle] += (names[cycle].empty() ? "" : " ") +
                    Escape(cut["feature"].get<std::string>());
  }
  html +=
      "<table class=\"num cuts\"><tr><th>cycle</th><th>first cut (h)</th>"
      "<th>last cut (h)</th><th>features</th></tr>";
  for (const auto& [cycle, range] : span) {
    html += fmt::format(
        "<tr><td><i class=\"dot\" style=\"background:{}\"></i>{}</td>"
        "<td>{}</td><td>{}</td><td class=\"l\">{}</td></tr>",
        report_internal::CycleColour(cycle),
        cycle < 0 ? std::string("?") : std::to_string(cycle),
        Num(range.first, 3), Num(range.second, 3), names[cycle]);
  }
  return html + "</table>\n</section>\n";
}

// Unit of a parameter from the suffix of its name (tau_wp_s -> s).
std::string ParamUnit(const std::string& name) {
  for (const char* suffix : {"_um_per_m", "_um_per_K", "_um", "_urad", "_mm",
                             "_s", "_K", "_deg", "_rad", "_pct"}) {
    const std::string s = suffix;
    if (name.size() > s.size() &&
        name.compare(name.size() - s.size(), s.size(), s) == 0) {
      return s.substr(1);
    }
  }
  return "1 (dimensionless)";
}

std::string DiagnosisSection(const json& data) {
  std::string html =
      "<section id=\"diagnosis\"><h2>5. Diagnosis: what the simulation gets "
      "wrong</h2>\n";
  const json* d = Find(data, "diagnosis");
  if (d == nullptr) return html + NotAvailable("no diagnosis") + "</section>\n";
  const std::string cause = d->value("cause", std::string("refused"));
  const json& base = (*d)["baseline"];
  const json& ext = (*d)["extended"];
  auto urad = [](const json& j) {
    return j.contains("rms_urad")
               ? fmt::format("<small>facet angles {} urad</small>",
                             Num(j["rms_urad"].get<double>()))
               : std::string();
  };
  html += fmt::format(
      "<div class=\"cards\"><div class=\"card\"><b>cause</b><span "
      "id=\"cause\">{}</span></div><div class=\"card\"><b>residual RMS, "
      "nominal model</b><span>{} um</span>{}</div><div class=\"card\"><b>"
      "residual RMS, extended model</b><span>{} um</span>{}</div><div "
      "class=\"card\"><b>gain (held-out cycles)</b><span>{} %</span></div>"
      "</div>\n",
      Escape(cause), Num(base["rms_um"].get<double>()), urad(base),
      Num(ext["rms_um"].get<double>()), urad(ext),
      Num((*d)["gain_pct"].get<double>(), 1));
  if (d->contains("summary")) {
    html += "<p id=\"diagnosis-summary\">" +
            Escape((*d)["summary"].get<std::string>()) + "</p>\n";
  }
  if (d->contains("gain") && (*d)["gain"].contains("method")) {
    html += "<p class=\"note\">Gain: " +
            Escape((*d)["gain"]["method"].get<std::string>()) + ".</p>\n";
  }
  html += "<h3>Fitted parameters</h3>\n";
  if (!ext.contains("params") || ext["params"].empty()) {
    html += cause == "none"
                ? "<p>None: the nominal model explains the data within "
                  "noise.</p>\n"
                : NotAvailable("fitted parameters");
  } else {
    html +=
        "<table class=\"num\" id=\"params\"><tr><th>parameter</th><th>value"
        "</th><th>standard uncertainty</th><th>unit</th></tr>";
    for (const auto& [name, value] : ext["params"].items()) {
      std::string u = "-";
      if (ext.contains("uncertainty") && ext["uncertainty"].contains(name)) {
        u = fmt::format("{:.3g}", ext["uncertainty"][name].get<double>());
      }
      html += fmt::format(
          "<tr><td class=\"l\">{}</td><td>{:.4g}</td><td>{}</td><td>{}</td>"
          "</tr>",
          Escape(name), value.get<double>(), u, Escape(ParamUnit(name)));
    }
    html += "</table>\n";
  }
  if (d->contains("residuals")) {
    html +=
        "<h3>Residuals per cycle: measured - simulated</h3>\n<p "
        "class=\"note\">Before: the nominal model (rigid table driven by the "
        "log). After: minus the fitted effect of the named cause (the "
        "per-figure constant offsets of the fit are not removed). Bars: "
        "standard uncertainty of the residual (measurement and machine-error "
        "estimate).</p>\n<div class=\"grid\"><div class=\"plot\" "
        "id=\"plot-residual-before\" data-plot=\"residual-before\"></div><div "
        "class=\"plot\" id=\"plot-residual-after\" "
        "data-plot=\"residual-after\"></div></div>\n";
  }
  html += "<h3>Evidence per candidate cause</h3>\n";
  const json& candidates = (*d)["candidates"];
  if (candidates.empty()) {
    return html + NotAvailable("candidates") + "</section>\n";
  }
  double most = 0;
  for (const json& c : candidates) {
    most = std::max(most, -c["delta_bic"].get<double>());
  }
  if (d->contains("evidence")) {
    html +=
        "<p class=\"note\">" + Escape((*d)["evidence"].get<std::string>()) +
        (d->contains("threshold") ? fmt::format(" (threshold {:g}).",
                                                (*d)["threshold"].get<double>())
                                  : std::string(".")) +
        " Bar: evidence against the nominal model (-delta BIC; longer is "
        "stronger).</p>";
  }
  html +=
      "<table class=\"num cand\" id=\"candidates\"><tr><th>cause</th><th>"
      "delta BIC</th><th>evidence</th><th>parameters</th><th>residual RMS "
      "(um)</th><th>angles (urad)</th><th>fitted values</th></tr>";
  for (const json& c : candidates) {
    const double delta = c["delta_bic"].get<double>();
    const double frac = most > 0 ? std::max(0.0, -delta) / most : 0.0;
    const bool chosen = c["cause"].get<std::string>() == cause;
    std::string values;
    if (c.contains("params")) {
      for (const auto& [name, p] : c["params"].items()) {
        values += (values.empty() ? "" : ", ") + Escape(name) + " = " +
                  fmt::format("{:.3g}", p["value"].get<double>());
      }
    }
    if (c.contains("note")) {
      values +=
          (values.empty() ? "" : "; ") + Escape(c["note"].get<std::string>());
    }
    auto opt = [&](const char* key, int decimals) {
      return c.contains(key) ? Num(c[key].get<double>(), decimals)
                             : std::string("-");
    };
    html += fmt::format(
        "<tr class=\"{}\"><td class=\"l\">{}</td><td>{:.1f}</td><td "
        "class=\"bar\"><i style=\"width:{:.0f}%\"></i></td><td>{}</td><td>{}"
        "</td><td>{}</td><td class=\"l\">{}</td></tr>",
        chosen ? "chosen" : "", Escape(c["cause"].get<std::string>()), delta,
        2 + 98 * frac, opt("parameters", 0), opt("rms_um", 3),
        opt("rms_urad", 2), values);
  }
  return html + "</table>\n</section>\n";
}

const char* kStyle = R"css(
:root{--ink:#1b2430;--muted:#5b6675;--line:#d8dee6;--accent:#0b4f8a;
--pass:#1e7b34;--fail:#b3261e;--und:#b26a00}
*{box-sizing:border-box}
body{font:14px/1.45 "DejaVu Sans",Helvetica,Arial,sans-serif;color:var(--ink);
margin:0;background:#f4f6f9}
header{background:var(--accent);color:#fff;padding:18px 32px}
header h1{margin:0;font-size:22px;font-weight:600}
header .meta{font-size:12.5px;opacity:.9;margin-top:4px}
main{max-width:1180px;margin:0 auto;padding:16px 24px 40px}
section{background:#fff;border:1px solid var(--line);border-radius:6px;
padding:14px 20px;margin:16px 0}
h2{font-size:17px;margin:0 0 10px;color:var(--accent);border-bottom:2px solid
var(--line);padding-bottom:6px}
h3{font-size:14.5px;margin:14px 0 6px}
.two{display:grid;grid-template-columns:minmax(320px,480px) 1fr;gap:20px;
align-items:start}
svg.piece{width:100%;height:auto}
svg .cyl{fill:#eef1f5;stroke:#9aa5b1;stroke-width:.4;stroke-dasharray:2 1.5}
svg .floor{fill:#e3e8ee;stroke:#7b8794;stroke-width:.4}
svg .strip{opacity:.55;stroke:#fff;stroke-width:.25}
svg .notch{fill:#c9d1da}
svg .segment{fill:#b8c2cd;stroke:#56606b;stroke-width:.4}
svg .facet{stroke-width:2.4;stroke-linecap:butt}
svg .mark{stroke:#000;stroke-width:.8}
svg .axes line{stroke:#333;stroke-width:.5}
svg .lbl{font-size:5px;text-anchor:middle;fill:#1b2430}
svg .lbl.small{font-size:4px}
svg .lbl.seg{font-size:7px;font-weight:700}
table{border-collapse:collapse;margin:6px 0;font-size:13px}
th,td{border:1px solid var(--line);padding:3px 8px}
th{background:#eef2f6;font-weight:600}
table.num td{text-align:right;font-variant-numeric:tabular-nums}
td.l{text-align:left!important}
table.verdict td{text-align:center;font-variant-numeric:tabular-nums}
td.pass{background:#e3f3e6;color:var(--pass)}
td.fail{background:#fbe4e2;color:var(--fail);font-weight:600}
td.undecidable{background:#fff1d6;color:var(--und)}
td.missing{color:#8a94a0;font-style:italic}
.stamp{display:inline-block;font-size:18px;font-weight:700;padding:6px 16px;
border:3px solid;border-radius:4px;margin:4px 0 10px;letter-spacing:.5px}
.stamp.pass{color:var(--pass)}.stamp.fail{color:var(--fail)}
.stamp.undecidable{color:var(--und)}
.rule{background:#f3f6fa;border-left:4px solid var(--accent);padding:6px 10px}
.note{color:var(--muted);font-size:12.5px}
.na{color:#8a4b00;background:#fff6e5;border:1px dashed #e0b060;padding:6px
10px;border-radius:4px}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(360px,1fr));
gap:10px}
.plot{min-height:250px}.plot.wide{grid-column:1/-1}
.legend{display:flex;flex-wrap:wrap;gap:4px 12px;font-size:12px;margin-top:8px}
.legend i,.dot{display:inline-block;width:11px;height:11px;border-radius:2px;
margin-right:5px;vertical-align:-1px}
.cards{display:flex;gap:12px;flex-wrap:wrap;margin-bottom:8px}
.card{border:1px solid var(--line);border-radius:5px;padding:8px 14px;
min-width:170px;background:#fafbfd}
.card b{display:block;font-size:11.5px;color:var(--muted);font-weight:600}
.card span{font-size:18px;font-weight:600}
td.bar{width:160px}td.bar i{display:block;height:10px;background:#7ea6cf;
border-radius:2px}
tr.chosen td{background:#eaf2fb;font-weight:600}
#js-errors:empty{display:none}
details.warnings{background:#fff6e5;border:1px solid #e0b060;border-radius:
4px;padding:6px 12px;margin-top:12px;font-size:13px}
.card small{display:block;color:var(--muted);font-size:11.5px}
#js-errors{background:#fbe4e2;color:var(--fail);padding:8px;white-space:pre}
footer{color:var(--muted);font-size:12px;text-align:center;padding:10px}
.uplot{font-family:inherit}.u-title{font-size:13.5px!important}
)css";

// Draws the plots and writes, per plot, how many data points landed inside
// the plot area (data-points) so a browser test can check them.
const char* kScript = R"js(
(function(){
"use strict";
var data = JSON.parse(document.getElementById("ttp-data").textContent);
var meta = JSON.parse(document.getElementById("ttp-meta").textContent);
var FIG = ["E_X","E_Y","E_Z","E_B","E_TTP"];
function el(id){ return document.getElementById(id); }
function width(div){ return Math.max(340, div.clientWidth || 360); }
function finite(v){ return v !== null && v !== undefined && isFinite(v); }
// Counts the points of the data series (not limits) that were drawn inside
// the plot area, after uPlot has drawn.
function countHook(series){
  return function(u){
    var n = 0, b = u.bbox;
    series.forEach(function(si){
      var xs = u.data[0], ys = u.data[si];
      for (var i = 0; i < xs.length; i++) {
        if (!finite(ys[i])) continue;
        var x = u.valToPos(xs[i], "x", true), y = u.valToPos(ys[i], u.series[si].scale, true);
        if (x >= b.left - 1 && x <= b.left + b.width + 1 && y >= b.top - 1 && y <= b.top + b.height + 1) n++;
      }
    });
    u.root.parentNode.setAttribute("data-points", String(n));
  };
}
function cutLines(u){
  var ctx = u.ctx, b = u.bbox;
  ctx.save(); ctx.lineWidth = 1; ctx.setLineDash([3, 3]);
  meta.cuts.forEach(function(c){
    var x = u.valToPos(c.t_h, "x", true);
    if (x < b.left || x > b.left + b.width) return;
    ctx.strokeStyle = c.colour; ctx.globalAlpha = 0.55;
    ctx.beginPath(); ctx.moveTo(x, b.top); ctx.lineTo(x, b.top + b.height); ctx.stroke();
  });
  ctx.restore();
}
// One legend entry for the pair of limit lines.
function hideLegend(label){
  return function(u){
    u.root.querySelectorAll(".u-legend .u-series").forEach(function(row){
      if (row.textContent.trim() === label) row.style.display = "none";
    });
  };
}
function byCycle(list){
  var m = {}; (list || []).forEach(function(e){ m[e.cycle] = e; }); return m;
}
function figurePlots(){
  var f = data.figures; if (!f) return;
  var meas = byCycle(f.measured), sim = byCycle(f.simulated), lin = f.simulated_linear ? byCycle(f.simulated_linear) : null;
  var cycles = Object.keys(Object.assign({}, meas, sim)).map(Number).sort(function(a,b){return a-b;});
  FIG.forEach(function(key){
    var div = el("plot-" + key); if (!div) return;
    var lim = key === "E_B" ? meta.limits.angular_um_per_m : meta.limits.linear_um;
    var unit = key === "E_B" ? "um/m" : "um";
    var m = cycles.map(function(c){ return meas[c] ? meas[c][key] : null; });
    var mu = cycles.map(function(c){ return meas[c] && meas[c].U ? meas[c].U[key] : null; });
    var s = cycles.map(function(c){ return sim[c] ? sim[c][key] : null; });
    var su = cycles.map(function(c){ return sim[c] && sim[c].U ? sim[c].U[key] : null; });
    var hi = cycles.map(function(){ return lim; }), lo = cycles.map(function(){ return -lim; });
    var sl = lin ? cycles.map(function(c){ return lin[c] ? lin[c][key] : null; }) : null;
    function whiskers(u){
      var ctx = u.ctx; ctx.save(); ctx.lineWidth = 1.5;
      [[1, mu, "#0b4f8a"], [2, su, "#c2410c"]].forEach(function(w){
        var ys = u.data[w[0]], us = w[1];
        ctx.strokeStyle = w[2];
        for (var i = 0; i < ys.length; i++) {
          if (!finite(ys[i]) || !finite(us[i])) continue;
          var x = u.valToPos(u.data[0][i], "x", true) + (w[0] === 2 ? 4 : 0);
          var y0 = u.valToPos(ys[i] - us[i], "y", true), y1 = u.valToPos(ys[i] + us[i], "y", true);
          ctx.beginPath(); ctx.moveTo(x, y0); ctx.lineTo(x, y1);
          ctx.moveTo(x - 4, y0); ctx.lineTo(x + 4, y0); ctx.moveTo(x - 4, y1); ctx.lineTo(x + 4, y1);
          ctx.stroke();
        }
      });
      ctx.restore();
    }
    var all = m.concat(s, hi, lo, sl || []).filter(finite);
    var ext = Math.max.apply(null, all.map(Math.abs).concat(mu.filter(finite).map(function(u, i){ return 0; })));
    var ymax = Math.max(lim * 1.25, ext * 1.15);
    cycles.forEach(function(c, i){ if (finite(m[i]) && finite(mu[i])) ymax = Math.max(ymax, (Math.abs(m[i]) + mu[i]) * 1.1); });
    new uPlot({
      title: key + " (" + unit + ")", width: width(div), height: 240, legend: { live: false },
      scales: { x: { time: false, range: [cycles[0] - 0.5, cycles[cycles.length - 1] + 0.5] }, y: { range: [-ymax, ymax] } },
      axes: [{ label: "cycle", incrs: [1], values: function(u, v){ return v.map(function(x){ return Number.isInteger(x) ? x : ""; }); } },
             { label: unit, size: 60 }],
      series: [{ label: "cycle" },
        { label: "measured", stroke: "#0b4f8a", width: 0, paths: function(){ return null; }, points: { show: true, size: 9, fill: "#0b4f8a" } },
        { label: "simulated", stroke: "#c2410c", width: 2, points: { show: true, size: 6, fill: "#fff" } },
        { label: "limits", stroke: "#b3261e", width: 1.2, dash: [6, 4], points: { show: false } },
        { label: "-limit", stroke: "#b3261e", width: 1.2, dash: [6, 4], points: { show: false } }].concat(sl ? [
        { label: "simulated, straight line", stroke: "#7b8794", width: 1.2, dash: [2, 3], points: { show: true, size: 4, fill: "#7b8794" } }] : []),
      hooks: { init: [hideLegend("-limit")], draw: [whiskers, countHook(sl ? [1, 2, 5] : [1, 2])] }
    }, [cycles, m, s, hi, lo].concat(sl ? [sl] : []), div);
  });
}
function logPlot(id, title, xs_h, series, axes){
  var div = el(id); if (!div) return;
  var d = [xs_h].concat(series.map(function(s){ return s.values; }));
  var idx = series.map(function(s, i){ return i + 1; });
  new uPlot({
    title: title, width: width(div), height: 260, legend: { live: false },
    scales: Object.assign({ x: { time: false } }, axes.scales || {}),
    axes: [{ label: "time since log start (h)" }].concat(axes.list),
    series: [{ label: "t (h)" }].concat(series.map(function(s){
      return { label: s.label, stroke: s.colour, width: s.width || 1.5, scale: s.scale || "y",
               paths: s.stepped ? uPlot.paths.stepped({ align: 1 }) : undefined,
               points: { show: !!s.points, size: 5, fill: s.colour }, spanGaps: !!s.points };
    })),
    hooks: { draw: [cutLines, countHook(idx)] }
  }, d, div);
}
function logPlots(){
  var log = data.log; if (!log) return;
  var palette = ["#0b4f8a", "#c2410c", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf"];
  if (log.samples) {
    var sm = log.samples, th = sm.t_s.map(function(t){ return t / 3600; });
    var temps = [];
    [["T_env", "T_env (degC)"], ["T_ws", "T_ws (degC)"], ["T_mwf", "T_mwf (degC)"]].forEach(function(c, i){
      if (sm[c[0]]) temps.push({ label: c[1], values: sm[c[0]], colour: palette[i] });
    });
    if (sm.dT_cool) temps.push({ label: "dT_cool (K)", values: sm.dT_cool, colour: palette[3], scale: "K" });
    logPlot("plot-temperatures", "Temperatures", th, temps,
      { list: [{ label: "degC", size: 60 }, { label: "K", scale: "K", side: 1, size: 50, grid: { show: false } }] });
    var speed = [];
    if (sm.c_rpm) speed.push({ label: "C speed (1/min)", values: sm.c_rpm, colour: palette[0], stepped: true });
    logPlot("plot-c-speed", "C-axis speed", th, speed, { list: [{ label: "1/min", size: 60 }] });
  }
  if (log.rtests) {
    var rt = log.rtests, rh = rt.t_s.map(function(t){ return t / 3600; });
    var lin = [], ang = [];
    ["EX0C", "EY0C", "EZ0T", "ER0T"].forEach(function(k, i){
      if (rt[k]) lin.push({ label: k + " (um)", values: rt[k], colour: palette[i], points: true });
    });
    ["EA0C", "EB0C", "EC0C"].forEach(function(k, i){
      if (rt[k]) ang.push({ label: k + " (um/m)", values: rt[k], colour: palette[i + 4], points: true });
    });
    logPlot("plot-rtest-linear", "R-test: linear errors of the C axis", rh, lin, { list: [{ label: "um", size: 60 }] });
    logPlot("plot-rtest-angular", "R-test: angular errors of the C axis", rh, ang, { list: [{ label: "um/m", size: 60 }] });
  }
}
function residualPlots(){
  var r = data.diagnosis && data.diagnosis.residuals; if (!r) return;
  var keys = ["E_X", "E_Y", "E_Z", "E_TTP"], colours = ["#0b4f8a", "#c2410c", "#2ca02c", "#9467bd"];
  var present = keys.filter(function(k){ return r.before[k]; });
  var ymax = 0.5;
  ["before", "after"].forEach(function(w){ present.forEach(function(k){ (r[w][k] || []).forEach(function(v, i){
    if (finite(v)) ymax = Math.max(ymax, 1.15 * (Math.abs(v) + (r.sigma && r.sigma[k] && finite(r.sigma[k][i]) ? r.sigma[k][i] : 0)));
  }); }); });
  [["before", "Before: nominal model"], ["after", "After: with the fitted effect"]].forEach(function(w){
    var div = el("plot-residual-" + w[0]); if (!div) return;
    var d = [r.cycles].concat(present.map(function(k){ return r[w[0]][k]; }));
    function bars(u){
      if (!r.sigma) return;
      var ctx = u.ctx; ctx.save(); ctx.lineWidth = 1.2;
      present.forEach(function(k, s){
        var ys = u.data[s + 1], us = r.sigma[k] || []; ctx.strokeStyle = colours[keys.indexOf(k)];
        for (var i = 0; i < ys.length; i++) {
          if (!finite(ys[i]) || !finite(us[i])) continue;
          var x = u.valToPos(u.data[0][i], "x", true) + (s - 1.5) * 4;
          var y0 = u.valToPos(ys[i] - us[i], "y", true), y1 = u.valToPos(ys[i] + us[i], "y", true);
          ctx.beginPath(); ctx.moveTo(x, y0); ctx.lineTo(x, y1); ctx.stroke();
        }
      });
      ctx.restore();
    }
    new uPlot({
      title: w[1] + " (um)", width: width(div), height: 240, legend: { live: false },
      scales: { x: { time: false, range: [r.cycles[0] - 0.5, r.cycles[r.cycles.length - 1] + 0.5] }, y: { range: [-ymax, ymax] } },
      axes: [{ label: "cycle", incrs: [1], values: function(u, v){ return v.map(function(x){ return Number.isInteger(x) ? x : ""; }); } },
             { label: "um", size: 60 }],
      series: [{ label: "cycle" }].concat(present.map(function(k){
        var c = colours[keys.indexOf(k)];
        return { label: k, stroke: c, width: 1, dash: [2, 3], points: { show: true, size: 7, fill: c } };
      })),
      hooks: { draw: [bars, countHook(present.map(function(k, i){ return i + 1; }))] }
    }, d, div);
  });
}
try { figurePlots(); logPlots(); residualPlots(); }
catch (e) { reportError(String(e && e.stack || e)); }
document.body.setAttribute("data-plots-done", "1");
})();
)js";

}  // namespace

namespace {
std::string WarningsBlock(const json& data) {
  const json* warnings = Find(data, "warnings");
  if (warnings == nullptr || warnings->empty()) return "";
  std::string html = fmt::format(
      "<details class=\"warnings\"><summary>{} warning(s) from reading the "
      "inputs</summary><ul>",
      warnings->size());
  for (const json& w : *warnings) {
    html += "<li>" + Escape(w.get<std::string>()) + "</li>";
  }
  return html + "</ul></details>\n";
}
}  // namespace

std::string RenderReportHtml(const json& report_data) {
  ValidateReportData(report_data);
  const PartSpec part =
      report_internal::PartFromReportData(report_data, "report data");
  Limits limits;
  if (const json* l = Find(report_data, "limits")) {
    limits.linear_um = l->value("linear_um", limits.linear_um);
    limits.angular_um_per_m =
        l->value("angular_um_per_m", limits.angular_um_per_m);
  }
  // What the page script needs beyond the data: limits and coloured cuts.
  json meta = {{"limits",
                {{"linear_um", limits.linear_um},
                 {"angular_um_per_m", limits.angular_um_per_m}}},
               {"cuts", json::array()}};
  if (const json* log = Find(report_data, "log");
      log && log->contains("cuts")) {
    for (const json& cut : (*log)["cuts"]) {
      FeatureKind kind;
      Segment segment;
      int index = 0;
      ParseFeatureId(cut["feature"].get<std::string>(), &kind, &segment,
                     &index);
      meta["cuts"].push_back({{"t_h", cut["t_s"].get<double>() / 3600.0},
                              {"colour", report_internal::CycleColour(
                                             CycleForIndex(part, index))}});
    }
  }
  const std::string title =
      report_data.value("title", std::string("Thermal test piece report"));
  std::string run_meta;
  if (const json* run = Find(report_data, "run")) {
    for (const auto& [key, value] : run->items()) {
      run_meta +=
          (run_meta.empty() ? "" : " &middot; ") + Escape(key) + ": " +
          Escape(value.is_string() ? value.get<std::string>() : value.dump());
    }
  }
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
      "<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\">"
      "\n<title>" +
      Escape(title) + "</title>\n<style>\n" +
      Joined(report_assets::kUplotCssPieces) + "\n" + kStyle +
      "</style>\n"
      "<script>\n// Any script error is shown on the page (and read by the "
      "browser test).\nfunction reportError(text){var e=document."
      "getElementById('js-errors');if(e){e.textContent+=text+'\\n';}"
      "document.documentElement.setAttribute('data-js-error','1');}\n"
      "window.onerror=function(msg,src,line,col){reportError(msg+' ('+line+"
      "':'+col+')');};\n</script>\n</head>\n<body>\n<header><h1>" +
      Escape(title) + "</h1><div class=\"meta\">" + run_meta +
      "</div></header>\n<main>\n<div id=\"js-errors\"></div>\n" +
      WarningsBlock(report_data) + PieceSection(report_data, part) +
      FiguresSection(report_data, limits) +
      VerdictSection(report_data, limits) + LogSection(report_data, part) +
      DiagnosisSection(report_data) +
      "</main>\n<footer>Generated by ttp (schema " + kReportSchema +
      "). Plots: uPlot (MIT).</footer>\n"
      "<script type=\"application/json\" id=\"ttp-data\">" +
      ScriptSafeJson(report_data) +
      "</script>\n<script type=\"application/json\" id=\"ttp-meta\">" +
      ScriptSafeJson(meta) + "</script>\n<script>\n" +
      Joined(report_assets::kUplotJsPieces) + "\n</script>\n<script>" +
      kScript + "</script>\n</body>\n</html>\n";
  return html;
}

}  // namespace ttp
