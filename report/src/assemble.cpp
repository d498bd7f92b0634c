// Report data from the modules' results. Every number in the page comes
// from here: nothing is recomputed in the renderer beyond the per-cell
// decision of the ISO 14253-1 rule.
#include "ttp/report/assemble.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "report_schema.h"
#include "ttp/diagnosis/explain.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/figures.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/report/report.h"

namespace ttp::report {
namespace {

using nlohmann::json;

json NumberOrNull(double v) { return std::isfinite(v) ? json(v) : json(); }

// Sample columns shown in the log plots (talc-log.md column names).
struct SampleColumn {
  const char* name;
  thermal::NumericColumn column;
};
constexpr SampleColumn kSampleColumns[] = {
    {"T_env", thermal::kTEnv}, {"T_ws", thermal::kTWs},
    {"T_mwf", thermal::kTMwf}, {"dT_cool", thermal::kDTCool},
    {"c_rpm", thermal::kCRpm}, {"spindle_rpm", thermal::kSpindleRpm}};

json LogData(const thermal::TalcLog& log) {
  json samples = {{"t_s", json::array()}};
  std::vector<json> columns(std::size(kSampleColumns), json::array());
  std::vector<bool> any(std::size(kSampleColumns), false);
  for (const thermal::LogRow& row : log.rows) {
    if (row.event != thermal::LogEvent::kSample) continue;
    samples["t_s"].push_back(row.t_s);
    for (size_t k = 0; k < std::size(kSampleColumns); ++k) {
      const double v = row.values[kSampleColumns[k].column];
      columns[k].push_back(NumberOrNull(v));
      any[k] = any[k] || std::isfinite(v);
    }
  }
  for (size_t k = 0; k < std::size(kSampleColumns); ++k) {
    if (any[k]) samples[kSampleColumns[k].name] = std::move(columns[k]);
  }
  // R-tests at the time their values describe, as logged (um, um/m; with
  // compensation on they are the residual after compensation).
  json rtests = {{"t_s", json::array()}};
  for (const char* key : kErrorNames) rtests[key] = json::array();
  for (const thermal::RTestRecord& r : log.rtests) {
    rtests["t_s"].push_back(r.t_ref_s);
    const std::array<double, 7> micro = r.measured.ToMicro();
    for (int k = 0; k < 7; ++k) {
      rtests[kErrorNames[k]].push_back(NumberOrNull(micro[k]));
    }
  }
  json cuts = json::array();
  for (const thermal::CutRecord& c : log.cuts) {
    cuts.push_back({{"t_s", c.t_s},
                    {"feature", c.feature.ToString()},
                    {"c_deg", c.c_rad * 180 / M_PI}});
  }
  json out = {{"samples", samples}, {"rtests", rtests}, {"cuts", cuts}};
  if (!log.start.empty()) out["start"] = log.start;
  return out;
}

// Simulated figures without U: the simulation has no per-figure
// uncertainty of its own (its error is in the diagnosis' residual sigma).
json SimulatedFigures(const std::vector<CycleFigures>& figures) {
  json list = FiguresToJson(figures)["figures"];
  for (json& entry : list) entry.erase("U");
  return list;
}

// The residual table as the report data holds it (null where none).
json ResidualsJson(const diagnosis::ResidualTable& t) {
  json out = {{"cycles", t.cycles},
              {"before", json::object()},
              {"after", json::object()},
              {"sigma", json::object()}};
  for (size_t g = 0; g < diagnosis::ResidualTable::kFigures.size(); ++g) {
    const char* key = diagnosis::ResidualTable::kFigures[g];
    for (auto [name, column] : {std::pair{"before", &t.before_um[g]},
                                std::pair{"after", &t.after_um[g]},
                                std::pair{"sigma", &t.sigma_um[g]}}) {
      json values = json::array();
      for (double v : *column) values.push_back(NumberOrNull(v));
      out[name][key] = values;
    }
  }
  return out;
}

}  // namespace

json AssembleReportData(const Config& config, const ReportInputs& in,
                        const ReportOptions& options) {
  if (in.measurement == nullptr || in.grade == nullptr)
    throw InputError("report", 0, "",
                     "a report needs a measurement and its grade");
  if (in.diagnosis != nullptr && in.log == nullptr)
    throw InputError("report", 0, "", "a diagnosis needs its TALC log");
  if ((in.diagnosis == nullptr) != (in.explanation == nullptr))
    throw InputError("report", 0, "",
                     "a diagnosis and its explanation go together");
  const inspect::InspectionResult& measured = in.measurement->result;
  const inspect::GradeLimits& limits = in.grade->limits;
  json data = {{"schema", kReportSchema}, {"title", options.title}};

  // Header: what was run and read.
  json run = json::object();
  if (in.log != nullptr) {
    const thermal::TalcLog& log = *in.log;
    if (!log.machine.empty()) run["machine"] = log.machine;
    run["compensation"] = log.compensation ? "on" : "off";
    run["log"] = log.source;
    run["log_span"] = fmt::format("{:.2f} h, {} R-tests, {} cuts",
                                  (log.LastTimeS() - log.FirstTimeS()) / 3600,
                                  log.rtests.size(), log.cuts.size());
  } else {
    run["log"] = "none (no TALC log: no simulation, machine or diagnosis)";
  }
  if (!measured.source.empty()) run["measurement"] = measured.source;
  run["measurement_kind"] = inspect::MeasurementKindName(in.measurement->kind);
  if (measured.points_total > 0) {
    run["points"] = fmt::format("{} read, {} on features, {} rejected",
                                measured.points_total, measured.points_assigned,
                                measured.points_rejected);
  }
  for (const auto& [key, value] : options.run_info) run[key] = value;
  data["run"] = run;
  data["part"] = ConfigToJson(config)["part"];
  data["limits"] = {{"linear_um", limits.linear_um},
                    {"angular_um_per_m", limits.angular_um_per_m}};

  // Drawn with the measurement's own U, as graded.
  json figures = {{"measured", FiguresToJson(measured.figures)["figures"]}};
  if (in.diagnosis != nullptr) {
    const diagnosis::PreparedRun& prepared = in.diagnosis->run;
    figures["simulated"] = SimulatedFigures(prepared.simulation.figures);
    figures["simulated_linear"] =
        SimulatedFigures(prepared.simulation.figures_linear);
  }
  data["figures"] = figures;
  json facets = json::object();
  for (const auto& [fid, r] : measured.features) {
    if (fid.kind != FeatureKind::kFacet) continue;
    const std::string id = fid.ToString();
    // An angle the instrument did not measure (dial gauge) is null: shown
    // as "not measured", never as 0.
    facets[id] = {{"distance_mm", r.present ? NumberOrNull(r.d_mm) : json()},
                  {"angle_error_urad",
                   r.present ? NumberOrNull(r.angle_rad * 1e6) : json()}};
  }
  if (!facets.empty()) data["facets"] = facets;

  data["grade"] = inspect::GradeToJson(*in.grade);
  if (in.log != nullptr) data["log"] = LogData(*in.log);

  if (in.diagnosis != nullptr) {
    const diagnosis::DiagnosisReport& d = in.diagnosis->report;
    json diag = diagnosis::DiagnosisToJson(d);
    diag["summary"] = in.explanation->summary;
    diag["threshold"] = options.diagnosis.evidence_threshold;
    diag["residuals"] = ResidualsJson(in.explanation->residuals);
    data["diagnosis"] = diag;
  }

  const std::string source =
      measured.source.empty() ? "measurement" : measured.source;
  json warnings = json::array();
  if (in.log != nullptr) {
    for (const auto& w : in.log->warnings) {
      warnings.push_back(fmt::format("{} line {}: {} ({})", in.log->source,
                                     w.line, w.message, w.rule));
    }
  }
  for (const auto& w : measured.warnings) warnings.push_back(source + ": " + w);
  if (!warnings.empty()) data["warnings"] = warnings;

  ValidateReportData(data, "assembled report data");
  return data;
}

json WriteReport(const Config& config, const ReportInputs& inputs,
                 const std::filesystem::path& html_path,
                 const std::filesystem::path& json_path,
                 const ReportOptions& options) {
  json data = AssembleReportData(config, inputs, options);
  const std::string html = RenderReportHtml(data);
  OutputBatch outputs;  // the page and its data, or neither
  outputs.Add(html_path, html);
  if (!json_path.empty()) outputs.Add(json_path, JsonText(data, 2) + "\n");
  outputs.Commit();
  return data;
}

double FigureSpanUm(const std::vector<CycleFigures>& figures,
                    inspect::Figure figure, double hours,
                    double cycle_period_s) {
  double lo = 0, hi = 0;  // cycle 0: the reference
  bool any = false;
  for (const CycleFigures& cf : figures) {
    if (cf.cycle * cycle_period_s > hours * 3600.0 + 1e-6) continue;
    double v = std::nan("");
    switch (figure) {
      case inspect::Figure::kEX:
        v = cf.e_x_mm;
        break;
      case inspect::Figure::kEY:
        v = cf.e_y_mm;
        break;
      case inspect::Figure::kEZ:
        v = cf.e_z_mm;
        break;
      case inspect::Figure::kETTP:
        v = cf.e_ttp_mm;
        break;
      default:
        break;
    }
    if (!std::isfinite(v)) continue;
    any = true;
    lo = std::min(lo, v * 1e3);
    hi = std::max(hi, v * 1e3);
  }
  return any ? hi - lo : std::nan("");
}

json AssembleComparisonData(const Config& config, const ComparedPiece& a,
                            const ComparedPiece& b, const std::string& title) {
  for (const ComparedPiece* p : {&a, &b}) {
    if (p->measurement == nullptr || p->grade == nullptr)
      throw InputError("report --compare", 0, "",
                       "each piece needs its measurement and its grade");
  }
  const double period_s = config.process.cycle_period_s;
  json pieces = json::array();
  const char* labels[2] = {"A", "B"};
  int k = 0;
  for (const ComparedPiece* p : {&a, &b}) {
    const inspect::Measurement& m = *p->measurement;
    pieces.push_back(
        {{"label", labels[k++]},
         {"measurement", m.source},
         {"measurement_kind", inspect::MeasurementKindName(m.kind)},
         {"figures", FiguresToJson(m.result.figures)["figures"]},
         {"grade", inspect::GradeToJson(*p->grade)}});
  }
  json spans = json::array();
  for (inspect::Figure f : {inspect::Figure::kEX, inspect::Figure::kEY,
                            inspect::Figure::kEZ, inspect::Figure::kETTP}) {
    for (double hours : {1.0, 4.0, 8.0}) {
      spans.push_back(
          {{"figure", inspect::FigureName(f)},
           {"period_h", hours},
           {"a_um", NumberOrNull(FigureSpanUm(a.measurement->result.figures, f,
                                              hours, period_s))},
           {"b_um", NumberOrNull(FigureSpanUm(b.measurement->result.figures, f,
                                              hours, period_s))}});
    }
  }
  const inspect::GradeLimits& limits = a.grade->limits;
  return {{"schema", kCompareSchema},
          {"title", title},
          {"part", ConfigToJson(config)["part"]},
          {"limits",
           {{"linear_um", limits.linear_um},
            {"angular_um_per_m", limits.angular_um_per_m}}},
          {"cycle_period_s", period_s},
          {"pieces", pieces},
          {"spans", spans}};
}

json WriteComparison(const Config& config, const ComparedPiece& a,
                     const ComparedPiece& b,
                     const std::filesystem::path& html_path,
                     const std::filesystem::path& json_path,
                     const std::string& title) {
  json data = AssembleComparisonData(config, a, b, title);
  const std::string html = RenderComparisonHtml(data);
  OutputBatch outputs;  // the page and its data, or neither
  outputs.Add(html_path, html);
  if (!json_path.empty()) outputs.Add(json_path, JsonText(data, 2) + "\n");
  outputs.Commit();
  return data;
}

}  // namespace ttp::report
