// Renders the report HTML. Tables, the verdict and the piece drawing are
// built here in C++; the plots are drawn in the page by uPlot from the data
// embedded as JSON. uPlot was chosen over Chart.js: ~50 kB minified, no
// dependencies, canvas-based and fast for a day of 1-row-a-minute logs, and
// actively maintained (github.com/leeoniya/uPlot).
#include "ttp/report/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "piece_drawing.h"
#include "report_schema.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/format.h"
#include "ttp/geometry/json_text.h"

namespace ttp::report_assets {
extern const char* const kUplotJsPieces[];
extern const char* const kUplotCssPieces[];
extern const char* const kReportJsPieces[];
extern const char* const kReportCssPieces[];
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
  std::string text = JsonText(doc);
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

std::string Num(double v, int decimals = 2) {
  return FormatNumber(v, decimals);
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
    for (const auto& item : facets->items()) {
      const json& facet = item.value();
      auto cell = [&](const char* key, int decimals) {
        return facet.contains(key) && !facet[key].is_null()
                   ? Num(facet[key].get<double>(), decimals)
                   : std::string("not measured");
      };
      html += "<tr><td>" + Escape(item.key()) + "</td><td>" +
              cell("distance_mm", 4) + "</td><td>" +
              cell("angle_error_urad", 1) + "</td></tr>";
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

// The grade exactly as inspect::GradeToJson gave it: nothing is decided
// here.
std::string VerdictSection(const json& data) {
  const json* grade = Find(data, "grade");
  std::string html =
      "<section id=\"verdict\"><h2>3. Verdict</h2>\n<p class=\"rule\">Decision "
      "rule ISO 14253-1: conformance is proven when |E| &le; limit - U (the "
      "conformance zone reduced by the expanded uncertainty U, k = 2), "
      "non-conformance when |E| &gt; limit + U; in between the result is "
      "undecidable. A figure passes when every cycle passes; a missing value "
      "leaves conformance unproven. A figure the instrument cannot measure, "
      "or whose U reaches its limit, is not decided and left out of the "
      "verdict.</p>\n";
  if (grade == nullptr) {
    return html + NotAvailable("no grade of the measured figures") +
           "</section>\n";
  }
  const std::string overall = (*grade)["verdict"].get<std::string>();
  const std::string text = overall == "fail" ? "FAIL - non-conformance proven"
                           : overall == "pass"
                               ? "PASS - conformance proven"
                               : "UNDECIDABLE - conformance not proven";
  html += fmt::format(
      "<div class=\"stamp {}\" id=\"overall-verdict\" "
      "data-verdict=\"{}\">{}</div>\n",
      overall, overall, text);
  if (grade->contains("summary"))
    html += "<p class=\"summary\" id=\"grade-summary\">" +
            Escape((*grade)["summary"].get<std::string>()) + ".</p>\n";
  if (grade->contains("limits") && (*grade)["limits"].contains("description"))
    html += "<p class=\"note\">Limits: " +
            Escape((*grade)["limits"]["description"].get<std::string>()) +
            ".</p>\n";
  // Figures not decided, with the reason.
  std::string reasons;
  if (grade->contains("figures")) {
    for (const json& f : (*grade)["figures"]) {
      if (f["decided"].get<bool>()) continue;
      reasons += "<li><b>" + Escape(f["figure"].get<std::string>()) +
                 "</b>: " + Escape(f["reason"].get<std::string>()) + "</li>";
    }
  }
  if (!reasons.empty())
    html += "<p class=\"note\">Not decided:</p><ul class=\"not-decided\">" +
            reasons + "</ul>\n";
  // Every graded value, coloured by its own decision.
  std::map<std::string, std::map<int, const json*>> by_figure;
  std::map<int, bool> cycles;
  std::vector<std::string> order;
  if (grade->contains("values")) {
    for (const json& v : (*grade)["values"]) {
      const std::string f = v["figure"].get<std::string>();
      if (!by_figure.count(f)) order.push_back(f);
      by_figure[f][v["cycle"].get<int>()] = &v;
      cycles[v["cycle"].get<int>()] = true;
    }
  }
  if (order.empty()) return html + "</section>\n";
  std::map<std::string, const json*> figure_grade;
  if (grade->contains("figures"))
    for (const json& f : (*grade)["figures"])
      figure_grade[f["figure"].get<std::string>()] = &f;
  std::string table = "<table class=\"verdict\"><tr><th>figure</th>";
  for (const auto& [cycle, unused] : cycles)
    table += fmt::format("<th>cycle {}</th>", cycle);
  table += "<th>limit</th><th>figure</th></tr>\n";
  for (const std::string& f : order) {
    table += "<tr><th>" + Escape(f) + "</th>";
    std::string unit, limit;
    for (const auto& [cycle, unused] : cycles) {
      auto it = by_figure[f].find(cycle);
      if (it == by_figure[f].end()) {
        table += "<td class=\"missing\">-</td>";
        continue;
      }
      const json& v = *it->second;
      unit = v["unit"].get<std::string>();
      limit = FormatNumber(v["limit"].get<double>(), -1);
      const std::string verdict = v["verdict"].get<std::string>();
      if (v["value"].is_null()) {
        table += "<td class=\"missing\">missing</td>";
      } else {
        table +=
            fmt::format("<td class=\"{}\">{} &plusmn; {}</td>", verdict,
                        FormatNumber(v["value"].get<double>(), 2),
                        v["u_expanded"].is_null()
                            ? std::string("?")
                            : FormatNumber(v["u_expanded"].get<double>(), 2));
      }
    }
    std::string fverdict = "not_decidable";
    if (figure_grade.count(f) && !(*figure_grade[f])["verdict"].is_null())
      fverdict = (*figure_grade[f])["verdict"].get<std::string>();
    table += fmt::format(
        "<td>&plusmn;{} {}</td><td class=\"{}\">{}</td></tr>\n", limit, unit,
        fverdict, fverdict == "not_decidable" ? "not decided" : fverdict);
  }
  table += "</table>\n";
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
  // What the diagnosis rests on that the reader should know (R-tests the
  // estimator left out as gross errors).
  if (d->contains("warnings") && !(*d)["warnings"].empty()) {
    html += "<ul class=\"warnings\" id=\"diagnosis-warnings\">";
    for (const json& w : (*d)["warnings"])
      html += "<li>" + Escape(w.get<std::string>()) + "</li>";
    html += "</ul>\n";
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
// The page around the sections: style, the error hook, the data and the
// scripts (uPlot and report/web/report.js).
std::string Page(const std::string& title, const std::string& header_meta,
                 const std::string& body, const json& data, const json& meta,
                 const char* schema) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta "
         "charset=\"utf-8\">\n"
         "<meta name=\"viewport\" "
         "content=\"width=device-width,initial-scale=1\">"
         "\n<title>" +
         Escape(title) + "</title>\n<style>\n" +
         Joined(report_assets::kUplotCssPieces) + "\n" +
         Joined(report_assets::kReportCssPieces) +
         "</style>\n"
         "<script>\n// Any script error is shown on the page (and read by the "
         "browser test).\nfunction reportError(text){var e=document."
         "getElementById('js-errors');if(e){e.textContent+=text+'\\n';}"
         "document.documentElement.setAttribute('data-js-error','1');}\n"
         "window.onerror=function(msg,src,line,col){reportError(msg+' ('+line+"
         "':'+col+')');};\n</script>\n</head>\n<body>\n<header><h1>" +
         Escape(title) + "</h1><div class=\"meta\">" + header_meta +
         "</div></header>\n<main>\n<div id=\"js-errors\"></div>\n" + body +
         "</main>\n<footer>Generated by ttp (schema " + schema +
         "). Plots: uPlot (MIT).</footer>\n"
         "<script type=\"application/json\" id=\"ttp-data\">" +
         ScriptSafeJson(data) +
         "</script>\n<script type=\"application/json\" id=\"ttp-meta\">" +
         ScriptSafeJson(meta) + "</script>\n<script>\n" +
         Joined(report_assets::kUplotJsPieces) + "\n</script>\n<script>" +
         Joined(report_assets::kReportJsPieces) +
         "</script>\n</body>\n</html>\n";
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
      run_meta += (run_meta.empty() ? "" : " &middot; ") + Escape(key) + ": " +
                  Escape(value.is_string() ? value.get<std::string>()
                                           : JsonText(value));
    }
  }
  return Page(title, run_meta,
              WarningsBlock(report_data) + PieceSection(report_data, part) +
                  FiguresSection(report_data, limits) +
                  VerdictSection(report_data) + LogSection(report_data, part) +
                  DiagnosisSection(report_data),
              report_data, meta, kReportSchema);
}

std::string RenderComparisonHtml(const json& d) {
  if (!d.is_object() || d.value("schema", std::string()) != kCompareSchema)
    throw InputError("comparison data", 0, "schema",
                     std::string("must be \"") + kCompareSchema + "\"");
  if (!d.contains("pieces") || !d["pieces"].is_array() ||
      d["pieces"].size() != 2)
    throw InputError("comparison data", 0, "pieces", "must hold two pieces");
  const json& a = d["pieces"][0];
  const json& b = d["pieces"][1];
  const std::string title = d.value("title", std::string("Comparison"));
  auto name = [](const json& p) {
    return p["label"].get<std::string>() + ": " +
           p["measurement"].get<std::string>() + " (" +
           p["measurement_kind"].get<std::string>() + ")";
  };
  std::string body = "<section id=\"pieces\"><h2>1. The two pieces</h2><ul>";
  for (const json* p : {&a, &b}) {
    const std::string verdict = (*p)["grade"]["verdict"].get<std::string>();
    body += "<li>" + Escape(name(*p)) + ": <span class=\"stamp-inline " +
            verdict + "\" data-verdict=\"" + verdict + "\">" +
            Escape((*p)["grade"]["summary"].get<std::string>()) +
            "</span></li>";
  }
  body += "</ul></section>\n";
  // Thesis table 7.2: spans over 1 h, 4 h and the whole test.
  body +=
      "<section id=\"spans\"><h2>2. Span of the figures (thesis table "
      "7.2)</h2>\n<p>Span (max - min, um) of each figure over the first "
      "hour, the first 4 hours and the whole test, cycle 0 (the reference) "
      "included.</p>\n<table class=\"num spans\"><tr><th>period</th>";
  std::vector<std::string> figures;
  for (const json& s : d["spans"]) {
    const std::string f = s["figure"].get<std::string>();
    if (std::find(figures.begin(), figures.end(), f) == figures.end())
      figures.push_back(f);
  }
  for (const std::string& f : figures)
    body += "<th>" + Escape(f) + " A</th><th>" + Escape(f) + " B</th>";
  body += "</tr>\n";
  for (double hours : {1.0, 4.0, 8.0}) {
    body += "<tr><th>" + FormatNumber(hours, -1) + " h</th>";
    for (const std::string& f : figures) {
      for (const json& s : d["spans"]) {
        if (s["figure"] != f || s["period_h"].get<double>() != hours) continue;
        for (const char* key : {"a_um", "b_um"}) {
          body += "<td>" +
                  (s[key].is_null() ? std::string("-")
                                    : FormatNumber(s[key].get<double>(), 1)) +
                  "</td>";
        }
      }
    }
    body += "</tr>\n";
  }
  body += "</table></section>\n";
  body +=
      "<section id=\"figures\"><h2>3. Figures per cycle</h2>\n<p>Piece A "
      "(points) and piece B (line), bars: expanded uncertainty U (k = 2); the "
      "red dashed lines are the limits.</p><div class=\"grid\">";
  for (const auto& key : kFigureKeys) {
    body += "<div class=\"plot\" id=\"plot-" + key + "\" data-plot=\"" + key +
            "\"></div>";
  }
  body += "</div></section>\n";
  // The page script draws figures.measured (A) and figures.simulated (B).
  const json plot_data = {
      {"figures", {{"measured", a["figures"]}, {"simulated", b["figures"]}}}};
  const json meta = {
      {"limits", d.value("limits", json::object())},
      {"cuts", json::array()},
      {"labels",
       {{"measured", "A: " + a["measurement"].get<std::string>()},
        {"simulated", "B: " + b["measurement"].get<std::string>()}}}};
  return Page(title, Escape(name(a)) + " &middot; " + Escape(name(b)), body,
              plot_data, meta, kCompareSchema);
}

}  // namespace ttp
