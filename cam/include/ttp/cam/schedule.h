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
#include "ttp/geometry/features.h"

namespace ttp::cam {

struct ScheduledCut {
  FeatureId feature;    // named as in talc-log.md section 5: "Z5", "X1-5"
  int cycle = 0;        // 0 = reference
  int index = 0;        // facet j or strip k
  double start_s = 0;   // program time the cutting pass starts
  double end_s = 0;     // program time it ends (= the report)
  double c_deg = 0;     // commanded table angle during the cut
  int tool = 0;         // tool number
  std::string tool_name;
  int source_line = 0;  // line of the report in the program text
};

// One position of an R-test: the sphere measured with the table at c_deg
// from measure_s (the measurement's start) to report_s (its report).
struct ScheduledRTestPosition {
  int position = 0;  // 1..5
  double c_deg = 0;
  double measure_s = 0;
  double report_s = 0;
  int source_line = 0;  // line of the report
};

// An R-test of the program (cam/programs.h) and the `rtest` row it gives in
// the TALC log (talc-log.md): the row comes when the measurement has ended
// (log_t_s, the last position's report) and covers dur_s from the first
// position's measurement start.
struct ScheduledRTest {
  int number = 0;
  int after_cycle = 0;  // the last cycle started before it
  double start_s = 0;   // program time the R-test starts (probe change)
  double end_s = 0;     // finishing tool back at the waiting position
  double log_t_s = 0;
  double dur_s = 0;
  std::vector<ScheduledRTestPosition> positions;
};

struct Schedule {
  double cycle_period_s = 0;
  std::vector<double> cycle_start_s;   // program time of each cycle's start
  double total_s = 0;                  // program length
  std::vector<ScheduledCut> cuts;      // in cutting order
  std::vector<ScheduledRTest> rtests;  // in program order
  // Commanded table angles (deg in [0, 360)) of every cut and R-test
  // position, in program order: what the controller's C must run through.
  std::vector<double> table_angles_deg;
};

// Builds the test-cycle program, writes it (LinuxCNC), reads it back and
// extracts the schedule. Throws InputError on a bad config. dry_run_s >= 0:
// of the dry run (cam::ShortenDwells, as `ttp gcode cycle --dry-run`).
Schedule BuildSchedule(const Config& config, double dry_run_s = -1);

// From canonical statements of any test-cycle program (either dialect):
// each cut report ends a cut that started with the last feed before it;
// cycle starts are the "cycle <k>" comments; R-tests run from their
// "R-test <n>" to their "R-test <n> done" comment, each position measured
// from the dwell before its `rtest` report. Throws InputError(source, line,
// "report", ...) on a report whose feature is not a test feature.
Schedule ScheduleFromCanon(const std::vector<gcode::CanonStatement>& canon,
                           const Config& config, const std::string& source);

std::string ScheduleToCsv(const Schedule& schedule);
// One row per R-test position; log_t_s and dur_s are the R-test's row in
// the TALC log.
std::string RTestsToCsv(const Schedule& schedule);
nlohmann::json ScheduleToJson(const Schedule& schedule);
// Aligned text table for a terminal.
std::string FormatScheduleTable(const Schedule& schedule);

// Atomic writes (WriteFileAtomic).
void WriteScheduleCsv(const std::filesystem::path& path,
                      const Schedule& schedule);
void WriteScheduleJson(const std::filesystem::path& path,
                       const Schedule& schedule);

}  // namespace ttp::cam
