// The CMM program is checked by the DMIS reader of the inspect module
// (statement table written from DMIS 5, label order, patterns, the stylus
// path against the part's mesh), which is itself checked on real CMM
// programs in tests/inspect/dmis_test.cpp. Here: the written program
// passes, and each defect the issue names makes it fail.
#include "ttp/plan/dmis_writer.h"

#include <gtest/gtest.h>

#include <regex>
#include <sstream>

#include "ttp/geometry/error.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/inspect/dmis.h"

namespace ttp::plan {
namespace {

const PartMesh& Finished() {
  static const PartMesh mesh = BuildPartMesh(PartSpec{}, Stage::kFinished);
  return mesh;
}

inspect::DmisProgramCheck Check(const std::string& text,
                                const PartSpec& part = PartSpec{}) {
  return inspect::CheckDmisProgram(inspect::ParseDmisProgram(text, "p.dmi"),
                                   part, Finished());
}

bool CheckPassed(const inspect::DmisProgramCheck& c, const std::string& name) {
  for (const auto& k : c.checks)
    if (k.name == name) return k.passed;
  ADD_FAILURE() << "no check " << name;
  return false;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}
std::string Join(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

const char* kPath = "moves clear the piece, adapter and table";
const char* kPatterns = "point patterns not degenerate";
const char* kStandard = "DMIS 5 statements and labels";

TEST(DmisWriterTest, ProgramPassesEveryCheck) {
  const PartSpec part;
  const auto points = CmmPoints(part);
  const std::string dmis = WriteDmisProgram(part, points);
  const auto c = Check(dmis);
  for (const auto& k : c.checks) {
    EXPECT_TRUE(k.passed) << k.name;
    for (const auto& f : k.findings)
      ADD_FAILURE() << "line " << f.line << ": " << f.problem;
  }
  EXPECT_EQ(c.probe_points, static_cast<int>(points.size()));
  EXPECT_GE(c.min_clearance_mm, 0.5);
  // One measurement and one output per feature, in the reader's labels.
  int meas = 0, outputs = 0;
  for (const auto& l : Lines(dmis)) {
    meas += l.rfind("MEAS/", 0) == 0;
    outputs += l.rfind("OUTPUT/FA(", 0) == 0;
  }
  EXPECT_EQ(meas, 49 + 3);  // 4 datums + 45 features + 3 by hand
  EXPECT_EQ(outputs, 49);
  EXPECT_NE(dmis.find("OUTPUT/FA(X1_5)"), std::string::npos);
  EXPECT_NE(dmis.find("D(W)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),YDIR,DAT(C),"
                      "XORIG,YORIG"),
            std::string::npos);
  // The stylus and the options reach the program.
  DmisOptions o;
  o.stylus_diameter_mm = 2.0;
  o.clearance_height_mm = 35;
  const std::string small = WriteDmisProgram(part, CmmPoints(part, {}, o), o);
  EXPECT_NE(small.find(",-1.0000,2.0000\n"), std::string::npos);
  EXPECT_NE(small.find(",35.0000\n"), std::string::npos);
  EXPECT_TRUE(Check(small).Passed());
}

TEST(DmisWriterTest, PlanesSpanTwoDirections) {
  const PartSpec part;
  // The probing plan's flank and strip points lie on lines: refused.
  try {
    WriteDmisProgram(part, PlanPoints(part));
    ADD_FAILURE() << "collinear flank points accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(e.field() == "FLANK+Y" || e.field() == "FLANK-Y" ||
                e.field()[0] == 'Z')
        << e.what();
  }
  // A program whose flank points were put back on one line fails the
  // pattern check.
  auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  bool in_flank = false;
  for (auto& l : lines) {
    if (l == "MEAS/PLANE,F(FLANK_PY),4") in_flank = true;
    if (l == "ENDMES") in_flank = false;
    if (in_flank && l.find("PTMEAS") != std::string::npos)
      l = std::regex_replace(l, std::regex(",-8\\.0000,"), ",-4.0000,");
  }
  const auto c = Check(Join(lines));
  EXPECT_FALSE(CheckPassed(c, kPatterns));
  EXPECT_TRUE(CheckPassed(c, kPath));
}

// Without the clearance moves the stylus goes straight from strip Z9 into
// segment X1 (the defect of the earlier program).
TEST(DmisWriterTest, MissingClearanceMoveIsFound) {
  const PartSpec part;
  auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  std::vector<std::string> cut;
  bool after_z9 = false;
  for (const auto& l : lines) {
    if (l.rfind("MEAS/PLANE,F(Z9)", 0) == 0) after_z9 = true;
    // Drop the move up at the end of Z9 and the move across at the
    // clearance height before X1-1.
    if (after_z9 && l.rfind("  GOTO/", 0) == 0 &&
        l.find(",20.0000") != std::string::npos)
      continue;
    if (after_z9 && l.rfind("GOTO/", 0) == 0) {
      after_z9 = false;
      continue;
    }
    cut.push_back(l);
  }
  ASSERT_EQ(cut.size() + 2, lines.size());
  const auto c = Check(Join(cut));
  EXPECT_FALSE(CheckPassed(c, kPath));
  EXPECT_TRUE(CheckPassed(c, kStandard));
  EXPECT_LT(c.min_clearance_mm, 0);
}

TEST(DmisWriterTest, DatumUsedBeforeItIsMeasuredIsFound) {
  const PartSpec part;
  auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  // Move "DATDEF/FA(TOP),DAT(A)" before the measurement of TOP.
  auto it = std::find(lines.begin(), lines.end(), "DATDEF/FA(TOP),DAT(A)");
  ASSERT_NE(it, lines.end());
  const std::string datdef = *it;
  lines.erase(it);
  auto top = std::find_if(lines.begin(), lines.end(), [](const std::string& l) {
    return l.rfind("F(TOP)=FEAT", 0) == 0;
  });
  lines.insert(top, datdef);
  const auto c = Check(Join(lines));
  EXPECT_FALSE(CheckPassed(c, kStandard));
}

TEST(DmisWriterTest, NoSensorNoFeedsNoAlignmentAreFound) {
  const PartSpec part;
  const auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  const auto without = [&](const std::string& prefix) {
    std::vector<std::string> out;
    for (const auto& l : lines)
      if (l.rfind(prefix, 0) != 0) out.push_back(l);
    return Check(Join(out));
  };
  EXPECT_FALSE(without("SNSLCT/").Passed());
  EXPECT_FALSE(CheckPassed(without("FEDRAT/MESVEL"),
                           "sensor, feeds and distances set before measuring"));
  EXPECT_FALSE(CheckPassed(without("D(MAN)=DATSET"),
                           "part aligned from measured datums before moving"));
}

TEST(DmisWriterTest, RefusesWhatCannotRun) {
  const PartSpec part;
  DmisOptions o;
  o.stylus_diameter_mm = 0;
  EXPECT_THROW(WriteDmisProgram(part, CmmPoints(part), o), InputError);
  // A ball too big to touch the 199 band above the step to the 200
  // cylinder.
  o.stylus_diameter_mm = 9;
  try {
    CmmPoints(part, {}, o);
    ADD_FAILURE() << "9 mm ball accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "stylus_diameter_mm");
  }
  auto points = CmmPoints(part);
  points.erase(std::remove_if(points.begin(), points.end(),
                              [](const PlannedPoint& p) {
                                return p.feature == "CYL199";
                              }),
               points.end());
  EXPECT_THROW(WriteDmisProgram(part, points), InputError);
}

}  // namespace
}  // namespace ttp::plan
