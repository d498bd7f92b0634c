#include "ttp/geometry/rtest.h"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <utility>
#include <vector>

#include "ttp/geometry/error.h"

namespace ttp {
namespace {

std::vector<double> ThesisAngles() { return {0, M_PI / 2, M_PI, 3 * M_PI / 2}; }

// Thesis table 5.4, resolution column: 1 um axis resolution, d = 0.32 m.
TEST(RTest, ReproducesTheResolutionColumnOfTable54) {
  RTestGeometry g;
  g.sphere_distance_mm = 160;
  g.sphere_height_mm = 0;  // the thesis refers the cycle to the sphere
  const auto res = RTestResolution(g, ThesisAngles(), 1e-3);
  const double expected_um[4] = {0.25, 0.25, 0.25, 0.25};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(res[i] * 1e3, expected_um[i], 1e-9);
  EXPECT_NEAR(res[4] * 1e6, 3.125, 1e-9);   // E_A0C um/m
  EXPECT_NEAR(res[5] * 1e6, 3.125, 1e-9);   // E_B0C
  EXPECT_NEAR(res[6] * 1e6, 1.5625, 1e-9);  // E_C0C
}

// Whatever the errors, sphere height, table sense and start angle, the
// solve returns the errors that displaced the sphere (noise-free).
TEST(RTest, RecoversRandomErrors) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    RTestGeometry g;
    g.sphere_height_mm = 40 + 60 * (u(rng) + 1);
    g.c_sense = trial % 2 ? 1 : -1;
    g.sphere_phi0_deg = 30 * u(rng);
    const CAxisErrors truth =
        CAxisErrors::FromMicro({5 * u(rng), 5 * u(rng), 5 * u(rng), 5 * u(rng),
                                20 * u(rng), 20 * u(rng), 20 * u(rng)});
    std::vector<SphereMeasurement> ref, cyc;
    for (double c : {0.0, M_PI / 2, M_PI, 3 * M_PI / 2, 2 * M_PI}) {
      const Eigen::Vector3d p = NominalSpherePosition(g, c);
      const Eigen::Vector3d offset(10 * u(rng), 10 * u(rng), 10 * u(rng));
      ref.push_back({c, p + offset});  // geometric errors cancel
      cyc.push_back(
          {c, p + offset + TableDisplacement(truth, p, g.sphere_distance_mm)});
    }
    const RTestSolution s = SolveRTest(g, ref, cyc);
    const auto got = s.errors.ToMicro(), want = truth.ToMicro();
    for (int i = 0; i < 7; ++i) EXPECT_NEAR(got[i], want[i], 1e-9) << i;
    EXPECT_LT(s.rms_residual_mm, 1e-12);
  }
}

TEST(RTest, TooFewAnglesIsAnError) {
  RTestGeometry g;
  std::vector<SphereMeasurement> two = {{0, {160, 0, 80}},
                                        {M_PI, {-160, 0, 80}}};
  EXPECT_THROW(SolveRTest(g, two, two), InputError);
}

// An R-test file: cycles in the order the file first names them, each
// position's angle and centre; values no machine reports refused naming the
// line and the column.
TEST(RTest, SphereFileCyclesInFileOrderAndValuesWithinLimits) {
  const std::string head = "cycle,c_deg,x,y,z\n";
  const std::vector<SphereCycle> cycles = ParseSphereMeasurements(
      head +
          "7,0,160,0,80\n7,90,0,-160,80\n3,0,160.001,0,80\n"
          "3,90,0,-160.002,80\n",
      "s.csv");
  ASSERT_EQ(cycles.size(), 2u);
  EXPECT_EQ(cycles[0].cycle, 7);
  EXPECT_EQ(cycles[1].cycle, 3);
  ASSERT_EQ(cycles[1].positions.size(), 2u);
  EXPECT_NEAR(cycles[1].positions[1].c_rad, M_PI / 2, 1e-15);
  EXPECT_EQ(cycles[1].positions[1].centre_mm.y(), -160.002);
  for (const auto& [row, field] :
       std::vector<std::pair<std::string, std::string>>{
           {"1,0,1e300,0,80", "x"},
           {"1,0,0,0,-2e5", "z"},
           {"1,1e9,0,0,80", "c_deg"},
           {"1.5,0,0,0,80", "cycle"}}) {
    try {
      ParseSphereMeasurements(head + "0,0,160,0,80\n" + row + "\n", "s.csv");
      ADD_FAILURE() << row;
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), field) << row;
      EXPECT_EQ(e.line(), 3) << row;
    }
  }
  EXPECT_THROW(ParseSphereMeasurements(head + "0,0,160,0,80\n", "s.csv"),
               InputError);  // one cycle: nothing to compare
}

// A cycle's centres must move as a sphere d/2 off the C axis does: the
// chord between two angles is 2 (d/2) sin(dc/2) (plane geometry). One
// point repeated at every angle, or a sphere at another distance than the
// one given, is refused naming the line; a sphere within the tolerance and
// micrometre thermal moves pass.
TEST(RTest, CentresThatDoNotMoveAsTheSphereDoesAreRefused) {
  RTestGeometry g;
  g.sphere_distance_mm = 160;
  const std::string head = "cycle,c_deg,x,y,z\n";
  const auto cycles_of = [&](const std::string& rows) {
    return ParseSphereMeasurements(head + rows, "s.csv");
  };
  // 163 mm instead of 160 (within 10 %) and a 2 um thermal move: accepted.
  for (const SphereCycle& c :
       cycles_of("0,0,163,0,80\n0,90,0,-163,80\n"
                 "1,0,163.002,0,80\n1,90,0,-163.001,80\n"))
    EXPECT_NO_THROW(CheckSpheresFollowGeometry(g, c, "s.csv"));
  const auto line_of_refusal = [&](const std::string& rows) {
    for (const SphereCycle& c : cycles_of(rows)) {
      try {
        CheckSpheresFollowGeometry(g, c, "s.csv");
      } catch (const InputError& e) {
        EXPECT_EQ(e.field(), "x,y,z");
        EXPECT_NE(std::string(e.what()).find("--distance-mm"),
                  std::string::npos);
        return e.line();
      }
    }
    return 0;
  };
  // One point at every angle.
  EXPECT_EQ(line_of_refusal("0,0,1,1,1\n0,90,1,1,1\n1,0,1,1,1\n1,90,1,1,1\n"),
            3);
  // A sphere 100 mm off the axis read as 160 mm.
  EXPECT_EQ(line_of_refusal("0,0,100,0,80\n0,180,-100,0,80\n"
                            "1,0,100,0,80\n1,180,-100,0,80\n"),
            3);
  // The second cycle 40 mm off at one angle.
  EXPECT_EQ(line_of_refusal("0,0,160,0,80\n0,90,0,-160,80\n"
                            "1,0,160,0,80\n1,90,40,-160,80\n"),
            5);
}

}  // namespace
}  // namespace ttp
