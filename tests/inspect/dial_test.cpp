#include "ttp/inspect/dial.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <sstream>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"

namespace ttp::inspect {
namespace {

std::string Expect(const std::string& text, const std::string& source) {
  try {
    ReadDialReadings(text, source, PartSpec{});
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// Readings drawn at random; the figures must follow the dial-gauge
// equations of test-piece.md section 4 written out here independently:
// E_X = (gX1 - gX2)/2, E_Y = (gY1 - gY2)/2, E_TTP = mean of the four g,
// E_Z = the strip reading.
TEST(DialTest, FiguresFollowTheGaugeEquations) {
  const PartSpec part;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> g(-12.0, 12.0);
  std::map<std::string, double> reading;
  std::ostringstream csv;
  csv.precision(17);
  csv << "feature,reading_um\n";
  for (int j = 1; j <= 9; ++j) {
    if (j == part.reference_index) continue;
    for (Segment s : {Segment::kX1, Segment::kX2, Segment::kY1, Segment::kY2})
      csv << FacetId(s, j) << "," << (reading[FacetId(s, j)] = g(rng)) << "\n";
    csv << StripId(j) << "," << (reading[StripId(j)] = g(rng)) << "\n";
  }
  const FeatureResults results =
      ReadDialReadings(csv.str(), "dial.csv", part, DialOptions{});
  const auto figures = ComputeFigures(part, results);
  ASSERT_EQ(figures.size(), 8u);
  for (const CycleFigures& f : figures) {
    const int j = IndexForCycle(part, f.cycle);
    const double gx1 = reading[FacetId(Segment::kX1, j)];
    const double gx2 = reading[FacetId(Segment::kX2, j)];
    const double gy1 = reading[FacetId(Segment::kY1, j)];
    const double gy2 = reading[FacetId(Segment::kY2, j)];
    EXPECT_NEAR(f.e_x_mm * 1e3, (gx1 - gx2) / 2, 1e-7) << f.cycle;
    EXPECT_NEAR(f.e_y_mm * 1e3, (gy1 - gy2) / 2, 1e-7) << f.cycle;
    EXPECT_NEAR(f.e_ttp_mm * 1e3, (gx1 + gx2 + gy1 + gy2) / 4, 1e-7);
    EXPECT_NEAR(f.e_z_mm * 1e3, reading[StripId(j)], 1e-7);
    EXPECT_TRUE(std::isnan(f.e_b_rad)) << "a gauge cannot give E_B";
    // u(E_X) = sqrt(2)/2 * u(reading), u(reading)^2 = res^2/12 + rep^2.
    const double u_reading_um = std::sqrt(1.0 / 12.0 + 0.25);
    EXPECT_NEAR(f.u_x_mm * 1e3, u_reading_um * std::sqrt(0.5), 1e-12);
    EXPECT_NEAR(f.u_z_mm * 1e3, u_reading_um, 1e-12);
  }
}

TEST(DialTest, MissingReadingsLeaveTheirFiguresMissing) {
  const PartSpec part;
  const int j = IndexForCycle(part, 3);
  std::string csv = "feature,reading_um\n" + FacetId(Segment::kX1, j) + ",2\n" +
                    FacetId(Segment::kX2, j) + ",-2\n";
  const auto figures =
      ComputeFigures(part, ReadDialReadings(csv, "d.csv", part));
  EXPECT_NEAR(figures[2].e_x_mm, 2e-3, 1e-12);
  EXPECT_TRUE(std::isnan(figures[2].e_y_mm));
  EXPECT_TRUE(std::isnan(figures[0].e_x_mm));
}

TEST(DialTest, BadFilesNameTheProblem) {
  EXPECT_NE(Expect("feature,value\nX1-1,2\n", "a.csv").find("reading_um"),
            std::string::npos);
  EXPECT_NE(Expect("feature,reading_um\nX1-1,abc\n", "b.csv").find("b.csv:2"),
            std::string::npos);
  EXPECT_NE(Expect("feature,reading_um\nX1-1,nan\n", "c.csv").find("c.csv:2"),
            std::string::npos);
  EXPECT_NE(Expect("feature,reading_um\nQ9,1\n", "d.csv").find("'Q9'"),
            std::string::npos);
  EXPECT_NE(Expect("feature,reading_um\nTOP,1\n", "d.csv").find("TOP"),
            std::string::npos);
  const std::string twice = Expect("feature,reading_um\nX1-1,1\nX1-1,2\n", "e");
  EXPECT_NE(twice.find("e:3"), std::string::npos) << twice;
  EXPECT_NE(twice.find("line 2"), std::string::npos) << twice;
  EXPECT_NE(Expect("feature,reading_um\nX1-5,3\n", "f").find("reference"),
            std::string::npos);
  EXPECT_EQ(Expect("feature,reading_um\nX1-5,0\n", "g"), "");
  DialOptions bad;
  bad.resolution_um = -1;
  EXPECT_THROW(bad.Validate(), InputError);
}

}  // namespace
}  // namespace ttp::inspect
