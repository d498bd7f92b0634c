// A touch-trigger probe on the machine, simulated from its physics and
// independently of the project's probe reader (shared by the probe tests
// and the samples' generator): the piece's true planes from per-feature
// deviations, the table angle that points a planned point's normal along
// machine +X, and the stylus ball's centre where its move along the normal
// first touches the true surface.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <map>
#include <string>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"
#include "ttp/plan/plan.h"

namespace ttp::test {

struct TruePlane {
  Eigen::Vector3d n;  // unit, outward
  double d;           // n . x = d
};

// The true plane of a facet (distance d_mm, normal turned by angle_rad
// about Z) or a strip (depth d_mm below W's origin, slope tan(angle_rad)
// along x), in W.
inline TruePlane TrueFeaturePlane(const NominalFeature& f, double d_mm,
                                  double angle_rad) {
  if (f.kind == FeatureKind::kStrip) {
    // z = -d + tan(beta) x  <=>  (-tan b, 0, 1) . x = -d, normalised.
    const Eigen::Vector3d n(-std::tan(angle_rad), 0, 1);
    return {n.normalized(), -d_mm / n.norm()};
  }
  const double phi = std::atan2(f.normal.y(), f.normal.x()) + angle_rad;
  return {Eigen::Vector3d(std::cos(phi), std::sin(phi), 0), d_mm};
}

// The table angle (rad, in (-pi, pi]) at which a planned point is probed:
// horizontal normals turned onto machine +X, vertical ones at C = 0.
inline double ProbeTableAngleRad(const Config& config,
                                 const plan::PlannedPoint& p) {
  const Eigen::Vector3d& n = p.normal_w;
  double c_rad = 0;
  if (std::abs(n.z()) <= 0.999)
    c_rad =
        TableAngleFor(std::atan2(n.y(), n.x()), 0.0, config.machine.c_sense);
  return std::remainder(c_rad, 2 * M_PI);
}

// The ball's centre (W) where the ball of radius r, moving from `start`
// along the line of `dir` (unit), touches the piece: a true plane of
// `planes` where the point's feature has one, the datum cylinder CYL199,
// else the nominal plane through the planned point (top face, flanks).
inline Eigen::Vector3d BallCentreAtTouch(
    const PartSpec& part, const std::map<FeatureId, TruePlane>& planes,
    const plan::PlannedPoint& p, const Eigen::Vector3d& start,
    const Eigen::Vector3d& dir, double r) {
  const auto it = planes.find(p.feature);
  if (it != planes.end()) {
    const TruePlane& tp = it->second;
    // tp.n . (start + t dir) - tp.d = r
    const double t = (r + tp.d - tp.n.dot(start)) / tp.n.dot(dir);
    return start + t * dir;
  }
  if (p.feature == FeatureId::DatumCylinder(part)) {
    // |xy(start + t dir)| = R + r
    const double big = part.ref_cylinders.front().diameter_mm / 2 + r;
    const Eigen::Vector2d s2 = start.head<2>(), d2 = dir.head<2>();
    const double a = d2.squaredNorm(), b = 2 * s2.dot(d2),
                 c = s2.squaredNorm() - big * big;
    const double t = (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
    return start + t * dir;
  }
  const Eigen::Vector3d& n = p.normal_w;
  const double t = (r + n.dot(p.point_w_mm) - n.dot(start)) / n.dot(dir);
  return start + t * dir;
}

}  // namespace ttp::test
