// Turns a measured plane (point + normal in W) into the per-feature result
// that the figures need (test-piece.md section 4). Shared by every
// measurement path that yields planes: cloud fits, DMIS feature results.
#pragma once

#include <Eigen/Core>

#include "ttp/geometry/features.h"
#include "ttp/geometry/figures.h"

namespace ttp::inspect {

struct PlaneInW {
  Eigen::Vector3d point_mm;
  Eigen::Vector3d normal;  // any sign; oriented like the nominal normal
};

// Facets: d = distance of the plane to W's origin along the outward normal,
// angle_rad = the normal's angle error about Z, tilt_rad = its elevation.
// Strips: d = depth at (0, y_k) below the top face z = top_z_mm (positive
// downwards), angle_rad = beta = atan(dz/dx). Variances are left at zero.
FeatureResult FeatureResultFromPlane(const NominalFeature& nominal,
                                     const PlaneInW& plane,
                                     double top_z_mm = 0.0);

}  // namespace ttp::inspect
