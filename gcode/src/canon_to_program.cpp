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
  for (const CanonStatement& s : statements) {
    switch (s.kind) {
      case CanonKind::kTraverse:
        p.statements.push_back(Rapid{AllAxes(s)});
        break;
      case CanonKind::kFeed:
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
