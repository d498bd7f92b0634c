// `ttp schedule`: every test feature with its planned cut start/end time,
// table angle and tool, from executing the test-cycle program.
#include <iostream>

#include "command.h"
#include "ttp/cam/schedule.h"
#include "ttp/geometry/file_io.h"

namespace ttp::app {
namespace {

void Register(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "schedule",
      "print the planned cut times, table angles and tools of the test "
      "features (from the test-cycle program's time model)");
  auto csv = std::make_shared<std::string>();
  auto json = std::make_shared<std::string>();
  cmd->add_option("--csv", *csv, "also write the schedule as CSV here");
  cmd->add_option("--json", *json, "also write the schedule as JSON here");
  cmd->callback([&global, csv, json] {
    const cam::Schedule schedule = cam::BuildSchedule(global.LoadConfig());
    OutputBatch outputs;  // both files or neither
    if (!csv->empty()) outputs.Add(*csv, cam::ScheduleToCsv(schedule));
    if (!json->empty())
      outputs.Add(*json, cam::ScheduleToJson(schedule).dump(2) + "\n");
    outputs.Commit();
    std::cout << cam::FormatScheduleTable(schedule);
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(25, Register);
}  // namespace ttp::app
