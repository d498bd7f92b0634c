#include "ttp/gcode/canon_to_program.h"

#include <cmath>

#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

Axes AllAxes(const CanonStatement& s) {
  return Axes{s.end_mm.x(), s.end_mm.y(), s.end_mm.z(),
              s.end_c_rad * 180.0 / M_PI};
}

}  // namespace

Program ProgramFromCanon(const std::vector<CanonStatement>& statements,
                         const std::string& name, int number,
                         const std::string& title, const std::string& source) {
  Program p;
  p.name = name;
  p.number = number;
  p.title = title;
  // The tool-length compensation in effect: switched before the first
  // motion that has another (a translated program keeps its G43 and G49).
  double offset_mm = 0;
  int offset_tool = -1;
  // Where the previous motion ended (the machine's start is not known: the
  // first motion is written absolute).
  Eigen::Vector3d position_mm = Eigen::Vector3d::Constant(std::nan(""));
  double c_rad = std::nan("");
  for (const CanonStatement& s : statements) {
    const bool motion = s.kind == CanonKind::kTraverse ||
                        s.kind == CanonKind::kFeed ||
                        s.kind == CanonKind::kProbe;
    if (motion && (s.length_offset_mm != offset_mm ||
                   s.length_offset_tool != offset_tool)) {
      if (s.length_offset_tool < 0 && s.length_offset_mm != 0)
        throw InputError(source, s.source_line, "G43",
                         "a tool-length offset without its tool number");
      p.statements.push_back(LengthCompensation{s.length_offset_tool});
      offset_mm = s.length_offset_mm;
      offset_tool = s.length_offset_tool;
    }
    // A turn of C alone by a whole turn or more is written incremental: on
    // a table with roll-over an absolute target one turn away is no move at
    // all. (Less than a turn stays absolute, as such programs write it.)
    const double dc_deg = (s.end_c_rad - c_rad) * 180.0 / M_PI;
    const bool c_turn =
        motion && s.end_mm == position_mm && std::abs(dc_deg) >= 360.0 - 1e-9;
    if (motion) {
      position_mm = s.end_mm;
      c_rad = s.end_c_rad;
    }
    switch (s.kind) {
      case CanonKind::kTraverse:
        if (c_turn)
          p.statements.push_back(Rapid{Axes{{}, {}, {}, dc_deg}, true});
        else
          p.statements.push_back(Rapid{AllAxes(s)});
        break;
      case CanonKind::kFeed:
        if (c_turn)
          p.statements.push_back(
              Feed{Axes{{}, {}, {}, dc_deg}, s.feed_per_min, true});
        else
          p.statements.push_back(Feed{AllAxes(s), s.feed_per_min});
        break;
      case CanonKind::kProbe:
        throw InputError(source, s.source_line, "probe",
                         "probe moves have no program IR statement");
      case CanonKind::kDwell:
        p.statements.push_back(Dwell{s.value});
        break;
      case CanonKind::kSpindle:
        if (s.value > 0)
          p.statements.push_back(SpindleOn{s.value, s.clockwise});
        else
          p.statements.push_back(SpindleOff{});
        break;
      case CanonKind::kCSpin:
        p.statements.push_back(CSpin{s.value});
        break;
      case CanonKind::kCoolant:
        p.statements.push_back(Coolant{s.value > 0});
        break;
      case CanonKind::kToolChange:
        p.statements.push_back(
            ToolChange{static_cast<int>(std::lround(s.value)), ""});
        break;
      case CanonKind::kClamp:
        p.statements.push_back(TableClamp{s.value > 0});
        break;
      case CanonKind::kReport: {
        ReportText r;
        if (!ParseReportText(s.text, &r))
          throw InputError(source, s.source_line, "report",
                           "expected <event>,<feature>,<c_deg>: " + s.text);
        p.statements.push_back(Report{r.event, r.feature, r.c_deg});
        break;
      }
      case CanonKind::kComment:
        p.statements.push_back(Comment{s.text});
        break;
      case CanonKind::kEnd:
        p.statements.push_back(ProgramEnd{});
        break;
    }
  }
  return p;
}

}  // namespace ttp::gcode
