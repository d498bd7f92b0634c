// The cut simulation passes correct programs and fails broken ones with the
// right finding.
#include "ttp/verify/verify.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "test_programs.h"

namespace ttp::verify {
namespace {

using testing::Canon;
using testing::MakeCycleProgram;
using testing::MakePreProgram;

VerifyReport Simulate(const gcode::Program& program, VerifyStage stage,
                      gcode::Dialect dialect = gcode::Dialect::kLinuxCnc,
                      const Config& config = Config{}) {
  VerifyOptions options;
  options.stage = stage;
  return VerifyStatements(Canon(program, config, dialect), config, options,
                          program.name);
}

std::string Failures(const VerifyReport& r) {
  std::string out;
  for (const Finding* f : r.Failed())
    out +=
        f->check + " " + std::to_string(f->measured) + " " + f->detail + "\n";
  return out;
}

TEST(VerifyTest, CorrectPreProgramPasses) {
  const VerifyReport r = Simulate(MakePreProgram(Config{}), VerifyStage::kPre);
  EXPECT_TRUE(r.AllPassed()) << Failures(r);
  // Every facet and datum of the drawing was probed.
  for (const char* id :
       {"surface TOP", "surface FLANK+Y", "surface CYL199", "surface CYL201",
        "surface NOTCH_SMALL", "surface NOTCH_BIG", "surface MARK",
        "surface X1-1", "surface Y2-9"})
    EXPECT_NE(r.Find(id), nullptr) << id;
  EXPECT_EQ(r.Find("surface Z5"), nullptr);
  // The simulation is exact: what is left is the program text's rounding
  // of coordinates to 0.1 um.
  for (const Finding& f : r.findings) {
    if (f.check.rfind("surface ", 0) == 0) {
      EXPECT_LT(f.measured, 0.1) << f.check;
    }
  }
}

TEST(VerifyTest, CorrectPreProgramPassesInFanucDialect) {
  const VerifyReport r = Simulate(MakePreProgram(Config{}), VerifyStage::kPre,
                                  gcode::Dialect::kFanuc);
  EXPECT_TRUE(r.AllPassed()) << Failures(r);
}

TEST(VerifyTest, CorrectCyclePasses) {
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}), VerifyStage::kCycle);
  EXPECT_TRUE(r.AllPassed()) << Failures(r);
  EXPECT_NE(r.Find("surface Z1"), nullptr);
  EXPECT_NE(r.Find("only C changes between cycles"), nullptr);
}

TEST(VerifyTest, StageIsDetectedFromReports) {
  const Config config;
  EXPECT_EQ(DetectStage(Canon(MakeCycleProgram(config), config)),
            VerifyStage::kCycle);
  EXPECT_EQ(DetectStage(Canon(MakePreProgram(config), config)),
            VerifyStage::kPre);
}

TEST(VerifyTest, FacetCutTooDeepFails) {
  testing::PreFaults faults;
  faults.facet = "X1-3";
  faults.facet_error_mm = -0.050;
  const VerifyReport r =
      Simulate(MakePreProgram(Config{}, faults), VerifyStage::kPre);
  const auto failed = r.Failed();
  ASSERT_EQ(failed.size(), 1u) << Failures(r);
  EXPECT_EQ(failed[0]->check, "surface X1-3");
  // The program text rounds coordinates to 0.1 um.
  EXPECT_NEAR(failed[0]->measured, 50.0, 0.1);
  EXPECT_GT(failed[0]->source_line, 0);
}

// The programs give the tool tip only through G43 H of the tool in the
// spindle: without G43 the tip runs a tool length below every programmed
// point, with another tool's H by the difference of the two lengths.
gcode::Program WithLengthOffsets(gcode::Program p, int h_tool) {
  for (gcode::Statement& s : p.statements)
    if (const auto* l = std::get_if<gcode::LengthOffset>(&s)) {
      if (h_tool < 0)
        s = gcode::Rapid{gcode::Axes{{}, {}, l->z_mm, {}}};
      else
        s = gcode::LengthOffset{h_tool, l->z_mm};
    }
  return p;
}

