// Stage 2 of the cloud inspection: which points belong to which feature.
// A point belongs to a facet / strip when it lies inside the feature's
// nominal extent in W shrunk by edge margins (facets facet_edge_margin_mm
// tangentially, edge_margin_mm in z; strips edge_margin_mm in y and from
// the small notch and the rim in x) and within capture_band_mm of its
// nominal surface.
#include <cmath>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/features.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {

Segmentation SegmentCloud(const PartSpec& part, const Eigen::Matrix3Xd& w,
                          const InspectOptions& o) {
  const int facets = part.facets_per_segment;
  Segmentation out;
  out.facets.resize(4 * facets);
  out.strips.resize(facets);
  const double r_cyl = part.ref_cylinders.front().diameter_mm / 2;
  const double d_facet = part.facet_final_distance_mm;
  const double half_facet = d_facet * std::tan(part.facet_step_deg / 2 * kDeg);
  const double fz_lo = part.facet_bottom_z_mm + o.edge_margin_mm;
  const double fz_hi = -o.edge_margin_mm;
  const double strip_half = part.strip_width_mm / 2 - o.edge_margin_mm;
  std::vector<Eigen::Vector2d> facet_dir(4 * facets);
  for (int s = 0; s < 4; ++s) {
    for (int j = 1; j <= facets; ++j) {
      const double a = FacetPhiDeg(part, kSegments[s], j) * kDeg;
      facet_dir[s * facets + j - 1] = Eigen::Vector2d(std::cos(a), std::sin(a));
    }
  }
  const double facet_r2_min = std::pow(d_facet - o.capture_band_mm, 2);
  const double facet_r2_max =
      std::pow(d_facet + o.capture_band_mm, 2) + half_facet * half_facet;
  for (Eigen::Index i = 0; i < w.cols(); ++i) {
    const double x = w(0, i), y = w(1, i), z = w(2, i);
    if (z > fz_lo && z < fz_hi) {
      // Only points near the facets' radius can be on one.
      const double r2 = x * x + y * y;
      if (r2 < facet_r2_min || r2 > facet_r2_max) continue;
      double phi = std::atan2(y, x) / kDeg;
      for (int s = 0; s < 4; ++s) {
        double rel = phi - part.segment_centre_deg[s];
        rel = std::remainder(rel, 360.0);
        const int j = static_cast<int>(std::lround(rel / part.facet_step_deg)) +
                      part.reference_index;
        if (j < 1 || j > facets) continue;
        const Eigen::Vector2d& dir = facet_dir[s * facets + j - 1];
        const double radial = x * dir.x() + y * dir.y();
        const double tang = -x * dir.y() + y * dir.x();
        if (std::abs(radial - d_facet) < o.capture_band_mm &&
            std::abs(tang) < half_facet - o.facet_edge_margin_mm) {
          out.facets[s * facets + j - 1].push_back(i);
        }
      }
    } else if (std::abs(z - part.strip_floor_z_mm) < o.capture_band_mm) {
      const int k = static_cast<int>(std::lround(y / part.strip_pitch_mm)) +
                    part.reference_index;
      if (k < 1 || k > facets) continue;
      if (std::abs(y - StripY(part, k)) > strip_half) continue;
      const double ye = std::abs(StripY(part, k)) + part.strip_width_mm / 2;
      const double x_end = std::sqrt(std::max(0.0, r_cyl * r_cyl - ye * ye));
      if (std::abs(x) < part.small_notch_half_width_mm + o.edge_margin_mm ||
          std::abs(x) > x_end - o.edge_margin_mm) {
        continue;
      }
      out.strips[k - 1].push_back(i);
    }
  }
  return out;
}

}  // namespace ttp::inspect
