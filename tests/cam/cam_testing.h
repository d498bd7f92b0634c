// Helpers shared by the cam tests: programs read back into canonical
// statements, and the cuts they report.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ttp/cam/programs.h"
#include "ttp/gcode/canon.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"

namespace ttp::cam::testing {

inline std::vector<gcode::CanonStatement> ReadBack(
    const gcode::Program& program, gcode::Dialect dialect,
    const Config& config) {
  const std::string text = gcode::WriteProgram(program, dialect, config);
  return gcode::ReadProgram(text, dialect, config, program.name);
}

// A reported cut: the feed move before the report, from `from` to `to`
// (program coordinates), at table angle c_rad.
struct ReportedCut {
  std::string feature;
  double report_c_deg = 0;
  Eigen::Vector3d from, to;
  double c_rad = 0;
  double start_s = 0, end_s = 0;
};

inline std::vector<ReportedCut> ReportedCuts(
    const std::vector<gcode::CanonStatement>& canon) {
  std::vector<ReportedCut> cuts;
  int last_feed = -1;
  for (size_t i = 0; i < canon.size(); ++i) {
    const gcode::CanonStatement& s = canon[i];
    if (s.kind == gcode::CanonKind::kFeed) last_feed = static_cast<int>(i);
    if (s.kind != gcode::CanonKind::kReport) continue;
    ReportedCut cut;
    gcode::ReportText report;
    EXPECT_TRUE(gcode::ParseReportText(s.text, &report)) << s.text;
    cut.feature = report.feature;
    cut.report_c_deg = report.c_deg;
    if (last_feed > 0) {
      const gcode::CanonStatement& f = canon[last_feed];
      cut.from = canon[last_feed - 1].end_mm;
      cut.to = f.end_mm;
      cut.c_rad = f.end_c_rad;
      cut.start_s = f.start_s;
      cut.end_s = f.start_s + f.duration_s;
    }
    cuts.push_back(cut);
  }
  return cuts;
}

}  // namespace ttp::cam::testing
