#include <gtest/gtest.h>

#include <string>

#include "synthetic_report_data.h"
#include "ttp/geometry/error.h"
#include "ttp/report/report.h"

namespace ttp {
namespace {

using nlohmann::json;

// Expects validation to fail and name `field`.
void ExpectFieldError(const json& data, const std::string& field) {
  try {
    ValidateReportData(data, "data.json");
    FAIL() << "accepted bad data, expected an error at " << field;
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_EQ(e.source(), "data.json");
  }
}

TEST(ReportSchema, AcceptsTheSyntheticRunAndTheBareMinimum) {
  EXPECT_NO_THROW(ValidateReportData(test::SyntheticReportData()));
  EXPECT_NO_THROW(ValidateReportData(json{{"schema", kReportSchema}}));
}

TEST(ReportSchema, RequiresTheSchemaTag) {
  ExpectFieldError(json::object(), "schema");
  ExpectFieldError(json{{"schema", "ttp-report/0"}}, "schema");
  ExpectFieldError(json::array(), "(root)");
}

TEST(ReportSchema, RejectsUnknownTopLevelKeys) {
  json data = test::SyntheticReportData();
  data["mesured"] = 1;
  ExpectFieldError(data, "mesured");
}

TEST(ReportSchema, NamesTheFigureThatIsWrong) {
  json data = test::SyntheticReportData();
  data["figures"]["measured"][3]["E_X"] = "1.0";
  ExpectFieldError(data, "figures.measured[3].E_X");

  data = test::SyntheticReportData();
  data["figures"]["measured"][2]["U"].erase("E_B");
  ExpectFieldError(data, "figures.measured[2].U.E_B");

  data = test::SyntheticReportData();
  data["figures"]["measured"][0]["U"]["E_Z"] = -0.1;
  ExpectFieldError(data, "figures.measured[0].U.E_Z");

  data = test::SyntheticReportData();
  data["figures"]["measured"][1].erase("U");
  ExpectFieldError(data, "figures.measured[1].U");

  data = test::SyntheticReportData();
  data["figures"]["simulated"][5]["cycle"] = 9;  // default piece: 8 cycles
  ExpectFieldError(data, "figures.simulated[5].cycle");

  data = test::SyntheticReportData();
  data["figures"]["simulated"][5]["cycle"] = 1;
  ExpectFieldError(data, "figures.simulated[5].cycle");
}

TEST(ReportSchema, AllowsMissingFiguresAsNull) {
  json data = test::SyntheticReportData();
  data["figures"]["measured"][4]["E_B"] = nullptr;
  data["figures"]["measured"][4]["U"]["E_B"] = nullptr;
  EXPECT_NO_THROW(ValidateReportData(data));
  // A value without its uncertainty cannot be graded.
  data["figures"]["measured"][4]["E_X"] = 1.0;
  data["figures"]["measured"][4]["U"]["E_X"] = nullptr;
  ExpectFieldError(data, "figures.measured[4].U.E_X");
}

TEST(ReportSchema, ChecksTheLogColumns) {
  json data = test::SyntheticReportData();
  data["log"]["samples"]["T_ws"].erase(10);
  ExpectFieldError(data, "log.samples.T_ws");

  data = test::SyntheticReportData();
  data["log"]["samples"]["t_s"][7] = 0.0;
  ExpectFieldError(data, "log.samples.t_s[7]");

  data = test::SyntheticReportData();
  data["log"]["rtests"]["EB0C"][3] = "x";
  ExpectFieldError(data, "log.rtests.EB0C[3]");

  data = test::SyntheticReportData();
  data["log"]["rtests"]["EQ0C"] = data["log"]["rtests"]["EB0C"];
  ExpectFieldError(data, "log.rtests.EQ0C");

  data = test::SyntheticReportData();
  data["log"]["cuts"][4]["feature"] = "Q7";
  ExpectFieldError(data, "log.cuts[4].feature");

  data = test::SyntheticReportData();
  data["log"]["cuts"][0].erase("t_s");
  ExpectFieldError(data, "log.cuts[0].t_s");
}

TEST(ReportSchema, ChecksTheDiagnosis) {
  json data = test::SyntheticReportData();
  data["diagnosis"]["baseline"].erase("rms_um");
  ExpectFieldError(data, "diagnosis.baseline.rms_um");

  data = test::SyntheticReportData();
  data["diagnosis"]["extended"]["params"]["tau_wp_s"] = "long";
  ExpectFieldError(data, "diagnosis.extended.params.tau_wp_s");

  data = test::SyntheticReportData();
  data["diagnosis"]["candidates"][2].erase("delta_bic");
  ExpectFieldError(data, "diagnosis.candidates[2].delta_bic");

  data = test::SyntheticReportData();
  data["diagnosis"]["residuals"]["after"]["E_Z"].erase(3);
  ExpectFieldError(data, "diagnosis.residuals.after.E_Z");

  data = test::SyntheticReportData();
  data["diagnosis"]["residuals"]["before"]["E_B"] = json::array();
  ExpectFieldError(data, "diagnosis.residuals.before.E_B");
}

TEST(ReportSchema, ChecksTheGradeAndWarnings) {
  json data = test::SyntheticReportData();
  data["grade"]["verdict"] = "maybe";
  ExpectFieldError(data, "grade.verdict");

  data = test::SyntheticReportData();
  data["grade"].erase("rule");
  ExpectFieldError(data, "grade.rule");

  data = test::SyntheticReportData();
  data["warnings"].push_back(3);
  ExpectFieldError(data, "warnings[1]");
}

TEST(ReportSchema, PartAndLimitsAreChecked) {
  json data = test::SyntheticReportData();
  data["limits"]["linear_um"] = 0;
  ExpectFieldError(data, "limits.linear_um");

  data = test::SyntheticReportData();
  data["part"] = {{"no_such_field", 1}};
  EXPECT_THROW(ValidateReportData(data), InputError);
}

}  // namespace
}  // namespace ttp
