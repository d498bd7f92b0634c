// Simulated piece: zero errors give zero figures, the figures are linear in
// the errors, a pure table growth shows as E_TTP, the sample run without a
// hidden effect is reproduced, and logs that do not cover the cuts are
// refused.
#include "ttp/thermal/simulate.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "synthetic_log.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"

namespace ttp::thermal {
namespace {

Simulation Simulate(const test::SyntheticRun& run) {
  const Config config;
  return SimulatePiece(ParseTalcLog(run.Text(config), "syn.csv"), config);
}

TEST(Simulate, ZeroErrorsGiveZeroFigures) {
  test::SyntheticRun run;
  run.scale = 0;
  run.rtest_noise_um = 0;
  const Simulation sim = Simulate(run);
  ASSERT_EQ(sim.figures.size(), 8u);
  EXPECT_EQ(sim.cuts.size(), 45u);
  for (const auto& f : sim.figures) {
    EXPECT_NEAR(f.e_x_mm, 0, 1e-9);
    EXPECT_NEAR(f.e_ttp_mm, 0, 1e-9);
    EXPECT_NEAR(f.e_b_rad, 0, 1e-12);
  }
}

TEST(Simulate, FiguresAreLinearInTheErrors) {
  test::SyntheticRun one, two;
  one.rtest_noise_um = two.rtest_noise_um = 0;
  two.scale = 2;
  const Simulation a = Simulate(one), b = Simulate(two);
  double largest = 0;
  for (size_t k = 0; k < a.figures.size(); ++k) {
    EXPECT_NEAR(b.figures[k].e_z_mm, 2 * a.figures[k].e_z_mm, 2e-6) << k;
    EXPECT_NEAR(b.figures[k].e_ttp_mm, 2 * a.figures[k].e_ttp_mm, 2e-6) << k;
    largest = std::max(largest, std::abs(a.figures[k].e_z_mm));
  }
  EXPECT_GT(largest, 5e-3);  // the synthetic EZ0T reaches -9.6 um
}

// A table growing radially by ER0T (um) moves every facet outwards by
// ER0T * R/(d/2): E_TTP follows it (compensation off, piece radius 97.3).
TEST(Simulate, RadialTableGrowthShowsAsETtp) {
  test::SyntheticRun run;
  run.rtest_noise_um = 0;
  run.gain = {0, 0, 0, 4.0, 0, 0, 0};
  const Simulation sim = Simulate(run);
  for (const auto& f : sim.figures) {
    EXPECT_GT(std::abs(f.e_ttp_mm), 0.0);
    EXPECT_NEAR(f.e_x_mm, 0, 1e-6);
    EXPECT_NEAR(f.e_y_mm, 0, 1e-6);
  }
  // Cycle 4 (end of warm-up): the growth since the reference cut.
  const auto& c4 = sim.cuts;
  double er_ref = 0, er_4 = 0;
  for (const auto& c : c4) {
    if (c.feature == FeatureId::Facet(Segment::kX1, 5))
      er_ref = c.machine.er0t_mm;
    if (c.feature == FeatureId::Facet(Segment::kX1, 4))
      er_4 = c.machine.er0t_mm;
  }
  const double expected = (er_4 - er_ref) * 97.3 / 160.0;
  EXPECT_NEAR(std::abs(sim.figures[3].e_ttp_mm), std::abs(expected),
              0.05 * std::abs(expected));
}

// run-b was made outside the project with no hidden effect: its truth
// figures are what the rigid-table model gives with the true errors.
TEST(Simulate, ReproducesTheSampleRunWithoutEffect) {
  const std::string dir = std::string(TTP_DATA_DIR) + "/samples/run-b";
  const Simulation sim = SimulatePiece(ReadTalcLog(dir + "/talc.csv"), {});
  const auto truth = nlohmann::json::parse(ReadTextFile(dir + "/truth.json"));
  for (size_t k = 0; k < sim.figures.size(); ++k) {
    const auto& t = truth["figures"][k];
    const auto& f = sim.figures[k];
    EXPECT_NEAR(f.e_x_mm * 1e3, t["E_X"].get<double>(), 1.0) << k;
    EXPECT_NEAR(f.e_y_mm * 1e3, t["E_Y"].get<double>(), 1.0) << k;
    EXPECT_NEAR(f.e_z_mm * 1e3, t["E_Z"].get<double>(), 1.0) << k;
    EXPECT_NEAR(f.e_b_rad * 1e6, t["E_B"].get<double>(), 2.0) << k;
    EXPECT_NEAR(f.e_ttp_mm * 1e3, t["E_TTP"].get<double>(), 1.0) << k;
  }
}

// After the last R-test the estimator extrapolates through its model with
// an uncertainty that grows with the distance; it follows the truth there.
TEST(Simulate, ExtrapolatesPastTheLastRTest) {
  test::SyntheticRun run;
  run.end_s = 8 * 3600 + 200;  // the last cycle's cuts end at 8 h + 354 s
  const Config config;
  const TalcLog log = ParseTalcLog(run.Text(config), "short.csv");
  const MachineErrorEstimator est = MachineErrorEstimator::Fit(log);
  const Simulation sim = SimulatePiece(log, config, est, {});
  int beyond = 0;
  for (const SimulatedCut& c : sim.cuts) {
    if (c.t_s <= est.LastRTestS()) continue;
    ++beyond;
    const auto truth = run.TruthMicro(c.t_s);
    const auto m = c.machine.ToMicro();
    for (int e = 0; e < 4; ++e)
      EXPECT_NEAR(m[e], truth[e], 0.3) << c.feature << " " << kErrorNames[e];
  }
  EXPECT_GT(beyond, 0);
  for (int e = 0; e < 7; ++e)
    EXPECT_GT(est.ErrorSigmaAt(e, est.LastRTestS() + 600),
              est.ErrorSigmaAt(e, est.LastRTestS()));
  // The user is told which cuts rest on the extrapolation.
  ASSERT_EQ(sim.warnings.size(), 1u);
  EXPECT_NE(sim.warnings[0].find(
                fmt::format("{} cut(s) after the last R-test", beyond)),
            std::string::npos)
      << sim.warnings[0];
  // With an R-test after the last cut, nothing is extrapolated.
  const TalcLog closed =
      ParseTalcLog(test::SyntheticRun().Text(config), "syn.csv");
  EXPECT_TRUE(SimulatePiece(closed, config).warnings.empty());
}

TEST(Simulate, CutGeometryRefusesUnknownFeatures) {
  EXPECT_THROW(
      ComputeCutGeometry(Config{}, FeatureId::Facet(Segment::kX1, 10), 0),
      std::invalid_argument);
  EXPECT_THROW(
      ComputeCutGeometry(Config{}, FeatureId::Datum(FeatureKind::kTopFace), 0),
      std::invalid_argument);
  const CutGeometry g =
      ComputeCutGeometry(Config{}, FeatureId::Facet(Segment::kX1, 5), M_PI / 3);
  EXPECT_EQ(g.p_m_mm.size(), 28u);
  EXPECT_NEAR(g.n_w.norm(), 1, 1e-12);
}

}  // namespace
}  // namespace ttp::thermal
