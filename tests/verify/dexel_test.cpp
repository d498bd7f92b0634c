// Exactness of the dexel cuts against analytic cases.
#include "ttp/verify/dexel.h"

#include <gtest/gtest.h>

#include <cmath>

namespace ttp::verify {
namespace {

constexpr double kPi = 3.14159265358979323846;

Ray VerticalRay(double x, double y, double z0, double length) {
  Ray r;
  r.origin = Eigen::Vector3d(x, y, z0);
  r.direction = Eigen::Vector3d::UnitZ();
  r.length_mm = length;
  r.material = {{0.0, length}};
  return r;
}

Ray HorizontalRay(const Eigen::Vector3d& origin, double angle_rad,
                  double length) {
  Ray r;
  r.origin = origin;
  r.direction = Eigen::Vector3d(std::cos(angle_rad), std::sin(angle_rad), 0);
  r.length_mm = length;
  r.material = {{0.0, length}};
  return r;
}

ToolShape Flat(double radius) { return {radius, 60.0, 0.0}; }

// Top of the first material interval, in z, of a vertical ray.
double TopZ(const Ray& r) { return r.origin.z() + r.material.front().second; }

TEST(RayTest, SubtractSplitsAndTrims) {
  Ray r = VerticalRay(0, 0, 0, 10);
  EXPECT_DOUBLE_EQ(r.Subtract(2, 3), 1.0);
  ASSERT_EQ(r.material.size(), 2u);
  EXPECT_DOUBLE_EQ(r.Subtract(-5, 0.5), 0.5);
  EXPECT_DOUBLE_EQ(r.Subtract(9, 20), 1.0);
  EXPECT_DOUBLE_EQ(r.Subtract(2.5, 2.7), 0.0);
  EXPECT_DOUBLE_EQ(r.MaterialLength(), 10 - 1 - 0.5 - 1);
}

TEST(DexelTest, StraightCutLeavesExactFloorAndWall) {
  DexelModel model;
  // Vertical rays across the path, at odd positions.
  std::vector<int> under, beside;
  for (double y = -7.9; y <= 7.9; y += 0.37)
    under.push_back(model.AddRay(VerticalRay(3.3, y, -1.234, 10)));
  beside.push_back(model.AddRay(VerticalRay(3.3, 8.001, -1.234, 10)));
  // Horizontal rays along Y at several heights through the path.
  const int wall_low =
      model.AddRay(HorizontalRay(Eigen::Vector3d(-2.0, -20, 3.0), kPi / 2, 40));
  const int wall_below =
      model.AddRay(HorizontalRay(Eigen::Vector3d(-2.0, -20, 2.0), kPi / 2, 40));
  model.Finalize();
  const double tip_z = 2.345678;
  model.Cut(Sweep::Straight(Flat(8.0), Eigen::Vector3d(-20, 0.0, tip_z),
                            Eigen::Vector3d(20, 0.0, tip_z)),
            7, nullptr);
  for (int i : under) {
    EXPECT_NEAR(TopZ(model.rays()[i]), tip_z, 1e-12);
    EXPECT_EQ(model.rays()[i].last_cut_statement, 7);
  }
  EXPECT_DOUBLE_EQ(model.rays()[beside[0]].MaterialLength(), 10);
  const Ray& wall = model.rays()[wall_low];
  ASSERT_EQ(wall.material.size(), 2u);
  EXPECT_NEAR(wall.material[0].second, 12.0, 1e-12);  // y = -8
  EXPECT_NEAR(wall.material[1].first, 28.0, 1e-12);   // y = +8
  EXPECT_DOUBLE_EQ(model.rays()[wall_below].MaterialLength(), 40);
}

TEST(DexelTest, ObliqueFlatMoveCutsToLowestTipOverRay) {
  DexelModel model;
  const int r = model.AddRay(VerticalRay(10, 0, -10, 20));
  model.Finalize();
  // Tip from z=5 at x=0 to z=-5 at x=20: over x in [2, 18] (within the
  // radius 8 of the ray) the lowest tip is at x = 18, z = -4.
  model.Cut(Sweep::Straight(Flat(8.0), Eigen::Vector3d(0, 0, 5),
                            Eigen::Vector3d(20, 0, -5)),
            0, nullptr);
  EXPECT_NEAR(TopZ(model.rays()[r]), -4.0, 1e-12);
}

TEST(DexelTest, ConeEngravesVGroove) {
  DexelModel model;
  const ToolShape engraver{3.0, 50.0, std::tan(45.0 * kPi / 180)};
  const int centre = model.AddRay(VerticalRay(5, 0, -2, 4));
  const int side = model.AddRay(VerticalRay(5, 0.2, -2, 4));
  const int outside = model.AddRay(VerticalRay(5, 0.31, -2, 4));
  // Horizontal ray across the groove at half depth: width 0.3.
  const int across =
      model.AddRay(HorizontalRay(Eigen::Vector3d(5, -1, -0.15), kPi / 2, 2));
  for (int i : {centre, side, outside})
    model.mutable_rays()[i].material = {{0, 2}};
  model.Finalize();
  model.Cut(Sweep::Straight(engraver, Eigen::Vector3d(0, 0, -0.3),
                            Eigen::Vector3d(10, 0, -0.3)),
            0, nullptr);
  EXPECT_NEAR(TopZ(model.rays()[centre]), -0.3, 1e-12);
  EXPECT_NEAR(TopZ(model.rays()[side]), -0.1, 1e-12);
  EXPECT_NEAR(TopZ(model.rays()[outside]), 0.0, 1e-12);
  const Ray& a = model.rays()[across];
  ASSERT_EQ(a.material.size(), 2u);
  EXPECT_NEAR(a.material[0].second, 0.85, 1e-12);
  EXPECT_NEAR(a.material[1].first, 1.15, 1e-12);
}

TEST(DexelTest, FullRotationTurnsExactCylinder) {
  DexelModel model;
  std::vector<int> radial;
  for (int i = 0; i < 37; ++i) {
    const double a = 0.1234 + i * 2 * kPi / 37;
    radial.push_back(model.AddRay(HorizontalRay(
        Eigen::Vector3d(95 * std::cos(a), 95 * std::sin(a), -3.7), a, 10)));
  }
  const int vertical_in = model.AddRay(VerticalRay(0, 99.9, -10, 15));
  const int vertical_out = model.AddRay(VerticalRay(-100.1, 0, -10, 15));
  model.Finalize();
  // Tool centre at radius 108 with radius 8: the cylinder r = 100 remains.
  model.Cut(Sweep::Rotation(Flat(8.0), 108.0, -4.0, 0.3, 0.3 + 2 * kPi), 1,
            nullptr);
  for (int i : radial) {
    const Ray& r = model.rays()[i];
    ASSERT_EQ(r.material.size(), 1u);
    EXPECT_NEAR(r.material[0].second, 5.0, 1e-12);
  }
  EXPECT_DOUBLE_EQ(model.rays()[vertical_in].MaterialLength(), 15);
  EXPECT_NEAR(TopZ(model.rays()[vertical_out]), -4.0, 1e-12);
}

TEST(DexelTest, PartialRotationCutsOnlyItsArc) {
  DexelModel model;
  const auto radial_at = [&](double deg) {
    const double a = deg * kPi / 180;
    return model.AddRay(HorizontalRay(
        Eigen::Vector3d(95 * std::cos(a), 95 * std::sin(a), 0), a, 10));
  };
  const int inside = radial_at(45);
  const int end_disc = radial_at(92);  // within the end disc at 90 deg
  const int outside = radial_at(180);
  const int before = radial_at(-10);
  model.Finalize();
  model.Cut(Sweep::Rotation(Flat(8.0), 108.0, -1.0, 0.0, kPi / 2), 0, nullptr);
  EXPECT_NEAR(model.rays()[inside].material[0].second, 5.0, 1e-12);
  // At 92 deg the end disc (centre at radius 108, 90 deg) reaches radius
  // |108 e(90) - r e(92)| = 8.
  const double a = 2 * kPi / 180;
  const double r_end =
      108 * std::cos(a) - std::sqrt(64 - std::pow(108 * std::sin(a), 2));
  EXPECT_NEAR(model.rays()[end_disc].material[0].second, r_end - 95, 1e-9);
  EXPECT_DOUBLE_EQ(model.rays()[outside].MaterialLength(), 10);
  EXPECT_DOUBLE_EQ(model.rays()[before].MaterialLength(), 10);
}

TEST(DexelTest, CutReportsLargestRemoval) {
  DexelModel model;
  model.AddRay(VerticalRay(0, 0, 0, 10));
  model.AddRay(VerticalRay(50, 0, 0, 10));
  model.Finalize();
  std::vector<int> touched;
  const double removed =
      model.Cut(Sweep::Straight(Flat(2.0), Eigen::Vector3d(-5, 0, 7.5),
                                Eigen::Vector3d(5, 0, 7.5)),
                3, &touched);
  EXPECT_DOUBLE_EQ(removed, 2.5);
  ASSERT_EQ(touched.size(), 1u);
  EXPECT_EQ(touched[0], 0);
}

}  // namespace
}  // namespace ttp::verify
