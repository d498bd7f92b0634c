#include "ttp/gcode/rs274.h"

#include <gtest/gtest.h>

#include "golden.h"
#include "sample_program.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

using testing::Expected;
using K = CanonKind;

#define SKIP_WITHOUT_RS274() \
  if (!Rs274Available()) GTEST_SKIP() << "/usr/bin/rs274 is not installed"

// A canon transcript in rs274's format, with the statements it stands for
// worked out from the meaning of each canonical call.
TEST(Rs274Test, ParsesCanonOutput) {
  const std::string canon =
      "    1 N..... USE_LENGTH_UNITS(CANON_UNITS_MM)\n"
      "    2 N..... COMMENT(\"interpreter: cutter radius compensation off\")\n"
      "    3 N3     COMMENT(\"hello, world\")\n"
      "    4 N4     SELECT_TOOL(2)\n"
      "    5 N4     START_CHANGE()\n"
      "    6 N4     STOP_SPINDLE_TURNING(0)\n"
      "    7 N4     CHANGE_TOOL(2)\n"
      "    8 N5     SET_SPINDLE_SPEED(0, 3000.0000)\n"
      "    9 N5     START_SPINDLE_CLOCKWISE(0)\n"
      "   10 N6     FLOOD_ON()\n"
      "   11 N7     STRAIGHT_TRAVERSE(1.0000, 2.0000, 3.0000, 0.0000, 0.0000, "
      "45.0000)\n"
      "   12 N8     SET_FEED_RATE(300.0000)\n"
      "   13 N8     STRAIGHT_FEED(1.0000, 2.0000, -4.0000, 0.0000, 0.0000, "
      "45.0000)\n"
      "   14 N9     DWELL(1.5000)\n"
      "   15 N10    SET_SPINDLE_SPEED(1, 20.0000)\n"
      "   16 N10    START_SPINDLE_CLOCKWISE(1)\n"
      "   17 N11    SET_AUX_OUTPUT_BIT(0)\n"
      "   18 N12    MESSAGE(\"ttp-report:cut,Z1,45.000\")\n"
      "   19 N13    STRAIGHT_PROBE(1.0000, 2.0000, -9.0000, 0.0000, 0.0000, "
      "45.0000)\n"
      "   20 N14    MIST_OFF()\n"
      "   21 N14    FLOOD_OFF()\n"
      "   22 N15    STOP_SPINDLE_TURNING(0)\n"
      "   23 N16    STOP_SPINDLE_TURNING(1)\n"
      "   24 N16    PROGRAM_END()\n"
      "   25 N..... ON_RESET()\n";
  const auto got = ParseRs274Canon(canon, "test");
  const std::vector<Expected> want = {
      {K::kComment, 3, 0, 0, 0, 0, 0, 0, "hello, world"},
      {K::kToolChange, 4, 0, 0, 0, 0, 0, 2},
      {K::kSpindle, 5, 0, 0, 0, 0, 0, 3000},
      {K::kCoolant, 6, 0, 0, 0, 0, 0, 1},
      {K::kTraverse, 7, 1, 2, 3, 45},
      {K::kFeed, 8, 1, 2, -4, 45, 300},
      {K::kDwell, 9, 1, 2, -4, 45, 0, 1.5},
      {K::kCSpin, 10, 1, 2, -4, 45, 0, 20},
      {K::kClamp, 11, 1, 2, -4, 45, 0, 1},
      {K::kReport, 12, 1, 2, -4, 45, 0, 0, "cut,Z1,45.000"},
      {K::kProbe, 13, 1, 2, -9, 45, 300},
      {K::kCoolant, 14, 1, 2, -9, 45, 0, 0},
      {K::kSpindle, 15, 1, 2, -9, 45, 0, 0},
      // The stop of spindle 1 shares M30's line: a reset, dropped.
      {K::kEnd, 16, 1, 2, -9, 45},
  };
  testing::ExpectTranscript(got, want);
}

TEST(Rs274Test, RejectsGarbageCanon) {
  EXPECT_THROW(ParseRs274Canon("this is not canon\n", "x"), InputError);
}

TEST(Rs274Test, WrittenProgramMatchesOurReader) {
  SKIP_WITHOUT_RS274();
  const Config config;
  const std::string text = WriteProgram(testing::EveryStatementProgram(),
                                        Dialect::kLinuxCnc, config);
  const Rs274Result rs = RunRs274(text, config);
  const auto ours = ReadProgram(text, Dialect::kLinuxCnc, config, "sample");
  const ToolpathDifference d = CompareToolpaths(ours, rs.statements, 1e-6);
  EXPECT_TRUE(d.same) << d.what << " (lines " << d.line_a << ", " << d.line_b
                      << ")\n"
                      << rs.canon_text;
  EXPECT_NEAR(TotalDuration(ours), TotalDuration(rs.statements), 1e-6);
  // Same source lines too: the harness numbered the blocks.
  size_t motions = 0;
  for (size_t i = 0, j = 0; i < ours.size() && j < rs.statements.size();
       ++i, ++j) {
    if (ours[i].kind != rs.statements[j].kind) break;
    EXPECT_EQ(ours[i].source_line, rs.statements[j].source_line) << i;
    if (ours[i].kind == CanonKind::kFeed) ++motions;
  }
  EXPECT_GE(motions, 4u);
}

