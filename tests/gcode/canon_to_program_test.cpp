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
