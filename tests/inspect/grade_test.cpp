#include "ttp/inspect/grade.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

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

TEST(Grade, OverallVerdictAndTable) {
  const nlohmann::json doc = {{"figures",
                               {{{"cycle", 1},
                                 {"E_X", 1.0},
                                 {"E_Y", 4.8},
                                 {"E_Z", -0.5},
                                 {"E_B", 2.0},
                                 {"E_TTP", 0.2},
                                 {"U",
                                  {{"E_X", 0.5},
                                   {"E_Y", 0.5},
                                   {"E_Z", 0.5},
                                   {"E_B", 1.0},
                                   {"E_TTP", 0.5}}}}}}};
  const GradeLimits limits;
  const GradeResult r = GradeFigures(doc, limits, "piece.json");
  EXPECT_EQ(r.overall, Verdict::kUndecidable);  // E_Y within U of 5 um
  EXPECT_EQ(r.counts[static_cast<int>(Verdict::kUndecidable)], 1);
  const std::string table = GradeTable(r, limits);
  EXPECT_NE(table.find("VERDICT: UNDECIDABLE (4 pass, 0 fail, 1 undecidable"),
            std::string::npos)
      << table;
  EXPECT_THROW(GradeFigures(nlohmann::json::object(), limits, "x.json"),
               InputError);
}

}  // namespace
}  // namespace ttp::inspect
