// The test-cycle schedule: every feature with its planned cut start and end
// time, table angle and tool, taken from executing the written program (the
// gcode reader's canonical statements and time model), not from a separate
// estimate.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/geometry/config.h"

namespace ttp::cam {

struct ScheduledCut {
  std::string feature;  // talc-log.md section 5: "Z5", "X1-5"
  int cycle = 0;        // 0 = reference
  int index = 0;        // facet j or strip k
  double start_s = 0;   // program time the cutting pass starts
  double end_s = 0;     // program time it ends (= the report)
  double c_deg = 0;     // commanded table angle during the cut
  int tool = 0;         // tool number
  std::string tool_name;
  int source_line = 0;  // line of the report in the program text
};

struct Schedule {
  double cycle_period_s = 0;
  std::vector<double> cycle_start_s;  // program time of each cycle's start
  double total_s = 0;                 // program length
  std::vector<ScheduledCut> cuts;     // in cutting order
};

// Builds the test-cycle program, writes it (LinuxCNC), reads it back and
// extracts the schedule. Throws InputError on a bad config.
Schedule BuildSchedule(const Config& config);

// From canonical statements of any test-cycle program (either dialect):
// each report ends a cut that started with the last feed before it; cycle
// starts are the "cycle <k>" comments. Throws InputError(source, line,
// "report", ...) on a report whose feature is not a test feature.
Schedule ScheduleFromCanon(const std::vector<gcode::CanonStatement>& canon,
                           const Config& config, const std::string& source);

std::string ScheduleToCsv(const Schedule& schedule);
nlohmann::json ScheduleToJson(const Schedule& schedule);
// Aligned text table for a terminal.
std::string FormatScheduleTable(const Schedule& schedule);

// Atomic writes (WriteFileAtomic).
void WriteScheduleCsv(const std::filesystem::path& path,
                      const Schedule& schedule);
void WriteScheduleJson(const std::filesystem::path& path,
                       const Schedule& schedule);

}  // namespace ttp::cam