TEST(VerifyTest, CutWithoutTheToolsLengthOffsetFails) {
  const Config config;
  const gcode::Program pre = MakePreProgram(config);
  const VerifyReport none =
      Simulate(WithLengthOffsets(pre, -1), VerifyStage::kPre);
  const Finding* f = none.Find("tool-length offset of the tool in the spindle");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->pass);
  EXPECT_NEAR(f->measured, config.process.roughing.length_mm, 1e-9);
  EXPECT_NE(f->detail.find("no G43"), std::string::npos) << f->detail;
  EXPECT_GT(f->source_line, 0);
  // The cut itself is simulated where the tip goes: far too deep.
  const Finding* top = none.Find("surface TOP");
  ASSERT_NE(top, nullptr);
  EXPECT_FALSE(top->pass);

  // Another tool's length (H of the notch cutter on the roughing tool).
  const int other = config.process.notch.number;
  const double diff =
      config.process.roughing.length_mm - config.process.notch.length_mm;
  ASSERT_GT(std::abs(diff), 1e-3);
  const VerifyReport wrong =
      Simulate(WithLengthOffsets(pre, other), VerifyStage::kPre);
  const Finding* g =
      wrong.Find("tool-length offset of the tool in the spindle");
  ASSERT_NE(g, nullptr);
  EXPECT_FALSE(g->pass);
  EXPECT_NE(g->detail.find(fmt::format("H{}", other)), std::string::npos)
      << g->detail;
  // The correct program passes the check with nothing to spare.
  const VerifyReport right = Simulate(pre, VerifyStage::kPre);
  const Finding* h =
      right.Find("tool-length offset of the tool in the spindle");
  ASSERT_NE(h, nullptr);
  EXPECT_TRUE(h->pass);
  EXPECT_EQ(h->measured, 0);
}

TEST(VerifyTest, FacetTooShallowFails) {
  testing::PreFaults faults;
  faults.facet = "Y2-7";
  faults.facet_error_mm = +0.010;
  const VerifyReport r =
      Simulate(MakePreProgram(Config{}, faults), VerifyStage::kPre);
  const auto failed = r.Failed();
  ASSERT_EQ(failed.size(), 1u) << Failures(r);
  EXPECT_EQ(failed[0]->check, "surface Y2-7");
  EXPECT_NEAR(failed[0]->measured, 10.0, 0.1);
}

TEST(VerifyTest, TravelExceededFails) {
  testing::PreFaults faults;
  faults.travel_exceeded = true;
  const VerifyReport r =
      Simulate(MakePreProgram(Config{}, faults), VerifyStage::kPre);
  const auto failed = r.Failed();
  ASSERT_EQ(failed.size(), 1u) << Failures(r);
  EXPECT_EQ(failed[0]->check, "within machine travel");
  EXPECT_NEAR(failed[0]->measured, 400.0 - 365.0, 1e-9);
  EXPECT_GT(failed[0]->source_line, 0);
}

TEST(VerifyTest, CutIntoAdapterFails) {
  testing::PreFaults faults;
  faults.cut_adapter = true;
  const VerifyReport r =
      Simulate(MakePreProgram(Config{}, faults), VerifyStage::kPre);
  const Finding* f = r.Find("adapter not cut");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->pass);
  // Tool centre at 95 mm with radius 8 reaches 87 mm: 3 mm into the 90 mm
  // adapter.
  EXPECT_NEAR(f->measured, 3.0, 1e-9);
}

TEST(VerifyTest, RapidThroughPieceFails) {
  testing::CycleFaults faults;
  faults.rapid_through_piece = true;
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}, faults), VerifyStage::kCycle);
  const Finding* f = r.Find("rapid cuts no material (straight rapids)");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->pass);
  EXPECT_GT(f->measured, 1.0);  // 7 mm of a segment's height at z = -5
  EXPECT_GT(f->source_line, 0);
}

// Only the named check fails.
void ExpectOnlyFailure(const VerifyReport& r, const std::string& check) {
  const auto failed = r.Failed();
  ASSERT_EQ(failed.size(), 1u) << Failures(r);
  EXPECT_EQ(failed[0]->check, check);
  EXPECT_GT(failed[0]->measured, 0.0);
  EXPECT_GT(failed[0]->source_line, 0);
}

