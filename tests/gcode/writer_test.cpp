#include "ttp/gcode/writer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "sample_program.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

Program SmallProgram() {
  Program p;
  p.name = "small";
  p.number = 1000;
  p.title = "t";
  p.statements = {ToolChange{1, ""},
                  SpindleOn{3000, true},
                  Rapid{{10.0, 0.0, 5.0, std::nullopt}},
                  Feed{{std::nullopt, std::nullopt, -1.0, std::nullopt}, 600},
                  Feed{{20.0, std::nullopt, std::nullopt, std::nullopt}, 600},
                  Dwell{1.5},
                  CSpin{20},
                  CSpin{0},
                  TableClamp{true},
                  Report{"cut", "Z5", 0.0},
                  ProgramEnd{}};
  return p;
}

TEST(WriterTest, FanucTextFollowsTheDocumentedForm) {
  const std::string expected =
      "%\n"
      "O1000 (t)\n"
      "G17 G21 G40 G49 G69 G80 G90 G94\n"
      "G54\n"
      "T1 M6\n"
      "M3 S3000\n"
      "G0 X10.0000 Y0.0000 Z5.0000\n"
      "G1 Z-1.0000 F600.0\n"
      "G1 X20.0000\n"
      "G04 X1.500\n"
      "M600 S20\n"
      "M601\n"
      "M10\n"
      "POPEN\n"
      "G53\n"
      "DPRNT[CUT*Z5*C0.000*T#3012[60]]\n"
      "PCLOS\n"
      "M30\n"
      "%\n";
  EXPECT_EQ(WriteProgram(SmallProgram(), Dialect::kFanuc, Config{}), expected);
}

TEST(WriterTest, LinuxCncTextFollowsTheDocumentedForm) {
  const std::string expected =
      "%\n"
      "(t)\n"
      "G17 G21 G40 G49 G80 G90 G94 G64 P0.005\n"
      "G54\n"
      "T1 M6\n"
      "M3 S3000\n"
      "G0 X10.0000 Y0.0000 Z5.0000\n"
      "G1 Z-1.0000 F600.0\n"
      "G1 X20.0000\n"
      "G4 P1.500\n"
      "M3 $1 S20\n"
      "M5 $1\n"
      "M64 P0\n"
      "(debug,cut,Z5,0.000)\n"
      "M30\n"
      "%\n";
  EXPECT_EQ(WriteProgram(SmallProgram(), Dialect::kLinuxCnc, Config{}),
            expected);
}

TEST(WriterTest, BuilderMCodesComeFromTheMachineProfile) {
  Config config;
  config.machine.m_c_turning_on = 123;
  config.machine.m_c_turning_off = 124;
  config.machine.m_table_clamp = 68;
  const std::string text =
      WriteProgram(SmallProgram(), Dialect::kFanuc, config);
  EXPECT_NE(text.find("\nM123 S20\nM124\nM68\n"), std::string::npos) << text;
}

TEST(WriterTest, SameProgramGivesSameText) {
  const Program p = testing::EveryStatementProgram();
  EXPECT_EQ(WriteProgram(p, Dialect::kFanuc, Config{}),
            WriteProgram(p, Dialect::kFanuc, Config{}));
}

TEST(WriterTest, RejectsStatementsThatCannotBeWritten) {
  Program p = SmallProgram();
  p.statements.insert(p.statements.begin() + 2, SpindleOn{-5, true});
  try {
    WriteProgram(p, Dialect::kFanuc, Config{});
    FAIL() << "negative rpm accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "statement 2");
  }
  Program q = SmallProgram();
  q.statements.push_back(
      Feed{{std::nan(""), std::nullopt, std::nullopt, std::nullopt}, 100});
  EXPECT_THROW(WriteProgram(q, Dialect::kLinuxCnc, Config{}), InputError);
  Program r = SmallProgram();
  r.statements.push_back(Report{"cut", "X1 5", 0});
  EXPECT_THROW(WriteProgram(r, Dialect::kFanuc, Config{}), InputError);
}

// Both dialects, read back by our reader, give the same toolpath and time.
TEST(WriterTest, BothDialectsReadBackToTheSameToolpathAndTime) {
  const Config config;
  const Program p = testing::EveryStatementProgram();
  const auto fanuc = ReadProgram(WriteProgram(p, Dialect::kFanuc, config),
                                 Dialect::kFanuc, config, "fanuc");
  const auto linuxcnc = ReadProgram(WriteProgram(p, Dialect::kLinuxCnc, config),
                                    Dialect::kLinuxCnc, config, "linuxcnc");
  const ToolpathDifference d = CompareToolpaths(fanuc, linuxcnc, 1e-12, 1e-12);
  EXPECT_TRUE(d.same) << d.what;
  EXPECT_NEAR(TotalDuration(fanuc), TotalDuration(linuxcnc), 1e-9);
  // Every statement type of the IR leaves a trace.
  std::set<CanonKind> kinds;
  for (const auto& s : fanuc) kinds.insert(s.kind);
  for (CanonKind k :
       {CanonKind::kTraverse, CanonKind::kFeed, CanonKind::kDwell,
        CanonKind::kSpindle, CanonKind::kCSpin, CanonKind::kCoolant,
        CanonKind::kToolChange, CanonKind::kClamp, CanonKind::kReport,
        CanonKind::kComment, CanonKind::kEnd})
    EXPECT_TRUE(kinds.count(k)) << CanonKindName(k);
  // Reports carry the feature and the angle of the IR.
  std::vector<std::string> reports;
  for (const auto& s : fanuc)
    if (s.kind == CanonKind::kReport) reports.push_back(s.text);
  EXPECT_EQ(reports,
            (std::vector<std::string>{"cut,Z5,0.000", "cut,X1-5,60.000",
                                      "cut,Y2-9,-30.000"}));
}

TEST(WriterTest, RandomProgramsReadBackAlikeInBothDialects) {
  const Config config;
  for (unsigned seed : {11u, 12u, 13u, 14u}) {
    const Program p = testing::RandomProgram(seed, 400);
    const auto fanuc = ReadProgram(WriteProgram(p, Dialect::kFanuc, config),
                                   Dialect::kFanuc, config, "fanuc");
    const auto linuxcnc =
        ReadProgram(WriteProgram(p, Dialect::kLinuxCnc, config),
                    Dialect::kLinuxCnc, config, "linuxcnc");
    const ToolpathDifference d =
        CompareToolpaths(fanuc, linuxcnc, 1e-12, 1e-12);
    EXPECT_TRUE(d.same) << "seed " << seed << ": " << d.what;
    EXPECT_NEAR(TotalDuration(fanuc), TotalDuration(linuxcnc), 1e-9);
    EXPECT_GT(TotalDuration(fanuc), 0.0);
  }
}

TEST(WriterTest, DetectDialectRecognisesBothWriters) {
  const Program p = testing::EveryStatementProgram();
  EXPECT_EQ(DetectDialect(WriteProgram(p, Dialect::kFanuc, Config{})),
            Dialect::kFanuc);
  EXPECT_EQ(DetectDialect(WriteProgram(p, Dialect::kLinuxCnc, Config{})),
            Dialect::kLinuxCnc);
}

}  // namespace
}  // namespace ttp::gcode
