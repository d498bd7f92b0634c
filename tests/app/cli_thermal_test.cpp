// `ttp log` and `ttp simulate` on the sample runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;
const std::string kThermalSamples = std::string(TTP_DATA_DIR) + "/samples/";

TEST(CliThermal, LogSummarisesTheSampleRun) {
  const fs::path json = test::TestDir("thermal") / "log.json";
  const auto r = test::RunTtp("log " + kThermalSamples +
                              "run-b/talc.csv --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("compensation  on"), std::string::npos);
  const auto j = test::ReadJson(json);
  EXPECT_EQ(j["cuts"], 45);
  EXPECT_EQ(j["compensation"], "on");
  EXPECT_TRUE(j["gaps"].empty());
}

TEST(CliThermal, LogRejectsABadFile) {
  const fs::path bad = test::TestDir("thermal") / "bad.csv";
  std::ofstream(bad) << "# talc-log: 1\n# compensation: off\nt_s,event\n";
  const auto r = test::RunTtp("log " + bad.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("start"), std::string::npos) << r.output;
}

// One test per sample run: each is the suite's longest under the
// sanitizers (minutes), and as two they run side by side.
class CliSimulate : public testing::TestWithParam<const char*> {};

TEST_P(CliSimulate, WritesFiguresAndTheInterpolationComparison) {
  const std::string run = GetParam();
  const fs::path json = test::TestDir("thermal") / (run + ".json");
  const auto r =
      test::RunTtp("simulate --log " + kThermalSamples + run +
                   "/talc.csv --compare-interpolation --json " + json.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warm-up start"), std::string::npos);
  const auto j = test::ReadJson(json);
  EXPECT_EQ(j["figures"].size(), 8u);
  EXPECT_EQ(j["cuts"].size(), 45u);
  const auto& w = j["interpolation_at_load_changes"]["windows"];
  ASSERT_EQ(w.size(), 2u) << run;
  EXPECT_EQ(w[0]["load_change"], "warm-up start");
  // With R-tests an hour apart the dynamic model is closer to the
  // held-out R-tests than the straight line across both load changes, and
  // the line is off by a micrometre or more at the cool-down start.
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT(w[k]["rms_model_linear_errors_um"].get<double>(),
              w[k]["rms_line_linear_errors_um"].get<double>())
        << run << " " << k;
  }
  EXPECT_GT(w[1]["max_line_um"].get<double>(), 1.0) << run;
  // Held-out R-tests are counted once however many phases hold them out:
  // never more than the log has.
  std::ifstream log(kThermalSamples + run + "/talc.csv");
  int rtests = 0;
  for (std::string line; std::getline(log, line);)
    if (line.find(",rtest,") != std::string::npos) ++rtests;
  ASSERT_GT(rtests, 0) << run;
  for (int k = 0; k < 2; ++k) {
    EXPECT_GT(w[k]["held_out_rtests"].get<int>(), 0) << run << " " << k;
    EXPECT_LE(w[k]["held_out_rtests"].get<int>(), rtests) << run << " " << k;
    EXPECT_GE(w[k]["held_out_evaluations"].get<int>(),
              w[k]["held_out_rtests"].get<int>())
        << run << " " << k;
  }
}
INSTANTIATE_TEST_SUITE_P(SampleRuns, CliSimulate,
                         testing::Values("run-a", "run-b"),
                         [](const testing::TestParamInfo<const char*>& info) {
                           std::string name = info.param;
                           name.erase(name.find('-'), 1);
                           return name;
                         });

}  // namespace
}  // namespace ttp
