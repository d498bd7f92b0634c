// `ttp verify`: the project's programs pass the cut simulation; programs
// with a deliberately wrong move fail with exit 1 and the line of the move.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;

fs::path VerifyDir() { return test::TestDir("verify"); }

std::vector<std::string> ReadLines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

void WriteLines(const fs::path& path, const std::vector<std::string>& lines) {
  std::ofstream out(path);
  for (const std::string& l : lines) out << l << "\n";
}

// Writes `ttp gcode NAME --dialect D` into the test folder.
fs::path Program(const std::string& name, const std::string& dialect) {
  const fs::path path =
      VerifyDir() / (name + (dialect == "fanuc" ? ".nc" : ".ngc"));
  if (!fs::exists(path)) {
    const auto r = test::RunTtp("gcode " + name + " --dialect " + dialect +
                                " -o " + path.string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
  }
  return path;
}

const nlohmann::json* FindCheck(const nlohmann::json& doc,
                                const std::string& check) {
  for (const auto& f : doc.at("findings"))
    if (f.at("check") == check) return &f;
  return nullptr;
}

// Inserts `extra` before the last spindle stop of the pre-machining program
// (the tool is at safe height, the spindle still turns) and returns the
// 1-based line of extra[mark] in the new text.
int InsertBeforeEnd(const fs::path& in, const fs::path& out,
                    const std::vector<std::string>& extra, int mark) {
  std::vector<std::string> lines = ReadLines(in);
  int at = -1;
  for (int i = 0; i < static_cast<int>(lines.size()); ++i)
    if (lines[i] == "M5" || lines[i] == "M05") at = i;
  EXPECT_GT(at, 0);
  lines.insert(lines.begin() + at, extra.begin(), extra.end());
  WriteLines(out, lines);
  return at + mark + 1;
}

class CliVerifyDialect : public ::testing::TestWithParam<std::string> {};

TEST_P(CliVerifyDialect, ProjectProgramsPass) {
  const fs::path pre = Program("pre", GetParam());
  const fs::path cycle = Program("cycle", GetParam());
  const fs::path json = VerifyDir() / ("pre_" + GetParam() + ".json");
  auto r = test::RunTtp("verify " + pre.string() + " --json " + json.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("all checks passed"), std::string::npos);
  const auto doc = nlohmann::json::parse(std::ifstream(json));
  EXPECT_EQ(doc.at("stage"), "pre");  // detected: no cut reports
  EXPECT_TRUE(doc.at("passed").get<bool>());
  // The test cycle on what the pre-machining program left.
  r = test::RunTtp("verify " + cycle.string() + " --after " + pre.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("stage cycle"), std::string::npos) << r.output;
  // The summary says what was checked; -v lists every check.
  EXPECT_NE(r.output.find("R-test sphere"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("only C changes between cycles"), std::string::npos);
  r = test::RunTtp("verify -v " + cycle.string() + " --after " + pre.string());
  EXPECT_NE(r.output.find("only C changes between cycles"), std::string::npos);
}

TEST_P(CliVerifyDialect, RapidThroughMaterialIsCaughtWithItsLine) {
  const fs::path bad = VerifyDir() / ("rapid_" + GetParam() + ".txt");
  const int line =
      InsertBeforeEnd(Program("pre", GetParam()), bad,
                      {"G0 X150.0000 Y60.0000 Z50.0000", "G0 Z-5.0000",
                       "G0 X-150.0000", "G0 Z50.0000"},
                      2);
  const fs::path json = VerifyDir() / ("rapid_" + GetParam() + ".json");
  const auto r = test::RunTtp("verify " + bad.string() + " --dialect " +
                              GetParam() + " --json " + json.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const auto doc = nlohmann::json::parse(std::ifstream(json));
  const nlohmann::json* f =
      FindCheck(doc, "rapid cuts no material (straight rapids)");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->at("pass").get<bool>());
  EXPECT_EQ(f->at("line").get<int>(), line);
  // The text names the check and the line.
  EXPECT_NE(
      r.output.find("FAIL rapid cuts no material (straight rapids): 5.0000 "
                    "mm (limit 0.0000), line " +
                    std::to_string(line)),
      std::string::npos)
      << r.output;
}

TEST_P(CliVerifyDialect, FeedIntoTheAdapterIsCaughtWithItsLine) {
  const fs::path bad = VerifyDir() / ("adapter_" + GetParam() + ".txt");
  const int line =
      InsertBeforeEnd(Program("pre", GetParam()), bad,
                      {"G0 X120.0000 Y0.0000 Z50.0000", "G0 Z-26.0000",
                       "G1 X95.0000 F300.0", "G1 X120.0000", "G0 Z50.0000"},
                      2);
  const fs::path json = VerifyDir() / ("adapter_" + GetParam() + ".json");
  const auto r =
      test::RunTtp("verify " + bad.string() + " --json " + json.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const auto doc = nlohmann::json::parse(std::ifstream(json));
  const nlohmann::json* f = FindCheck(doc, "adapter not cut");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->at("pass").get<bool>());
  EXPECT_EQ(f->at("line").get<int>(), line);
  // 16 mm tool at 95 mm from the axis: 3 mm into the 180 mm adapter.
  EXPECT_NEAR(f->at("measured").get<double>(), 3.0, 1e-6);
  EXPECT_NE(r.output.find("FAIL adapter not cut: 3.0000 mm (limit 0.0000), "
                          "line " +
                          std::to_string(line)),
            std::string::npos)
      << r.output;
}

INSTANTIATE_TEST_SUITE_P(BothDialects, CliVerifyDialect,
                         ::testing::Values("fanuc", "linuxcnc"));

TEST(CliVerify, CycleWithoutItsPreMachiningFails) {
  // An empty pre-machining: the cycle's rapids then run through the blank.
  const fs::path empty = VerifyDir() / "empty.ngc";
  WriteLines(empty, {"%", "(nothing)", "M30", "%"});
  const auto r =
      test::RunTtp("verify " + Program("cycle", "linuxcnc").string() +
                   " --after " + empty.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("FAIL"), std::string::npos);
}

TEST(CliVerify, WithoutAProgramVerifiesTheProjectsOwnPrograms) {
  const fs::path json = VerifyDir() / "both.json";
  auto r = test::RunTtp("verify --dialect linuxcnc --json " + json.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("both programs: passed"), std::string::npos)
      << r.output;
  const auto doc = nlohmann::json::parse(std::ifstream(json));
  EXPECT_TRUE(doc.at("passed").get<bool>());
  EXPECT_EQ(doc.at("dialect"), "linuxcnc");
  EXPECT_EQ(doc.at("pre").at("stage"), "pre");
  EXPECT_EQ(doc.at("cycle").at("stage"), "cycle");
  EXPECT_LT(doc.at("max_surface_deviation_um").get<double>(), 5.0);
  // --stage and --after need a program.
  r = test::RunTtp("verify --stage pre");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

TEST(CliVerify, BadInputIsExit2) {
  auto r = test::RunTtp("verify " + (VerifyDir() / "missing.nc").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::RunTtp("verify " + Program("pre", "fanuc").string() +
                   " --stage half");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("stage"), std::string::npos) << r.output;
  r = test::RunTtp("verify " + Program("pre", "fanuc").string() +
                   " --dialect heidenhain");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("dialect"), std::string::npos) << r.output;
  const fs::path garbage = VerifyDir() / "garbage.ngc";
  WriteLines(garbage, {"%", "G1 X1 Y", "M30", "%"});
  r = test::RunTtp("verify " + garbage.string() + " --dialect linuxcnc");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(":2"), std::string::npos) << r.output;
}

// A notch wider than the piece is refused with the field's name before
// anything is written (it used to crash the cut simulation).
TEST(CliVerify, FeaturesThatDoNotFitAreRefusedNamingTheField) {
  const fs::path config = VerifyDir() / "wide_notch.json";
  WriteLines(config, {R"({"part":{"big_notch_half_width_mm":200}})"});
  const fs::path json = VerifyDir() / "wide_notch_result.json";
  for (const std::string& args : {std::string("verify --json ") + json.string(),
                                  std::string("gcode cycle --dialect linuxcnc"),
                                  std::string("schedule")}) {
    const auto r = test::RunTtp("--config " + config.string() + " " + args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.output;
    EXPECT_NE(r.output.find("part.big_notch_half_width_mm"), std::string::npos)
        << r.output;
  }
  EXPECT_FALSE(fs::exists(json));
}

}  // namespace
}  // namespace ttp
