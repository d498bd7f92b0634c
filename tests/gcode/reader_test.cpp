#include "ttp/gcode/reader.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "golden.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

// The machine starts at machine zero; with W's origin there the hand-worked
// positions of the transcripts start at program (0, 0, 0).
Config OriginAtMachineZero() {
  Config c;
  c.machine.table_top_z_mm = -(c.part.adapter_height_mm + c.part.height_mm());
  return c;
}

using testing::Expected;
using K = CanonKind;

const char* kFanucGolden =
    "%\n"                            // 1
    "O2000 (GOLDEN)\n"               // 2
    "G21 G90 G17 G40 G49 G80 G94\n"  // 3
    "G54\n"                          // 4
    "T3 M6\n"                        // 5
    "G43 H3\n"                       // 6
    "M3 S8000\n"                     // 7
    "M8\n"                           // 8
    "G0 X10. Y-5. Z20.\n"            // 9
    "G1 Z-1.5 F500\n"                // 10
    "X20 Y1000\n"                    // 11: no point = 0.001 mm units
    "G91 G1 X5. C90. F1800.\n"       // 12
    "G90\n"                          // 13
    "G04 X2.5\n"                     // 14
    "G04 P1500\n"                    // 15: ms
    "M600 S30\n"                     // 16
    "M601\n"                         // 17
    "M10\n"                          // 18
    "POPEN\n"                        // 19
    "DPRNT[CUT*X2-3*C222.000]\n"     // 20
    "PCLOS\n"                        // 21
    "G31 Z-10. F100.\n"              // 22: one-shot probe
    "Z0.\n"                          // 23: back to G1
    "M5\n"                           // 24
    "M9\n"                           // 25
    "M30\n"                          // 26
    "%\n";

TEST(ReaderTest, FanucGoldenTranscript) {
  const auto got = ReadProgram(kFanucGolden, Dialect::kFanuc,
                               OriginAtMachineZero(), "golden.nc");
  const std::vector<Expected> want = {
      {K::kComment, 2, 0, 0, 0, 0, 0, 0, "GOLDEN"},
      {K::kToolChange, 5, 0, 0, 0, 0, 0, 3},
      // G43 H3: the same physical position is 55 mm (T3's gauge length)
      // lower in program Z, as rs274 reports it.
      {K::kSpindle, 7, 0, 0, -55, 0, 0, 8000},
      {K::kCoolant, 8, 0, 0, -55, 0, 0, 1},
      {K::kTraverse, 9, 10, -5, 20, 0},
      {K::kFeed, 10, 10, -5, -1.5, 0, 500},
      {K::kFeed, 11, 0.020, 1.0, -1.5, 0, 500},
      {K::kFeed, 12, 5.020, 1.0, -1.5, 90, 1800},
      {K::kDwell, 14, 5.020, 1.0, -1.5, 90, 0, 2.5},
      {K::kDwell, 15, 5.020, 1.0, -1.5, 90, 0, 1.5},
      {K::kCSpin, 16, 5.020, 1.0, -1.5, 90, 0, 30},
      {K::kCSpin, 17, 5.020, 1.0, -1.5, 90, 0, 0},
      {K::kClamp, 18, 5.020, 1.0, -1.5, 90, 0, 1},
      {K::kReport, 20, 5.020, 1.0, -1.5, 90, 0, 0, "cut,X2-3,222.000"},
      {K::kProbe, 22, 5.020, 1.0, -10, 90, 100},
      {K::kFeed, 23, 5.020, 1.0, 0, 90, 100},
      {K::kSpindle, 24, 5.020, 1.0, 0, 90, 0, 0},
      {K::kCoolant, 25, 5.020, 1.0, 0, 90, 0, 0},
      {K::kEnd, 26, 5.020, 1.0, 0, 90},
  };
  testing::ExpectTranscript(got, want);
}

const char* kLinuxCncGolden =
    "%\n"                            // 1
    "(golden)\n"                     // 2
    "G21 G90 G17 G40 G49 G80 G94\n"  // 3
    "G54\n"                          // 4
    "T1 M6\n"                        // 5
    "G43 H1\n"                       // 6
    "M3 S3000\n"                     // 7
    "G0 X0 Y0 Z10 C45\n"             // 8: no point = mm here
    "G1 C135 F3600\n"                // 9: pure C, deg/min
    "G1 X1 Y2 Z3\n"                  // 10
    "M3 $1 S1200\n"                  // 11
    "G4 P10\n"                       // 12
    "M5 $1\n"                        // 13
    "M64 P0\n"                       // 14
    "M65 P0\n"                       // 15
    "(print,cut,Z1,0.000)\n"         // 16
    "(msg,hello)\n"                  // 17
    "M4 S2000 ; reverse\n"           // 18
    "G38.2 Z-5 F50\n"                // 19
    "M5\n"                           // 20
    "M5\n"                           // 21: already stopped: nothing
    "M30\n"                          // 22
    "S100\n"                         // 23: after the end, not read
    "%\n";

