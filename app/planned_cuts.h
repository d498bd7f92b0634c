// The program's cut schedule as the plain data the log check takes
// (thermal does not depend on cam).
#pragma once

#include <string>
#include <vector>

#include "ttp/cam/schedule.h"
#include "ttp/geometry/error.h"
#include "ttp/thermal/check.h"

namespace ttp::app {

inline std::vector<thermal::PlannedCut> PlannedCuts(const Config& config) {
  std::vector<thermal::PlannedCut> planned;
  for (const cam::ScheduledCut& c : cam::BuildSchedule(config).cuts)
    planned.push_back({c.feature, c.cycle, c.start_s, c.end_s, c.c_deg});
  return planned;
}

// The program's schedule checked on the log: empty when the log follows
// it, else why the log and the piece cannot belong together (the reason a
// diagnosis is refused with, in `diagnose` and `report` alike).
inline std::string ScheduleRefusal(const thermal::TalcLog& log,
                                   const Config& config) {
  try {
    thermal::CheckLogAgainstSchedule(log, PlannedCuts(config));
  } catch (const InputError& e) {
    return std::string(
               "the log does not match the program that cut the "
               "piece: ") +
           e.what();
  }
  return "";
}

// An error of the diagnosis that refuses it rather than the input: cuts the
// log's R-tests do not cover (t_s), or too few R-tests to give the machine's
// error (rtest). Both files were read; the log cannot explain this piece.
inline bool RefusesTheDiagnosis(const InputError& e) {
  return e.field() == "t_s" || e.field() == "rtest";
}

}  // namespace ttp::app