TEST(VerifyTest, DogLegRapidIsCaughtOnlyUnderPerAxisRapids) {
  testing::CycleFaults faults;
  faults.dog_leg_rapid = true;
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}, faults), VerifyStage::kCycle);
  const Finding* per_axis = r.Find("rapid cuts no material (per-axis rapids)");
  ASSERT_NE(per_axis, nullptr);
  EXPECT_FALSE(per_axis->pass);
  EXPECT_NEAR(per_axis->measured, 5.0, 1e-6);  // the whole 5 mm of Z
  EXPECT_GT(per_axis->source_line, 0);
  EXPECT_TRUE(r.Find("rapid cuts no material (straight rapids)")->pass);
  // What the dog-leg cut away shows on the surfaces it crossed; nothing
  // else fails.
  for (const Finding* f : r.Failed()) {
    if (f != per_axis) {
      EXPECT_EQ(f->check.rfind("surface ", 0), 0u) << f->check;
    }
  }
}

TEST(VerifyTest, WaitingInTheSphereRingWhileCTurnsIsCaught) {
  testing::CycleFaults faults;
  faults.spin_in_sphere_ring = true;
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}, faults), VerifyStage::kCycle);
  ExpectOnlyFailure(r, "clear of what C sweeps while turning");
  EXPECT_NE(r.Find("clear of what C sweeps while turning")
                ->detail.find("R-test sphere"),
            std::string::npos);
}

TEST(VerifyTest, ToolChangeOverThePieceIsCaught) {
  testing::CycleFaults faults;
  faults.tool_change_over_piece = true;
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}, faults), VerifyStage::kCycle);
  ExpectOnlyFailure(r, "tool change away from the piece");
}

TEST(VerifyTest, CutWithCUnclampedIsCaught) {
  testing::CycleFaults faults;
  faults.unclamped_cut = true;
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}, faults), VerifyStage::kCycle);
  ExpectOnlyFailure(r, "C clamped while cutting, free while turning");
}

TEST(VerifyTest, SphereInTheWayOfAMoveIsCaught) {
  // The same correct program on a machine whose sphere stands where the
  // cycle's tool passes: the collision model sees it.
  Config config;
  config.machine.sphere_distance_mm = 120.0;
  config.machine.sphere_height_mm = 40.0;
  config.machine.waiting_position_w_mm = {0.0, 0.0, 50.0};
  const VerifyReport r = Simulate(MakeCycleProgram(config), VerifyStage::kCycle,
                                  gcode::Dialect::kLinuxCnc, config);
  const Finding* f = r.Find("tool and holder clear the fixtures");
  ASSERT_NE(f, nullptr);
  EXPECT_FALSE(f->pass);
}

TEST(VerifyTest, ZMoveBetweenCyclesFails) {
  testing::CycleFaults faults;
  faults.z_shift_cycle = 3;
  const VerifyReport r =
      Simulate(MakeCycleProgram(Config{}, faults), VerifyStage::kCycle);
  const Finding* z = r.Find("Z fixed while cutting");
  ASSERT_NE(z, nullptr);
  EXPECT_FALSE(z->pass);
  EXPECT_NEAR(z->measured, 0.01, 1e-9);
  const Finding* c = r.Find("only C changes between cycles");
  ASSERT_NE(c, nullptr);
  EXPECT_FALSE(c->pass);
  EXPECT_NEAR(c->measured, 0.01, 1e-9);
}

TEST(VerifyTest, ReportJsonListsFindings) {
  testing::PreFaults faults;
  faults.travel_exceeded = true;
  const VerifyReport r =
      Simulate(MakePreProgram(Config{}, faults), VerifyStage::kPre);
  const nlohmann::json j = ReportToJson(r);
  EXPECT_FALSE(j["passed"].get<bool>());
  EXPECT_EQ(j["findings"].size(), r.findings.size());
  EXPECT_NE(FormatReportTable(r).find("FAIL"), std::string::npos);
}

}  // namespace
}  // namespace ttp::verify
