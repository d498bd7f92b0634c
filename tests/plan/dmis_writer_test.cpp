#include <gtest/gtest.h>

#include <regex>
#include <sstream>

#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

TEST(DmisWriterTest, OneMeasurementPerFeatureWithItsPoints) {
  const PartSpec part;
  const auto points = PlanPoints(part);
  const std::string dmis = PointsToDmis(points, part);
  std::istringstream in(dmis);
  std::string line;
  int meas = 0, ptmeas = 0, endmes = 0, outputs = 0, declared = 0;
  int in_block = -1;
  const std::regex meas_re(R"(MEAS/(PLANE|CIRCLE),F\((\w+)\),(\d+))");
  std::smatch m;
  while (std::getline(in, line)) {
    if (std::regex_search(line, m, meas_re)) {
      ++meas;
      declared += std::stoi(m[3]);
      in_block = 0;
    } else if (line.find("PTMEAS/CART") != std::string::npos) {
      ++ptmeas;
      ASSERT_GE(in_block, 0) << "PTMEAS outside MEAS";
      ++in_block;
    } else if (line == "ENDMES") {
      ++endmes;
      in_block = -1;
    } else if (line.rfind("OUTPUT/FA(", 0) == 0) {
      ++outputs;
    }
  }
  EXPECT_EQ(meas, 49);  // 4 datums + 36 facets + 9 strips
  EXPECT_EQ(endmes, meas);
  EXPECT_EQ(outputs, meas);
  EXPECT_EQ(ptmeas, static_cast<int>(points.size()));
  EXPECT_EQ(declared, ptmeas);
  EXPECT_NE(dmis.find("F(X1_5)=FEAT/PLANE"), std::string::npos);
  EXPECT_NE(dmis.find("F(FLANK_PY)=FEAT/PLANE"), std::string::npos);
  EXPECT_NE(dmis.find("F(CYL199)=FEAT/CIRCLE,OUTER"), std::string::npos);
  EXPECT_FALSE(std::regex_search(dmis, std::regex(R"(F\([^)]*[+-])")))
      << "DMIS labels are letters, digits and _";
  EXPECT_EQ(dmis.rfind("ENDFIL"), dmis.size() - 7);
}

}  // namespace
}  // namespace ttp::plan
