// `ttp report` and `ttp report-html` end to end on the two sample runs made
// outside the project (samples/).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "run_ttp.h"
#include "ttp/geometry/file_io.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::RunTtp;

fs::path Sample(const std::string& run, const std::string& file) {
  return fs::path(TTP_DATA_DIR) / "samples" / run / file;
}

fs::path OutDir() { return test::TestDir("report"); }

std::string Q(const fs::path& p) { return "'" + p.string() + "'"; }

struct SampleCase {
  const char* run;
  const char* measurement;
};

class CliReport : public ::testing::TestWithParam<SampleCase> {};

TEST_P(CliReport, WritesThePageAndItsDataForTheSampleRun) {
  const SampleCase c = GetParam();
  const fs::path html = OutDir() / (std::string(c.run) + ".html");
  const fs::path data_path = OutDir() / (std::string(c.run) + ".json");
  const auto r = RunTtp("report --log " + Q(Sample(c.run, "talc.csv")) + " " +
                        Q(Sample(c.run, c.measurement)) + " -o " + Q(html) +
                        " --json " + Q(data_path));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json data = json::parse(ReadTextFile(data_path));
  const json truth = json::parse(ReadTextFile(Sample(c.run, "truth.json")));
  // The sample's hidden cause (made outside the project) is found.
  EXPECT_EQ(data["diagnosis"]["cause"], truth["cause"]);
  EXPECT_EQ(data["run"]["compensation"], truth["compensation"]);
  EXPECT_NE(r.output.find("cause " + truth["cause"].get<std::string>()),
            std::string::npos)
      << r.output;
  // The measured figures are near the truth (within 3 U, linear figures).
  for (size_t i = 0; i < truth["figures"].size(); ++i) {
    const json& t = truth["figures"][i];
    const json& m = data["figures"]["measured"][i];
    ASSERT_EQ(m["cycle"], t["cycle"]);
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_TTP"}) {
      EXPECT_NEAR(m[key].get<double>(), t[key].get<double>(),
                  3 * m["U"][key].get<double>())
          << c.run << " cycle " << t["cycle"] << " " << key;
    }
  }
  const std::string page = ReadTextFile(html);
  EXPECT_NE(page.find("data-verdict=\"" +
                      data["grade"]["verdict"].get<std::string>() + "\""),
            std::string::npos);

  // report-html renders the same page from the data file.
  const fs::path again = OutDir() / (std::string(c.run) + "-again.html");
  const auto h = RunTtp("report-html " + Q(data_path) + " -o " + Q(again));
  ASSERT_EQ(h.exit_code, 0) << h.output;
  EXPECT_EQ(ReadTextFile(again), page);
}

INSTANTIATE_TEST_SUITE_P(Samples, CliReport,
                         ::testing::Values(SampleCase{"run-a", "piece.ply"},
                                           SampleCase{"run-b", "piece.xyz"}),
                         [](const auto& info) {
                           return std::string(info.param.run) == "run-a"
                                      ? "RunA"
                                      : "RunB";
                         });