TEST(ReaderTest, LinuxCncGoldenTranscript) {
  const auto got = ReadProgram(kLinuxCncGolden, Dialect::kLinuxCnc,
                               OriginAtMachineZero(), "golden.ngc");
  std::vector<Expected> want = {
      {K::kComment, 2, 0, 0, 0, 0, 0, 0, "golden"},
      {K::kToolChange, 5, 0, 0, 0, 0, 0, 1},
      {K::kSpindle, 7, 0, 0, -60, 0, 0, 3000},  // G43 H1: T1 is 60 mm
      {K::kTraverse, 8, 0, 0, 10, 45},
      {K::kFeed, 9, 0, 0, 10, 135, 3600},
      {K::kFeed, 10, 1, 2, 3, 135, 3600},
      {K::kCSpin, 11, 1, 2, 3, 135, 0, 1200},
      {K::kDwell, 12, 1, 2, 3, 135, 0, 10},
      {K::kCSpin, 13, 1, 2, 3, 135, 0, 0},
      {K::kClamp, 14, 1, 2, 3, 135, 0, 1},
      {K::kClamp, 15, 1, 2, 3, 135, 0, 0},
      {K::kReport, 16, 1, 2, 3, 135, 0, 0, "cut,Z1,0.000"},
      {K::kComment, 17, 1, 2, 3, 135, 0, 0, "hello"},
      {K::kSpindle, 18, 1, 2, 3, 135, 0, 2000, "", false},
      {K::kProbe, 19, 1, 2, -5, 135, 50},
      {K::kSpindle, 20, 1, 2, -5, 135, 0, 0},
      {K::kEnd, 22, 1, 2, -5, 135},
  };
  testing::ExpectTranscript(got, want);
}

TEST(ReaderTest, InchUnitsAndIncrementalDistances) {
  const auto got =
      ReadProgram("G20 G91 G80\nG0 X1 Y-2\nG0 X1\nG21 G90\nG0 X3\n",
                  Dialect::kLinuxCnc, Config{}, "inch.ngc");
  ASSERT_EQ(got.size(), 3u);
  EXPECT_NEAR(got[0].end_mm.x(), 25.4, 1e-12);
  EXPECT_NEAR(got[0].end_mm.y(), -50.8, 1e-12);
  EXPECT_NEAR(got[1].end_mm.x(), 50.8, 1e-12);
  EXPECT_NEAR(got[2].end_mm.x(), 3.0, 1e-12);
}

TEST(ReaderTest, FanucLeastIncrementsFollowTheUnits) {
  const auto got = ReadProgram("G21 G80\nG0 X1000 C500\nG20\nG0 X1000\n",
                               Dialect::kFanuc, Config{}, "p.nc");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_NEAR(got[0].end_mm.x(), 1.0, 1e-12);              // 0.001 mm
  EXPECT_NEAR(got[0].end_c_rad, 0.5 * M_PI / 180, 1e-15);  // 0.001 deg
  EXPECT_NEAR(got[1].end_mm.x(), 0.1 * 25.4, 1e-12);       // 0.0001 inch
  // The coordinate limit is on the length: X450000 is 450 mm, not 450 m.
  const auto far = ReadProgram("G21\nG0 X450000 Z-450000\n", Dialect::kFanuc,
                               Config{}, "p.nc");
  ASSERT_EQ(far.size(), 1u);
  EXPECT_NEAR(far[0].end_mm.x(), 450.0, 1e-12);
}

// G43 without H: LinuxCNC takes the tool in the spindle, not one selected
// since (rs274 agrees: Rs274Test.ShopEditsMatchOurReader); FANUC's H is
// modal. Every statement carries the offset in effect and its tool.
TEST(ReaderTest, LengthOffsetWithoutHIsTheSpindlesTool) {
  const Config config;
  const ToolSpec& t1 = config.process.roughing;
  const ToolSpec& t2 = config.process.finishing;
  const auto lin = ReadProgram(
      fmt::format("G21\nT{} M6\nT{}\nG43\nG0 Z50\nG49\nG0 Z60\nM30\n",
                  t1.number, t2.number),
      Dialect::kLinuxCnc, config, "p.ngc");
  ASSERT_GE(lin.size(), 3u);
  EXPECT_EQ(lin[1].kind, CanonKind::kTraverse);
  EXPECT_EQ(lin[1].length_offset_tool, t1.number);
  EXPECT_EQ(lin[1].length_offset_mm, t1.length_mm);
  EXPECT_EQ(lin[2].length_offset_tool, -1);
  EXPECT_EQ(lin[2].length_offset_mm, 0);
  const auto fan = ReadProgram(
      fmt::format("O1\nG21\nT{} M6\nG43 H{}\nG0 Z50.\nG49\nG0 Z60.\n"
                  "G43\nG0 Z50.\nM30\n",
                  t1.number, t2.number),
      Dialect::kFanuc, config, "p.nc");
  ASSERT_GE(fan.size(), 4u);
  EXPECT_EQ(fan[3].length_offset_tool, t2.number);
  EXPECT_EQ(fan[3].length_offset_mm, t2.length_mm);
}

