#include "ttp/inspect/plane_result.h"

#include <cmath>

namespace ttp::inspect {

FeatureResult FeatureResultFromPlane(const NominalFeature& nominal,
                                     const PlaneInW& plane, double top_z_mm) {
  Eigen::Vector3d n = plane.normal.normalized();
  if (n.dot(nominal.normal) < 0) n = -n;
  FeatureResult r;
  r.present = true;
  if (nominal.kind == FeatureKind::kStrip) {
    // z on the plane at (0, y_k): n . (q - p) = 0 solved for q.z.
    const double y = nominal.point.y();
    const Eigen::Vector3d& p = plane.point_mm;
    const double z =
        p.z() - (n.x() * (0.0 - p.x()) + n.y() * (y - p.y())) / n.z();
    r.d_mm = top_z_mm - z;
    r.angle_rad = std::atan(-n.x() / n.z());
    return r;
  }
  r.d_mm = n.dot(plane.point_mm);
  const double nominal_phi = std::atan2(nominal.normal.y(), nominal.normal.x());
  r.angle_rad =
      std::remainder(std::atan2(n.y(), n.x()) - nominal_phi, 2.0 * M_PI);
  r.tilt_rad = std::asin(std::clamp(n.z(), -1.0, 1.0));
  return r;
}

}  // namespace ttp::inspect
