#include "ttp/sim/synth.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>

#include "feature_ids.h"
#include "synth_piece.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"

namespace ttp::sim {
namespace {

using test::FinishedMesh;

// Without noise, strays or pose, the points tagged near a facet lie on its
// deviated plane and those on a strip on its sloped floor.
TEST(SynthTest, PointsLieOnTheDeviatedPlanes) {
  const PartSpec part;
  SynthOptions o;
  o.points = 40000;
  o.noise_um = 0;
  o.stray_fraction = 0;
  o.random_pose = false;
  o.seed = 3;
  o.deviation_d_um = 20;
  o.deviation_angle_urad = 200;
  const FeatureResults dev = RandomDeviations(part, o);
  const SynthPiece s = SynthesizePiece(part, FinishedMesh(), dev, o);
  ASSERT_EQ(s.cloud.size(), o.points);
  EXPECT_TRUE(s.rotation.isIdentity());
  int on_facet = 0, on_strip = 0;
  for (Eigen::Index i = 0; i < s.cloud.size(); ++i) {
    const Eigen::Vector3d p = s.cloud.xyz_mm.col(i);
    // Facet X1-2 (well inside its region).
    const NominalFeature f = [&] {
      for (const auto& nf : TestFeatures(part))
        if (nf.id == "X1-2") return nf;
      return NominalFeature{};
    }();
    const double phi = std::atan2(f.normal.y(), f.normal.x());
    const double tang = -p.x() * std::sin(phi) + p.y() * std::cos(phi);
    const double radial = p.x() * std::cos(phi) + p.y() * std::sin(phi);
    if (std::abs(radial - f.size_mm) < 0.1 && std::abs(tang) < 4 &&
        p.z() < -1 && p.z() > -11) {
      const double a = phi + dev.at(test::Fid("X1-2")).angle_rad;
      const Eigen::Vector3d n(std::cos(a), std::sin(a), 0);
      EXPECT_NEAR(n.dot(p), dev.at(test::Fid("X1-2")).d_mm, 1e-9);
      ++on_facet;
    }
    const double yk = StripY(part, 3);
    if (std::abs(p.y() - yk) < 5 && std::abs(p.x()) > 7 &&
        std::abs(p.x()) < 80 && std::abs(p.z() - part.strip_floor_z_mm) < 0.1) {
      const FeatureResult& z3 = dev.at(test::Fid("Z3"));
      EXPECT_NEAR(p.z(), -z3.d_mm + std::tan(z3.angle_rad) * p.x(), 1e-9);
      ++on_strip;
    }
  }
  EXPECT_GT(on_facet, 50);
  EXPECT_GT(on_strip, 200);
}

TEST(SynthTest, PoseStraysAndMissingFeatures) {
  const PartSpec part;
  SynthOptions o;
  o.points = 10000;
  o.stray_fraction = 0.01;
  o.seed = 9;
  o.missing = {"Y1-4", "Z2"};
  const SynthPiece s =
      SynthesizePiece(part, FinishedMesh(), RandomDeviations(part, o), o);
  EXPECT_EQ(s.cloud.size(), 10100);
  EXPECT_NEAR(
      (s.rotation * s.rotation.transpose() - Eigen::Matrix3d::Identity())
          .norm(),
      0.0, 1e-12);
  EXPECT_NEAR(s.rotation.determinant(), 1.0, 1e-12);
  EXPECT_FALSE(s.truth.features.at(test::Fid("Y1-4")).present);
  EXPECT_FALSE(s.truth.features.at(test::Fid("Z2")).present);
  EXPECT_TRUE(s.truth.features.at(test::Fid("Y1-5")).present);
  // Same seed, same cloud.
  const SynthPiece t =
      SynthesizePiece(part, FinishedMesh(), RandomDeviations(part, o), o);
  EXPECT_EQ((s.cloud.xyz_mm - t.cloud.xyz_mm).norm(), 0.0);
}

TEST(SynthTest, OptionsNameTheInvalidField) {
  SynthOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.stray_fraction = 5;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error.rfind("SynthOptions.stray_fraction:", 0), 0u) << error;
  EXPECT_THROW(RandomDeviations(PartSpec{}, o), InputError);
  o = SynthOptions();
  o.points = 0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error.rfind("SynthOptions.points:", 0), 0u) << error;
}

}  // namespace
}  // namespace ttp::sim
