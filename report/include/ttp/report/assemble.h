// The report data (docs/REPORT.md) of one run, assembled from the typed
// results the other modules produced: the measured piece and its grade
// (inspect), the TALC log (thermal), the simulation and the diagnosis
// (diagnosis). Nothing is decided or fitted here. `ttp report` and `ttp run`
// both end here.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/diagnosis/explain.h"
#include "ttp/geometry/config.h"
#include "ttp/inspect/grade.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/measurement.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::report {

struct ReportOptions {
  diagnosis::DiagnosisOptions diagnosis;  // its evidence threshold is shown
  std::string title = "Thermal test piece report";
  // Shown in the page header (e.g. {"measurement_kind", "cloud"}); the
  // machine, compensation state and log span are added from the log.
  std::map<std::string, std::string> run_info;
};

// The typed results a report renders; each was computed once by its module.
struct ReportInputs {
  // Required: the measured piece (any kind LoadMeasurement reads) and its
  // grade (inspect::GradeMeasurement: the page shows exactly this verdict).
  const inspect::Measurement* measurement = nullptr;
  const inspect::GradeResult* grade = nullptr;
  // Optional: the TALC log. Without it (an uncompensated acceptance test)
  // the page has no simulation, machine or diagnosis section.
  const thermal::TalcLog* log = nullptr;
  // Optional (needs the log): the diagnosis with the run it was prepared on
  // (simulation and residuals).
  const diagnosis::PreparedDiagnosis* diagnosis = nullptr;
  // With the diagnosis: its summary and residual table
  // (diagnosis::ExplainDiagnosis).
  const diagnosis::DiagnosisExplanation* explanation = nullptr;
};

// The report data (docs/REPORT.md). Throws InputError when a required input
// is missing.
nlohmann::json AssembleReportData(const Config& config,
                                  const ReportInputs& inputs,
                                  const ReportOptions& options = {});

// Assembles, renders and writes the report: html_path (the page) and, when
// json_path is not empty, the data it is made from. Both atomically. Returns
// the data.
nlohmann::json WriteReport(const Config& config, const ReportInputs& inputs,
                           const std::filesystem::path& html_path,
                           const std::filesystem::path& json_path,
                           const ReportOptions& options = {});

}  // namespace ttp::report

namespace ttp::report {

// One piece of a comparison: its measurement and its grade.
struct ComparedPiece {
  const inspect::Measurement* measurement = nullptr;
  const inspect::GradeResult* grade = nullptr;
};

// Span (max - min, um) of each linear figure over the first `hours` of the
// test, cycle 0 (the reference, 0 by definition) included: thesis table
// 7.2. NaN when no cycle of the period was measured.
double FigureSpanUm(const std::vector<CycleFigures>& figures,
                    inspect::Figure figure, double hours,
                    double cycle_period_s);

// The comparison data (schema "ttp-compare/1", docs/REPORT.md) of piece A
// (e.g. without compensation) and piece B (with).
nlohmann::json AssembleComparisonData(const Config& config,
                                      const ComparedPiece& a,
                                      const ComparedPiece& b,
                                      const std::string& title);
nlohmann::json WriteComparison(const Config& config, const ComparedPiece& a,
                               const ComparedPiece& b,
                               const std::filesystem::path& html_path,
                               const std::filesystem::path& json_path,
                               const std::string& title);

}  // namespace ttp::report