struct BadProgram {
  Dialect dialect;
  const char* text;
  int line;
  const char* field;
};

TEST(ReaderTest, BadProgramsNameLineAndWord) {
  const BadProgram cases[] = {
      {Dialect::kLinuxCnc, "G21\nG1 X10\n", 2, "G1"},
      {Dialect::kFanuc, "G21\nG0 X1 Y2 X3\n", 2, "X3"},
      {Dialect::kFanuc, "G0 G1 X1 F10\n", 1, "G1"},
      {Dialect::kFanuc, "G0 X1.2.3\n", 1, "X1.2.3"},
      {Dialect::kLinuxCnc, "G0 Xabc\n", 1, "XABC"},
      {Dialect::kLinuxCnc, "G0 A10\n", 1, "A10"},
      {Dialect::kFanuc, "M3 M5 S100\n", 1, "M5"},
      {Dialect::kLinuxCnc, "G4 X2\n", 1, "X2"},
      {Dialect::kFanuc, "(x)\n#100=1\n", 2, "#100"},
      {Dialect::kFanuc, "WHILE[#1LT3]DO1\n", 1, "WHILE"},
      {Dialect::kFanuc, "DPRNT[CUT*Z1*C0.000]\n", 1, "DPRNT"},
      {Dialect::kFanuc, "G2 X1 Y1\n", 1, "G2"},
      {Dialect::kLinuxCnc, "G0 X1 (comment\n", 1, "("},
      {Dialect::kLinuxCnc, "G1 X1 F-5\n", 1, "F-5"},
      {Dialect::kFanuc, "M600\n", 1, "M600"},
      {Dialect::kLinuxCnc, "O100\n", 1, "O100"},
      {Dialect::kFanuc, "G80\nG0 X1\nG80\nX5\n", 4, "X5"},
      {Dialect::kLinuxCnc, "M64 P3\n", 1, "M64"},
      {Dialect::kFanuc, "G55\nG0 X1\n", 1, "G55"},
      {Dialect::kFanuc, "M6\n", 1, "M6"},
      {Dialect::kFanuc, "M3 M600 S20\n", 1, "M600"},
      {Dialect::kLinuxCnc, "G0 X1\n/G0 X2\n", 2, "/"},
      {Dialect::kLinuxCnc, "M3 $2 S100\n", 1, "$2"},
      {Dialect::kFanuc, "G04 X1. Y2.\n", 1, "Y2."},
      // Numbers beyond int's range (found by the fuzzer: converting them
      // was undefined behaviour).
      {Dialect::kFanuc, "T222222222228.\n", 1, "T222222222228."},
      {Dialect::kLinuxCnc, "M3 $99999999999 S100\n", 1, "$99999999999"},
      {Dialect::kFanuc, "M30000000000\n", 1, "M30000000000"},
      // A macro variable of 127 digits in a DPRNT (the fuzzer's: std::stoi
      // threw out_of_range past the reader).
      {Dialect::kFanuc,
       "DPRNT[C*C#22222222222222222222222222222222222222222222222222222222222"
       "22222222222222222222222222222222222222222222222222222222222222222222"
       ".C#.5*B#.001]\n",
       1, "DPRNT"},
      {Dialect::kFanuc, "IF[ABS[#99999999999999-1.0]GT0.5]THEN#3000=1\n", 1,
       "IF"},
      // FANUC ';' ends the block: another block after it is not dropped.
      {Dialect::kFanuc, "G21\nG0 X10.; G0 Y20.\n", 2, "; G0 Y20."},
      {Dialect::kFanuc, "G21\nG43 Z50.\n", 2, "G43"},
      {Dialect::kLinuxCnc, "G21\nG43\n", 2, "G43"},
  };
  for (const BadProgram& c : cases) {
    SCOPED_TRACE(c.text);
    try {
      ReadProgram(c.text, c.dialect, Config{}, "bad.nc");
      ADD_FAILURE() << "accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), "bad.nc");
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_EQ(e.field(), c.field) << e.what();
    }
  }
}

