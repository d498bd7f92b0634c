// `ttp check --log LOG MEASUREMENT`: measured and simulated figures side by
// side per cycle with U, and the temperature comparison of thesis 7.10.
// Before comparing, the log is checked against the program's schedule (cut
// names, order, times, coverage, R-tests around each cut). Exit 0 when every
// figure agrees within the combined U; 1 when one does not, or when log and
// measurement cannot be compared (refused); 2 when a file cannot be read.
#include <fmt/format.h>

#include "command.h"
#include "planned_cuts.h"
#include "ttp/geometry/error.h"
#include "ttp/inspect/measurement.h"
#include "ttp/thermal/check.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::app {
namespace {

void RegisterCheck(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "check",
      "measured vs simulated figures per cycle with U and the 7.10 "
      "temperature comparison; exit 0 agree, 1 disagree or refused (log and "
      "measurement cannot be compared), 2 a file cannot be read");
  auto log_path = std::make_shared<std::string>();
  auto measurement = std::make_shared<std::string>();
  auto json_out = std::make_shared<std::string>();
  auto tolerance = std::make_shared<double>(120.0);
  auto no_schedule = std::make_shared<bool>(false);
  cmd->add_option("--log", *log_path, "TALC log (CSV)")->required();
  cmd->add_option("measurement", *measurement,
                  "measured piece: point cloud (PLY/PCD/XYZ), inspection "
                  "JSON, dial-gauge CSV, DMIS output or probe results")
      ->required();
  cmd->add_option("--json", *json_out, "also write the check as JSON");
  auto how = std::make_shared<MeasurementArgs>();
  AddMeasurementOptions(cmd, how.get());
  cmd->add_option("--time-tolerance-s", *tolerance,
                  "how far a logged cut may end from its planned time "
                  "(default 120 s)")
      ->check(FiniteRange(0.0, 86400.0));
  cmd->add_flag("--no-schedule-check", *no_schedule,
                "skip the log <-> program schedule check");
  cmd->callback([&global, cmd, log_path, measurement, json_out, tolerance,
                 no_schedule, how] {
    const Config config = global.LoadConfig();
    const thermal::TalcLog log = ReadTalcLogWarning(*log_path, global);
    // Any measurement file (cloud, inspection JSON, dial CSV, DMIS output,
    // probe results).
    const inspect::Measurement loaded = inspect::LoadMeasurement(
        config, *measurement, ToMeasurementOptions(*how, *cmd));
    PrintMeasurementWarnings(*measurement, loaded.result.warnings, global);
    const std::vector<CycleFigures>& measured = loaded.result.figures;
    // Both read: from here on, a log and a measurement that cannot be
    // compared (the log does not follow the program, does not cover the
    // cuts, has no figure in common with the measurement) do not belong
    // together. Refused (exit 1), as the diagnosis says it (diagnosis.md
    // section 3), not bad input: both files were read.
    nlohmann::json schedule_json;
    thermal::CheckResult result;
    std::string refusal;
    try {
      if (!*no_schedule) {
        thermal::ScheduleCheckOptions so;
        so.tolerance_s = *tolerance;
        const thermal::ScheduleCheck sc =
            thermal::CheckLogAgainstSchedule(log, PlannedCuts(config), so);
        schedule_json = {{"offset_s", sc.offset_s},
                         {"max_deviation_s", sc.max_deviation_s},
                         {"matched_cuts", sc.matched},
                         {"tolerance_s", so.tolerance_s}};
      }
      result = thermal::CheckPiece(log, config, measured);
      if (result.compared == 0)
        throw InputError(*measurement, 0, "figures",
                         "the measurement gives no figure the simulation has");
    } catch (const InputError& e) {
      refusal = e.what();
    }
    if (!refusal.empty()) {
      if (!global.quiet || json_out->empty())
        TextOut(*json_out) << fmt::format(
            "status: refused\n  ({})\nthe measurement and the log cannot be "
            "compared: they do not belong together, or the log does not "
            "cover the piece's cuts\n",
            refusal);
      if (!json_out->empty())
        WriteJson(*json_out,
                  {{"status", "refused"},
                   {"reason", refusal},
                   {"agree", false},
                   {"compared", 0},
                   {"disagreements", 0},
                   {"cycles", nlohmann::json::array()},
                   {"log", *log_path},
                   {"measurement", *measurement},
                   {"measurement_warnings", loaded.result.warnings}});
      global.exit_code = kExitJudgedFailure;
      return;
    }
    if (!global.quiet || json_out->empty()) {
      std::string text = thermal::CheckTable(result);
      if (!schedule_json.is_null()) {
        text = fmt::format(
                   "schedule   {} cuts match the program (log = program + "
                   "{:.0f} s, largest deviation {:.0f} s)\n",
                   schedule_json["matched_cuts"].get<int>(),
                   schedule_json["offset_s"].get<double>(),
                   schedule_json["max_deviation_s"].get<double>()) +
               text;
      }
      TextOut(*json_out) << text;
    }
    if (!json_out->empty()) {
      nlohmann::json j = thermal::CheckToJson(result);
      j["status"] = result.agree() ? "agree" : "disagree";
      j["measurement"] = *measurement;
      j["measurement_warnings"] = loaded.result.warnings;
      j["schedule"] = schedule_json;
      WriteJson(*json_out, j);
    }
    if (!result.agree()) global.exit_code = kExitJudgedFailure;
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(42, RegisterCheck);
}  // namespace ttp::app
