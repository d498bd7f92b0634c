// Every JSON output kind has its schema (schemas/*.schema.json): the
// outputs of `ttp` on the samples, for every kind of measurement, validate
// against them with an independent validator (python3-jsonschema, through
// schemas/validate.py), and a broken document does not.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "run_ttp.h"
#include "test_dir.h"

namespace {

namespace fs = std::filesystem;
using ttp::test::RunCommand;
using ttp::test::RunTtp;

std::string Sample(const std::string& rel) {
  return ttp::test::ShellQuoted(fs::path(TTP_DATA_DIR) / "samples" / rel);
}

// Validates `doc` against schemas/NAME.schema.json; the validator's output
// on failure.
::testing::AssertionResult Valid(const std::string& name, const fs::path& doc) {
  const auto r = RunCommand(
      "python3 " +
      ttp::test::ShellQuoted(fs::path(TTP_SOURCE_DIR) / "schemas/validate.py") +
      " " + name + " " + ttp::test::ShellQuoted(doc) + " 2>&1");
  if (r.exit_code == 0) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << doc.filename() << " against " << name << ".schema.json:\n"
         << r.output;
}

TEST(Schemas, MeasurementOutputsOfEveryKind) {
  const fs::path dir = ttp::test::TestDir("schemas");
  const char* files[] = {"run-a/piece.ply", "run-b/piece.xyz", "run-c/dial.csv",
                         "run-c/probe.csv", "run-c/piece.dmo"};
  int k = 0;
  for (const char* f : files) {
    const fs::path insp = dir / ("inspection-" + std::to_string(k) + ".json");
    const fs::path grade = dir / ("grade-" + std::to_string(k) + ".json");
    ++k;
    auto r = RunTtp("inspect " + Sample(f) + " --json " +
                    ttp::test::ShellQuoted(insp));
    ASSERT_EQ(r.exit_code, 0) << r.output;
    r = RunTtp("grade " + Sample(f) + " --json " +
               ttp::test::ShellQuoted(grade));
    ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
    EXPECT_TRUE(Valid("inspection", insp)) << f;
    EXPECT_TRUE(Valid("grade", grade)) << f;
  }
}

TEST(Schemas, CheckDiagnosisReportAndComparison) {
  const fs::path dir = ttp::test::TestDir("schemas-run");
  const std::string log = Sample("run-a/talc.csv");
  const std::string piece = Sample("run-a/piece.ply");
  auto r = RunTtp("check --log " + log + " " + piece + " --json " +
                  ttp::test::ShellQuoted(dir / "check.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  EXPECT_TRUE(Valid("check", dir / "check.json"));
  r = RunTtp("diagnose --log " + log + " " + piece + " --json " +
             ttp::test::ShellQuoted(dir / "diagnosis.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_TRUE(Valid("diagnosis", dir / "diagnosis.json"));
  r = RunTtp("report --log " + log + " " + piece + " -o " +
             ttp::test::ShellQuoted(dir / "report.html") + " --json " +
             ttp::test::ShellQuoted(dir / "report.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  EXPECT_TRUE(Valid("report", dir / "report.json"));
  r = RunTtp("report " + Sample("run-c/dial.csv") + " -o " +
             ttp::test::ShellQuoted(dir / "dial.html") + " --json " +
             ttp::test::ShellQuoted(dir / "dial.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  EXPECT_TRUE(Valid("report", dir / "dial.json"));
  r = RunTtp("report --compare " + piece + " " + Sample("run-b/piece.xyz") +
             " -o " + ttp::test::ShellQuoted(dir / "compare.html") +
             " --json " + ttp::test::ShellQuoted(dir / "compare.json"));
  ASSERT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;  // graded
  EXPECT_TRUE(Valid("compare", dir / "compare.json"));
}

// The validation can fail: one type per key, snake_case, no unknown keys.
TEST(Schemas, BrokenDocumentsAreRefused) {
  const fs::path dir = ttp::test::TestDir("schemas-broken");
  auto r = RunTtp("grade " + Sample("run-b/piece.xyz") + " --json " +
                  ttp::test::ShellQuoted(dir / "grade.json"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "grade.json");
  const nlohmann::json good = nlohmann::json::parse(in);
  const auto broken = [&](const char* what, nlohmann::json doc) {
    const fs::path p = dir / (std::string(what) + ".json");
    std::ofstream(p) << doc.dump();
    EXPECT_FALSE(Valid("grade", p)) << what;
  };
  nlohmann::json doc = good;
  doc["verdict"] = "maybe";
  broken("verdict", doc);
  doc = good;
  doc["values"][0]["value"] = "1.0";
  broken("string-number", doc);
  doc = good;
  doc["log span"] = "8 h";
  broken("key-with-space", doc);
  doc = good;
  doc["values"][0]["line"] = 0;
  broken("unknown-key", doc);
}

}  // namespace
