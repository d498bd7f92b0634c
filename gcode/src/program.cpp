#include "ttp/gcode/program.h"

#include <cstdlib>

#include "ttp/gcode/canon.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {

Dialect ParseDialect(const std::string& name, const std::string& source) {
  if (name == "fanuc") return Dialect::kFanuc;
  if (name == "linuxcnc") return Dialect::kLinuxCnc;
  throw InputError(source, 0, "dialect",
                   "'" + name + "' is not one of fanuc, linuxcnc");
}

const char* DialectName(Dialect d) {
  return d == Dialect::kFanuc ? "fanuc" : "linuxcnc";
}

bool ParseReportText(const std::string& text, ReportText* out) {
  const size_t a = text.find(',');
  if (a == std::string::npos) return false;
  const size_t b = text.find(',', a + 1);
  if (b == std::string::npos) return false;
  out->event = text.substr(0, a);
  out->feature = text.substr(a + 1, b - a - 1);
  const std::string angle = text.substr(b + 1);
  char* end = nullptr;
  out->c_deg = std::strtod(angle.c_str(), &end);
  return !out->event.empty() && !out->feature.empty() && !angle.empty() &&
         *end == '\0';
}

const char* CanonKindName(CanonKind kind) {
  switch (kind) {
    case CanonKind::kTraverse:
      return "traverse";
    case CanonKind::kFeed:
      return "feed";
    case CanonKind::kDwell:
      return "dwell";
    case CanonKind::kSpindle:
      return "spindle";
    case CanonKind::kCSpin:
      return "c_spin";
    case CanonKind::kCoolant:
      return "coolant";
    case CanonKind::kToolChange:
      return "tool_change";
    case CanonKind::kClamp:
      return "clamp";
    case CanonKind::kReport:
      return "report";
    case CanonKind::kComment:
      return "comment";
    case CanonKind::kEnd:
      return "end";
    case CanonKind::kProbe:
      return "probe";
  }
  return "?";
}

}  // namespace ttp::gcode
