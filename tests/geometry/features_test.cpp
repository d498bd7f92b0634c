#include "ttp/geometry/features.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

namespace ttp {
namespace {

TEST(Features, CycleIndexMappingFollowsTheSpec) {
  PartSpec p;
  const int expected[9] = {5, 1, 2, 3, 4, 6, 7, 8, 9};
  for (int cycle = 0; cycle <= 8; ++cycle) {
    EXPECT_EQ(IndexForCycle(p, cycle), expected[cycle]);
    EXPECT_EQ(CycleForIndex(p, expected[cycle]), cycle);
  }
}

TEST(Features, FacetAnglesAndWidth) {
  PartSpec p;
  EXPECT_DOUBLE_EQ(FacetPhiDeg(p, Segment::kX1, 1), 36.0);
  EXPECT_DOUBLE_EQ(FacetPhiDeg(p, Segment::kY2, 9), 324.0);
  for (const auto& f : TestFeatures(p)) {
    if (f.kind != FeatureKind::kFacet) continue;
    EXPECT_NEAR(f.t_max_mm - f.t_min_mm, 10.2, 0.01) << f.id;  // drawing
    EXPECT_NEAR(f.point.norm(), 97.3, 1e-12);
    EXPECT_NEAR(f.normal.norm(), 1.0, 1e-12);
  }
}

TEST(Features, StripsStayOnTheFloor) {
  PartSpec p;
  for (int k = 1; k <= 9; ++k) {
    EXPECT_LE(std::abs(StripY(p, k)) + p.strip_width_mm / 2,
              p.big_notch_half_width_mm + 1e-12);
  }
  EXPECT_DOUBLE_EQ(StripY(p, 5), 0.0);
}

TEST(Features, TestFeaturesAreUniqueAndComplete) {
  PartSpec p;
  auto features = TestFeatures(p);
  ASSERT_EQ(features.size(), 45u);
  std::set<std::string> ids;
  for (auto& f : features) ids.insert(f.id);
  EXPECT_EQ(ids.size(), 45u);
  EXPECT_EQ(features.front().id, "Z5");
  EXPECT_EQ(features[5].id, "Z1");
}

TEST(Features, ParseFeatureIds) {
  FeatureKind kind;
  Segment s;
  int index;
  ASSERT_TRUE(ParseFeatureId("Y2-7", &kind, &s, &index));
  EXPECT_EQ(kind, FeatureKind::kFacet);
  EXPECT_EQ(s, Segment::kY2);
  EXPECT_EQ(index, 7);
  ASSERT_TRUE(ParseFeatureId("Z9", &kind, &s, &index));
  EXPECT_EQ(kind, FeatureKind::kStrip);
  EXPECT_FALSE(ParseFeatureId("X3-1", &kind, &s, &index));
  EXPECT_FALSE(ParseFeatureId("Z0", &kind, &s, &index));
  EXPECT_FALSE(ParseFeatureId("X1-10", &kind, &s, &index));
  EXPECT_FALSE(ParseFeatureId("TOP", &kind, &s, &index));  // a datum
}

// Every nominal feature's name parses to a typed id that prints back the
// same name; names of no feature parse to nothing; ids order and compare
// by their parts, not by their text ("X1-10" would sort before "X1-2").
TEST(Features, FeatureIdRoundTripsEveryNominalName) {
  const PartSpec part;
  for (const NominalFeature& f : BuildNominalFeatures(part, Stage::kFinished)) {
    const std::optional<FeatureId> id = FeatureId::Parse(f.id);
    ASSERT_TRUE(id.has_value()) << f.id;
    EXPECT_EQ(id->ToString(), f.id);
    EXPECT_EQ(id->kind, f.kind) << f.id;
    if (f.kind == FeatureKind::kFacet) {
      EXPECT_EQ(id->segment, *f.segment) << f.id;
      EXPECT_EQ(id->index, f.index) << f.id;
    }
  }
  for (const char* bad : {"", "X1-0", "X3-1", "Z10", "x1-5", "TOP ", "CYL",
                          "CYL0", "FLANK+X", "Z-1"})
    EXPECT_FALSE(FeatureId::Parse(bad).has_value()) << bad;
  EXPECT_EQ(*FeatureId::Parse("Y2-7"), FeatureId::Facet(Segment::kY2, 7));
  EXPECT_NE(FeatureId::Facet(Segment::kX1, 7),
            FeatureId::Facet(Segment::kY1, 7));
  EXPECT_NE(FeatureId::Facet(Segment::kX1, 7), FeatureId::Strip(7));
  EXPECT_TRUE(FeatureId::Facet(Segment::kX1, 2) <
              FeatureId::Facet(Segment::kX1, 9));
  EXPECT_EQ(FeatureId::Datum(FeatureKind::kCylinder, 199000).ToString(),
            DatumCylinderId(part));
  EXPECT_EQ(FeatureId::Parse("CYL99.5")->index, 99500);
  EXPECT_EQ(FeatureId::Parse("CYL99.5")->ToString(), "CYL99.5");
}

TEST(Features, StagesHoldTheRightFeatures) {
  PartSpec p;
  auto pre = BuildNominalFeatures(p, Stage::kPreMachined);
  auto fin = BuildNominalFeatures(p, Stage::kFinished);
  int pre_strips = 0, fin_strips = 0;
  for (auto& f : pre) {
    if (f.kind == FeatureKind::kStrip) ++pre_strips;
    if (f.kind == FeatureKind::kFacet) {
      EXPECT_DOUBLE_EQ(f.size_mm, 97.4);
    }
  }
  for (auto& f : fin) {
    if (f.kind == FeatureKind::kStrip) ++fin_strips;
    if (f.kind == FeatureKind::kFacet) {
      EXPECT_DOUBLE_EQ(f.size_mm, 97.3);
    }
  }
  EXPECT_EQ(pre_strips, 0);
  EXPECT_EQ(fin_strips, 9);
}

}  // namespace
}  // namespace ttp
