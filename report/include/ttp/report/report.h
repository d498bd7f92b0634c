// The human-readable report of a thermal test: one self-contained HTML file
// (uPlot and all CSS/JS inlined, no network) rendered from one JSON
// document whose schema is docs/REPORT.md. Inspection, the log reader,
// the simulation and the diagnosis each fill their part; a part left out is
// shown as "not available".
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace ttp {

// Current schema tag; documents carry it in "schema".
constexpr const char* kReportSchema = "ttp-report/1";

// Checks `report_data` against docs/REPORT.md. Throws InputError(source,
// 0, "<JSON path>", problem), e.g. field "figures.measured[3].U.E_X".
void ValidateReportData(const nlohmann::json& report_data,
                        const std::string& source = "report data");

// Validates, then renders the report. Same input gives the same bytes.
std::string RenderReportHtml(const nlohmann::json& report_data);

}  // namespace ttp

namespace ttp {

constexpr const char* kCompareSchema = "ttp-compare/1";
// Renders a comparison of two pieces (AssembleComparisonData). Same input
// gives the same bytes.
std::string RenderComparisonHtml(const nlohmann::json& compare_data);

}  // namespace ttp
