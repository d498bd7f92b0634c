// The conventions every subcommand shares (app/command.h, app/main.cpp):
// suggestions for misspelt commands and options, case-insensitive enum
// values, validated counts, global options after the subcommand, `--json -`
// as pure JSON, defaults in the help.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>

#include "../../app/command.h"
#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;
using test::RunCommand;
using test::RunTtp;

TEST(EditDistance, CountsInsertionsDeletionsSubstitutionsSwaps) {
  EXPECT_EQ(app::EditDistance("inspct", "inspect"), 1);
  EXPECT_EQ(app::EditDistance("--jsn", "--json"), 1);
  EXPECT_EQ(app::EditDistance("kitten", "sitting"), 3);
  EXPECT_EQ(app::EditDistance("", "abc"), 3);
  EXPECT_EQ(app::EditDistance("grdae", "grade"), 1);  // a swap
  EXPECT_EQ(app::ClosestMatch("grdae", {"grade", "gcode", "report"}), "grade");
  // Nothing close enough: no suggestion rather than a wrong one.
  EXPECT_EQ(app::ClosestMatch("xyzzy", {"grade", "gcode", "report"}), "");
}

TEST(CliCommand, SuggestsMisspeltCommandsAndOptions) {
  auto r = RunTtp("inspct " + test::DataPath("samples/run-a/piece.ply"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("did you mean 'inspect'?"), std::string::npos)
      << r.output;
  r = RunTtp("grade --jsn x.json " + test::DataPath("samples/run-b/piece.xyz"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("did you mean '--json'?"), std::string::npos)
      << r.output;
}

TEST(CliCommand, EnumValuesIgnoreCaseAndCountsMustNotBeNegative) {
  const fs::path dir = test::TestDir("cli-command");
  auto r = RunTtp("gcode pre --dialect FANUC -o " + (dir / "pre.nc").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  r = RunTtp("twin --seed -1 -o " + (dir / "twin").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("must be 0 or more"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "twin"));
}

TEST(CliCommand, GlobalOptionsAfterTheSubcommand) {
  const fs::path dir = test::TestDir("cli-command-config");
  auto r = RunTtp("config --config /no/such.toml");
  EXPECT_EQ(r.exit_code, 2) << r.output;  // read, and refused
  r = RunTtp("grade " + test::DataPath("samples/run-b/piece.xyz") + " -q");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, "");
}

TEST(CliCommand, JsonToStdoutIsPureJson) {
  const auto r = test::RunCommand(
      std::string(TTP_BINARY_DIR) + "/app/ttp grade " +
      test::DataPath("samples/run-b/piece.xyz") + " --json - 2>/dev/null");
  EXPECT_EQ(r.exit_code, 0);
  const nlohmann::json j = nlohmann::json::parse(r.output);  // throws if not
  EXPECT_EQ(j["verdict"], "pass");
}

// `simulate --json` gives the simulated figures the U that `check` uses.
TEST(CliCommand, SimulateAndCheckShareTheSimulatedU) {
  const std::string ttp = std::string(TTP_BINARY_DIR) + "/app/ttp ";
  const std::string log = test::DataPath("samples/run-a/talc.csv");
  const auto sim =
      RunCommand(ttp + "simulate --log " + log + " --json - 2>/dev/null");
  const auto check = RunCommand(ttp + "check --log " + log + " " +
                                test::DataPath("samples/run-a/piece.ply") +
                                " --json - 2>/dev/null");
  ASSERT_EQ(sim.exit_code, 0);
  const nlohmann::json s = nlohmann::json::parse(sim.output);
  const nlohmann::json c = nlohmann::json::parse(check.output);
  ASSERT_EQ(s["figures"].size(), c["cycles"].size());
  for (size_t i = 0; i < c["cycles"].size(); ++i) {
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_B", "E_TTP"}) {
      const double u = s["figures"][i]["U"][key].get<double>();
      EXPECT_GT(u, 0.0) << key;
      EXPECT_NEAR(u, c["cycles"][i][key]["U_simulated"].get<double>(), 1e-9)
          << key << " cycle " << i + 1;
    }
  }
}

TEST(CliCommand, RunSizeZeroIsAnError) {
  const auto r = RunTtp("run --size 0 -o " +
                        (test::TestDir("cli-run-size") / "out").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("--size"), std::string::npos) << r.output;
}

TEST(CliCommand, OutputIsDashOOrOutputEverywhere) {
  const fs::path dir = test::TestDir("cli-command-output");
  EXPECT_EQ(RunTtp("plan cmm --output " + (dir / "plan").string()).exit_code,
            0);
  EXPECT_TRUE(fs::exists(dir / "plan" / "cmm_points.csv"));
  EXPECT_EQ(
      RunTtp("twin --seed 2 --output " + (dir / "twin").string()).exit_code, 0);
  EXPECT_TRUE(fs::exists(dir / "twin" / "talc.csv"));
}

// The version a result was made with, for a lab's records: the project's
// version from CMake, with no subcommand needed.
TEST(CliCommand, VersionNeedsNoSubcommand) {
  const auto r = RunTtp("--version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(
      std::regex_match(r.output, std::regex("ttp [0-9]+\\.[0-9]+\\.[0-9]+\n")))
      << r.output;
}

// A command group given alone lists what it holds (exit 2: nothing ran).
TEST(CliCommand, AGroupAloneListsItsSubcommands) {
  auto r = RunTtp("");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("diagnose"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("give one of the subcommands above"),
            std::string::npos)
      << r.output;
  r = RunTtp("thermal");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("predict"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("compare"), std::string::npos) << r.output;
  // A misspelt subcommand keeps its suggestion.
  r = RunTtp("thermal fitt x");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("did you mean 'fit'?"), std::string::npos)
      << r.output;
}

TEST(CliCommand, HelpShowsDefaults) {
  const auto r = RunTtp("grade --help");
  EXPECT_NE(r.output.find("--limit-linear-um FLOAT=5"), std::string::npos)
      << r.output;
}

}  // namespace
}  // namespace ttp
