#include "ttp/geometry/rigid_table.h"

#include <gtest/gtest.h>

#include <random>

namespace ttp {
namespace {

TEST(RigidTable, MicroRoundTrip) {
  const std::array<double, 7> v = {1, -2, 3, -4, 5, -6, 7};
  const auto back = CAxisErrors::FromMicro(v).ToMicro();
  for (int i = 0; i < 7; ++i) EXPECT_NEAR(back[i], v[i], 1e-12);
  EXPECT_DOUBLE_EQ(CAxisErrors::FromMicro(v).ex0c_mm, 1e-3);
  EXPECT_DOUBLE_EQ(CAxisErrors::FromMicro(v).ec0c_rad, 7e-6);
}

TEST(RigidTable, EquationsOfSectionSix) {
  // One error at a time against the printed equations.
  const Eigen::Vector3d p(100, 50, 80);
  const double r = 160;
  CAxisErrors e;
  e.eb0c_rad = 1e-5;
  EXPECT_NEAR(
      (TableDisplacement(e, p, r) - Eigen::Vector3d(1e-5 * 80, 0, -1e-5 * 100))
          .norm(),
      0, 1e-15);
  e = {};
  e.ea0c_rad = 1e-5;  // -E_A0C Z in dY, +E_A0C Y in dZ
  EXPECT_NEAR(
      (TableDisplacement(e, p, r) - Eigen::Vector3d(0, -1e-5 * 80, 1e-5 * 50))
          .norm(),
      0, 1e-15);
  e = {};
  e.er0t_mm = 2e-3;
  EXPECT_NEAR((TableDisplacement(e, p, r) -
               Eigen::Vector3d(2e-3 * 100 / 160, 2e-3 * 50 / 160, 0))
                  .norm(),
              0, 1e-15);
}

TEST(RigidTable, RotationsAreRigid) {
  // The A, B and C terms are an infinitesimal rotation: they preserve the
  // distance between any two points to first order.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-200, 200);
  CAxisErrors e;
  e.ea0c_rad = 3e-5;
  e.eb0c_rad = -2e-5;
  e.ec0c_rad = 4e-5;
  for (int i = 0; i < 50; ++i) {
    const Eigen::Vector3d a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
    const Eigen::Vector3d da = TableDisplacement(e, a, 160);
    const Eigen::Vector3d db = TableDisplacement(e, b, 160);
    EXPECT_NEAR((b - a).dot(db - da), 0, 1e-9);
  }
}

TEST(RigidTable, PerfectCompensationCancels) {
  CAxisErrors e = CAxisErrors::FromMicro({3, -2, 5, 4, 10, -12, 8});
  const Eigen::Vector3d p(103.3, 0, 48), n(1, 0, 0);
  EXPECT_NEAR(SurfaceShiftMm(e, e, p, p, n, 160), 0, 1e-15);
  // Uncompensated X error moves a +X facet inwards (thinner piece).
  CAxisErrors x = CAxisErrors::FromMicro({5, 0, 0, 0, 0, 0, 0});
  EXPECT_NEAR(SurfaceShiftMm(x, {}, p, p, n, 160), -5e-3, 1e-15);
}

}  // namespace
}  // namespace ttp
