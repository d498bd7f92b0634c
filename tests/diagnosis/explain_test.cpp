#include "ttp/diagnosis/explain.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ttp/diagnosis/twin.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::diagnosis {
namespace {

// A twin run with a hidden workpiece expansion: the summary names it with
// its evidence, the residuals before are the observations (measured -
// simulated) and the chosen effect removes most of them.
TEST(ExplainDiagnosis, SummaryAndResidualsOfATwinRun) {
  const Config config;
  TwinOptions o;
  o.effect = Cause::kWorkpieceExpansion;
  o.size = 1.0;
  o.seed = 7;
  const TwinRun twin = RunTwin(config, o);
  const thermal::TalcLog log = thermal::ParseTalcLog(twin.log_text, "twin.csv");
  const MeasuredPiece piece =
      MeasuredPieceFromFeatures(config.part, twin.measured);
  const PreparedRun run = PrepareRun(log, config, piece);
  DiagnosisReport report = DiagnosePrepared(run, log, config.part, piece);
  ASSERT_EQ(report.cause, "workpiece_expansion");
  const DiagnosisExplanation e =
      ExplainDiagnosis(run, report, config.part, 10.0);
  EXPECT_EQ(e.summary.rfind("workpiece_expansion: its BIC is lower", 0), 0u)
      << e.summary;
  EXPECT_NE(e.summary.find("the next best candidate"), std::string::npos);
  ASSERT_EQ(e.residuals.cycles.size(),
            static_cast<size_t>(config.part.cycles()));
  double before2 = 0, after2 = 0;
  int matched = 0;
  for (size_t i = 0; i < run.observations.size(); ++i) {
    const int g = run.observations.group[i], c = run.observations.cycle[i];
    if (g < 0 || g > 3 || c < 1) continue;
    EXPECT_DOUBLE_EQ(e.residuals.before_um[g][c - 1],
                     run.observations.value[i]);
    before2 += std::pow(e.residuals.before_um[g][c - 1], 2);
    after2 += std::pow(e.residuals.after_um[g][c - 1], 2);
    ++matched;
  }
  EXPECT_EQ(matched, 4 * config.part.cycles());
  EXPECT_LT(after2, 0.5 * before2);
  // No cause: nothing is removed.
  report.cause = "none";
  const DiagnosisExplanation none =
      ExplainDiagnosis(run, report, config.part, 10.0);
  EXPECT_EQ(none.summary.rfind("No cause beyond noise", 0), 0u);
  for (int g = 0; g < 4; ++g)
    EXPECT_EQ(none.residuals.after_um[g], none.residuals.before_um[g]);
}

}  // namespace
}  // namespace ttp::diagnosis
