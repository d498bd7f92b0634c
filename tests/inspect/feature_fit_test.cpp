// FitFeatures alone: points on known planes in W (a facet turned and moved
// by known amounts, a tilted strip) with noise and strays; the results
// come back within their stated uncertainty, strays are rejected, and a
// feature with too few points is missing.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "ttp/geometry/features.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {
namespace {

TEST(FitFeatures, KnownPlanesComeBackWithinTheirUncertainty) {
  const PartSpec part;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.5e-3);
  std::uniform_real_distribution<double> along(-4, 4), depth(-10, -1),
      x(20, 60);
  const int facets = part.facets_per_segment;
  Segmentation seg;
  seg.facets.resize(4 * facets);
  seg.strips.resize(facets);
  std::vector<Eigen::Vector3d> pts;
  // Facet X1-3: angle error 30 urad, d = nominal + 4 um.
  const double phi0 =
      (part.segment_centre_deg[0] + (3 - part.reference_index) * 6.0) * M_PI /
      180;
  const double angle = 30e-6, d = part.facet_final_distance_mm + 4e-3;
  const Eigen::Vector3d n(std::cos(phi0 + angle), std::sin(phi0 + angle), 0);
  const Eigen::Vector3d t(-n.y(), n.x(), 0);
  for (int i = 0; i < 400; ++i) {
    Eigen::Vector3d p = d * n + along(rng) * t +
                        Eigen::Vector3d(0, 0, depth(rng)) + noise(rng) * n;
    if (i % 100 == 3) p += 0.05 * n;  // strays
    seg.facets[2].push_back(static_cast<Eigen::Index>(pts.size()));
    pts.push_back(p);
  }
  // Strip Z7: depth 12.1 mm + 3 um at x = 0, slope beta = -40 urad.
  const double y7 = (7 - part.reference_index) * part.strip_pitch_mm;
  const double strip_d = -part.strip_floor_z_mm + 3e-3, beta = -40e-6;
  for (int i = 0; i < 300; ++i) {
    const double xi = x(rng) * (i % 2 ? 1 : -1);
    seg.strips[6].push_back(static_cast<Eigen::Index>(pts.size()));
    pts.emplace_back(xi, y7 + along(rng) / 4,
                     -strip_d + std::tan(beta) * xi + noise(rng));
  }
  // Facet Y2-1: 5 points, fewer than min_points.
  for (int i = 0; i < 5; ++i) {
    seg.facets[3 * facets].push_back(static_cast<Eigen::Index>(pts.size()));
    pts.emplace_back(0, -97.3, -i - 1.0);
  }
  Eigen::Matrix3Xd w(3, static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) w.col(i) = pts[i];
  InspectOptions o;
  o.instrument = Instrument::kNone;
  const FittedFeatures f =
      FitFeatures(part, w, seg, Eigen::Matrix2d::Zero(), o);
  const FeatureResult& facet = f.features.at(FeatureId::Facet(Segment::kX1, 3));
  ASSERT_TRUE(facet.present);
  EXPECT_EQ(facet.points, 396);
  EXPECT_NEAR(facet.d_mm, d, 4 * std::sqrt(facet.var_d_mm2));
  EXPECT_NEAR(facet.angle_rad, angle, 4 * std::sqrt(facet.var_angle_rad2));
  EXPECT_LT(std::sqrt(facet.var_d_mm2), 0.2e-3);
  const FeatureResult& strip = f.features.at(FeatureId::Strip(7));
  ASSERT_TRUE(strip.present);
  EXPECT_NEAR(strip.d_mm, strip_d, 4 * std::sqrt(strip.var_d_mm2));
  EXPECT_NEAR(strip.angle_rad, beta, 4 * std::sqrt(strip.var_angle_rad2));
  EXPECT_EQ(f.points_rejected, 4);
  EXPECT_FALSE(f.features.at(FeatureId::Facet(kSegments[3], 1)).present);
  EXPECT_EQ(f.diagnostics.size(), 5u * facets);
  int missing = 0;
  for (const FeatureDiagnostic& dg : f.diagnostics)
    missing += dg.status == "missing";
  EXPECT_EQ(missing, 5 * facets - 2);
}

TEST(InspectOptions, IsValidNamesTheField) {
  InspectOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.capture_band_mm = 0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error.rfind("InspectOptions.capture_band_mm:", 0), 0u) << error;
  o = InspectOptions();
  o.thin_points = 2;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error.rfind("InspectOptions.thin_points:", 0), 0u) << error;
  o = InspectOptions();
  o.min_points = 2;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error.rfind("InspectOptions.min_points:", 0), 0u) << error;
}

}  // namespace
}  // namespace ttp::inspect
