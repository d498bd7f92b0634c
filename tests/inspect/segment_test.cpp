// SegmentCloud alone: points placed in W on each nominal feature (from the
// drawing's numbers written here: facet normal at the segment centre plus
// (j - 5) x 6 deg, strips at y = (k - 5) x pitch on the floor) land in that
// feature's region; points in the edge margins or off the surfaces land
// nowhere.
#include <gtest/gtest.h>

#include <cmath>

#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {
namespace {

TEST(SegmentCloud, PointsLandInTheirFeatureOnly) {
  const PartSpec part;
  const int facets = part.facets_per_segment;
  std::vector<Eigen::Vector3d> pts;
  std::vector<std::pair<bool, int>> want;  // (strip?, bin) or bin -1
  for (int s = 0; s < 4; ++s) {
    for (int j = 1; j <= facets; ++j) {
      const double phi =
          (part.segment_centre_deg[s] + (j - 5) * 6.0) * M_PI / 180;
      const Eigen::Vector3d n(std::cos(phi), std::sin(phi), 0);
      const Eigen::Vector3d t(-n.y(), n.x(), 0);
      const double d = part.facet_final_distance_mm;
      // Inside: 3 mm along, 2 mm below the top, 0.05 mm off the plane.
      pts.push_back(d * n + 0.05 * n + 3.0 * t - Eigen::Vector3d(0, 0, 2));
      want.push_back({false, s * facets + j - 1});
      // In the tangential margin (0.5 mm from the facet's edge).
      const double half = d * std::tan(3.0 * M_PI / 180);
      pts.push_back(d * n + (half - 0.5) * t - Eigen::Vector3d(0, 0, 2));
      want.push_back({false, -1});
      // 0.3 mm off the plane: outside the 0.15 mm capture band.
      pts.push_back((d + 0.3) * n - Eigen::Vector3d(0, 0, 2));
      want.push_back({false, -1});
    }
  }
  for (int k = 1; k <= facets; ++k) {
    const double y = (k - 5) * part.strip_pitch_mm;
    pts.emplace_back(40.0, y + 1.0, part.strip_floor_z_mm + 0.02);
    want.push_back({true, k - 1});
    // In the small notch (|x| below its half width): no strip there.
    pts.emplace_back(0.5 * part.small_notch_half_width_mm, y,
                     part.strip_floor_z_mm);
    want.push_back({true, -1});
  }
  Eigen::Matrix3Xd w(3, static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) w.col(i) = pts[i];
  const Segmentation seg = SegmentCloud(part, w, InspectOptions{});
  ASSERT_EQ(seg.facets.size(), 4u * facets);
  ASSERT_EQ(seg.strips.size(), static_cast<size_t>(facets));
  std::vector<int> where(pts.size(), -1);
  std::vector<bool> is_strip(pts.size(), false);
  int assigned = 0;
  for (size_t b = 0; b < seg.facets.size(); ++b)
    for (Eigen::Index i : seg.facets[b]) where[i] = b, ++assigned;
  for (size_t b = 0; b < seg.strips.size(); ++b)
    for (Eigen::Index i : seg.strips[b])
      where[i] = b, is_strip[i] = true, ++assigned;
  int expected = 0;
  for (size_t i = 0; i < pts.size(); ++i) {
    EXPECT_EQ(where[i], want[i].second) << "point " << i;
    if (want[i].second >= 0) {
      EXPECT_EQ(is_strip[i], want[i].first) << "point " << i;
      ++expected;
    }
  }
  EXPECT_EQ(assigned, expected);  // no point in two regions
}

}  // namespace
}  // namespace ttp::inspect
