// The report of a thermal log (thermal-log.md): every model structure
// compared on a chronological holdout, per output the measured and the
// predicted displacement over time and the residual against the leading
// temperature, and the TALC replay of the default strategy (P99 against
// the measurement interval, the hourly compensation over time), as one
// self-contained HTML page (uPlot embedded).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "ttp/models/compare.h"

namespace ttp::report {

// The data the page is drawn from (JSON, also written by --json).
nlohmann::json ThermalReportData(const models::CompareResult& r);
std::string ThermalReportHtml(const nlohmann::json& data,
                              const std::string& title);

// True when `text` is a thermal log (its comment block holds
// `# thermal-log:`), as opposed to a TALC log.
bool LooksLikeThermalLog(const std::string& text);

// `ttp report` on a thermal log: compares the structures with the holdout
// starting at two thirds of the log's span, replays TALC (data["replay"]),
// writes the page (and the data as JSON when json_out is not empty).
// Returns the data.
nlohmann::json WriteThermalReport(const std::string& log_path,
                                  const std::string& html_out,
                                  const std::string& json_out);

}  // namespace ttp::report
