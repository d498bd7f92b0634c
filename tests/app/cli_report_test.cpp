// `ttp report` and `ttp report-html` end to end on the sample runs
// (samples/): run-a and run-b made outside the project, run-c's instruments
// by the project's generators.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
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

struct SampleCase {
  const char* run;
  const char* measurement;
};

class CliReport : public ::testing::TestWithParam<SampleCase> {};

TEST_P(CliReport, WritesThePageAndItsDataForTheSampleRun) {
  const SampleCase c = GetParam();
  const fs::path html = OutDir() / (std::string(c.run) + ".html");
  const fs::path data_path = OutDir() / (std::string(c.run) + ".json");
  const auto r = RunTtp(
      "report --log " + test::ShellQuoted(Sample(c.run, "talc.csv")) + " " +
      test::ShellQuoted(Sample(c.run, c.measurement)) + " -o " +
      test::ShellQuoted(html) + " --json " + test::ShellQuoted(data_path));
  const json data = json::parse(ReadTextFile(data_path));
  // Exit 1 unless the verdict is pass (as `ttp grade`) and the diagnosis
  // is not refused.
  ASSERT_EQ(r.exit_code, data["grade"]["verdict"] == "pass" &&
                                 data["diagnosis"]["status"] != "refused"
                             ? 0
                             : 1)
      << r.output;
  const json truth = json::parse(ReadTextFile(Sample(c.run, "truth.json")));
  // The sample's hidden cause (made outside the project) is found.
  EXPECT_EQ(data["diagnosis"]["cause"], truth["cause"]);
  EXPECT_EQ(data["run"]["compensation"], truth["compensation"]);
  // The summary line says the diagnosis's status, and the cause if named.
  const std::string cause = truth["cause"];
  EXPECT_NE(r.output.find(cause == "none" ? "diagnosis none"
                                          : "diagnosis named " + cause),
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
  const auto h = RunTtp("report-html " + test::ShellQuoted(data_path) + " -o " +
                        test::ShellQuoted(again));
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

// A log that was read but ends before the program's last cut: the page is
// written with the piece's grade and the diagnosis refused, saying why
// (as `ttp diagnose`), exit 1; not bad input.
TEST(CliReportErrors, ALogThatDoesNotCoverTheCutsIsARefusedDiagnosis) {
  const fs::path dir = OutDir();
  const fs::path shortened = dir / "short-talc.csv";
  {
    std::ifstream in(Sample("run-a", "talc.csv"));
    std::ofstream out(shortened);
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) &&
          std::stod(line) > 4.5 * 3600)
        break;
      out << line << "\n";
    }
  }
  const fs::path html = dir / "short.html", data_path = dir / "short.json";
  const auto r = RunTtp("report --log " + test::ShellQuoted(shortened) + " " +
                        test::ShellQuoted(Sample("run-a", "piece.ply")) +
                        " -o " + test::ShellQuoted(html) + " --json " +
                        test::ShellQuoted(data_path));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  ASSERT_TRUE(fs::exists(html)) << r.output;
  const json data = json::parse(ReadTextFile(data_path));
  EXPECT_EQ(data["diagnosis"]["status"], "refused");
  EXPECT_NE(data["diagnosis"]["reason"].get<std::string>().find("last cut"),
            std::string::npos)
      << data["diagnosis"];
  EXPECT_NE(r.output.find("diagnosis refused"), std::string::npos) << r.output;
}

