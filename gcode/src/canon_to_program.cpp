#include "ttp/gcode/canon_to_program.h"

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

Axes AllAxes(const CanonStatement& s) {
  return Axes{s.end_mm.x(), s.end_mm.y(), s.end_mm.z(),
              s.end_c_rad * 180.0 / M_PI};
}

// The header row of ttp's probing log (FANUC DPRNT after POPEN), as read.
constexpr const char* kProbeLogHeader = "TTP,PROBE,LOG,";

std::vector<std::string> SplitCommas(const std::string& text) {
  std::vector<std::string> out(1);
  for (char ch : text) {
    if (ch == ',')
      out.emplace_back();
    else
      out.back() += ch;
  }
  return out;
}

// The log row a FANUC probing program prints after a probe move
// (PASS*ID*FEATURE*X#5061[44]*..., read as "PASS,ID,FEATURE,X#...,..."):
// the probe move's point, feature and pass, or false for another text.
bool ParseProbeRow(const std::string& text, Probe* probe) {
  const std::vector<std::string> f = SplitCommas(text);
  if (f.size() < 4 || f[0].empty() || f[2].empty() || f[3].rfind("X#", 0) != 0)
    return false;
  char* end = nullptr;
  const long id = std::strtol(f[1].c_str(), &end, 10);
  if (f[1].empty() || *end != '\0' || id < 0 || id > 1000000000) return false;
  probe->point_id = static_cast<int>(id);
  probe->feature = f[2];
  probe->pass = Lower(f[0]);
  return true;
}

}  // namespace

bool IsProbeLogReport(const std::string& text) {
  Probe probe{};
  return text.rfind(kProbeLogHeader, 0) == 0 || ParseProbeRow(text, &probe);
}

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
  // A probing program's log: opened by its header row, closed at the end.
  bool probe_log_open = false;
  std::vector<bool> consumed(statements.size(), false);
  for (size_t index = 0; index < statements.size(); ++index) {
    if (consumed[index]) continue;
    const CanonStatement& s = statements[index];
    const Eigen::Vector3d previous_mm = position_mm;
    const double previous_c_rad = c_rad;
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
      case CanonKind::kProbe: {
        // A probe move runs along one linear axis from where the last
        // move ended.
        Probe probe{{},        s.feed_per_min, 0,   "probe",
                    "measure", std::nan(""),   1.0, 1};
        int axes = 0;
        for (int a = 0; a < 3; ++a) {
          if (!std::isfinite(previous_mm[a]))
            throw InputError(source, s.source_line, "probe",
                             "a probe move before any position is known");
          if (std::abs(s.end_mm[a] - previous_mm[a]) <= 1e-9) continue;
          ++axes;
          (a == 0   ? probe.to.x_mm
           : a == 1 ? probe.to.y_mm
                    : probe.to.z_mm) = s.end_mm[a];
        }
        if (axes != 1 || std::abs(s.end_c_rad - previous_c_rad) > 1e-12)
          throw InputError(source, s.source_line, "probe",
                           "a probe move along more than one axis (or with "
                           "C) cannot be written in the other dialect");
        // The log row printed after it names its point, feature and pass
        // (the LinuxCNC program writes the row with the move). The nominal
        // contact stays unknown: a FANUC touch check cannot be written.
        for (size_t j = index + 1; j < statements.size(); ++j) {
          const CanonKind k = statements[j].kind;
          if (k == CanonKind::kComment) continue;
          if (k == CanonKind::kReport &&
              ParseProbeRow(statements[j].text, &probe))
            consumed[j] = true;
          break;
        }
        p.statements.push_back(probe);
        break;
      }
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
        if (s.text.rfind(kProbeLogHeader, 0) == 0) {
          p.statements.push_back(ProbeLog{true, "ttp-probe-log.csv"});
          probe_log_open = true;
          break;
        }
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
        if (probe_log_open) p.statements.push_back(ProbeLog{false, ""});
        probe_log_open = false;
        p.statements.push_back(ProgramEnd{});
        break;
    }
  }
  return p;
}

}  // namespace ttp::gcode
