// `ttp schedule`: every test feature with its planned cut start/end time,
// table angle and tool, and every R-test with its positions, from executing
// the test-cycle program.
#include <iostream>

#include "command.h"
#include "ttp/cam/schedule.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"

namespace ttp::app {
namespace {

void RegisterSchedule(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "schedule",
      "print the planned cut times, table angles and tools of the test "
      "features (from the test-cycle program's time model)");
  auto csv = std::make_shared<std::string>();
  auto json = std::make_shared<std::string>();
  cmd->add_option("--csv", *csv, "also write the schedule as CSV here");
  cmd->add_option("--json", *json, "also write the schedule as JSON here");
  auto rtests_csv = std::make_shared<std::string>();
  cmd->add_option("--rtests-csv", *rtests_csv,
                  "also write the R-tests (one row per table position, with "
                  "the TALC log row's time and duration) as CSV here");
  auto rtest_interval = std::make_shared<double>(-1.0);
  cmd->add_option("--rtest-interval", *rtest_interval,
                  "R-test every this many seconds (0 = none; default: "
                  "process.rtest_interval_s of the config)")
      ->check(FiniteRange(0.0, 86400.0));
  auto dry_run = std::make_shared<double>(-1.0);
  cmd->add_option("--dry-run", *dry_run,
                  "schedule of the dry run (`ttp gcode cycle --dry-run S`: "
                  "every dwell at most S seconds)")
      ->check(FiniteRange(0.0, 86400.0));
  cmd->callback([&global, csv, json, rtests_csv, rtest_interval, dry_run] {
    Config config = global.LoadConfig();
    if (*rtest_interval >= 0) config.process.rtest_interval_s = *rtest_interval;
    const cam::Schedule schedule = cam::BuildSchedule(config, *dry_run);
    OutputBatch outputs;  // all files or none
    if (!csv->empty()) outputs.Add(*csv, cam::ScheduleToCsv(schedule));
    if (!rtests_csv->empty())
      outputs.Add(*rtests_csv, cam::RTestsToCsv(schedule));
    if (!json->empty())
      outputs.Add(*json, JsonText(cam::ScheduleToJson(schedule), 2) + "\n");
    outputs.Commit();
    std::cout << cam::FormatScheduleTable(schedule);
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(25, RegisterSchedule);
}  // namespace ttp::app
