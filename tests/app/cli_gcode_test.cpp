// `ttp gcode`: the two programs in both dialects (same toolpath and total
// time), rs274's check, and bad configuration fields named with exit 2.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;

fs::path GcodeDir() { return test::TestDir("gcode"); }

nlohmann::json Read(const fs::path& program) {
  const fs::path json = program.string() + ".json";
  const auto r =
      test::RunTtp("gcode read " + program.string() + " -o " + json.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  return nlohmann::json::parse(std::ifstream(json));
}

class CliGcodeProgram : public ::testing::TestWithParam<std::string> {};

TEST_P(CliGcodeProgram, FanucAndLinuxCncTwinsGiveTheSameToolpathAndTime) {
  const std::string name = GetParam();
  const fs::path nc = GcodeDir() / (name + ".nc"),
                 ngc = GcodeDir() / (name + ".ngc");
  auto r = test::RunTtp("gcode " + name + " -o " + nc.string());  // fanuc
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = test::RunTtp("gcode " + name + " --dialect linuxcnc -o " + ngc.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto a = Read(nc), b = Read(ngc);
  EXPECT_EQ(a.at("dialect"), "fanuc");  // detected from the text
  EXPECT_EQ(b.at("dialect"), "linuxcnc");
  EXPECT_GT(a.at("total_s").get<double>(), name == "cycle" ? 8 * 3600 : 600);
  EXPECT_NEAR(a.at("total_s").get<double>(), b.at("total_s").get<double>(),
              1e-6);
  // Statement by statement: same kinds, end points, C and feeds (comments
  // and line numbers may differ).
  const auto& sa = a.at("statements");
  const auto& sb = b.at("statements");
  ASSERT_EQ(sa.size(), sb.size());
  int moves = 0;
  for (size_t i = 0; i < sa.size(); ++i) {
    SCOPED_TRACE(i);
    ASSERT_EQ(sa[i].at("kind"), sb[i].at("kind"));
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(sa[i]["end_mm"][k].get<double>(),
                  sb[i]["end_mm"][k].get<double>(), 1e-9);
    EXPECT_NEAR(sa[i]["end_c_deg"].get<double>(),
                sb[i]["end_c_deg"].get<double>(), 1e-9);
    EXPECT_NEAR(sa[i]["start_s"].get<double>(), sb[i]["start_s"].get<double>(),
                1e-6);
    if (sa[i].contains("feed_per_min")) {
      ++moves;
      EXPECT_NEAR(sa[i]["feed_per_min"].get<double>(),
                  sb[i]["feed_per_min"].get<double>(), 1e-9);
    }
  }
  EXPECT_GT(moves, 20);
  // rs274 reads the LinuxCNC text (and the FANUC one's translation) into
  // the same canonical moves as the project's reader.
  for (const fs::path& p : {ngc, nc}) {
    r = test::RunTtp("gcode check " + p.string());
    if (r.output.find("rs274") != std::string::npos &&
        r.output.find("not found") != std::string::npos)
      GTEST_SKIP() << "rs274 missing";
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("same toolpath"), std::string::npos) << r.output;
  }
}

INSTANTIATE_TEST_SUITE_P(BothPrograms, CliGcodeProgram,
                         ::testing::Values("pre", "cycle"));

struct BadConfig {
  const char* name;
  const char* toml;
  const char* field;  // must appear in the message
};

class CliGcodeBadConfig : public ::testing::TestWithParam<BadConfig> {};

TEST_P(CliGcodeBadConfig, IsExit2NamingTheField) {
  const BadConfig& c = GetParam();
  const fs::path path = GcodeDir() / (std::string(c.name) + ".toml");
  std::ofstream(path) << c.toml;
  const fs::path out = GcodeDir() / (std::string(c.name) + ".nc");
  const auto r = test::RunTtp("--config " + path.string() + " gcode cycle -o " +
                              out.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(c.field), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out));  // nothing written
}

INSTANTIATE_TEST_SUITE_P(
    Fields, CliGcodeBadConfig,
    ::testing::Values(
        BadConfig{"part_larger_than_blank",
                  "[part]\nref_cylinders = [{diameter_mm = 210.0, "
                  "z_bottom_mm = -24.0, z_top_mm = -12.0}]\n",
                  "part.ref_cylinders[0].diameter_mm"},
        BadConfig{"rim_larger_than_blank", "[part]\nrim_diameter_mm = 250.0\n",
                  "part.rim_diameter_mm"},
        BadConfig{"tool_larger_than_notch",
                  "[process.notch]\ndiameter_mm = 30.0\n",
                  "process.notch.diameter_mm"},
        BadConfig{"travel_exceeded", "[machine]\ntravel_x_mm = [-50.0, 50.0]\n",
                  "machine.travel_x_mm"},
        BadConfig{"negative_dimension", "[part]\nblank_height_mm = -25.0\n",
                  "part.blank_height_mm"},
        BadConfig{"missing_dimension",
                  "[part]\nref_cylinders = [{z_bottom_mm = -24.0, "
                  "z_top_mm = -12.0}]\n",
                  "part.ref_cylinders[0].diameter_mm"},
        BadConfig{"not_a_number", "[part]\nblank_diameter_mm = \"big\"\n",
                  "part.blank_diameter_mm"},
        BadConfig{"unknown_field", "[part]\nblank_diamter_mm = 203.0\n",
                  "blank_diamter_mm"},
        BadConfig{"unreadable_profile", "[machine\ntravel = 1\n", ":1"},
        // Checked where the program is laid out, and still named by file.
        BadConfig{"waiting_in_route",
                  "[machine]\nwaiting_position_w_mm = [100.0, 0.0, 50.0]\n",
                  "waiting_in_route.toml: machine.waiting_position_w_mm"},
        BadConfig{"m_code_shared", "[machine]\nm_probe_off = 600\n",
                  "m_code_shared.toml: machine.m_probe_off: M600 is also "
                  "machine.m_c_turning_on"}),
    [](const ::testing::TestParamInfo<BadConfig>& info) {
      return std::string(info.param.name);
    });

