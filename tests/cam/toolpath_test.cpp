#include "toolpath.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace ttp::cam {
namespace {

TEST(RouteAroundTest, EverySegmentKeepsItsDistanceFromTheAxis) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI);
  std::uniform_real_distribution<double> extra(0.0, 60.0);
  const double keep = 107.5, route = 110.5;
  for (int trial = 0; trial < 500; ++trial) {
    const double ra = route + extra(rng), rb = route + extra(rng);
    const double aa = angle(rng), ab = angle(rng);
    const Eigen::Vector2d a(ra * std::cos(aa), ra * std::sin(aa));
    const Eigen::Vector2d b(rb * std::cos(ab), rb * std::sin(ab));
    const auto way = RouteAround(a, b, keep, route);
    ASSERT_FALSE(way.empty());
    EXPECT_EQ(way.back(), b);
    Eigen::Vector2d at = a;
    for (const Eigen::Vector2d& p : way) {
      EXPECT_GE(SegmentDistanceFromOrigin(at, p), keep - 1e-9);
      at = p;
    }
    // Not much longer than the arc round the route circle.
    double length = 0;
    at = a;
    for (const Eigen::Vector2d& p : way) {
      length += (p - at).norm();
      at = p;
    }
    const double arc = std::abs(std::remainder(ab - aa, 2 * M_PI)) * route;
    EXPECT_LT(length, arc + (ra - route) + (rb - route) + 1e-6 + 0.05 * arc);
  }
}

TEST(RouteAroundTest, GoesStraightWhenNothingIsInTheWay) {
  const auto way = RouteAround({120, -30}, {120, 30}, 107.5, 110.5);
  ASSERT_EQ(way.size(), 1u);
}

TEST(SegmentDistanceTest, Cases) {
  EXPECT_DOUBLE_EQ(SegmentDistanceFromOrigin({-5, 3}, {5, 3}), 3.0);
  EXPECT_DOUBLE_EQ(SegmentDistanceFromOrigin({3, 4}, {6, 8}), 5.0);
  EXPECT_DOUBLE_EQ(SegmentDistanceFromOrigin({2, 0}, {2, 0}), 2.0);
}

// M3 (clockwise from +Z), climb milling: a tooth at the contact point
// moves against the feed. Tooth velocity at offset o is (-z) x o.
TEST(ClimbHeadingTest, ToothMovesAgainstTheFeedAtTheContact) {
  for (double deg = 0; deg < 360; deg += 15) {
    const Eigen::Vector2d m(std::cos(deg * M_PI / 180),
                            std::sin(deg * M_PI / 180));
    const Eigen::Vector2d h = ClimbHeading(m);
    const Eigen::Vector2d tooth(m.y(), -m.x());  // (-z) x m
    EXPECT_NEAR(h.dot(tooth), -1.0, 1e-12) << deg;
  }
  // test-piece.md: X1 (material -X of the tool) is cut moving -Y.
  EXPECT_NEAR(ClimbHeading({-1, 0}).y(), -1.0, 1e-12);
}

SlotPass SmallNotch() {
  SlotPass s;
  s.along = 1;
  s.half_width_mm = 5;
  s.floor_z_mm = -14;
  s.tool_radius_mm = 4;
  s.length_mm = 110;
  s.step_down_mm = 3;
  s.stepover_mm = 6;
  s.feed_mm_min = 500;
  s.safe_z_mm = 50;
  return s;
}

TEST(MillSlotTest, ReachesTheFloorInStepsAndClimbsBothWalls) {
  std::vector<gcode::Statement> out;
  PathWriter path(&out);
  path.Assume({0, 0, 50}, 0);
  const SlotPass slot = SmallNotch();
  MillSlot(path, slot);
  Eigen::Vector3d at(0, 0, 50);
  double deepest = 0, previous_level = 0;
  bool plus_wall = false, minus_wall = false;
  for (const gcode::Statement& s : out) {
    if (const auto* f = std::get_if<gcode::Feed>(&s)) {
      const Eigen::Vector3d to(*f->to.x_mm, *f->to.y_mm, *f->to.z_mm);
      EXPECT_EQ(to.z(), at.z()) << "feeds are level";
      EXPECT_EQ(to.x(), at.x()) << "feeds run along Y";
      EXPECT_DOUBLE_EQ(std::abs(to.y()), slot.length_mm);
      if (to.z() < previous_level - 1e-9) {
        EXPECT_LE(previous_level - to.z(), slot.step_down_mm + 1e-9);
        previous_level = to.z();
      }
      deepest = std::min(deepest, to.z());
      const bool up = to.y() > at.y();
      if (std::abs(to.x() - 1.0) < 1e-9) plus_wall |= up;    // +X wall
      if (std::abs(to.x() + 1.0) < 1e-9) minus_wall |= !up;  // -X wall
      at = to;
    } else if (const auto* r = std::get_if<gcode::Rapid>(&s)) {
      const Eigen::Vector3d to(*r->to.x_mm, *r->to.y_mm, *r->to.z_mm);
      // Rapids below the top happen only outside the piece's length.
      if (std::min(to.z(), at.z()) < 0) {
        EXPECT_DOUBLE_EQ(std::abs(to.y()), slot.length_mm);
      }
      at = to;
    }
  }
  EXPECT_DOUBLE_EQ(deepest, slot.floor_z_mm);
  EXPECT_TRUE(plus_wall);
  EXPECT_TRUE(minus_wall);
  EXPECT_EQ(at.z(), slot.safe_z_mm);
}

TEST(MillSlotTest, LeavesTheAllowanceOnFloorAndWalls) {
  std::vector<gcode::Statement> out;
  PathWriter path(&out);
  SlotPass slot;
  slot.along = 0;
  slot.half_width_mm = 53;
  slot.floor_z_mm = -12;
  slot.tool_radius_mm = 8;
  slot.length_mm = 112.5;
  slot.step_down_mm = 3;
  slot.allowance_mm = 0.2;
  slot.stepover_mm = 12;
  slot.feed_mm_min = 600;
  slot.safe_z_mm = 50;
  MillSlot(path, slot);
  double min_z = 0, max_abs_y = 0;
  for (const gcode::Statement& s : out)
    if (const auto* f = std::get_if<gcode::Feed>(&s)) {
      min_z = std::min(min_z, *f->to.z_mm);
      max_abs_y = std::max(max_abs_y, std::abs(*f->to.y_mm));
    }
  EXPECT_NEAR(min_z, -11.8, 1e-12);
  EXPECT_NEAR(max_abs_y, 53 - 8 - 0.2, 1e-12);
}

}  // namespace
}  // namespace ttp::cam
