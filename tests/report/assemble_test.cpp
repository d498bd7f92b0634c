#include "ttp/report/assemble.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "test_dir.h"
#include "ttp/sim/twin.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/report/report.h"
#include "ttp/thermal/simulate.h"

namespace ttp::report {
namespace {

using nlohmann::json;

// One twin run with a hidden workpiece expansion, shared by the tests.
struct TwinFixture {
  Config config;
  sim::TwinRun twin;
  thermal::TalcLog log;
  inspect::InspectionResult measured;

  TwinFixture() {
    sim::TwinOptions o;
    o.workpiece_gain = 1.0;
    o.seed = 7;
    twin = sim::RunTwin(config, o);
    log = thermal::ParseTalcLog(twin.log_text, "twin.csv");
    measured.source = "twin measurement";
    measured.features = twin.measured;
    measured.figures = ComputeFigures(config.part, twin.measured);
  }
};

const TwinFixture& Twin() {
  static const TwinFixture fixture;
  return fixture;
}

const json& TwinData() {
  static const json data =
      AssembleReportData(Twin().log, Twin().config, Twin().measured);
  return data;
}

TEST(AssembleReportData, IsValidAndHasEverySection) {
  const json& data = TwinData();
  EXPECT_NO_THROW(ValidateReportData(data));
  for (const char* key : {"run", "part", "limits", "figures", "facets", "grade",
                          "log", "diagnosis"}) {
    EXPECT_TRUE(data.contains(key)) << key;
  }
  EXPECT_EQ(data["facets"].size(), 36u);
  const std::string html = RenderReportHtml(data);
  EXPECT_EQ(html.find("Not available"), std::string::npos);
}

TEST(AssembleReportData, FiguresAreTheMeasuredAndSimulatedOnes) {
  const json& data = TwinData();
  const auto& measured = Twin().measured.figures;
  const thermal::Simulation sim =
      thermal::SimulatePiece(Twin().log, Twin().config);
  ASSERT_EQ(data["figures"]["measured"].size(), measured.size());
  ASSERT_EQ(data["figures"]["simulated"].size(), sim.figures.size());
  for (size_t i = 0; i < measured.size(); ++i) {
    const json& m = data["figures"]["measured"][i];
    EXPECT_EQ(m["cycle"], measured[i].cycle);
    EXPECT_NEAR(m["E_TTP"].get<double>(), measured[i].e_ttp_mm * 1e3, 1e-9);
    EXPECT_NEAR(m["E_B"].get<double>(), measured[i].e_b_rad * 1e6, 1e-9);
    EXPECT_NEAR(m["U"]["E_X"].get<double>(), 2 * measured[i].u_x_mm * 1e3,
                1e-9);
    const json& s = data["figures"]["simulated"][i];
    EXPECT_NEAR(s["E_Z"].get<double>(), sim.figures[i].e_z_mm * 1e3, 1e-9);
    EXPECT_FALSE(s.contains("U"));
    const json& l = data["figures"]["simulated_linear"][i];
    EXPECT_NEAR(l["E_TTP"].get<double>(), sim.figures_linear[i].e_ttp_mm * 1e3,
                1e-9);
  }
}

TEST(AssembleReportData, LogHasEverySampleRTestAndCut) {
  const json& log = TwinData()["log"];
  const thermal::TalcLog& talc = Twin().log;
  EXPECT_EQ(log["samples"]["t_s"].size(),
            static_cast<size_t>(talc.CountEvent(thermal::LogEvent::kSample)));
  EXPECT_EQ(log["rtests"]["t_s"].size(), talc.rtests.size());
  for (const char* key : kErrorNames) {
    ASSERT_EQ(log["rtests"][key].size(), talc.rtests.size()) << key;
  }
  EXPECT_NEAR(log["rtests"]["ER0T"][10].get<double>(),
              talc.rtests[10].measured.er0t_mm * 1e3, 1e-9);
  EXPECT_EQ(log["cuts"].size(), talc.cuts.size());
  EXPECT_EQ(log["cuts"].size(), 45u);
  EXPECT_TRUE(log["samples"].contains("T_ws"));
  EXPECT_TRUE(log["samples"].contains("c_rpm"));
}

TEST(AssembleReportData, GradeIsTheInspectionGrade) {
  const json& data = TwinData();
  const inspect::GradeResult grade = inspect::GradeFigures(
      json{{"figures", FiguresToJson(Twin().measured.figures)["figures"]}},
      inspect::GradeLimits{}, "twin");
  EXPECT_EQ(data["grade"]["verdict"], inspect::VerdictName(grade.overall));
  EXPECT_EQ(data["grade"]["values"].size(), grade.values.size());
  const std::string html = RenderReportHtml(data);
  EXPECT_NE(html.find(std::string("data-verdict=\"") +
                      inspect::VerdictName(grade.overall) + "\""),
            std::string::npos);
}

TEST(AssembleReportData, LimitsReachTheGradeAndThePage) {
  ReportOptions options;
  options.limits.linear_um = 100;
  options.limits.angular_um_per_m = 1000;
  const json data = AssembleReportData(Twin().log, Twin().config,
                                       Twin().measured, nullptr, options);
  EXPECT_EQ(data["limits"]["linear_um"], 100.0);
  EXPECT_EQ(data["grade"]["verdict"], "pass");
  options.limits.linear_um = 0;
  EXPECT_THROW(AssembleReportData(Twin().log, Twin().config, Twin().measured,
                                  nullptr, options),
               InputError);
}

TEST(AssembleReportData, DiagnosisNamesTheHiddenCauseWithEvidence) {
  const json& d = TwinData()["diagnosis"];
  EXPECT_EQ(d["cause"], Twin().twin.truth["cause"]);
  EXPECT_TRUE(d["extended"]["params"].contains("tau_wp_s"));
  EXPECT_LT(d["extended"]["rms_um"].get<double>(),
            d["baseline"]["rms_um"].get<double>());
  EXPECT_EQ(d["candidates"].size(), 11u);  // none, 4 causes, 6 pairs
  EXPECT_EQ(d["status"], "named");
  EXPECT_NE(d["summary"].get<std::string>().find("workpiece_expansion"),
            std::string::npos);
  // Same as the diagnosis run on its own.
  const diagnosis::DiagnosisReport alone =
      diagnosis::DiagnoseRun(Twin().log, Twin().config,
                             diagnosis::MeasuredPieceFromFeatures(
                                 Twin().config.part, Twin().measured.features));
  EXPECT_EQ(d["cause"], alone.cause);
  EXPECT_NEAR(d["gain_pct"].get<double>(), alone.gain_pct, 1e-9);
}

TEST(AssembleReportData, ResidualsAreMeasuredMinusSimulated) {
  const json& data = TwinData();
  const json& r = data["diagnosis"]["residuals"];
  double before2 = 0, after2 = 0;
  int n = 0;
  for (size_t i = 0; i < r["cycles"].size(); ++i) {
    const json& m = data["figures"]["measured"][i];
    const json& s = data["figures"]["simulated"][i];
    ASSERT_EQ(m["cycle"], r["cycles"][i]);
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_TTP"}) {
      const double before = r["before"][key][i].get<double>();
      EXPECT_NEAR(before, m[key].get<double>() - s[key].get<double>(), 1e-9)
          << key << " cycle " << i + 1;
      EXPECT_GT(r["sigma"][key][i].get<double>(), 0.0);
      before2 += before * before;
      after2 += std::pow(r["after"][key][i].get<double>(), 2);
      ++n;
    }
  }
  // The hidden expansion explains most of the residual.
  EXPECT_LT(after2, 0.5 * before2)
      << std::sqrt(before2 / n) << " " << std::sqrt(after2 / n);
}

TEST(AssembleReportData, TakesTheCallersDiagnosis) {
  const diagnosis::MeasuredPiece piece = diagnosis::MeasuredPieceFromFeatures(
      Twin().config.part, Twin().measured.features);
  diagnosis::PreparedDiagnosis given;
  given.run = diagnosis::PrepareRun(Twin().log, Twin().config, piece);
  given.report = diagnosis::DiagnosePrepared(given.run, Twin().log,
                                             Twin().config.part, piece);
  const json same =
      AssembleReportData(Twin().log, Twin().config, Twin().measured, &given);
  EXPECT_EQ(same, TwinData());
  given.report.cause = "none";
  given.report.status = diagnosis::DiagnosisStatus::kNone;
  given.report.figure_after_um = given.run.observations.figure_value_um;
  const json none =
      AssembleReportData(Twin().log, Twin().config, Twin().measured, &given);
  EXPECT_EQ(none["diagnosis"]["cause"], "none");
  // With no cause, "after" is "before".
  EXPECT_EQ(none["diagnosis"]["residuals"]["after"],
            none["diagnosis"]["residuals"]["before"]);
}

TEST(AssembleReportData, FiguresAloneAreEnough) {
  inspect::InspectionResult figures_only;
  figures_only.source = "figures.json";
  figures_only.figures = Twin().measured.figures;
  const json data = AssembleReportData(Twin().log, Twin().config, figures_only);
  EXPECT_EQ(data["figures"]["measured"], TwinData()["figures"]["measured"]);
  EXPECT_FALSE(data.contains("facets"));
  EXPECT_EQ(data["run"]["measurement"], "figures.json");

  inspect::InspectionResult empty;
  empty.source = "empty.json";
  try {
    AssembleReportData(Twin().log, Twin().config, empty);
    FAIL() << "accepted a measurement without results";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "empty.json");
  }
}

TEST(WriteReport, WritesThePageAndItsData) {
  const std::filesystem::path dir = test::TestDir("report");
  const json data =
      WriteReport(Twin().log, Twin().config, Twin().measured, nullptr,
                  dir / "report.html", dir / "report.json");
  EXPECT_EQ(json::parse(ReadTextFile(dir / "report.json")), data);
  EXPECT_EQ(ReadTextFile(dir / "report.html"), RenderReportHtml(data));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ttp::report
