// The cam module's real programs through the cut simulation: the
// pre-machining from the blank, then the test cycle from what it left.
#include "ttp/verify/programs.h"

#include <gtest/gtest.h>

#include "ttp/cam/programs.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/features.h"

namespace ttp::verify {
namespace {

std::string Failures(const ProgramsVerification& v) {
  std::string out;
  for (const VerifyReport* r : {&v.pre, &v.cycle})
    for (const Finding* f : r->Failed())
      out += std::string(StageName(r->stage)) + " " + f->check + " " +
             std::to_string(f->measured) + " " + f->detail + "\n";
  return out;
}

class ProgramsVerifyTest : public ::testing::TestWithParam<gcode::Dialect> {};

TEST_P(ProgramsVerifyTest, PreThenCycleCutEveryFeatureInPlace) {
  const Config config;
  const ProgramsVerification v = VerifyPrograms(config, GetParam());
  EXPECT_TRUE(v.Passed()) << Failures(v);
  // After the pre-machining every feature of the drawing is at nominal plus
  // allowance (facets at their pre-machining distance), within 5 um.
  for (const NominalFeature& f :
       BuildNominalFeatures(config.part, Stage::kPreMachined)) {
    const Finding* s = v.pre.Find("surface " + f.id);
    ASSERT_NE(s, nullptr) << f.id << " not probed after the pre-machining";
    EXPECT_TRUE(s->pass) << f.id;
    EXPECT_LE(s->measured, 5.0) << f.id;
  }
  // After the cycle the strips and facets are at their finished place.
  int strips = 0, facets = 0;
  for (const NominalFeature& f :
       BuildNominalFeatures(config.part, Stage::kFinished)) {
    if (f.kind != FeatureKind::kFacet && f.kind != FeatureKind::kStrip)
      continue;
    (f.kind == FeatureKind::kFacet ? facets : strips)++;
    const Finding* s = v.cycle.Find("surface " + f.id);
    ASSERT_NE(s, nullptr) << f.id << " not probed after the cycle";
    EXPECT_LE(s->measured, 5.0) << f.id << ": " << s->detail;
  }
  EXPECT_EQ(facets, 4 * config.part.facets_per_segment);
  EXPECT_EQ(strips, config.part.facets_per_segment);
  for (const char* check :
       {"rapid cuts no material (straight rapids)", "within machine travel",
        "adapter not cut", "Z fixed while cutting",
        "only C changes between cycles"}) {
    const Finding* f = v.cycle.Find(check);
    ASSERT_NE(f, nullptr) << check;
    EXPECT_TRUE(f->pass) << check << " " << f->detail;
  }
  for (const char* check : {"rapid cuts no material (straight rapids)",
                            "within machine travel", "adapter not cut"})
    EXPECT_TRUE(v.pre.Find(check)->pass) << check;
  EXPECT_LT(v.MaxSurfaceDeviationUm(), 5.0);
  const nlohmann::json j = ProgramsVerificationToJson(v);
  EXPECT_TRUE(j["passed"].get<bool>());
  EXPECT_TRUE(j["failed"].empty());
}

INSTANTIATE_TEST_SUITE_P(BothDialects, ProgramsVerifyTest,
                         ::testing::Values(gcode::Dialect::kFanuc,
                                           gcode::Dialect::kLinuxCnc));

TEST(ProgramsVerifyChainTest, CycleIsJudgedOnWhatThePreMachiningLeft) {
  // Without a pre-machining the cycle starts from the blank: the top was
  // never faced, the notches never cut.
  const Config config;
  gcode::Program nothing;
  nothing.name = "nothing";
  nothing.number = 1;
  nothing.title = "no pre-machining";
  nothing.statements.push_back(gcode::ProgramEnd{});
  const auto d = gcode::Dialect::kLinuxCnc;
  const ProgramsVerification good = VerifyPrograms(config, d);
  ASSERT_TRUE(good.Passed()) << Failures(good);
  const std::string cycle_text =
      gcode::WriteProgram(cam::BuildTestCycleProgram(config), d, config);
  const ProgramsVerification v = VerifyProgramTexts(
      gcode::WriteProgram(nothing, d, config), cycle_text, d, config);
  EXPECT_FALSE(v.Passed());
  ASSERT_NE(v.cycle.Find("surface TOP"), nullptr);
  EXPECT_FALSE(v.cycle.Find("surface TOP")->pass);
  EXPECT_NEAR(v.cycle.Find("surface TOP")->measured,
              config.part.face_depth_mm * 1000, 1e-6);
  const Finding* notch = v.cycle.Find("surface NOTCH_SMALL");
  ASSERT_NE(notch, nullptr);
  EXPECT_FALSE(notch->pass);
  EXPECT_NE(notch->detail.find("material left"), std::string::npos);
  // Facets and strips are where the cycle puts them, whatever the stock.
  EXPECT_TRUE(v.cycle.Find("surface X1-5")->pass);
  EXPECT_TRUE(v.cycle.Find("surface Z5")->pass);
}

// The TALC run's R-test: the probe goes to the sphere at five table angles
// and the collision model accepts the approach (probe and holder clear of
// the sphere, its stem, the adapter and the clamps). The same program on a
// machine whose sphere is larger than the program was made for puts the
// probe into the ball: caught, at an R-test line.
TEST(ProgramsVerifyRTestTest, SphereApproachPassesAndARealCollisionIsCaught) {
  Config config;
  config.process.rtest_interval_s = 3600;
  const auto d = gcode::Dialect::kFanuc;
  const std::string text =
      gcode::WriteProgram(cam::BuildTestCycleProgram(config), d, config);
  const auto canon = gcode::ReadProgram(text, d, config, "cycle");
  VerifyOptions options;
  options.stage = VerifyStage::kCycle;
  const VerifyReport good = VerifyStatements(canon, config, options, "cycle");
  std::string failures;
  for (const Finding* f : good.Failed()) failures += f->check + "; ";
  EXPECT_TRUE(good.AllPassed()) << failures;
  const Finding* clear = good.Find("tool and holder clear the fixtures");
  ASSERT_NE(clear, nullptr);
  EXPECT_TRUE(clear->pass);

  Config bigger = config;
  bigger.machine.sphere_radius_mm = 20.0;  // top 7.3 mm higher
  const VerifyReport bad = VerifyStatements(canon, bigger, options, "cycle");
  const Finding* hit = bad.Find("tool and holder clear the fixtures");
  ASSERT_NE(hit, nullptr);
  EXPECT_FALSE(hit->pass);
  EXPECT_NE(hit->detail.find("R-test sphere"), std::string::npos)
      << hit->detail;
  // The probe tip stood the clearance plus the stylus ball radius above
  // the ball.
  EXPECT_NEAR(hit->measured,
              20.0 - 12.7 - config.process.clearance_mm -
                  config.process.probe.diameter_mm / 2,
              1e-6);
  // The line is a move of an R-test (between its comments).
  const std::string line_text = [&] {
    std::string::size_type pos = 0;
    for (int l = 1; l < hit->source_line; ++l) pos = text.find('\n', pos) + 1;
    return text.substr(pos, text.find('\n', pos) - pos);
  }();
  const size_t at = text.find(line_text);
  const size_t open = text.rfind("(R-test ", at);
  ASSERT_NE(open, std::string::npos) << line_text;
  EXPECT_EQ(text.find("done)", open), text.find("done)", at)) << line_text;
}

}  // namespace
}  // namespace ttp::verify
