// `ttp report --log LOG MEASUREMENT -o report.html [--json data.json]`: the
// whole story of a run as one self-contained HTML page (docs/REPORT.md).
// `ttp report-html DATA.json -o report.html`: renders a report data file.
#include <cstdio>
#include <nlohmann/json.hpp>

#include "command.h"
#include "planned_cuts.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/inspect/measurement.h"
#include "ttp/report/assemble.h"
#include "ttp/report/report.h"
#include "ttp/report/thermal_report.h"
#include "ttp/thermal/check.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::app {
namespace {

void RegisterReport(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "report",
      "the report of a run: measured piece vs its simulation from the TALC "
      "log, verdict and diagnosis, as one HTML page");
  auto log_path = std::make_shared<std::string>();
  auto measurement = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>("report.html");
  auto json_out = std::make_shared<std::string>();
  auto options = std::make_shared<report::ReportOptions>();
  cmd->add_option("--log", *log_path, "TALC log (CSV)")->required();
  cmd->add_option("MEASUREMENT", *measurement,
                  "measured piece: point cloud (PLY, PCD, XYZ/CSV), "
                  "inspection JSON, dial-gauge CSV, DMIS output or probe "
                  "results; not needed for a thermal log (thermal-log.md)");
  cmd->add_option("-o,--output", *out, "HTML file to write");
  cmd->add_option("--json", *json_out,
                  "also write the report data (JSON) the page is made from");
  cmd->add_option("--limit-linear-um", options->limits.linear_um,
                  "limit of E_X, E_Y, E_Z, E_TTP (default 5 um)");
  cmd->add_option("--limit-angular-um-per-m", options->limits.angular_um_per_m,
                  "limit of E_B (default 15 um/m)");
  cmd->add_option("--evidence", options->diagnosis.evidence_threshold,
                  "BIC margin over the nominal model needed to name a cause "
                  "(default 10)");
  cmd->add_option("--title", options->title, "title of the page");
  auto no_schedule = std::make_shared<bool>(false);
  cmd->add_flag("--no-schedule-check", *no_schedule,
                "do not check the log's cuts against the program's schedule "
                "(for a log of another program)");
  cmd->callback([&global, log_path, measurement, out, json_out, options,
                 no_schedule] {
    if (report::LooksLikeThermalLog(ReadTextFile(*log_path))) {
      report::WriteThermalReport(*log_path, *out, *json_out);  // thermal log
      return;
    }
    if (measurement->empty())
      throw InputError("", 0, "MEASUREMENT", "required with a TALC log");
    const Config config = global.LoadConfig();
    const thermal::TalcLog log = thermal::ReadTalcLog(*log_path);
    // As `ttp diagnose`: a log that did not come from this program is an
    // input error.
    if (!*no_schedule)
      thermal::CheckLogAgainstSchedule(log, PlannedCuts(config));
    const inspect::Measurement m =
        inspect::LoadMeasurement(config, *measurement);
    const inspect::InspectionResult& measured = m.result;
    const std::string kind = inspect::MeasurementKindName(m.kind);
    report::ReportOptions o = *options;
    o.run_info.emplace("measurement kind", kind);
    const nlohmann::json data =
        report::WriteReport(log, config, measured, nullptr, *out, *json_out, o);
    if (!global.quiet) {
      std::fprintf(stderr, "report written to %s (verdict %s, cause %s)\n",
                   out->c_str(),
                   data["grade"]["verdict"].get<std::string>().c_str(),
                   data["diagnosis"]["cause"].get<std::string>().c_str());
    }
  });
}

void RegisterReportHtml(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "report-html", "render a report data file (JSON) as one HTML page");
  auto data_path = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>("report.html");
  cmd->add_option("DATA", *data_path, "report data (docs/REPORT.md)")
      ->required();
  cmd->add_option("-o,--output", *out, "HTML file to write ('-' = stdout)");
  cmd->callback([data_path, out, &global] {
    const std::string text = ReadTextFile(*data_path);
    nlohmann::json data;
    try {
      data = nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
      throw InputError(*data_path, 0, "", std::string("not JSON: ") + e.what());
    }
    try {
      WriteText(*out, RenderReportHtml(data));
    } catch (const InputError& e) {
      // Name the data file rather than the renderer's generic source.
      throw InputError(*data_path, e.line(), e.field(), e.problem());
    }
    if (!global.quiet && *out != "-") {
      std::fprintf(stderr, "report written to %s\n", out->c_str());
    }
  });
}

void Register(CLI::App& root, GlobalOptions& global) {
  RegisterReport(root, global);
  RegisterReportHtml(root, global);
}

}  // namespace
TTP_REGISTER_COMMANDS(80, Register);
}  // namespace ttp::app
