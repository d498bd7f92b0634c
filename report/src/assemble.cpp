// Report data from the modules' results. Every number in the page comes
// from here: nothing is recomputed in the renderer beyond the per-cell
// decision of the ISO 14253-1 rule.
#include "ttp/report/assemble.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "report_schema.h"
#include "ttp/diagnosis/effects.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/figures.h"
#include "ttp/geometry/file_io.h"
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
                    {"feature", c.feature},
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

std::string ParamText(const diagnosis::ParamEstimate& p) {
  return fmt::format("{} = {:.3g} +- {:.2g}", p.name, p.value, p.uncertainty);
}

// What a person reads first: the cause and its evidence against the others.
std::string Summary(const diagnosis::DiagnosisReport& d, double threshold) {
  std::vector<const diagnosis::CandidateResult*> ranked;
  for (const auto& c : d.candidates) {
    if (!c.causes.empty()) ranked.push_back(&c);
  }
  std::sort(ranked.begin(), ranked.end(), [](const auto* a, const auto* b) {
    return a->delta_bic < b->delta_bic;
  });
  if (d.status == diagnosis::DiagnosisStatus::kRefused ||
      d.status == diagnosis::DiagnosisStatus::kUnexplained) {
    std::string s = fmt::format("{}: {}.", diagnosis::StatusName(d.status),
                                d.reason);
    for (const auto& l : d.structure)
      s += fmt::format(" {}: {:.3g} {} (chi2 per observation {:.1f}).",
                       l.where, l.rms, l.unit, l.chi2_per_observation);
    return s;
  }
  if (d.cause == "none") {
    std::string s = fmt::format(
        "No cause beyond noise: no extension of the model beats the nominal "
        "model by the evidence threshold (delta BIC < -{:g}).",
        threshold);
    if (!ranked.empty()) {
      s += fmt::format(" Best candidate: {} (delta BIC {:.1f}).",
                       ranked[0]->name,
                       ranked[0]->delta_bic);
    }
    return s;
  }
  std::string s;
  for (const auto* c : ranked) {
    if (c->name != d.cause) continue;
    s = fmt::format(
        "{}: its BIC is lower than the nominal model's by {:.1f} (delta "
        "BIC {:+.1f}; a cause is named below -{:g})",
        d.cause, -c->delta_bic, c->delta_bic, threshold);
  }
  for (const auto* c : ranked) {
    if (c->name == d.cause) continue;
    s += fmt::format("; the next best candidate, {}, has delta BIC {:+.1f}",
                     c->name, c->delta_bic);
    break;
  }
  s += ". Fitted: ";
  for (size_t i = 0; i < d.params.size(); ++i) {
    s += (i ? ", " : "") + ParamText(d.params[i]);
  }
  s += fmt::format(
      ". Residual RMS of the figures {:.2f} um -> {:.2f} um; on held-out "
      "cycles the extension removes {:.0f} % of the residual.",
      d.baseline_rms_um, d.extended_rms_um, d.gain_pct);
  return s;
}

// Residuals of the figures per cycle before and after the chosen effect.
json Residuals(const diagnosis::PreparedRun& run,
               const diagnosis::DiagnosisReport& d, const PartSpec& part) {
  const diagnosis::Observations& obs = run.observations;
  const char* keys[4] = {"E_X", "E_Y", "E_Z", "E_TTP"};
  json out = {{"cycles", json::array()},
              {"before", json::object()},
              {"after", json::object()},
              {"sigma", json::object()}};
  for (int c = 1; c <= part.cycles(); ++c) out["cycles"].push_back(c);
  for (const char* part_name : {"before", "after", "sigma"}) {
    for (const char* key : keys) {
      out[part_name][key] = json::array();
      for (int c = 1; c <= part.cycles(); ++c)
        out[part_name][key].push_back(nullptr);
    }
  }
  for (size_t i = 0; i < obs.figures(); ++i) {
    const int g = obs.figure_kind[i], c = obs.figure_cycle[i];
    if (g < 0 || g > 3 || c < 1 || c > part.cycles()) continue;
    out["before"][keys[g]][c - 1] = obs.figure_value_um[i];
    if (i < d.figure_after_um.size())
      out["after"][keys[g]][c - 1] = d.figure_after_um[i];
    out["sigma"][keys[g]][c - 1] = obs.figure_sigma_um[i];
  }
  return out;
}

}  // namespace