TEST(Rs274Test, HandWrittenProgramWithProbeMatchesOurReader) {
  SKIP_WITHOUT_RS274();
  const char* text =
      "(probe)\n"
      "G21 G90 G80\n"
      "T3 M6\n"
      "M4 S2000\n"
      "G0 X10 Y0 Z5 C30\n"
      "G91 G1 X-2 Z-1 F200\n"
      "G90 G38.2 Z-20 F50\n"
      "G0 Z50\n"
      "G1 C-60 F720\n"
      "G 1 X 12. Y- 2 F 100\n"
      "M5\n"
      "M30\n";
  const Config config;
  const auto ours = ReadProgram(text, Dialect::kLinuxCnc, config, "probe");
  const auto rs = RunRs274(text, config);
  const ToolpathDifference d = CompareToolpaths(ours, rs.statements, 1e-6);
  EXPECT_TRUE(d.same) << d.what << "\n" << rs.canon_text;
  bool has_probe = false;
  for (const auto& s : rs.statements) has_probe |= s.kind == CanonKind::kProbe;
  EXPECT_TRUE(has_probe);
}

TEST(Rs274Test, RandomProgramsMatchOurReader) {
  SKIP_WITHOUT_RS274();
  const Config config;
  for (unsigned seed : {1u, 2u, 3u}) {
    const std::string text = WriteProgram(testing::RandomProgram(seed, 300),
                                          Dialect::kLinuxCnc, config);
    const auto ours = ReadProgram(text, Dialect::kLinuxCnc, config, "random");
    const auto rs = RunRs274(text, config);
    const ToolpathDifference d = CompareToolpaths(ours, rs.statements, 1e-6);
    EXPECT_TRUE(d.same) << "seed " << seed << ": " << d.what << " (line "
                        << d.line_a << ")";
    EXPECT_NEAR(TotalDuration(ours), TotalDuration(rs.statements), 1e-6);
  }
}

// A machinist's edits of a LinuxCNC program, read by rs274 and by us alike:
// the program's own block numbers, G43 without H after another tool was
// selected (the spindle's tool counts), the length offset in inches under
// G20, and coordinates finer than rs274 prints (4 decimals in the
// program's units: the comparison allows that rounding, no more).
TEST(Rs274Test, ShopEditsMatchOurReader) {
  SKIP_WITHOUT_RS274();
  const Config config;
  const char* programs[] = {
      "N10 G21 G90\nN20 T1 M6\nN30 T2\nN40 G43\nN50 G0 X10.12345 Z50\n"
      "N60 G49 G0 Z80\nN70 M30\n",
      "G20 G90\nT2 M6\nG43 H2\nG0 X1.23456 Y0.5 Z2\nG1 Z1.5 F10\n"
      "G49\nG0 Z3\nM30\n",
  };
  for (const char* text : programs) {
    SCOPED_TRACE(text);
    const auto ours = ReadProgram(text, Dialect::kLinuxCnc, config, "shop");
    const Rs274Result rs = RunRs274(text, config);
    const ToolpathDifference d =
        CompareToolpaths(ours, rs.statements, rs.ResolutionMm());
    EXPECT_TRUE(d.same) << d.what << "\n" << rs.canon_text;
    bool offset = false;
    for (const CanonStatement& s : rs.statements)
      offset |= s.kind == CanonKind::kTraverse && s.length_offset_mm > 40;
    EXPECT_TRUE(offset) << "no G43 seen in rs274's canon";
  }
  // Without H after T2 preselected: tool 1's length (rs274's reading).
  const auto rs = RunRs274(programs[0], config);
  for (const CanonStatement& s : rs.statements) {
    if (s.kind == CanonKind::kTraverse && s.length_offset_mm > 0) {
      EXPECT_NEAR(s.length_offset_mm, config.process.roughing.length_mm, 1e-3);
    }
  }
}

TEST(Rs274Test, ToolTableIsConvertedToInches) {
  SKIP_WITHOUT_RS274();
  Config config;
  config.process.roughing.length_mm = 72.5;
  const auto rs = RunRs274("G21\nT1 M6\nG43 H1\nM30\n", config);
  // rs274 reports the offset in program units (mm): 72.5 mm, not 72.5 in.
  EXPECT_NE(rs.canon_text.find("USE_TOOL_LENGTH_OFFSET(0.0000 0.0000 72.5000"),
            std::string::npos)
      << rs.canon_text;
}

TEST(Rs274Test, ErrorsNameTheLine) {
  SKIP_WITHOUT_RS274();
  try {
    RunRs274("G21\n\nG1 X10\nM30\n", Config{});
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "rs274");
    EXPECT_EQ(e.line(), 3);
    EXPECT_NE(e.problem().find("feed"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ttp::gcode
