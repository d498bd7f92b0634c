// `ttp inspect` and `ttp grade` end to end on the sample run made outside
// the project and on the other measurement kinds.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;

fs::path InspectDir() { return test::TestDir("inspect"); }

nlohmann::json Load(const fs::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

TEST(CliInspect, SampleCloudToFiguresThenGrade) {
  const std::string sample =
      std::string(TTP_DATA_DIR) + "/samples/run-a/piece.ply";
  const fs::path out = InspectDir() / "a.json";
  auto r = test::RunTtp("inspect " + sample + " --json " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("E_TTP"), std::string::npos);
  const nlohmann::json a = Load(out);
  const nlohmann::json truth =
      Load(std::string(TTP_DATA_DIR) + "/samples/run-a/truth.json");
  EXPECT_EQ(a["kind"], "cloud");
  ASSERT_EQ(a["figures"].size(), 8u);
  for (size_t i = 0; i < 8; ++i) {
    EXPECT_EQ(a["figures"][i]["cycle"], static_cast<int>(i + 1));
    for (const char* k : {"E_X", "E_Y", "E_Z", "E_TTP"})
      EXPECT_NEAR(a["figures"][i][k].get<double>(),
                  truth["figures"][i][k].get<double>(), 0.3)
          << k;
    EXPECT_GT(a["figures"][i]["U"]["E_X"].get<double>(), 0.0);
  }
  EXPECT_EQ(a["facets"].size(), 36u);
  EXPECT_TRUE(a["facets"]["X1-1"].contains("distance_mm"));
  EXPECT_TRUE(a["facets"]["X1-1"].contains("angle_error_urad"));

  // The JSON is itself a measurement: same figures.
  const fs::path again = InspectDir() / "a2.json";
  r = test::RunTtp("inspect " + out.string() + " --json " + again.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json b = Load(again);
  EXPECT_EQ(b["kind"], "inspection-json");
  EXPECT_NEAR(b["figures"][3]["E_Z"].get<double>(),
              a["figures"][3]["E_Z"].get<double>(), 1e-9);

  // run-a's E_Z is about -9 um: fails the default 5 um limit (exit 1) ...
  const fs::path verdict = InspectDir() / "grade.json";
  r = test::RunTtp("grade " + out.string() + " --json " + verdict.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("FAIL"), std::string::npos);
  // ... and passes limits far above it (the cloud graded directly).
  r = test::RunTtp("grade " + sample +
                   " --limit-linear-um 100 --limit-angular-um-per-m 500");
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

// A millimetre cloud read with the wrong --units is 1000 (25.4) times the
// piece: the refusal says how far its points lie and asks about the units,
// and a log given where the piece goes says what it is.
TEST(CliInspect, WrongUnitsAndALogInThePiecesPlaceSayWhatIsWrong) {
  const std::string sample =
      std::string(TTP_DATA_DIR) + "/samples/run-b/piece.xyz";
  for (const char* units : {"m", "in"}) {
    const auto r = test::RunTtp("inspect " + sample + " --units " + units);
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("are the cloud's units right? --units"),
              std::string::npos)
        << r.output;
  }
  const auto r = test::RunTtp("inspect " + std::string(TTP_DATA_DIR) +
                              "/samples/run-a/talc.csv");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("a TALC log (talc-log.md), not a measured piece"),
            std::string::npos)
      << r.output;
}

TEST(CliInspect, DialReadingsAndBadInput) {
  const fs::path dial = InspectDir() / "dial.csv";
  std::ofstream(dial) << "feature,reading_um\nX1-1,4\nX2-1,-2\n";
  const fs::path out = InspectDir() / "dial.json";
  auto r = test::RunTtp("inspect " + dial.string() + " --json " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json d = Load(out);
  EXPECT_EQ(d["kind"], "dial");
  EXPECT_TRUE(d["figures"][0]["E_B"].is_null());

  const fs::path bad = InspectDir() / "bad.csv";
  std::ofstream(bad) << "feature,reading_um\nX1-1,four\n";
  r = test::RunTtp("inspect " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("bad.csv:2"), std::string::npos) << r.output;
  r = test::RunTtp("grade " + (InspectDir() / "missing.ply").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = test::RunTtp("inspect " + dial.string() + " --probe-repeatability-um -1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace ttp