TEST(CliReportErrors, BadInputExitsWithTwoNamingTheFile) {
  const fs::path html = OutDir() / "bad.html";
  auto r = RunTtp("report --log " + Q(Sample("run-a", "talc.csv")) +
                  " /no/such/piece.ply -o " + Q(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("/no/such/piece.ply"), std::string::npos);
  // A point cloud given as the log.
  r = RunTtp("report --log " + Q(Sample("run-a", "piece.ply")) + " " +
             Q(Sample("run-a", "piece.ply")) + " -o " + Q(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("piece.ply"), std::string::npos);
  EXPECT_FALSE(fs::exists(html));
  // The log is required.
  r = RunTtp("report " + Q(Sample("run-a", "piece.ply")) + " -o " + Q(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  // Another run's piece: no cause named (as by `ttp diagnose`).
  r = RunTtp("report --log " + Q(Sample("run-b", "talc.csv")) + " " +
             Q(Sample("run-a", "piece.ply")) + " -o " + Q(html));
  EXPECT_EQ(r.output.find("cause workpiece_expansion"), std::string::npos)
      << r.output;
  // A report data file that breaks the schema names the field.
  const fs::path bad = OutDir() / "bad.json";
  WriteFileAtomic(bad,
                  R"({"schema": "ttp-report/1", "limits": {"linear_um": -1}})");
  r = RunTtp("report-html " + Q(bad) + " -o " + Q(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("limits.linear_um"), std::string::npos) << r.output;
}

TEST(CliReportFormats, AnyMeasurementFileGivesTheSameReport) {
  const fs::path dir = OutDir();
  const std::string log = Q(Sample("run-a", "talc.csv"));
  auto r = RunTtp("report --log " + log + " " +
                  Q(Sample("run-a", "piece.ply")) + " -o " +
                  Q(dir / "cloud.html") + " --json " + Q(dir / "cloud.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  // The inspection JSON of the same cloud.
  r = RunTtp("inspect " + Q(Sample("run-a", "piece.ply")) + " --json " +
             Q(dir / "inspection.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;  // graded
  r = RunTtp("report --log " + log + " " + Q(dir / "inspection.json") + " -o " +
             Q(dir / "inspection.html") + " --json " +
             Q(dir / "inspection.json.report"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json cloud = json::parse(ReadTextFile(dir / "cloud.json"));
  const json insp = json::parse(ReadTextFile(dir / "inspection.json.report"));
  ASSERT_EQ(insp["figures"]["measured"].size(),
            cloud["figures"]["measured"].size());
  for (size_t i = 0; i < cloud["figures"]["measured"].size(); ++i) {
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_B", "E_TTP"}) {
      EXPECT_NEAR(insp["figures"]["measured"][i][key].get<double>(),
                  cloud["figures"]["measured"][i][key].get<double>(), 1e-6)
          << key;
    }
  }
  EXPECT_EQ(insp["diagnosis"]["cause"], cloud["diagnosis"]["cause"]);
  EXPECT_EQ(insp["run"]["measurement kind"], "inspection-json");

  // The report's diagnosis is the one `ttp diagnose` gives for the same
  // file: one reading of a measurement for both.
  r = RunTtp("diagnose --log " + log + " " + Q(Sample("run-a", "piece.ply")) +
             " --json " + Q(dir / "diagnose.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json diagnose = json::parse(ReadTextFile(dir / "diagnose.json"));
  for (const json* report : {&cloud, &insp}) {
    const json& d = (*report)["diagnosis"];
    EXPECT_EQ(d["cause"], diagnose["cause"]);
    EXPECT_NEAR(d["gain_pct"].get<double>(), diagnose["gain_pct"].get<double>(),
                1e-6);
    for (const auto& [name, value] : diagnose["extended"]["params"].items()) {
      EXPECT_NEAR(d["extended"]["params"][name].get<double>(),
                  value.get<double>(), 1e-9 * std::abs(value.get<double>()))
          << name;
      EXPECT_NEAR(d["extended"]["uncertainty"][name].get<double>(),
                  diagnose["extended"]["uncertainty"][name].get<double>(),
                  1e-6 * std::abs(value.get<double>()))
          << name;
    }
  }

  // Figures with the facet angle errors beside them, as the sample's
  // truth.json: the angles reach the diagnosis.
  r = RunTtp("report --log " + log + " " + Q(Sample("run-a", "truth.json")) +
             " -o " + Q(dir / "truth.html") + " --json " +
             Q(dir / "truth.report.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json from_truth = json::parse(ReadTextFile(dir / "truth.report.json"));
  EXPECT_GT(from_truth["diagnosis"]["baseline"]["rms_urad"].get<double>(), 0);

  // The per-feature results `ttp twin` writes (and `ttp diagnose` reads).
  r = RunTtp(
      "twin --effect tool_wear --size 4 --seed 3 --measurement json -o " +
      Q(dir / "twin"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunTtp("report --log " + Q(dir / "twin" / "talc.csv") + " " +
             Q(dir / "twin" / "measured.json") + " -o " + Q(dir / "twin.html") +
             " --json " + Q(dir / "twin.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const json twin = json::parse(ReadTextFile(dir / "twin.json"));
  const json truth = json::parse(ReadTextFile(dir / "twin" / "truth.json"));
  EXPECT_EQ(twin["diagnosis"]["cause"], truth["cause"]);
}

}  // namespace
}  // namespace ttp