json AssembleReportData(const thermal::TalcLog& log, const Config& config,
                        const inspect::InspectionResult& measured,
                        const diagnosis::PreparedDiagnosis* given,
                        const ReportOptions& options) {
  const PartSpec& part = config.part;
  options.limits.Validate();
  json data = {{"schema", kReportSchema}, {"title", options.title}};

  // Header: what was run and read.
  json run = json::object();
  if (!log.machine.empty()) run["machine"] = log.machine;
  run["compensation"] = log.compensation ? "on" : "off";
  run["log"] = log.source;
  run["log span"] = fmt::format("{:.2f} h, {} R-tests, {} cuts",
                                (log.LastTimeS() - log.FirstTimeS()) / 3600,
                                log.rtests.size(), log.cuts.size());
  if (!measured.source.empty()) run["measurement"] = measured.source;
  if (measured.points_total > 0) {
    run["points"] = fmt::format("{} read, {} on features, {} rejected",
                                measured.points_total, measured.points_assigned,
                                measured.points_rejected);
  }
  for (const auto& [key, value] : options.run_info) run[key] = value;
  data["run"] = run;
  data["part"] = ConfigToJson(config)["part"];
  data["limits"] = {{"linear_um", options.limits.linear_um},
                    {"angular_um_per_m", options.limits.angular_um_per_m}};

  // The measured piece as the diagnosis reads it (as `ttp diagnose` does).
  const diagnosis::MeasuredPiece piece =
      diagnosis::MeasuredPieceFromInspection(part, measured);
  diagnosis::PreparedDiagnosis computed;
  if (given == nullptr) {
    computed.run = diagnosis::PrepareRun(log, config, piece, options.diagnosis);
    computed.report = diagnosis::DiagnosePrepared(computed.run, log, part,
                                                  piece, options.diagnosis);
  }
  const diagnosis::PreparedRun& prepared = given ? given->run : computed.run;
  const diagnosis::DiagnosisReport& d = given ? given->report : computed.report;

  // Graded and drawn with the measurement's own U; the diagnosis judges
  // the same values against the fits' scatter (piece.figures).
  const json measured_figures = FiguresToJson(
      measured.figures.empty() ? piece.figures : measured.figures)["figures"];
  data["figures"] = {
      {"measured", measured_figures},
      {"simulated", SimulatedFigures(prepared.simulation.figures)},
      {"simulated_linear",
       SimulatedFigures(prepared.simulation.figures_linear)}};
  json facets = json::object();
  for (const auto& [id, r] : measured.features) {
    FeatureKind kind;
    Segment segment;
    int index = 0;
    if (!ParseFeatureId(id, &kind, &segment, &index) ||
        kind != FeatureKind::kFacet) {
      continue;
    }
    facets[id] = {
        {"distance_mm", r.present ? json(r.d_mm) : json()},
        {"angle_error_urad", r.present ? json(r.angle_rad * 1e6) : json()}};
  }
  if (!facets.empty()) data["facets"] = facets;

  const std::string grade_source =
      measured.source.empty() ? "measurement" : measured.source;
  const inspect::GradeResult grade = inspect::GradeFigures(
      json{{"figures", measured_figures}}, options.limits, grade_source);
  data["grade"] = inspect::GradeToJson(grade, options.limits);

  data["log"] = LogData(log);

  json diag = diagnosis::DiagnosisToJson(d);
  diag["summary"] = Summary(d, options.diagnosis.evidence_threshold);
  diag["threshold"] = options.diagnosis.evidence_threshold;
  diag["residuals"] = Residuals(prepared, d, part);
  data["diagnosis"] = diag;

  json warnings = json::array();
  for (const auto& w : log.warnings) {
    warnings.push_back(fmt::format("{} line {}: {} ({})", log.source, w.line,
                                   w.message, w.rule));
  }
  for (const auto& w : measured.warnings) {
    warnings.push_back(grade_source + ": " + w);
  }
  if (!warnings.empty()) data["warnings"] = warnings;

  ValidateReportData(data, "assembled report data");
  return data;
}

json WriteReport(const thermal::TalcLog& log, const Config& config,
                 const inspect::InspectionResult& measured,
                 const diagnosis::PreparedDiagnosis* diagnosis,
                 const std::filesystem::path& html_path,
                 const std::filesystem::path& json_path,
                 const ReportOptions& options) {
  json data = AssembleReportData(log, config, measured, diagnosis, options);
  const std::string html = RenderReportHtml(data);
  if (!json_path.empty()) WriteFileAtomic(json_path, data.dump(2) + "\n");
  WriteFileAtomic(html_path, html);
  return data;
}

}  // namespace ttp::report