TEST(CliGcode, UnknownDialectOrMissingProfileIsExit2) {
  auto r = test::RunTtp("gcode pre --dialect heidenhain");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--dialect"), std::string::npos) << r.output;
  r = test::RunTtp("--config " + (GcodeDir() / "missing.toml").string() +
                   " gcode pre");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("missing.toml"), std::string::npos) << r.output;
}

// A program that does not show its dialect and whose values the two
// controls read differently (a FANUC program without its O-number line) is
// refused with its line and word, not read a thousand times too large; with
// --dialect it is read.
TEST(CliGcode, UndecidedDialectIsRefusedWhereItMatters) {
  const fs::path program = GcodeDir() / "no_o_number.nc";
  std::ofstream(program) << "%\nG90 G17\nG0 X10. Y20.\nG0 Z5000\nM30\n%\n";
  auto r = test::RunTtp("gcode read " + program.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(program.string() + ":4"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("Z5000"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("--dialect"), std::string::npos) << r.output;
  const fs::path json = GcodeDir() / "no_o_number.json";
  r = test::RunTtp("gcode read " + program.string() + " --dialect fanuc -o " +
                   json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto j = nlohmann::json::parse(std::ifstream(json));
  ASSERT_GE(j.at("statements").size(), 2u);
  EXPECT_NEAR(j["statements"][1]["end_mm"][2].get<double>(), 5.0, 1e-12);
}

// A comment in Latin-1 (a program written on a control, not in UTF-8) is
// read; the JSON carries it with U+FFFD for the byte that is not UTF-8.
TEST(CliGcode, ACommentThatIsNotUtf8IsRead) {
  const fs::path program = GcodeDir() / "latin1.nc";
  std::ofstream(program) << "O0001\n(Fr\xe9sage)\nG0 X1.\nM30\n";
  const auto j = Read(program);
  ASSERT_GE(j.at("statements").size(), 1u);
  EXPECT_EQ(j["statements"][0]["text"], "Fr\xef\xbf\xbdsage");
}

// What LinuxCNC's interpreter refuses is the program's fault: the message
// names the program file and its line, not rs274.
TEST(CliGcode, CheckNamesTheProgramWhenRs274RefusesIt) {
  const fs::path program = GcodeDir() / "no_closing_percent.ngc";
  std::ofstream(program) << "%\nG21 G90\nG0 X0 Y0 Z10\n";
  const auto r = test::RunTtp("gcode check " + program.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("no_closing_percent.ngc:3"), std::string::npos)
      << r.output;
  EXPECT_NE(r.output.find("percent"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("error: rs274"), std::string::npos) << r.output;
}

std::vector<std::string> LinesWith(const fs::path& path,
                                   const std::string& needle) {
  std::ifstream in(path);
  std::vector<std::string> out;
  for (std::string line; std::getline(in, line);)
    if (line.find(needle) != std::string::npos) out.push_back(line);
  return out;
}

// The FANUC probing program is checked by rs274 through its LinuxCNC
// translation: each G31 becomes a G38.2 whose log row (from the DPRNT after
// it) is the one the LinuxCNC probing program writes itself. Back to FANUC
// the touch check cannot be written (a G38.2 has no nominal contact).
TEST(CliGcode, TheFanucProbingProgramIsCheckedAndTranslated) {
  const fs::path dir = GcodeDir();
  const fs::path nc = dir / "probe.nc", ngc = dir / "probe.ngc";
  ASSERT_EQ(test::RunTtp("plan probe --dialect fanuc -o " + nc.string() +
                         " --points-csv " + (dir / "probe_nc.csv").string())
                .exit_code,
            0);
  ASSERT_EQ(test::RunTtp("plan probe --dialect linuxcnc -o " + ngc.string() +
                         " --points-csv " + (dir / "probe_ngc.csv").string())
                .exit_code,
            0);
  auto r = test::RunTtp("gcode check " + nc.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("same toolpath"), std::string::npos) << r.output;
  const fs::path translated = dir / "probe_translated.ngc";
  r = test::RunTtp("gcode translate " + nc.string() + " --to linuxcnc -o " +
                   translated.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto logged = LinesWith(translated, "LOG");
  EXPECT_EQ(logged.size(), LinesWith(ngc, "LOG").size());
  EXPECT_EQ(logged, LinesWith(ngc, "LOG"));
  EXPECT_EQ(LinesWith(translated, "G38.2").size(), LinesWith(nc, "G31").size());
  r = test::RunTtp("gcode translate " + ngc.string() + " --to fanuc");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("touch check"), std::string::npos) << r.output;
  // ttp verify simulates cutting programs: it says what checks a probing
  // program instead of taking every touch for a cut.
  r = test::RunTtp("verify " + nc.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("probe.nc:"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("a probing program"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace ttp
