// `ttp run`: the main job end to end on the embedded defaults.
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

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(CliRun, WritesEveryStageAndNamesTheHiddenCause) {
  const fs::path dir = test::TestDir("run");
  const auto r = test::RunTtp("run -o " + dir.string() +
                              " --effect workpiece_expansion --seed 7");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* name :
       {"pre_fanuc.nc", "pre_linuxcnc.ngc", "cycle_fanuc.nc",
        "cycle_linuxcnc.ngc", "schedule.csv", "schedule.json",
        "rs274_check.json", "verify.json", "part/part-finished.ply",
        "part/features-finished.csv", "twin/talc.csv", "twin/truth.json",
        "twin/piece.ply", "inspection.json", "check.json", "diagnosis.json",
        "report.html", "report.json"}) {
    EXPECT_TRUE(fs::exists(dir / name)) << name;
    EXPECT_NE(r.output.find((dir / name).string()), std::string::npos)
        << "the summary lists " << name;
  }
  // Not a terminal: no progress lines.
  EXPECT_EQ(r.output.find("[1/"), std::string::npos) << r.output;
  const auto rs = test::ReadJson(dir / "rs274_check.json");
  ASSERT_EQ(rs.size(), 2u);
  for (const auto& p : rs) {
    EXPECT_TRUE(p["rs274_equals_own_reader"].get<bool>()) << p.dump();
    EXPECT_TRUE(p["fanuc_equals_linuxcnc"].get<bool>()) << p.dump();
  }
  const auto verify = test::ReadJson(dir / "verify.json");
  EXPECT_TRUE(verify["passed"].get<bool>()) << verify.dump(1);
  const auto inspection = test::ReadJson(dir / "inspection.json");
  ASSERT_EQ(inspection["figures"].size(), 8u);
  // Every figure of the complete piece is compared; every planned cut is
  // on the log.
  const auto check = test::ReadJson(dir / "check.json");
  EXPECT_EQ(check["compared"].get<int>(),
            static_cast<int>(inspection["figures"].size()) * 5);
  EXPECT_EQ(check["schedule"]["matched_cuts"].get<size_t>(),
            test::ReadJson(dir / "schedule.json")["cuts"].size());
  // The report names the same cause as the diagnosis (its diagnosis
  // section, not the header that shows the hidden effect).
  const auto report = test::ReadJson(dir / "report.json");
  EXPECT_EQ(report["diagnosis"]["cause"], "workpiece_expansion");
  const auto truth = test::ReadJson(dir / "twin/truth.json");
  EXPECT_EQ(truth["cause"], "workpiece_expansion");
  const auto diagnosis = test::ReadJson(dir / "diagnosis.json");
  EXPECT_EQ(diagnosis["cause"], "workpiece_expansion") << diagnosis.dump(1);
}

// Another machine and process: C turning the other way (c_sense -1: the
// log's table angles, such as -60 deg, are the program's 300 deg), a
// 45-minute cycle, C spinning only between cycles 0 and 2, seven facets per
// segment. The twin's log follows the programs' schedule (every planned cut
// found on it), and C turns only in the warm-up the configuration asks for.
TEST(CliRun, TheTwinFollowsTheConfiguredCycle) {
  const fs::path dir = test::TestDir("run_cycle");
  const fs::path config = dir / "process.toml";
  fs::create_directories(dir);
  std::ofstream(config) << "[part]\nfacets_per_segment = 7\n"
                           "reference_index = 4\n"
                           "[machine]\nc_sense = -1\n"
                           "[process]\ncycle_period_s = 2700.0\n"
                           "warmup_cycles = 2\n";
  const fs::path out = dir / "out";
  const auto r = test::RunTtp("--config " + config.string() + " run -o " +
                              out.string() + " --seed 3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto schedule = test::ReadJson(out / "schedule.json");
  ASSERT_EQ(schedule["cuts"].size(), 35u);  // cycles 0..6, five cuts each
  const auto check = test::ReadJson(out / "check.json");
  EXPECT_EQ(check["schedule"]["matched_cuts"].get<size_t>(),
            schedule["cuts"].size())
      << check["schedule"].dump(1);
  // The log's cut rows are 2700 s apart, and C turns only between the
  // first cut of cycle 0 and that of cycle 2.
  std::ifstream log(out / "twin/talc.csv");
  std::string line;
  std::vector<double> z_cuts;
  double last_turning_s = -1;
  while (std::getline(log, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("t_s", 0) == 0) continue;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    ASSERT_GE(f.size(), 6u) << line;
    const double t = std::stod(f[0]);
    if (f[1] == "cut" && line.find(",Z") != std::string::npos)
      z_cuts.push_back(t);
    if (f[1] == "sample" && std::stod(f[5]) > 0) last_turning_s = t;
  }
  ASSERT_EQ(z_cuts.size(), 7u);
  for (size_t i = 1; i < z_cuts.size(); ++i)
    EXPECT_NEAR(z_cuts[i] - z_cuts[i - 1], 2700.0, 1.0);
  EXPECT_GT(last_turning_s, z_cuts[1]);
  EXPECT_LT(last_turning_s, z_cuts[2]);
}

TEST(CliRun, SameInputSameOutput) {
  const fs::path a = test::TestDir("run_a"), b = test::TestDir("run_b");
  ASSERT_EQ(
      test::RunTtp("--quiet run -o " + a.string() + " --seed 3").exit_code, 0);
  ASSERT_EQ(
      test::RunTtp("--quiet run -o " + b.string() + " --seed 3").exit_code, 0);
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(a)) {
    if (!entry.is_regular_file()) continue;
    const fs::path rel = fs::relative(entry.path(), a);
    ASSERT_TRUE(fs::exists(b / rel)) << rel;
    // Files name where they are (the log's path); all else is the same.
    std::string text_a = ReadText(entry.path()), text_b = ReadText(b / rel);
    for (auto [text, dir] : {std::pair{&text_a, a}, std::pair{&text_b, b}}) {
      const std::string d = dir.string();
      for (size_t at; (at = text->find(d)) != std::string::npos;)
        text->replace(at, d.size(), "OUT");
    }
    EXPECT_TRUE(text_a == text_b) << rel;
    ++compared;
  }
  EXPECT_GE(compared, 20);
}

TEST(CliRun, BadOptionsAreUsageErrors) {
  const fs::path dir = test::TestDir("run_bad");
  auto r = test::RunTtp("run -o " + dir.string() + " --effect warping");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("effect"), std::string::npos) << r.output;
  r = test::RunTtp("run");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // The output folder is a file: nothing is written, exit 2.
  std::ofstream(dir / "a_file") << "x";
  r = test::RunTtp("run -o " + (dir / "a_file").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace ttp
