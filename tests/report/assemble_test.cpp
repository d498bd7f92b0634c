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
  inspect::Measurement measurement;
  inspect::InspectionResult& measured = measurement.result;
  inspect::GradeResult grade;
  // The diagnosis as its caller (`ttp report`) prepares it.
  diagnosis::PreparedDiagnosis diagnosed;
  diagnosis::DiagnosisExplanation explained;

  TwinFixture() {
    sim::TwinOptions o;
    o.workpiece_gain = 1.0;
    o.seed = 7;
    twin = sim::RunTwin(config, o);
    log = thermal::ParseTalcLog(twin.log_text, "twin.csv");
    measured.source = "twin measurement";
    measured.features = twin.measured;
    measured.figures = ComputeFigures(config.part, twin.measured);
    measurement.kind = inspect::MeasurementKind::kInspectionJson;
    grade = inspect::GradeMeasurement(measurement, {});
    const diagnosis::MeasuredPiece piece =
        diagnosis::MeasuredPieceFromInspection(config.part, measured);
    diagnosed.run = diagnosis::PrepareRun(log, config, piece);
    diagnosed.report =
        diagnosis::DiagnosePrepared(diagnosed.run, log, config.part, piece);
    explained = diagnosis::ExplainDiagnosis(diagnosed.run, diagnosed.report,
                                            config.part, 10.0);
  }
  ReportInputs Inputs() const {
    ReportInputs in;
    in.measurement = &measurement;
    in.grade = &grade;
    in.log = &log;
    in.diagnosis = &diagnosed;
    in.explanation = &explained;
    return in;
  }
};

const TwinFixture& Twin() {
  static const TwinFixture fixture;
  return fixture;
}

const json& TwinData() {
  static const json data = AssembleReportData(Twin().config, Twin().Inputs());
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

// The page shows exactly the grade it is given (no second decision path):
// a grade with other limits gives another verdict on the same figures.
TEST(AssembleReportData, GradeIsTheGivenGrade) {
  const json& data = TwinData();
  EXPECT_EQ(data["grade"], inspect::GradeToJson(Twin().grade));
  const std::string html = RenderReportHtml(data);
  EXPECT_NE(html.find(std::string("data-verdict=\"") +
                      inspect::VerdictName(Twin().grade.overall) + "\""),
            std::string::npos);
  inspect::GradeLimits wide;
  wide.linear_um = 100;
  wide.angular_um_per_m = 1000;
  const inspect::GradeResult pass =
      inspect::GradeMeasurement(Twin().measurement, wide);
  ASSERT_EQ(pass.overall, inspect::Verdict::kPass);
  ReportInputs in = Twin().Inputs();
  in.grade = &pass;
  const json wide_data = AssembleReportData(Twin().config, in);
  EXPECT_EQ(wide_data["limits"]["linear_um"], 100.0);
  EXPECT_EQ(wide_data["grade"]["verdict"], "pass");
  EXPECT_NE(RenderReportHtml(wide_data).find("data-verdict=\"pass\""),
            std::string::npos);
}

// An uncompensated acceptance test without a TALC log still gets a page:
// the piece and its verdict.
TEST(AssembleReportData, WithoutALog) {
  ReportInputs in = Twin().Inputs();
  in.log = nullptr;
  in.diagnosis = nullptr;
  in.explanation = nullptr;
  const json data = AssembleReportData(Twin().config, in);
  EXPECT_FALSE(data.contains("log"));
  EXPECT_FALSE(data.contains("diagnosis"));
  EXPECT_FALSE(data["figures"].contains("simulated"));
  EXPECT_EQ(data["grade"], TwinData()["grade"]);
  const std::string html = RenderReportHtml(data);
  EXPECT_NE(html.find("id=\"overall-verdict\""), std::string::npos);
  // A diagnosis without its log is refused.
  in.diagnosis = &Twin().diagnosed;
  EXPECT_THROW(AssembleReportData(Twin().config, in), InputError);
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
  // Same as the diagnosis run on its own (the report renders the one it
  // is given).
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

TEST(AssembleReportData, RendersTheCallersDiagnosis) {
  diagnosis::PreparedDiagnosis given = Twin().diagnosed;
  given.report.cause = "none";
  given.report.status = diagnosis::DiagnosisStatus::kNone;
  given.report.figure_after_um = given.run.observations.figure_value_um;
  const diagnosis::DiagnosisExplanation explained = diagnosis::ExplainDiagnosis(
      given.run, given.report, Twin().config.part, 10.0);
  ReportInputs in = Twin().Inputs();
  in.diagnosis = &given;
  in.explanation = &explained;
  const json none = AssembleReportData(Twin().config, in);
  EXPECT_EQ(none["diagnosis"]["cause"], "none");
  // With no cause, "after" is "before".
  EXPECT_EQ(none["diagnosis"]["residuals"]["after"],
            none["diagnosis"]["residuals"]["before"]);
}

TEST(AssembleReportData, NeedsAMeasurementAndItsGrade) {
  ReportInputs in = Twin().Inputs();
  in.grade = nullptr;
  EXPECT_THROW(AssembleReportData(Twin().config, in), InputError);
}

// Thesis table 7.2: spans over 1 h, 4 h and 8 h, cycle 0 (= 0) included.
TEST(Comparison, SpansOverThePeriods) {
  std::vector<CycleFigures> f(8);
  const double x_um[8] = {2, -1, 3, 0.5, 7, 1, 1, -4};
  for (int i = 0; i < 8; ++i) {
    f[i].cycle = i + 1;
    f[i].e_x_mm = x_um[i] * 1e-3;
  }
  EXPECT_NEAR(FigureSpanUm(f, inspect::Figure::kEX, 1, 3600), 2.0, 1e-12);
  EXPECT_NEAR(FigureSpanUm(f, inspect::Figure::kEX, 4, 3600), 4.0, 1e-12);
  EXPECT_NEAR(FigureSpanUm(f, inspect::Figure::kEX, 8, 3600), 11.0, 1e-12);
  f[0].e_x_mm = std::nan("");
  EXPECT_TRUE(std::isnan(FigureSpanUm(f, inspect::Figure::kEX, 1, 3600)));
  ComparedPiece a{&Twin().measurement, &Twin().grade};
  const json data = AssembleComparisonData(Twin().config, a, a, "same");
  EXPECT_EQ(data["spans"].size(), 12u);
  for (const json& s : data["spans"]) EXPECT_EQ(s["a_um"], s["b_um"]);
  const std::string html = RenderComparisonHtml(data);
  EXPECT_NE(html.find("thesis table 7.2"), std::string::npos);
}

TEST(WriteReport, WritesThePageAndItsData) {
  const std::filesystem::path dir = test::TestDir("report");
  const json data = WriteReport(Twin().config, Twin().Inputs(),
                                dir / "report.html", dir / "report.json");
  EXPECT_EQ(json::parse(ReadTextFile(dir / "report.json")), data);
  EXPECT_EQ(ReadTextFile(dir / "report.html"), RenderReportHtml(data));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace ttp::report
