#include <cmath>

#include "ttp/gcode/reader.h"

namespace ttp::gcode {

void ApplyTimeModel(std::vector<CanonStatement>& statements,
                    const MachineProfile& machine,
                    const Eigen::Vector3d& start_mm) {
  constexpr double kRadToDeg = 180.0 / M_PI;
  Eigen::Vector3d position_mm = start_mm;
  double c_rad = 0;
  double c_rpm = 0;
  double t_s = 0;
  for (CanonStatement& s : statements) {
    const double length_mm = (s.end_mm - position_mm).norm();
    const double c_move_deg = std::abs(s.end_c_rad - c_rad) * kRadToDeg;
    double duration_s = 0;
    switch (s.kind) {
      case CanonKind::kTraverse:
        duration_s = std::max(length_mm / machine.rapid_mm_min * 60.0,
                              c_move_deg / machine.c_index_deg_s);
        break;
      case CanonKind::kFeed:
      case CanonKind::kProbe:
        if (s.feed_per_min > 0) {
          const double travel = length_mm > 0 ? length_mm : c_move_deg;
          duration_s = travel / s.feed_per_min * 60.0;
        }
        break;
      case CanonKind::kDwell:
        duration_s = s.value;
        break;
      case CanonKind::kCSpin:
        duration_s =
            machine.c_spinup_s * std::abs(s.value - c_rpm) / machine.c_max_rpm;
        c_rpm = s.value;
        break;
      default:
        break;
    }
    s.start_s = t_s;
    s.duration_s = duration_s;
    t_s += duration_s;
    position_mm = s.end_mm;
    c_rad = s.end_c_rad;
  }
}

double TotalDuration(const std::vector<CanonStatement>& statements) {
  if (statements.empty()) return 0;
  return statements.back().start_s + statements.back().duration_s;
}

}  // namespace ttp::gcode
