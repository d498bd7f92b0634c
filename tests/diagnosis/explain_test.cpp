#include "ttp/diagnosis/explain.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ttp/sim/twin.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::diagnosis {
namespace {

// A twin run with a hidden workpiece expansion: the summary names it with
// its evidence, the residuals before are the observations (measured -
// simulated) and the chosen effect removes most of them.
TEST(ExplainDiagnosis, SummaryAndResidualsOfATwinRun) {
  const Config config;
  sim::TwinOptions o;
  o.workpiece_gain = 1.0;
  o.seed = 7;
  const sim::TwinRun twin = sim::RunTwin(config, o);
  const thermal::TalcLog log = thermal::ParseTalcLog(twin.log_text, "twin.csv");
  const MeasuredPiece piece =
      MeasuredPieceFromFeatures(config.part, twin.measured);
  const PreparedRun run = PrepareRun(log, config, piece);
  DiagnosisReport report = DiagnosePrepared(run, log, config.part, piece);
  ASSERT_EQ(report.status, DiagnosisStatus::kNamed);
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
  for (size_t i = 0; i < run.observations.figures(); ++i) {
    const int g = run.observations.figure_kind[i],
              c = run.observations.figure_cycle[i];
    if (g < 0 || g > 3 || c < 1) continue;
    EXPECT_DOUBLE_EQ(e.residuals.before_um[g][c - 1],
                     run.observations.figure_value_um[i]);
    EXPECT_DOUBLE_EQ(e.residuals.after_um[g][c - 1],
                     report.figure_after_um[i]);
    before2 += std::pow(e.residuals.before_um[g][c - 1], 2);
    after2 += std::pow(e.residuals.after_um[g][c - 1], 2);
    ++matched;
  }
  EXPECT_EQ(matched, 4 * config.part.cycles());
  EXPECT_LT(after2, 0.5 * before2);
  // No cause (and nothing left by a fit): nothing is removed.
  report.cause = "none";
  report.status = DiagnosisStatus::kNone;
  report.figure_after_um = run.observations.figure_value_um;
  const DiagnosisExplanation none =
      ExplainDiagnosis(run, report, config.part, 10.0);
  EXPECT_EQ(none.summary.rfind("No cause beyond noise", 0), 0u);
  // Unexplained or refused: the status and why come first.
  report.status = DiagnosisStatus::kUnexplained;
  report.reason = "structure no cause explains";
  EXPECT_EQ(ExplainDiagnosis(run, report, config.part, 10.0)
                .summary.rfind("unexplained: structure no cause explains", 0),
            0u);
  for (int g = 0; g < 4; ++g)
    EXPECT_EQ(none.residuals.after_um[g], none.residuals.before_um[g]);
}

// An angle cause is described by the facet angles it turns (urad), not by
// the figures' distances.
TEST(ExplainDiagnosis, AngleCauseShowsItsAngleResidual) {
  const Config config;
  sim::TwinOptions o;
  o.c_indexing_amplitude_urad = 400;
  o.seed = 4;
  const sim::TwinRun twin = sim::RunTwin(config, o);
  const thermal::TalcLog log = thermal::ParseTalcLog(twin.log_text, "twin.csv");
  const MeasuredPiece piece =
      MeasuredPieceFromFeatures(config.part, twin.measured);
  const PreparedRun run = PrepareRun(log, config, piece);
  const DiagnosisReport report =
      DiagnosePrepared(run, log, config.part, piece);
  ASSERT_EQ(report.cause, "c_axis_indexing") << report.reason;
  const std::string s =
      ExplainDiagnosis(run, report, config.part, 12.0).summary;
  EXPECT_NE(s.find("Residual RMS of the facet angles"), std::string::npos)
      << s;
  EXPECT_EQ(s.find("Residual RMS of the figures"), std::string::npos) << s;
  EXPECT_GT(report.baseline_rms_urad, 2 * report.extended_rms_urad);
}

}  // namespace
}  // namespace ttp::diagnosis
