// AlignCloud alone: the frame W from the datums of synthetic clouds (the
// project's generator, synth.cpp, in a random pose), and the clouds whose
// orientation cannot be determined: refused, naming what is missing.
#include <gtest/gtest.h>

#include <cmath>

#include "synth_piece.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {
namespace {

using sim::SynthPiece;

SynthPiece Piece(uint32_t seed, std::vector<std::string> missing = {}) {
  return test::RandomSynthPiece(seed, 20000, std::move(missing));
}

std::string RefusalOf(const PointCloud& cloud) {
  try {
    AlignCloud(PartSpec{}, cloud, InspectOptions{});
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "alignment");
    return e.what();
  }
  return "";
}

// Drops the points whose W position satisfies `drop` (W from the
// generator's own pose, not from the alignment under test).
PointCloud Without(const SynthPiece& s,
                   const std::function<bool(const Eigen::Vector3d&)>& drop) {
  PointCloud out = s.cloud;
  const Eigen::Matrix3Xd w =
      s.rotation.transpose() * (s.cloud.xyz_mm.colwise() - s.translation);
  Eigen::Index kept = 0;
  for (Eigen::Index i = 0; i < w.cols(); ++i)
    if (!drop(w.col(i))) out.xyz_mm.col(kept++) = s.cloud.xyz_mm.col(i);
  out.xyz_mm.conservativeResize(3, kept);
  return out;
}

TEST(AlignCloud, UndoesAnyPose) {
  for (uint32_t seed : {3u, 4u}) {
    const SynthPiece s = Piece(seed);
    const AlignedCloud a = AlignCloud(PartSpec{}, s.cloud, InspectOptions{});
    EXPECT_TRUE(a.alignment.mark_found);
    EXPECT_EQ(a.alignment.mark_points_opposite, 0);
    // W = R cloud + t must invert cloud = rotation W + translation.
    EXPECT_LT((a.alignment.rotation * s.rotation - Eigen::Matrix3d::Identity())
                  .norm(),
              1e-4);
    EXPECT_LT(
        (a.alignment.rotation * s.translation + a.alignment.translation).norm(),
        2e-3);
    EXPECT_NEAR(a.alignment.circle_diameter_mm, 199.0, 1e-3);
    EXPECT_GT(a.origin_covariance_mm2(0, 0), 0);
    EXPECT_TRUE(a.warnings.empty());
  }
}

// x -> -x: every datum is still there, but the mark sits where only a
// mirrored piece has it; the cycles would come out reversed.
TEST(AlignCloud, MirrorImageIsRefused) {
  SynthPiece s = Piece(5);
  s.cloud.xyz_mm.row(0) *= -1;
  const std::string e = RefusalOf(s.cloud);
  EXPECT_NE(e.find("mirror image"), std::string::npos) << e;
}

// Without the datum circle the origin would be the rough centre of the
// other cylinders, micrometres off: refused, naming CYL199.
TEST(AlignCloud, MissingDatumCircleIsRefused) {
  const SynthPiece s = Piece(6, {DatumCylinderId(PartSpec{})});
  const std::string e = RefusalOf(s.cloud);
  EXPECT_NE(e.find("CYL199"), std::string::npos) << e;
  EXPECT_NE(e.find("origin"), std::string::npos) << e;
}

TEST(AlignCloud, MissingMarkIsRefused) {
  const std::string e = RefusalOf(Piece(7, {"MARK"}).cloud);
  EXPECT_NE(e.find("engraved mark"), std::string::npos) << e;
  EXPECT_NE(e.find("X1"), std::string::npos) << e;
}

// The whole X1 sector cut away (its facets, the top face and the mark on
// it): which end is X1 is then unknown, and the cloud is refused rather
// than turned by a guess.
TEST(AlignCloud, MissingSegmentX1SectorIsRefused) {
  const PartSpec part;
  const double centre = part.segment_centre_deg[0] * M_PI / 180;
  const SynthPiece s = Piece(8);
  const PointCloud cut = Without(s, [&](const Eigen::Vector3d& w) {
    return std::abs(std::remainder(std::atan2(w.y(), w.x()) - centre,
                                   2 * M_PI)) < 30 * M_PI / 180;
  });
  ASSERT_LT(cut.xyz_mm.cols(), s.cloud.xyz_mm.cols());
  const std::string e = RefusalOf(cut);
  EXPECT_NE(e.find("engraved mark"), std::string::npos) << e;
}

// Only X1's facets missing (the mark is there): the orientation is found
// and the missing features are X1's, not the opposite segment's.
TEST(AlignCloud, MissingX1FacetsKeepTheOrientation) {
  std::vector<std::string> x1;
  for (int j = 1; j <= PartSpec{}.facets_per_segment; ++j)
    x1.push_back(FacetId(Segment::kX1, j));
  const SynthPiece s = Piece(9, x1);
  const InspectionResult r = InspectCloud(PartSpec{}, s.cloud);
  EXPECT_LT(
      (r.alignment.rotation * s.rotation - Eigen::Matrix3d::Identity()).norm(),
      1e-4);
  for (const FeatureDiagnostic& d : r.diagnostics)
    EXPECT_EQ(d.status == "missing", d.id.rfind("X1-", 0) == 0) << d.id;
  for (size_t c = 0; c < r.figures.size(); ++c)
    EXPECT_NEAR(r.figures[c].e_y_mm, s.truth.figures[c].e_y_mm, 0.2e-3) << c;
}

}  // namespace
}  // namespace ttp::inspect
