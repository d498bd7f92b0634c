// CheckCloudUnits alone: a piece in metres, inches or of the wrong size.
#include <gtest/gtest.h>

#include "ttp/geometry/error.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {
namespace {

// A disc of the piece's diameter (the check looks at the extent only).
PointCloud Disc(double scale) {
  PointCloud c;
  c.source = "disc.xyz";
  c.xyz_mm.resize(3, 2000);
  for (int i = 0; i < 2000; ++i) {
    const double a = 0.1 * i, r = 101.5 * std::sqrt((i % 100) / 99.0);
    c.xyz_mm.col(i) =
        scale * Eigen::Vector3d(r * std::cos(a), r * std::sin(a), -(i % 24));
  }
  return c;
}

std::string UnitsErrorOf(const PointCloud& c, bool check = true) {
  InspectOptions o;
  o.check_units = check;
  try {
    CheckCloudUnits(PartSpec{}, c, o);
  } catch (const InputError& e) {
    return e.field() + ": " + e.problem();
  }
  return "";
}

TEST(CheckCloudUnits, MillimetresPassOthersAreNamed) {
  EXPECT_EQ(UnitsErrorOf(Disc(1.0)), "");
  EXPECT_NE(UnitsErrorOf(Disc(1e-3)).find("units: "), std::string::npos);
  EXPECT_NE(UnitsErrorOf(Disc(1e-3)).find("--units m"), std::string::npos);
  EXPECT_NE(UnitsErrorOf(Disc(1 / 25.4)).find("--units in"), std::string::npos);
  EXPECT_NE(UnitsErrorOf(Disc(20.0)).find("alignment: no test piece"),
            std::string::npos);
  EXPECT_EQ(UnitsErrorOf(Disc(1e-3), false), "");
}

}  // namespace
}  // namespace ttp::inspect
