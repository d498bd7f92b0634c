#include "ttp/geometry/frames.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ttp/geometry/features.h"

namespace ttp {
namespace {

TEST(Frames, WorkpieceOriginSitsOnTheAdapter) {
  Config c;
  EXPECT_DOUBLE_EQ(WorkpieceOriginHeightMm(c), 54.0);
  const Eigen::Vector3d m = WorkpieceToMachine(c, Eigen::Vector3d::Zero(), 1);
  EXPECT_NEAR((m - Eigen::Vector3d(0, 0, 54)).norm(), 0, 1e-12);
}

TEST(Frames, FacetNormalsPointWhereTheCycleNeedsThem) {
  // With C = phi(X1, j) the X1 facet faces +X; at phi(X1,j) - 30 deg the Y1
  // facet faces +Y (test-piece.md section 3).
  Config c;
  for (int j = 1; j <= 9; ++j) {
    const double c_x = FacetPhiDeg(c.part, Segment::kX1, j) * M_PI / 180;
    auto dir = [&](Segment s, double table) -> Eigen::Vector3d {
      const double phi = FacetPhiDeg(c.part, s, j) * M_PI / 180;
      return WorkpieceToMachineRotation(table, 1) *
             Eigen::Vector3d(std::cos(phi), std::sin(phi), 0);
    };
    EXPECT_NEAR((dir(Segment::kX1, c_x) - Eigen::Vector3d::UnitX()).norm(), 0,
                1e-12);
    EXPECT_NEAR((dir(Segment::kX2, c_x) + Eigen::Vector3d::UnitX()).norm(), 0,
                1e-12);
    const double c_y = c_x - M_PI / 6;
    EXPECT_NEAR((dir(Segment::kY1, c_y) - Eigen::Vector3d::UnitY()).norm(), 0,
                1e-12);
    EXPECT_NEAR((dir(Segment::kY2, c_y) + Eigen::Vector3d::UnitY()).norm(), 0,
                1e-12);
  }
}

TEST(Frames, RoundTripAndOppositeSense) {
  Config c;
  const Eigen::Vector3d p(12.5, -40, -3);
  for (int sense : {1, -1}) {
    c.machine.c_sense = sense;
    const Eigen::Vector3d m = WorkpieceToMachine(c, p, 0.7);
    EXPECT_NEAR((MachineToWorkpiece(c, m, 0.7) - p).norm(), 0, 1e-12);
    const double table = TableAngleFor(0.3, -0.2, sense);
    const Eigen::Vector3d d = WorkpieceToMachineRotation(table, sense) *
                              Eigen::Vector3d(std::cos(0.3), std::sin(0.3), 0);
    EXPECT_NEAR(std::atan2(d.y(), d.x()), -0.2, 1e-12);
  }
}

}  // namespace
}  // namespace ttp
