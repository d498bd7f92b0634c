// The program's cut schedule as the plain data the log check takes
// (thermal does not depend on cam).
#pragma once

#include <vector>

#include "ttp/cam/schedule.h"
#include "ttp/thermal/check.h"

namespace ttp::app {

inline std::vector<thermal::PlannedCut> PlannedCuts(const Config& config) {
  std::vector<thermal::PlannedCut> planned;
  for (const cam::ScheduledCut& c : cam::BuildSchedule(config).cuts)
    planned.push_back({c.feature, c.cycle, c.start_s, c.end_s, c.c_deg});
  return planned;
}

}  // namespace ttp::app