TEST(ReaderTest, FanucBuilderCodesFollowTheProfile) {
  Config config;
  config.machine.m_c_turning_on = 250;
  config.machine.m_c_turning_off = 251;
  const auto got =
      ReadProgram("M250 S10\nM251\n", Dialect::kFanuc, config, "p.nc");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].kind, CanonKind::kCSpin);
  EXPECT_EQ(got[0].value, 10);
  EXPECT_EQ(got[1].value, 0);
  // The default code is no longer known to this machine.
  EXPECT_THROW(ReadProgram("M600 S10\n", Dialect::kFanuc, config, "p.nc"),
               InputError);
}

TEST(ReaderTest, ToolChangeStopsTurningSpindles) {
  const auto got = ReadProgram("T1 M6\nM3 S1000\nT2 M6\n", Dialect::kFanuc,
                               Config{}, "p.nc");
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[2].kind, CanonKind::kSpindle);
  EXPECT_EQ(got[2].value, 0);
  EXPECT_EQ(got[3].kind, CanonKind::kToolChange);
  EXPECT_EQ(got[3].value, 2);
}

TEST(ReaderTest, DetectDialect) {
  EXPECT_EQ(DetectDialect(kFanucGolden), Dialect::kFanuc);
  EXPECT_EQ(DetectDialect(kLinuxCncGolden), Dialect::kLinuxCnc);
  EXPECT_EQ(DetectDialect("G0 X1\nG4 P2\n"), Dialect::kLinuxCnc);
  EXPECT_EQ(DetectDialect("G0 X1\n"), Dialect::kLinuxCnc);
  EXPECT_EQ(DetectDialect("%\nO0001\nG0 X1\n"), Dialect::kFanuc);
}

// Without anything that shows the dialect, a value the two controls read
// differently is refused with its line and word; a program that reads the
// same in both is LinuxCNC.
TEST(ReaderTest, ResolveDialectRefusesWhatTheDialectsReadDifferently) {
  EXPECT_FALSE(DecideDialect("G0 X1.\n").has_value());
  EXPECT_EQ(ResolveDialect(kFanucGolden, "p.nc"), Dialect::kFanuc);
  EXPECT_EQ(ResolveDialect(kLinuxCncGolden, "p.ngc"), Dialect::kLinuxCnc);
  EXPECT_EQ(ResolveDialect("G0 X1. Y-2.5 C0\nG1 Z0 F100\n", "p.nc"),
            Dialect::kLinuxCnc);
  // (the O-number decides before any value is looked at)
  EXPECT_EQ(ResolveDialect("O0001\nG0 X10\n", "p.nc"), Dialect::kFanuc);
  struct Case {
    const char* text;
    int line;
    const char* word;
    const char* meaning;
  };
  const Case cases[] = {
      {"G0 X1.\nG1 Y10 F100\n", 2, "Y10", "0.01 mm on a FANUC control"},
      {"G0 Z5.\nG0 C90\n", 2, "C90", "0.09 deg on a FANUC control"},
      {"G0 X1.\nG04 P1500\n", 2, "P1500", "1.5 s on a FANUC control"},
  };
  for (const Case& c : cases) {
    try {
      ResolveDialect(c.text, "p.nc");
      ADD_FAILURE() << c.text << ": not refused";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_EQ(e.line(), c.line) << what;
      EXPECT_EQ(e.field(), c.word) << what;
      EXPECT_NE(what.find(c.meaning), std::string::npos) << what;
      EXPECT_NE(what.find("--dialect"), std::string::npos) << what;
    }
  }
  // LinuxCNC's own extension decides.
  EXPECT_EQ(ResolveDialect("G0 X1.\nG1 Y10 F100\n", "dir.nc/p.NGC"),
            Dialect::kLinuxCnc);
  // A line that does not lex is left to the reader.
  EXPECT_EQ(ResolveDialect("G0 X1.\nG1 X2.. F100\n", "p.nc"),
            Dialect::kLinuxCnc);
}

TEST(ReaderTest, SpacesInsideWordsAndM2) {
  const auto got = ReadProgram("G 1 X 10. Y- 2 F 100\nM2\nG0 X0\n",
                               Dialect::kLinuxCnc, Config{}, "p.ngc");
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].kind, CanonKind::kFeed);
  EXPECT_NEAR(got[0].end_mm.x(), 10.0, 1e-12);
  EXPECT_NEAR(got[0].end_mm.y(), -2.0, 1e-12);
  EXPECT_EQ(got[0].feed_per_min, 100.0);
  EXPECT_EQ(got[1].kind, CanonKind::kEnd);
}

}  // namespace
}  // namespace ttp::gcode
