// The report data (docs/REPORT.md) of one run, assembled from what the other
// modules produce: the TALC log (thermal), the measured piece (inspect), its
// simulation from the log (thermal), the grade (inspect/grade.h) and the
// diagnosis (diagnosis). `ttp report` and `ttp run` both end here.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/geometry/config.h"
#include "ttp/inspect/grade.h"
#include "ttp/inspect/inspect.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::report {

struct ReportOptions {
  inspect::GradeLimits limits;            // grade and plot limits
  diagnosis::DiagnosisOptions diagnosis;  // when the diagnosis is run here
  std::string title = "Thermal test piece report";
  // Shown in the page header (e.g. {"measurement", "piece.ply"}); the
  // machine, compensation state and log span are added from the log.
  std::map<std::string, std::string> run_info;
};

// The report data of a run. `measured` is any measurement as
// LoadMeasurement reads it; the diagnosis reads it the way `ttp diagnose`
// does (diagnosis::MeasuredPieceFromInspection). `diagnosis` is the caller's,
// with the run it was prepared on (`ttp run` already has both), or, when
// null, the run is prepared and diagnosed here with options.diagnosis. Throws
// InputError for a log that does not cover the cuts or a measurement with
// nothing to compare.
nlohmann::json AssembleReportData(
    const thermal::TalcLog& log, const Config& config,
    const inspect::InspectionResult& measured,
    const diagnosis::PreparedDiagnosis* diagnosis = nullptr,
    const ReportOptions& options = {});

// Assembles, renders and writes the report: html_path (the page) and, when
// json_path is not empty, the data it is made from. Both atomically. Returns
// the data.
nlohmann::json WriteReport(const thermal::TalcLog& log, const Config& config,
                           const inspect::InspectionResult& measured,
                           const diagnosis::PreparedDiagnosis* diagnosis,
                           const std::filesystem::path& html_path,
                           const std::filesystem::path& json_path,
                           const ReportOptions& options = {});

}  // namespace ttp::report
