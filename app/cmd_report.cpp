// `ttp report [--log LOG] MEASUREMENT -o report.html [--json data.json]`:
// the whole story of a run as one self-contained HTML page; `ttp report
// --compare A B -o compare.html`: two pieces side by side (docs/REPORT.md).
// The grade and the diagnosis are computed here by their modules; the report
// module only renders them.
// `ttp report-html DATA.json -o report.html`: renders a report data file.
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "command.h"
#include "planned_cuts.h"
#include "ttp/diagnosis/diagnose.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/inspect/grade.h"
#include "ttp/inspect/measurement.h"
#include "ttp/report/assemble.h"
#include "ttp/report/report.h"
#include "ttp/report/thermal_report.h"
#include "ttp/thermal/check.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::app {
namespace {

// Never overwrite an input, and never write into a folder that is not
// there (a typo would otherwise scatter files).
void CheckOutputPath(const std::string& out,
                     const std::vector<std::string>& inputs,
                     const char* option) {
  namespace fs = std::filesystem;
  const fs::path p(out);
  const fs::path dir = p.parent_path();
  if (!dir.empty() && !fs::is_directory(dir))
    throw InputError(option, 0, "output",
                     "the folder '" + dir.string() + "' does not exist");
  std::error_code ec;
  if (fs::is_directory(p, ec))
    throw InputError(option, 0, "output",
                     "'" + out + "' is a folder, not a file");
  for (const std::string& in : inputs) {
    if (!in.empty() && fs::exists(p) && fs::equivalent(p, in, ec))
      throw InputError(option, 0, "output",
                       "'" + out + "' is an input of this command");
  }
}

void RegisterReport(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "report",
      "the report of a run as one HTML page: the measured piece, its verdict "
      "(as `ttp grade`), and with --log its simulation from the TALC log and "
      "the diagnosis; exit 1 unless the verdict is pass and the diagnosis is "
      "not refused");
  auto log_path = std::make_shared<std::string>();
  auto measurement = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto json_out = std::make_shared<std::string>();
  auto compare = std::make_shared<std::vector<std::string>>();
  auto options = std::make_shared<report::ReportOptions>();
  auto limits = std::make_shared<inspect::GradeLimits>();
  auto figures = std::make_shared<std::string>("thesis");
  cmd->add_option("MEASUREMENT", *measurement,
                  "measured piece: point cloud (PLY, PCD, XYZ/CSV), "
                  "inspection JSON, dial-gauge CSV, DMIS output or probe "
                  "results; not needed for a thermal log (thermal-log.md)");
  cmd->add_option("--log", *log_path,
                  "TALC log (CSV); without it the page shows the piece and "
                  "its verdict only (e.g. an uncompensated acceptance test). "
                  "A thermal log (thermal-log.md) alone gives its page: the "
                  "thermal error models compared and TALC replayed");
  cmd->add_option("--compare", *compare,
                  "two measured pieces, A (e.g. without compensation) and B "
                  "(with): their figures side by side and the spans over "
                  "1 h, 4 h and 8 h (thesis table 7.2)")
      ->expected(2);
  cmd->add_option("-o,--output", *out,
                  "HTML file to write (required; its folder must exist; "
                  "an existing file is replaced, an input never)")
      ->required();
  cmd->add_option("--json", *json_out,
                  "also write the report data (JSON) the page is made from");
  AddLimitOptions(cmd, limits.get(), figures.get());
  auto how = std::make_shared<MeasurementArgs>();
  AddMeasurementOptions(cmd, how.get());
  cmd->add_option("--evidence", options->diagnosis.evidence_threshold,
                  "BIC margin over the nominal model needed to name a cause")
      ->capture_default_str();
  cmd->add_option("--title", options->title, "title of the page")
      ->capture_default_str();
  auto no_schedule = std::make_shared<bool>(false);
  cmd->add_flag("--no-schedule-check", *no_schedule,
                "do not check the log's cuts against the program's schedule "
                "(for a log of another program)");
  cmd->callback([&global, cmd, log_path, measurement, out, json_out, compare,
                 options, limits, figures, no_schedule, how] {
    limits->figures = inspect::ParseFigureList(*figures);
    limits->Validate();
    // A thermal log given as the measurement (`ttp report train.csv -o
    // page.html`) is that log's page, as with --log.
    if (log_path->empty() && compare->empty() && !measurement->empty() &&
        inspect::SniffLogFormat(ReadFileHead(*measurement, 4096)) ==
            "thermal-log") {
      *log_path = *measurement;
      measurement->clear();
    }
    if (!log_path->empty() &&
        report::LooksLikeThermalLog(ReadFileHead(*log_path, 4096))) {
      // A thermal log's page is the log's alone: a piece given beside it
      // would silently not be shown.
      if (!measurement->empty() || !compare->empty())
        throw InputError(
            "report", 0, measurement->empty() ? "--compare" : "MEASUREMENT",
            fmt::format("{} is a thermal log (thermal-log.md), whose page "
                        "shows no measured piece: give the piece's TALC log "
                        "as --log, or the thermal log alone",
                        *log_path));
      CheckOutputPath(*out, {*log_path}, "--output");
      if (!json_out->empty()) CheckOutputPath(*json_out, {*log_path}, "--json");
      report::WriteThermalReport(*log_path, *out, *json_out);  // thermal log
      return;
    }
    const Config config = global.LoadConfig();
    const inspect::MeasurementOptions measured_how =
        ToMeasurementOptions(*how, *cmd);
    if (!compare->empty()) {
      if (!measurement->empty() || !log_path->empty())
        throw InputError("--compare", 0, "compare",
                         "give either --compare A B or one MEASUREMENT "
                         "(with --log)");
      std::error_code same_ec;
      if (std::filesystem::equivalent((*compare)[0], (*compare)[1], same_ec))
        std::fprintf(stderr,
                     "warning: --compare: %s and %s are the same file\n",
                     (*compare)[0].c_str(), (*compare)[1].c_str());
      CheckOutputPath(*out, *compare, "--output");
      if (!json_out->empty()) CheckOutputPath(*json_out, *compare, "--json");
      const inspect::Measurement a =
          inspect::LoadMeasurement(config, (*compare)[0], measured_how);
      const inspect::Measurement b =
          inspect::LoadMeasurement(config, (*compare)[1], measured_how);
      const inspect::GradeResult ga = inspect::GradeMeasurement(a, *limits);
      const inspect::GradeResult gb = inspect::GradeMeasurement(b, *limits);
      const std::string title = options->title == report::ReportOptions{}.title
                                    ? "Thermal test pieces compared"
                                    : options->title;
      const nlohmann::json data = report::WriteComparison(
          config, {&a, &ga}, {&b, &gb}, *out, *json_out, title);
      if (!global.quiet)
        std::fprintf(stderr, "comparison written to %s (A %s, B %s)\n",
                     out->c_str(), inspect::VerdictName(ga.overall),
                     inspect::VerdictName(gb.overall));
      // As for one piece: exit 1 unless both verdicts are pass.
      if (ga.overall != inspect::Verdict::kPass ||
          gb.overall != inspect::Verdict::kPass)
        global.exit_code = kExitJudgedFailure;
      return;
    }
    if (measurement->empty())
      throw InputError("report", 0, "MEASUREMENT",
                       "missing: give the measured piece (or --compare A B)");
    CheckOutputPath(*out, {*measurement, *log_path}, "--output");
    if (!json_out->empty())
      CheckOutputPath(*json_out, {*measurement, *log_path}, "--json");
    const inspect::Measurement m =
        inspect::LoadMeasurement(config, *measurement, measured_how);
    // The verdict of `ttp grade`, computed once and rendered as is.
    const inspect::GradeResult grade = inspect::GradeMeasurement(m, *limits);
    report::ReportInputs inputs;
    inputs.measurement = &m;
    inputs.grade = &grade;
    std::optional<thermal::TalcLog> log;
    diagnosis::PreparedDiagnosis diagnosed;
    diagnosis::DiagnosisExplanation explained;
    if (!log_path->empty()) {
      log = ReadTalcLogWarning(*log_path, global);
      // As `ttp diagnose`: a log that did not come from this program (or
      // does not cover its cuts) cannot belong to the measured piece: the
      // diagnosis is refused, and the page says so with the piece's grade.
      std::string refusal = *no_schedule ? "" : ScheduleRefusal(*log, config);
      if (refusal.empty()) {
        const diagnosis::MeasuredPiece piece =
            diagnosis::MeasuredPieceFromInspection(config.part, m.result);
        try {
          diagnosed.run =
              diagnosis::PrepareRun(*log, config, piece, options->diagnosis);
          diagnosed.report = diagnosis::DiagnosePrepared(
              diagnosed.run, *log, config.part, piece, options->diagnosis);
        } catch (const InputError& e) {
          if (!RefusesTheDiagnosis(e)) throw;
          diagnosed.run = {};
          refusal = e.what();
        }
      }
      if (!refusal.empty()) {
        diagnosed.report = {};
        diagnosed.report.status = diagnosis::DiagnosisStatus::kRefused;
        diagnosed.report.reason = refusal;
      }
      explained = diagnosis::ExplainDiagnosis(
          diagnosed.run, diagnosed.report, config.part,
          options->diagnosis.evidence_threshold);
      inputs.log = &*log;
      inputs.diagnosis = &diagnosed;
      inputs.explanation = &explained;
    }
    const nlohmann::json data =
        report::WriteReport(config, inputs, *out, *json_out, *options);
    if (!global.quiet) {
      // The diagnosis as its status says it: a cause only when one is named.
      std::string diagnosis;
      if (inputs.diagnosis) {
        diagnosis = std::string("; diagnosis ") +
                    diagnosis::StatusName(diagnosed.report.status);
        if (diagnosed.report.status == diagnosis::DiagnosisStatus::kNamed)
          diagnosis += " " + diagnosed.report.cause;
      }
      std::fprintf(stderr, "report written to %s: %s%s\n", out->c_str(),
                   data["grade"]["summary"].get<std::string>().c_str(),
                   diagnosis.c_str());
    }
    // Exit 1 unless the verdict is pass and the diagnosis (when there is
    // one) is not refused: both are judged outcomes.
    if (grade.overall != inspect::Verdict::kPass ||
        (inputs.diagnosis &&
         diagnosed.report.status == diagnosis::DiagnosisStatus::kRefused))
      global.exit_code = kExitJudgedFailure;
  });
}

void RegisterReportHtml(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "report-html", "render a report data file (JSON) as one HTML page");
  auto data_path = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  cmd->add_option("DATA", *data_path, "report data (docs/REPORT.md)")
      ->required();
  cmd->add_option("-o,--output", *out,
                  "HTML file to write ('-' = stdout; required; its folder "
                  "must exist)")
      ->required();
  cmd->callback([data_path, out, &global] {
    if (*out != "-") CheckOutputPath(*out, {*data_path}, "--output");
    const nlohmann::json data = ReadJsonFile(*data_path);
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

void RegisterReportCommands(CLI::App& root, GlobalOptions& global) {
  RegisterReport(root, global);
  RegisterReportHtml(root, global);
}

}  // namespace
TTP_REGISTER_COMMANDS(80, RegisterReportCommands);
}  // namespace ttp::app
