// Canonical machine statements: what a program makes the machine do, after
// reading and interpreting the text (our reader, or rs274's canon output
// parsed back). Times come from the time model of the machine profile.
//
// CONTRACT between gcode (producer) and cam/verify, schedule (consumers).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace ttp::gcode {

enum class CanonKind {
  kTraverse,  // rapid, straight in XYZ and C
  kFeed,      // linear feed in XYZ and/or C
  kDwell,
  kSpindle,     // rpm (0 = off), clockwise
  kCSpin,       // C turning mode rpm (0 = off)
  kCoolant,     // on = value > 0
  kToolChange,  // tool number
  kClamp,       // table clamp on = value > 0
  kReport,      // text = "cut,<feature>,<c_deg>"
  kComment,
  kEnd,
  // Probe move (FANUC G31, LinuxCNC G38.2): straight feed towards end_mm
  // that stops on contact; the nominal end is the commanded target.
  kProbe,
};

const char* CanonKindName(CanonKind kind);

// The text of a kReport statement, "<event>,<feature>,<c_deg>".
struct ReportText {
  std::string event, feature;
  double c_deg = 0;
};
// False unless `text` has that form (all three fields, a number at the end).
bool ParseReportText(const std::string& text, ReportText* out);

struct CanonStatement {
  CanonKind kind;
  // Position after the statement (program coordinates, mm) and table angle
  // (rad); for non-motion statements the unchanged current position.
  Eigen::Vector3d end_mm = Eigen::Vector3d::Zero();
  double end_c_rad = 0;
  double feed_per_min = 0;  // kFeed: mm/min (deg/min if pure C)
  double value = 0;         // rpm, dwell seconds, tool, on/off
  bool clockwise = true;
  std::string text;
  // Tool-length compensation in effect at the statement: the length (mm)
  // G43 applies, 0 after G49 or before any G43; and the tool whose length
  // it is (G43 H), -1 when none or not known (rs274's canon gives only the
  // length). end_mm is the controlled point: the tool tip only when the
  // offset is the length of the tool in the spindle.
  double length_offset_mm = 0;
  int length_offset_tool = -1;
  int source_line = 0;  // line in the program text
  double start_s = 0;   // program time at start (time model)
  double duration_s = 0;
};

}  // namespace ttp::gcode
