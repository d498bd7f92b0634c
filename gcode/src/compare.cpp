#include <fmt/format.h>

#include <cmath>

#include "ttp/gcode/rs274.h"

namespace ttp::gcode {
namespace {

bool IsMotion(CanonKind k) {
  return k == CanonKind::kTraverse || k == CanonKind::kFeed ||
         k == CanonKind::kProbe;
}

std::vector<size_t> Compared(const std::vector<CanonStatement>& s) {
  std::vector<size_t> out;
  for (size_t i = 0; i < s.size(); ++i)
    if (s[i].kind != CanonKind::kComment) out.push_back(i);
  return out;
}

// Empty when equal, else why not.
std::string Differ(const CanonStatement& a, const CanonStatement& b,
                   double tolerance_mm, double tolerance_rad) {
  if (a.kind != b.kind)
    return fmt::format("kind {} vs {}", CanonKindName(a.kind),
                       CanonKindName(b.kind));
  if (IsMotion(a.kind)) {
    const double d = (a.end_mm - b.end_mm).cwiseAbs().maxCoeff();
    if (d > tolerance_mm)
      return fmt::format(
          "end ({:.6f}, {:.6f}, {:.6f}) vs ({:.6f}, {:.6f}, "
          "{:.6f}) mm",
          a.end_mm.x(), a.end_mm.y(), a.end_mm.z(), b.end_mm.x(), b.end_mm.y(),
          b.end_mm.z());
    if (std::abs(a.length_offset_mm - b.length_offset_mm) > tolerance_mm)
      return fmt::format("tool-length offset {:.6f} vs {:.6f} mm",
                         a.length_offset_mm, b.length_offset_mm);
    if (std::abs(a.end_c_rad - b.end_c_rad) > tolerance_rad)
      return fmt::format("C {:.9f} vs {:.9f} rad", a.end_c_rad, b.end_c_rad);
    if (a.kind != CanonKind::kTraverse &&
        std::abs(a.feed_per_min - b.feed_per_min) >
            1e-9 * std::max(1.0, std::abs(a.feed_per_min)))
      return fmt::format("feed {} vs {} per min", a.feed_per_min,
                         b.feed_per_min);
    return "";
  }
  switch (a.kind) {
    case CanonKind::kDwell:
    case CanonKind::kCoolant:
    case CanonKind::kClamp:
    case CanonKind::kToolChange:
      if (std::abs(a.value - b.value) > 1e-9)
        return fmt::format("value {} vs {}", a.value, b.value);
      return "";
    case CanonKind::kSpindle:
    case CanonKind::kCSpin:
      if (std::abs(a.value - b.value) > 1e-9)
        return fmt::format("rpm {} vs {}", a.value, b.value);
      if (a.value > 0 && a.clockwise != b.clockwise) return "direction";
      return "";
    case CanonKind::kReport:
      if (a.text != b.text)
        return fmt::format("report '{}' vs '{}'", a.text, b.text);
      return "";
    default:
      return "";
  }
}

}  // namespace

ToolpathDifference CompareToolpaths(const std::vector<CanonStatement>& a,
                                    const std::vector<CanonStatement>& b,
                                    double tolerance_mm, double tolerance_rad) {
  const auto ia = Compared(a), ib = Compared(b);
  ToolpathDifference diff;
  const size_t n = std::min(ia.size(), ib.size());
  for (size_t k = 0; k < n; ++k) {
    const std::string why =
        Differ(a[ia[k]], b[ib[k]], tolerance_mm, tolerance_rad);
    if (why.empty()) continue;
    diff.same = false;
    diff.index_a = ia[k];
    diff.index_b = ib[k];
    diff.line_a = a[ia[k]].source_line;
    diff.line_b = b[ib[k]].source_line;
    diff.what = fmt::format("statement {}: {}", k, why);
    return diff;
  }
  if (ia.size() != ib.size()) {
    diff.same = false;
    diff.index_a = n < ia.size() ? ia[n] : a.size();
    diff.index_b = n < ib.size() ? ib[n] : b.size();
    diff.line_a = n < ia.size() ? a[ia[n]].source_line : 0;
    diff.line_b = n < ib.size() ? b[ib[n]].source_line : 0;
    diff.what =
        fmt::format("{} vs {} compared statements", ia.size(), ib.size());
  }
  return diff;
}

}  // namespace ttp::gcode
