#include "ttp/inspect/grade.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "ttp/geometry/error.h"

namespace ttp::inspect {
namespace {

// ISO 14253-1: conformance proven only inside limit - U, non-conformance
// only outside limit + U.
TEST(Grade, DecisionRuleReducesTheZoneByU) {
  EXPECT_EQ(Decide(3.9, 1.0, 5.0), Verdict::kPass);
  EXPECT_EQ(Decide(-4.5, 1.0, 5.0), Verdict::kUndecidable);
  EXPECT_EQ(Decide(5.5, 1.0, 5.0), Verdict::kUndecidable);
  EXPECT_EQ(Decide(-6.1, 1.0, 5.0), Verdict::kFail);
  EXPECT_EQ(Decide(std::nan(""), 1.0, 5.0), Verdict::kMissing);
  // The report's verdict table uses the same rule (report_test.cpp).
  EXPECT_EQ(Decide(3.9, 1.0, 5.0), Verdict::kPass);
  EXPECT_EQ(Decide(-4.0, 1.0, 5.0), Verdict::kPass);
  EXPECT_EQ(Decide(4.1, 1.0, 5.0), Verdict::kUndecidable);
  EXPECT_EQ(Decide(-5.9, 1.0, 5.0), Verdict::kUndecidable);
  EXPECT_EQ(Decide(6.1, 1.0, 5.0), Verdict::kFail);
  // U larger than the limit: conformance can never be proven.
  EXPECT_EQ(Decide(0.0, 6.0, 5.0), Verdict::kUndecidable);
  EXPECT_STREQ(VerdictName(Verdict::kFail), "fail");
}

// One cycle of figures in the units of CycleFigures (mm, rad; k = 1),
// written from um and um/m with U (k = 2) so that the cases read as the
// grade prints them.
CycleFigures Cycle(int cycle, double x, double y, double z, double b,
                   double ttp, double u_lin_um, double u_ang_um_per_m) {
  CycleFigures f;
  f.cycle = cycle;
  f.e_x_mm = x * 1e-3;
  f.e_y_mm = y * 1e-3;
  f.e_z_mm = z * 1e-3;
  f.e_b_rad = b * 1e-6;
  f.e_ttp_mm = ttp * 1e-3;
  f.u_x_mm = f.u_y_mm = f.u_z_mm = f.u_ttp_mm = u_lin_um * 1e-3 / 2;
  f.u_b_rad = u_ang_um_per_m * 1e-6 / 2;
  return f;
}

CycleExtras Extras(int cycle, double c_um_per_m, double u_um_per_m) {
  CycleExtras e;
  e.cycle = cycle;
  e.e_c_rad = c_um_per_m * 1e-6;
  e.u_c_rad = u_um_per_m * 1e-6 / 2;
  return e;
}

const FigureGrade& Of(const GradeResult& r, Figure f) {
  for (const FigureGrade& g : r.figures)
    if (g.figure == f) return g;
  throw std::runtime_error("no such figure");
}

TEST(Grade, OverallVerdictAndSummary) {
  const GradeLimits limits;
  const GradeResult r = GradeFigures({Cycle(1, 1.0, 4.8, -0.5, 2.0, 0.2, 1, 2)},
                                     {}, Capability{}, limits);
  EXPECT_EQ(r.overall, Verdict::kUndecidable);  // E_Y within U of 5 um
  EXPECT_EQ(r.counts[static_cast<int>(Verdict::kUndecidable)], 1);
  EXPECT_EQ(r.counts[static_cast<int>(Verdict::kPass)], 4);
  const std::string table = GradeTable(r, false);
  EXPECT_EQ(table.rfind("VERDICT: UNDECIDABLE on E_X, E_Y, E_Z, E_B, E_TTP: 4 "
                        "of 5 values pass, 0 fail, 1 undecidable",
                        0),
            0u)
      << table;
  // The limits and where they come from are stated.
  EXPECT_NE(table.find("5 um linear, 15 um/m angular (the thesis' TALC "
                       "action control limits"),
            std::string::npos)
      << table;
  // The per-value table only with verbose.
  EXPECT_EQ(table.find("cycle figure"), std::string::npos);
  EXPECT_NE(GradeTable(r, true).find("    1 E_Y        4.800"),
            std::string::npos);
}

// The thesis (7.2.1) evaluates no E_C: not graded unless asked for.
TEST(Grade, ECOnlyOnRequest) {
  const std::vector<CycleFigures> f = {Cycle(1, 1, 1, 1, 1, 1, 1, 2)};
  const std::vector<CycleExtras> ex = {Extras(1, 40.0, 2.0)};  // E_C fails
  GradeLimits limits;
  GradeResult r = GradeFigures(f, ex, Capability{}, limits);
  EXPECT_EQ(r.overall, Verdict::kPass);
  EXPECT_FALSE(Of(r, Figure::kEC).decided);
  EXPECT_NE(Of(r, Figure::kEC).reason.find("not requested"), std::string::npos);
  limits.figures = ParseFigureList("all");
  r = GradeFigures(f, ex, Capability{}, limits);
  EXPECT_EQ(r.overall, Verdict::kFail);
  EXPECT_TRUE(Of(r, Figure::kEC).decided);
}

// A figure whose U reaches its limit cannot be shown to conform: it is
// left out of the verdict with the reason, whatever its values.
TEST(Grade, UAtTheLimitIsNotDecidable) {
  const std::vector<CycleFigures> f = {
      Cycle(1, 0.5, 0.5, 0.5, 0.1, 0.5, 1, 14),
      Cycle(2, 0.5, 0.5, 0.5, 0.1, 0.5, 1, 15)};
  const GradeResult r = GradeFigures(f, {}, Capability{}, GradeLimits{});
  const FigureGrade& b = Of(r, Figure::kEB);
  EXPECT_FALSE(b.decided);
  EXPECT_NE(b.reason.find("U up to 15.0 um/m is at or above the limit 15"),
            std::string::npos)
      << b.reason;
  EXPECT_EQ(r.overall, Verdict::kPass);  // on E_X, E_Y, E_Z, E_TTP
  const std::vector<Figure> on = r.DecidedOn();
  EXPECT_EQ(on.size(), 4u);
  EXPECT_EQ(std::count(on.begin(), on.end(), Figure::kEB), 0);
  EXPECT_EQ(r.counts[static_cast<int>(Verdict::kNotDecidable)], 2);
  // Just below the limit it is graded (and undecidable: 0.1 > 15 - 14.9).
  const GradeResult r2 =
      GradeFigures({Cycle(1, 0.5, 0.5, 0.5, 0.2, 0.5, 1, 14.9)}, {},
                   Capability{}, GradeLimits{});
  EXPECT_TRUE(Of(r2, Figure::kEB).decided);
  EXPECT_EQ(r2.overall, Verdict::kUndecidable);
}

// A dial gauge measures no angle: E_B is not decidable with that reason,
// and the piece can pass on the other figures. A CMM measures E_B: its
// missing values are not shown to conform, even when all of them are
// missing (the piece does not pass on less data).
TEST(Grade, InstrumentWithoutAnglesDecidesOnTheRest) {
  CycleFigures c = Cycle(1, 1, 1, 1, 0, 1, 1, 0);
  c.e_b_rad = c.u_b_rad = std::nan("");
  const GradeResult r = GradeFigures(
      {c}, {}, CapabilityOf(MeasurementKind::kDial), GradeLimits{});
  EXPECT_EQ(r.overall, Verdict::kPass);
  EXPECT_NE(
      Of(r, Figure::kEB).reason.find("dial gauge measures no facet angle"),
      std::string::npos);
  // The same missing E_B from a CMM is a missing value: not proven.
  const GradeResult cmm = GradeFigures(
      {c}, {}, CapabilityOf(MeasurementKind::kCloud), GradeLimits{});
  EXPECT_EQ(cmm.overall, Verdict::kUndecidable);
  EXPECT_TRUE(Of(cmm, Figure::kEB).decided);
  EXPECT_EQ(Of(cmm, Figure::kEB).verdict, Verdict::kUndecidable);
  EXPECT_EQ(cmm.counts[static_cast<int>(Verdict::kMissing)], 1);
  EXPECT_NE(cmm.Summary().find("1 missing"), std::string::npos);
  CycleFigures c2 = Cycle(2, 1, 1, 1, 1, 1, 1, 2);
  const GradeResult part = GradeFigures(
      {c, c2}, {}, CapabilityOf(MeasurementKind::kCloud), GradeLimits{});
  EXPECT_EQ(part.overall, Verdict::kUndecidable);  // cycle 1's E_B missing
}

// An inspection JSON grades as the typed figures it holds.
TEST(Grade, InspectionJsonGradesAsItsFigures) {
  const std::vector<CycleFigures> f = {
      Cycle(1, 1.0, 4.8, -0.5, 2.0, 0.2, 1, 2)};
  const nlohmann::json doc = {{"kind", "cloud"},
                              {"figures", FiguresToJson(f)["figures"]}};
  const GradeResult a = GradeFigures(doc, GradeLimits{}, "piece.json");
  const GradeResult b = GradeFigures(f, {}, Capability{}, GradeLimits{});
  EXPECT_EQ(GradeToJson(a), GradeToJson(b));
  EXPECT_THROW(GradeFigures(nlohmann::json::object(), GradeLimits{}, "x.json"),
               InputError);
}

TEST(Grade, LimitsValidateAndJsonHasOneTypePerKey) {
  GradeLimits limits;
  limits.linear_um = 0;
  std::string error;
  EXPECT_FALSE(limits.IsValid(&error));
  EXPECT_EQ(error.rfind("linear_um", 0), 0u);
  EXPECT_THROW(limits.Validate(), InputError);
  EXPECT_THROW(ParseFigureList("E_X,E_Q"), InputError);
  EXPECT_EQ(ParseFigureList("e_x, E_ttp").size(), 2u);
  limits = GradeLimits{};
  limits.linear_um = 10;
  limits.basis = "customer agreement";
  EXPECT_NE(limits.Describe().find("10 um linear, 15 um/m angular (customer "
                                   "agreement)"),
            std::string::npos);
  const nlohmann::json j = GradeToJson(
      GradeFigures({Cycle(1, 1, 1, 1, 1, 1, 1, 2)}, {}, Capability{}, limits));
  EXPECT_EQ(j["verdict"], "pass");
  for (const auto& f : j["figures"]) {
    EXPECT_TRUE(f["reason"].is_null() == f["decided"].get<bool>()) << f;
  }
  EXPECT_EQ(j["limits"]["linear_um"], 10.0);
}

}  // namespace
}  // namespace ttp::inspect
