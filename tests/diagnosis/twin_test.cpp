// The digital twin: deterministic runs, a parseable log, a cloud that the
// inspection reads back to the twin's cut geometry.
#include "ttp/diagnosis/twin.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "test_dir.h"
#include "ttp/inspect/inspect.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::diagnosis {
namespace {

TEST(Twin, SameSeedSameRunAndTheLogParses) {
  const Config config;
  TwinOptions o;
  o.effect = Cause::kToolWear;
  o.size = 2;
  o.seed = 9;
  o.compensation = true;
  const TwinRun a = RunTwin(config, o), b = RunTwin(config, o);
  EXPECT_EQ(a.log_text, b.log_text);
  EXPECT_EQ(a.truth.dump(), b.truth.dump());
  const thermal::TalcLog log = thermal::ParseTalcLog(a.log_text, "twin");
  EXPECT_EQ(log.cuts.size(), 45u);
  EXPECT_EQ(a.truth["cause"], "tool_wear");
  EXPECT_EQ(a.truth["params"]["wear_um_per_m"], 2.0);
  o.seed = 10;
  EXPECT_NE(RunTwin(config, o).log_text, a.log_text);
  o.rtest_interval_s = 10;
  EXPECT_THROW(RunTwin(config, o), std::invalid_argument);
}

TEST(Twin, CloudInspectsBackToTheCutGeometry) {
  const Config config;
  TwinOptions o;
  o.effect = Cause::kClampingDistortion;
  o.size = 3;
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
    if (id[0] == 'Z') continue;
    ++facets;
    // Within 5 sigma of the fit noise the twin assumes for a facet (plus
    // the datum alignment's share).
    EXPECT_NEAR(m.d_mm, truth.d_mm, 5 * noise.facet.d_mm + 0.3e-3) << id;
    EXPECT_NEAR(m.angle_rad, truth.angle_rad, 5 * noise.facet.angle_rad + 5e-6)
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

}  // namespace
}  // namespace ttp::diagnosis
