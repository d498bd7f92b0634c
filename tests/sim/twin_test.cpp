// The digital twin: deterministic runs, a parseable log, a cloud that the
// inspection reads back to the twin's cut geometry.
#include "ttp/sim/twin.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "test_dir.h"
#include "ttp/inspect/inspect.h"
#include "ttp/thermal/talc_log.h"
#include "feature_ids.h"

namespace ttp::sim {
namespace {

TEST(Twin, SameSeedSameRunAndTheLogParses) {
  const Config config;
  TwinOptions o;
  o.tool_wear_um_per_m = 2;
  o.seed = 9;
  o.compensation = true;
  const TwinRun a = RunTwin(config, o), b = RunTwin(config, o);
  EXPECT_EQ(a.log_text, b.log_text);
  EXPECT_EQ(a.truth.dump(), b.truth.dump());
  const thermal::TalcLog log = thermal::ParseTalcLog(a.log_text, "twin");
  EXPECT_EQ(log.cuts.size(), 45u);
  EXPECT_EQ(a.truth["cause"], "tool_wear");
  EXPECT_EQ(a.truth["params"]["tool_wear_um_per_m"], 2.0);
  o.seed = 10;
  EXPECT_NE(RunTwin(config, o).log_text, a.log_text);
  o.rtest_interval_s = 10;
  EXPECT_THROW(RunTwin(config, o), std::invalid_argument);
}

TEST(Twin, CloudInspectsBackToTheCutGeometry) {
  const Config config;
  TwinOptions o;
  o.clamping_amplitude_um = 3;
  o.seed = 4;
  o.cloud_points = 20000;
  o.point_noise_um = 0.4;
  const TwinRun run = RunTwin(config, o);
  const inspect::PointCloud cloud = TwinCloud(config, run, o);
  EXPECT_GE(cloud.size(), 20000);
  const inspect::InspectionResult r = inspect::InspectCloud(config.part, cloud);
  const FitNoise noise = CloudFitNoise(config.part, 0.4, 20000);
  int facets = 0;
  for (const auto& [id, truth] : run.true_results) {
    const FeatureResult& m = r.features.at(id);
    ASSERT_TRUE(m.present) << id;
    if (id.kind == FeatureKind::kStrip) continue;
    ++facets;
    // Within 5 sigma of the fit noise the twin assumes for a facet (plus
    // the datum alignment's share).
    EXPECT_NEAR(m.d_mm, truth.d_mm, 5 * noise.facet_d_mm + 0.3e-3)
        << id;
    EXPECT_NEAR(m.angle_rad, truth.angle_rad, 5 * noise.facet_angle_rad + 5e-6)
        << id;
  }
  EXPECT_EQ(facets, 36);
}

TEST(Twin, WritesTheChosenMeasurement) {
  const Config config;
  TwinOptions o;
  o.seed = 2;
  const TwinRun run = RunTwin(config, o);
  const auto dir = test::TestDir("twin");
  std::filesystem::remove_all(dir);
  EXPECT_EQ(WriteTwin(config, run, o, dir.string(), TwinMeasurement::kXyz),
            (dir / "piece.xyz").string());
  EXPECT_EQ(WriteTwin(config, run, o, dir.string(), TwinMeasurement::kJson),
            (dir / "measured.json").string());
  for (const char* f : {"talc.csv", "truth.json", "piece.xyz", "measured.json"})
    EXPECT_TRUE(std::filesystem::exists(dir / f)) << f;
  EXPECT_EQ(TwinMeasurementFromName("cloud"), TwinMeasurement::kPly);
  EXPECT_THROW(TwinMeasurementFromName("stl"), std::invalid_argument);
}

// The effects act through the geometric simulation, from their physics:
// wear leaves later facets further out; the three clamping lobes show in
// the facet distances with period 120 deg and turn the facets; a C stop
// error turns the facets and hardly moves them; a step moves only the
// facets of the cycles from the step on.
TEST(Twin, EffectsShowWhereTheirPhysicsPutsThem) {
  const Config config;
  TwinOptions base;
  base.seed = 31;
  const TwinRun none = RunTwin(config, base);
  auto delta = [&](const TwinOptions& o, const std::string& id) {
    const TwinRun r = RunTwin(config, o);
    return std::make_pair(
        (r.true_results.at(test::Fid(id)).d_mm - none.true_results.at(test::Fid(id)).d_mm) * 1e3,
        (r.true_results.at(test::Fid(id)).angle_rad - none.true_results.at(test::Fid(id)).angle_rad) *
            1e6);
  };
  TwinOptions wear = base;
  wear.tool_wear_um_per_m = 5;
  EXPECT_GT(delta(wear, "X1-9").first, delta(wear, "X1-1").first);
  EXPECT_GT(delta(wear, "X1-1").first, 0);
  EXPECT_NEAR(delta(wear, "Z5").first, 0, 1e-9);  // radial only
  TwinOptions c_axis = base;
  c_axis.c_indexing_amplitude_urad = 200;
  double turned = 0;
  for (const char* id : {"X1-1", "X1-4", "Y2-7"}) {
    EXPECT_LT(std::abs(delta(c_axis, id).first), 0.05) << id;
    turned = std::max(turned, std::abs(delta(c_axis, id).second));
  }
  EXPECT_GT(turned, 20);
  TwinOptions clamp = base;
  clamp.clamping_amplitude_um = 4;
  double largest = 0;
  for (int j = 1; j <= 9; ++j)
    largest =
        std::max(largest, std::abs(delta(clamp, "X1-" + std::to_string(j)).first));
  EXPECT_GT(largest, 1.0);
  TwinOptions step = base;
  step.step_um = 2;
  step.step_from_cycle = 5;
  EXPECT_EQ(step.ExpectedOutcome(), "unexplained");
  EXPECT_NEAR(delta(step, FacetId(Segment::kX1, IndexForCycle(config.part, 6)))
                  .first,
              2.0, 1e-6);
  EXPECT_NEAR(delta(step, FacetId(Segment::kX1, IndexForCycle(config.part, 2)))
                  .first,
              0.0, 1e-9);
  TwinOptions pair = base;
  pair.tool_wear_um_per_m = 1;
  pair.c_indexing_amplitude_urad = 1;
  EXPECT_EQ(pair.ExpectedOutcome(), "c_axis_indexing+tool_wear");
}

TEST(Twin, OptionsValidateThemselves) {
  TwinOptions o;
  std::string error;
  EXPECT_TRUE(o.IsValid(&error));
  o.rtest_interval_s = 10;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("rtest_interval_s"), std::string::npos);
  o = TwinOptions{};
  o.tool_wear_um_per_m = -1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("tool_wear_um_per_m"), std::string::npos);
  EXPECT_THROW(SetEffect(&o, "spindle_growth", 1), std::invalid_argument);
}

// A dial gauge measures no angles.
TEST(Twin, InstrumentsMeasureWhatTheyCan) {
  const Config config;
  const TwinRun run = RunTwin(config, TwinOptions{});
  const FeatureResults dial = MeasureWith(config.part, run.true_results,
                                          Instrument::kDial, 0.4, 3);
  for (const auto& [id, r] : dial) EXPECT_FALSE(std::isfinite(r.angle_rad));
  const FeatureResults probe = MeasureWith(config.part, run.true_results,
                                           Instrument::kProbe, 0.4, 3);
  for (const auto& [id, r] : probe) EXPECT_TRUE(std::isfinite(r.angle_rad));
}

}  // namespace
}  // namespace ttp::sim
