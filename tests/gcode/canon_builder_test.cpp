#include "canon_builder.h"

#include <gtest/gtest.h>

namespace ttp::gcode {
namespace {

TEST(CanonBuilderTest, EmitsSpindleOnlyOnStateChanges) {
  CanonBuilder b;
  int line = 0;
  b.SetLine(++line);
  b.SetSpindleSpeed(0, 1000);  // off: only remembered
  b.SetLine(++line);
  b.StopSpindle(0);  // already off
  b.SetLine(++line);
  b.StartSpindle(0, true);  // 1000 cw
  b.SetLine(++line);
  b.StartSpindle(0, true);  // unchanged
  b.SetLine(++line);
  b.SetSpindleSpeed(0, 1500);  // running: new speed
  b.SetLine(++line);
  b.StartSpindle(0, false);  // reverse
  b.SetLine(++line);
  b.StopSpindle(0);
  const auto s = b.Take();
  ASSERT_EQ(s.size(), 4u);
  EXPECT_EQ(s[0].value, 1000);
  EXPECT_TRUE(s[0].clockwise);
  EXPECT_EQ(s[1].value, 1500);
  EXPECT_EQ(s[2].value, 1500);
  EXPECT_FALSE(s[2].clockwise);
  EXPECT_EQ(s[3].value, 0);
  for (const auto& st : s) EXPECT_EQ(st.kind, CanonKind::kSpindle);
}

TEST(CanonBuilderTest, MergesSpindleChangesOfOneLine) {
  CanonBuilder b;
  b.SetLine(1);
  b.SetSpindleSpeed(0, 1000);
  b.StartSpindle(0, true);
  b.SetLine(2);
  b.SetSpindleSpeed(0, 2000);  // M4 S2000: one change, not two
  b.StartSpindle(0, false);
  b.Dwell(1);  // another statement flushes the change before it
  const auto s = b.Take();
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[1].kind, CanonKind::kSpindle);
  EXPECT_EQ(s[1].value, 2000);
  EXPECT_FALSE(s[1].clockwise);
  EXPECT_EQ(s[1].source_line, 2);
  EXPECT_EQ(s[2].kind, CanonKind::kDwell);
}

TEST(CanonBuilderTest, SpindleOneIsCTurning) {
  CanonBuilder b;
  b.SetSpindleSpeed(1, 20);
  b.StartSpindle(1, true);
  const auto s = b.Take();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].kind, CanonKind::kCSpin);
  EXPECT_EQ(s[0].value, 20);
}

TEST(CanonBuilderTest, CarriesPositionAndLineToLaterStatements) {
  CanonBuilder b;
  b.SetLine(7);
  b.Traverse(Eigen::Vector3d(1, 2, 3), 90);
  b.SetLine(8);
  b.SetCoolant(true);
  b.SetCoolant(true);  // no change
  b.SetClamp(false);   // first clamp command always counts
  b.SetClamp(false);
  const auto s = b.Take();
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].source_line, 7);
  EXPECT_EQ(s[1].source_line, 8);
  EXPECT_EQ(s[1].kind, CanonKind::kCoolant);
  EXPECT_EQ(s[2].kind, CanonKind::kClamp);
  EXPECT_EQ(s[2].value, 0);
  EXPECT_TRUE(s[2].end_mm.isApprox(Eigen::Vector3d(1, 2, 3)));
  EXPECT_NEAR(s[2].end_c_rad, M_PI / 2, 1e-15);
}

}  // namespace
}  // namespace ttp::gcode