TEST(CliReportErrors, BadInputExitsWithTwoNamingTheFile) {
  const fs::path html = OutDir() / "bad.html";
  auto r =
      RunTtp("report --log " + test::ShellQuoted(Sample("run-a", "talc.csv")) +
             " /no/such/piece.ply -o " + test::ShellQuoted(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("/no/such/piece.ply"), std::string::npos);
  // A point cloud given as the log.
  r = RunTtp("report --log " + test::ShellQuoted(Sample("run-a", "piece.ply")) +
             " " + test::ShellQuoted(Sample("run-a", "piece.ply")) + " -o " +
             test::ShellQuoted(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("piece.ply"), std::string::npos);
  EXPECT_FALSE(fs::exists(html));
  // -o is required, its folder must exist, and an input is never replaced.
  r = RunTtp("report " + test::ShellQuoted(Sample("run-a", "piece.ply")));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunTtp("report " + test::ShellQuoted(Sample("run-a", "piece.ply")) +
             " -o " +
             test::ShellQuoted(OutDir() / "no-such-folder" / "r.html"));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("does not exist"), std::string::npos) << r.output;
  const fs::path copy = OutDir() / "talc-copy.csv";
  fs::copy_file(Sample("run-a", "talc.csv"), copy,
                fs::copy_options::overwrite_existing);
  const std::string before = ReadTextFile(copy);
  r = RunTtp("report --log " + test::ShellQuoted(copy) + " " +
             test::ShellQuoted(Sample("run-a", "piece.ply")) + " -o " +
             test::ShellQuoted(copy));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("is an input"), std::string::npos) << r.output;
  EXPECT_EQ(ReadTextFile(copy), before);
  // A truth file is not a measurement.
  r = RunTtp("report " + test::ShellQuoted(Sample("run-a", "truth.json")) +
             " -o " + test::ShellQuoted(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("truth file"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(html));
  // Another run's piece: no cause named (as by `ttp diagnose`).
  r = RunTtp("report --log " + test::ShellQuoted(Sample("run-b", "talc.csv")) +
             " " + test::ShellQuoted(Sample("run-a", "piece.ply")) + " -o " +
             test::ShellQuoted(html));
  EXPECT_EQ(r.output.find("cause workpiece_expansion"), std::string::npos)
      << r.output;
  // A dial sheet with only a reference cycle's reading: nothing to
  // diagnose, and the message names the sheet (as `ttp diagnose` does).
  const fs::path dial = OutDir() / "one-reading.csv";
  WriteFileAtomic(dial, "feature,reading_um\nX1-1,1.5\n");
  for (const std::string cmd : {"report", "diagnose"}) {
    r = RunTtp(cmd + " --log " +
               test::ShellQuoted(Sample("run-a", "talc.csv")) + " " +
               test::ShellQuoted(dial) +
               (cmd == "report" ? " -o " + test::ShellQuoted(html) : ""));
    EXPECT_EQ(r.exit_code, 2) << cmd << r.output;
    EXPECT_NE(r.output.find("one-reading.csv"), std::string::npos)
        << cmd << r.output;
  }
  // A report data file that breaks the schema names the field.
  const fs::path bad = OutDir() / "bad.json";
  WriteFileAtomic(bad,
                  R"({"schema": "ttp-report/1", "limits": {"linear_um": -1}})");
  r = RunTtp("report-html " + test::ShellQuoted(bad) + " -o " +
             test::ShellQuoted(html));
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("limits.linear_um"), std::string::npos) << r.output;
}

TEST(CliReportFormats, AnyMeasurementFileGivesTheSameReport) {
  const fs::path dir = OutDir();
  const std::string log = test::ShellQuoted(Sample("run-a", "talc.csv"));
  auto r = RunTtp("report --log " + log + " " +
                  test::ShellQuoted(Sample("run-a", "piece.ply")) + " -o " +
                  test::ShellQuoted(dir / "cloud.html") + " --json " +
                  test::ShellQuoted(dir / "cloud.json"));
  ASSERT_EQ(r.exit_code, 1) << r.output;  // run-a fails
  // The inspection JSON of the same cloud.
  r = RunTtp("inspect " + test::ShellQuoted(Sample("run-a", "piece.ply")) +
             " --json " + test::ShellQuoted(dir / "inspection.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;  // graded
  r = RunTtp("report --log " + log + " " +
             test::ShellQuoted(dir / "inspection.json") + " -o " +
             test::ShellQuoted(dir / "inspection.html") + " --json " +
             test::ShellQuoted(dir / "inspection.json.report"));
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
  EXPECT_EQ(insp["run"]["measurement_kind"], "inspection-json");

  // The report's diagnosis is the one `ttp diagnose` gives for the same
  // file: one reading of a measurement for both.
  r = RunTtp("diagnose --log " + log + " " +
             test::ShellQuoted(Sample("run-a", "piece.ply")) + " --json " +
             test::ShellQuoted(dir / "diagnose.json"));
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

  // The per-feature results `ttp twin` writes (and `ttp diagnose` reads).
  r = RunTtp(
      "twin --effect tool_wear --size 4 --seed 3 --measurement json -o " +
      test::ShellQuoted(dir / "twin"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunTtp("report --log " + test::ShellQuoted(dir / "twin" / "talc.csv") +
             " " + test::ShellQuoted(dir / "twin" / "measured.json") + " -o " +
             test::ShellQuoted(dir / "twin.html") + " --json " +
             test::ShellQuoted(dir / "twin.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  const json twin = json::parse(ReadTextFile(dir / "twin.json"));
  const json truth = json::parse(ReadTextFile(dir / "twin" / "truth.json"));
  EXPECT_EQ(twin["diagnosis"]["cause"], truth["cause"]);
}

// One decision everywhere: `ttp grade` and `ttp report` give the same
// verdict, exit code and grade on every kind of measurement.
struct KindCase {
  const char* run;
  const char* file;
  bool with_log;  // the report with the run's TALC log and diagnosis
};

class CliVerdicts : public ::testing::TestWithParam<KindCase> {};

TEST_P(CliVerdicts, GradeAndReportAgree) {
  const KindCase c = GetParam();
  const fs::path dir = OutDir();
  const std::string m = test::ShellQuoted(Sample(c.run, c.file));
  const auto g =
      RunTtp("grade " + m + " --json " + test::ShellQuoted(dir / "grade.json"));
  ASSERT_TRUE(g.exit_code == 0 || g.exit_code == 1) << g.output;
  const auto r = RunTtp(
      "report " + m +
      (c.with_log ? " --log " + test::ShellQuoted(Sample(c.run, "talc.csv"))
                  : std::string()) +
      " -o " + test::ShellQuoted(dir / "r.html") + " --json " +
      test::ShellQuoted(dir / "r.json"));
  EXPECT_EQ(r.exit_code, g.exit_code) << r.output;
  const json grade = json::parse(ReadTextFile(dir / "grade.json"));
  const json data = json::parse(ReadTextFile(dir / "r.json"));
  EXPECT_EQ(data["grade"], grade);
  EXPECT_EQ(g.exit_code, grade["verdict"] == "pass" ? 0 : 1);
  EXPECT_EQ(data.contains("diagnosis"), c.with_log);
  // The summary names what the verdict was decided on.
  EXPECT_NE(g.output.find(" on E_X, E_Y, E_Z"), std::string::npos) << g.output;
  const std::string page = ReadTextFile(dir / "r.html");
  EXPECT_NE(
      page.find("data-verdict=\"" + grade["verdict"].get<std::string>() + "\""),
      std::string::npos);
  // Angles the instrument did not measure are not shown as numbers.
  if (std::string(c.file) == "dial.csv") {
    for (const auto& [id, facet] : data["facets"].items())
      EXPECT_TRUE(facet["angle_error_urad"].is_null()) << id;
    EXPECT_NE(page.find("not measured"), std::string::npos);
    EXPECT_NE(g.output.find("E_B: not measured: a dial gauge"),
              std::string::npos)
        << g.output;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, CliVerdicts,
    ::testing::Values(KindCase{"run-a", "piece.ply", true},
                      KindCase{"run-b", "piece.xyz", false},
                      KindCase{"run-c", "piece.ply", false},
                      KindCase{"run-c", "dial.csv", true},
                      KindCase{"run-c", "piece.dmo", true},
                      KindCase{"run-c", "probe.csv", false}),
    [](const auto& info) {
      std::string name = std::string(info.param.run) + "_" + info.param.file;
      for (char& ch : name)
        if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
      return name;
    });

// `ttp run` grades its twin's piece as `ttp grade` does and its report
// shows that grade; its summary leads with the verdict.
TEST(CliVerdicts, RunAgreesWithGrade) {
  const fs::path dir = OutDir() / "run";
  const auto run = RunTtp("run --seed 4 -o " + test::ShellQuoted(dir));
  ASSERT_TRUE(run.exit_code == 0 || run.exit_code == 1) << run.output;
  const auto g =
      RunTtp("grade " + test::ShellQuoted(dir / "twin" / "piece.ply") +
             " --json " + test::ShellQuoted(OutDir() / "run-grade.json"));
  ASSERT_TRUE(g.exit_code == 0 || g.exit_code == 1) << g.output;
  const json grade = json::parse(ReadTextFile(OutDir() / "run-grade.json"));
  EXPECT_EQ(json::parse(ReadTextFile(dir / "grade.json")), grade);
  EXPECT_EQ(json::parse(ReadTextFile(dir / "report.json"))["grade"], grade);
  EXPECT_EQ(run.output.rfind("verdict on the twin's piece (as ttp grade): " +
                                 grade["summary"].get<std::string>(),
                             0),
            0u)
      << run.output;
}

// Thesis table 7.2 on the samples: run-a (compensation off) against run-b
// (on).
TEST(CliReportCompare, SpansOfTwoPieces) {
  const fs::path dir = OutDir();
  const auto r = RunTtp("report --compare " +
                        test::ShellQuoted(Sample("run-a", "piece.ply")) + " " +
                        test::ShellQuoted(Sample("run-b", "piece.xyz")) +
                        " -o " + test::ShellQuoted(dir / "compare.html") +
                        " --json " + test::ShellQuoted(dir / "compare.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  const json data = json::parse(ReadTextFile(dir / "compare.json"));
  // Exit 1 unless both verdicts are pass, as for one piece.
  ASSERT_EQ(data["pieces"].size(), 2u);
  const bool both_pass = data["pieces"][0]["grade"]["verdict"] == "pass" &&
                         data["pieces"][1]["grade"]["verdict"] == "pass";
  EXPECT_EQ(r.exit_code, both_pass ? 0 : 1) << r.output;
  ASSERT_EQ(data["spans"].size(), 12u);
  for (const json& s : data["spans"]) {
    ASSERT_TRUE(s["a_um"].is_number() && s["b_um"].is_number()) << s;
    EXPECT_GE(s["a_um"].get<double>(), 0.0);
  }
  // The uncompensated piece with its hidden workpiece expansion spreads
  // more in E_TTP over the 8 hours than the compensated one.
  for (const json& s : data["spans"]) {
    if (s["figure"] == "E_TTP" && s["period_h"] == 8.0) {
      EXPECT_GT(s["a_um"].get<double>(), s["b_um"].get<double>());
    }
  }
  EXPECT_NE(ReadTextFile(dir / "compare.html").find("thesis table 7.2"),
            std::string::npos);
}

}  // namespace
}  // namespace ttp
