#include <gtest/gtest.h>

#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"

namespace ttp::gcode {
namespace {

std::vector<CanonStatement> Read(const char* text) {
  return ReadProgram(text, Dialect::kLinuxCnc, Config{}, "t.ngc");
}

TEST(CompareTest, IdenticalAndCommentOnlyDifferencesAreSame) {
  const auto a = Read("G0 X1 Y2\n(note)\nG1 Z-1 F100\n");
  const auto b = Read("G0 X1 Y2\nG1 Z-1 F100\n");
  EXPECT_TRUE(CompareToolpaths(a, a).same);
  EXPECT_TRUE(CompareToolpaths(a, b).same);
}

TEST(CompareTest, FindsTheFirstDifferingStatement) {
  const auto a = Read("G0 X1 Y2\nG1 Z-1 F100\nG1 X5\n");
  const auto b = Read("G0 X1 Y2\nG1 Z-1 F100\nG1 X5.001\n");
  const ToolpathDifference d = CompareToolpaths(a, b, 1e-6);
  EXPECT_FALSE(d.same);
  EXPECT_EQ(d.index_a, 2u);
  EXPECT_EQ(d.line_a, 3);
  EXPECT_EQ(d.line_b, 3);
  // Within a looser tolerance they agree.
  EXPECT_TRUE(CompareToolpaths(a, b, 1e-2).same);
}

TEST(CompareTest, SeesFeedCAndReportDifferences) {
  EXPECT_FALSE(
      CompareToolpaths(Read("G1 X1 F100\n"), Read("G1 X1 F200\n")).same);
  EXPECT_FALSE(CompareToolpaths(Read("G0 C10\n"), Read("G0 C10.001\n")).same);
  EXPECT_FALSE(CompareToolpaths(Read("(print,cut,Z1,0.000)\n"),
                                Read("(print,cut,Z2,0.000)\n"))
                   .same);
  EXPECT_FALSE(CompareToolpaths(Read("M3 S100\n"), Read("M4 S100\n")).same);
  EXPECT_FALSE(CompareToolpaths(Read("G4 P1\n"), Read("G4 P2\n")).same);
}

TEST(CompareTest, ReportsAMissingTail) {
  const auto a = Read("G0 X1\nG0 X2\n");
  const auto b = Read("G0 X1\n");
  const ToolpathDifference d = CompareToolpaths(a, b);
  EXPECT_FALSE(d.same);
  EXPECT_EQ(d.index_a, 1u);
  EXPECT_EQ(d.index_b, b.size());
}

}  // namespace
}  // namespace ttp::gcode
