#include "ttp/gcode/canon_to_program.h"

#include <gtest/gtest.h>

#include "sample_program.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

// FANUC -> canon -> IR -> LinuxCNC -> canon gives the same toolpath.
TEST(CanonToProgramTest, TranslatesBetweenDialects) {
  const Config config;
  const std::string fanuc_text =
      WriteProgram(testing::EveryStatementProgram(), Dialect::kFanuc, config);
  const auto fanuc = ReadProgram(fanuc_text, Dialect::kFanuc, config, "f");
  const Program translated = ProgramFromCanon(fanuc, "t", 1, "t", "f");
  const auto linuxcnc =
      ReadProgram(WriteProgram(translated, Dialect::kLinuxCnc, config),
                  Dialect::kLinuxCnc, config, "l");
  const ToolpathDifference d = CompareToolpaths(fanuc, linuxcnc, 1e-12, 1e-12);
  EXPECT_TRUE(d.same) << d.what;
  EXPECT_NEAR(TotalDuration(fanuc), TotalDuration(linuxcnc), 1e-9);
}

// A translation keeps the tool-length compensation (G43 H, G49) and turns
// C by whole turns as turns: an absolute C target on a table with roll-over
// would take the short way.
TEST(CanonToProgramTest, KeepsLengthCompensationAndTurnsOfC) {
  const Config config;
  const char* text =
      "G21 G90\nT1 M6\nG0 G43 H1 Z50\nG0 X100 Y0\nM3 S1000\n"
      "G1 Z0 F500\nG91 G1 C-360 F600\nG90\nG1 C-370 F600\n"
      "G49 G53 G0 Z0\nM30\n";
  const auto canon = ReadProgram(text, Dialect::kLinuxCnc, config, "l");
  const Program translated = ProgramFromCanon(canon, "t", 1, "t", "l");
  for (Dialect d : {Dialect::kFanuc, Dialect::kLinuxCnc}) {
    const std::string out = WriteProgram(translated, d, config);
    EXPECT_NE(out.find("G43 H1"), std::string::npos) << out;
    EXPECT_NE(out.find("G49"), std::string::npos) << out;
    EXPECT_NE(out.find("G91 G1 C-360.000"), std::string::npos) << out;
    const auto back = ReadProgram(out, d, config, "t");
    const ToolpathDifference diff = CompareToolpaths(canon, back, 1e-9, 1e-12);
    EXPECT_TRUE(diff.same) << diff.what << "\n" << out;
  }
}

TEST(CanonToProgramTest, ReportsKeepFeatureAndAngle) {
  const auto canon = ReadProgram("(print,cut,Y1-4,-12.500)\n",
                                 Dialect::kLinuxCnc, Config{}, "l");
  const Program p = ProgramFromCanon(canon, "t", 1, "t", "l");
  ASSERT_EQ(p.statements.size(), 1u);
  const auto& r = std::get<Report>(p.statements[0]);
  EXPECT_EQ(r.event, "cut");
  EXPECT_EQ(r.feature, "Y1-4");
  EXPECT_EQ(r.c_deg, -12.5);
}

// A FANUC probe move becomes a probe along its one moving axis, named by
// the log row printed after it; a diagonal one has no such statement.
TEST(CanonToProgramTest, ProbeMovesTakeTheirLogRow) {
  const Config config;
  const auto canon = ReadProgram(
      "O0001\nPOPEN\nG0 X10. Y0 Z5.\nG31 Z-2. F100.\n"
      "DPRNT[MEASURE*12*X1-5*X#5061[44]*Y#5062[44]*Z#5063[44]*C#5065[33]]\n"
      "PCLOS\nM30\n",
      Dialect::kFanuc, config, "f");
  const Program p = ProgramFromCanon(canon, "t", 1, "t", "f");
  const Probe* probe = nullptr;
  int reports = 0;
  for (const auto& st : p.statements) {
    if (const auto* q = std::get_if<Probe>(&st)) probe = q;
    if (std::holds_alternative<Report>(st)) ++reports;
  }
  ASSERT_NE(probe, nullptr);
  EXPECT_FALSE(probe->to.x_mm.has_value());
  EXPECT_FALSE(probe->to.y_mm.has_value());
  ASSERT_TRUE(probe->to.z_mm.has_value());
  EXPECT_DOUBLE_EQ(*probe->to.z_mm, -2.0);
  EXPECT_EQ(probe->point_id, 12);
  EXPECT_EQ(probe->feature, "X1-5");
  EXPECT_EQ(probe->pass, "measure");
  EXPECT_EQ(reports, 0);  // the row is the probe's log line, not a report
  const auto diagonal =
      ReadProgram("O0001\nG0 X10. Y0 Z5.\nG31 X9. Z-2. F100.\nM30\n",
                  Dialect::kFanuc, config, "f");
  EXPECT_THROW(ProgramFromCanon(diagonal, "t", 1, "t", "f"), InputError);
}

TEST(CanonToProgramTest, RejectsWhatTheIrCannotSay) {
  const Config config;
  const auto probe =
      ReadProgram("G38.2 Z-5 F10\n", Dialect::kLinuxCnc, config, "l");
  EXPECT_THROW(ProgramFromCanon(probe, "t", 1, "t", "l"), InputError);
  const auto note =
      ReadProgram("(print,hello)\n", Dialect::kLinuxCnc, config, "l");
  try {
    ProgramFromCanon(note, "t", 1, "t", "l");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 1);
    EXPECT_EQ(e.field(), "report");
  }
}

}  // namespace
}  // namespace ttp::gcode
