#include "ttp/cam/programs.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "cam_testing.h"
#include "toolpath.h"
#include "ttp/gcode/rs274.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"

namespace ttp::cam {
namespace {

using gcode::CanonKind;
using gcode::CanonStatement;
using gcode::Dialect;
using testing::ReadBack;
using testing::ReportedCuts;

constexpr double kDeg = M_PI / 180.0;
// The writers keep 4 decimals of mm.
constexpr double kWrittenMm = 1e-4;

// Fixture: both programs built and read back once (the test cycle is long).
class ProgramsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config_ = new Config();
    pre_ = new gcode::Program(BuildPreMachiningProgram(*config_));
    cycle_ = new gcode::Program(BuildTestCycleProgram(*config_));
    pre_canon_ = new std::vector<CanonStatement>(
        ReadBack(*pre_, Dialect::kLinuxCnc, *config_));
    cycle_canon_ = new std::vector<CanonStatement>(
        ReadBack(*cycle_, Dialect::kLinuxCnc, *config_));
  }
  static void TearDownTestSuite() {
    delete config_;
    delete pre_;
    delete cycle_;
    delete pre_canon_;
    delete cycle_canon_;
  }
  static Config* config_;
  static gcode::Program *pre_, *cycle_;
  static std::vector<CanonStatement>*pre_canon_, *cycle_canon_;
};
Config* ProgramsTest::config_;
gcode::Program* ProgramsTest::pre_;
gcode::Program* ProgramsTest::cycle_;
std::vector<CanonStatement>* ProgramsTest::pre_canon_;
std::vector<CanonStatement>* ProgramsTest::cycle_canon_;

bool IsMotion(const CanonStatement& s) {
  return s.kind == CanonKind::kTraverse || s.kind == CanonKind::kFeed;
}

Eigen::Vector3d ToW(const Config& c, const Eigen::Vector3d& p_prog,
                    double c_rad) {
  return MachineToWorkpiece(c, ProgramToMachine(c, p_prog), c_rad);
}

TEST_F(ProgramsTest, LinuxCncProgramsPassRs274AndMatchOurReader) {
  if (!gcode::Rs274Available()) GTEST_SKIP() << "/usr/bin/rs274 missing";
  for (const gcode::Program* p : {pre_, cycle_}) {
    const std::string text =
        gcode::WriteProgram(*p, Dialect::kLinuxCnc, *config_);
    const auto ours = p == pre_ ? *pre_canon_ : *cycle_canon_;
    const gcode::Rs274Result rs = gcode::RunRs274(text, *config_);
    const auto d = gcode::CompareToolpaths(ours, rs.statements);
    EXPECT_TRUE(d.same) << p->name << ": " << d.what << " at line " << d.line_a;
    EXPECT_NEAR(gcode::TotalDuration(ours), gcode::TotalDuration(rs.statements),
                1e-6);
  }
}

TEST_F(ProgramsTest, FanucAndLinuxCncGiveTheSameToolpathAndTime) {
  for (const gcode::Program* p : {pre_, cycle_}) {
    const auto linuxcnc = p == pre_ ? *pre_canon_ : *cycle_canon_;
    const auto fanuc = ReadBack(*p, Dialect::kFanuc, *config_);
    const auto d = gcode::CompareToolpaths(fanuc, linuxcnc);
    EXPECT_TRUE(d.same) << p->name << ": " << d.what;
    EXPECT_NEAR(gcode::TotalDuration(fanuc), gcode::TotalDuration(linuxcnc),
                1e-6);
  }
}

TEST_F(ProgramsTest, SameConfigGivesTheSameText) {
  const gcode::Program again = BuildTestCycleProgram(*config_);
  EXPECT_EQ(gcode::WriteProgram(again, Dialect::kFanuc, *config_),
            gcode::WriteProgram(*cycle_, Dialect::kFanuc, *config_));
}

// Test-cycle order of test-piece.md section 3: per cycle strip, X1, X2, Y1,
// Y2 of index k' (5, 1..4, 6..9), with the commanded table angle.
TEST_F(ProgramsTest, TestCycleReportsEveryCutInOrderWithItsTableAngle) {
  const PartSpec& part = config_->part;
  std::vector<std::string> expected;
  for (int k = 0; k <= 8; ++k) {
    const int j = k == 0 ? 5 : (k <= 4 ? k : k + 1);
    expected.push_back("Z" + std::to_string(j));
    for (const char* s : {"X1", "X2", "Y1", "Y2"})
      expected.push_back(std::string(s) + "-" + std::to_string(j));
  }
  const auto cuts = ReportedCuts(*cycle_canon_);
  ASSERT_EQ(cuts.size(), expected.size());
  for (size_t i = 0; i < cuts.size(); ++i) {
    EXPECT_EQ(cuts[i].feature, expected[i]) << i;
    EXPECT_NEAR(cuts[i].report_c_deg, cuts[i].c_rad / kDeg, 1e-3);
    const int j = std::stoi(cuts[i].feature.substr(cuts[i].feature.size() - 1));
    const double phi_x1 = part.segment_centre_deg[0] + (j - 5) * 6.0;
    const char first = cuts[i].feature[0];
    const double expected_c = first == 'Z'   ? 0.0
                              : first == 'X' ? phi_x1
                                             : phi_x1 - 30.0;
    EXPECT_NEAR(cuts[i].report_c_deg, expected_c, 1e-9) << cuts[i].feature;
  }
}

// Each facet pass: the tool centre at r + tool radius along the facet's
// normal in W, climb-milled with M3 (material on the right of the heading),
// starting and ending outside the blank; each strip along +X at y_k.
TEST_F(ProgramsTest, TestCyclePassesAreAtTheirPlaceAndClimbMilled) {
  const PartSpec& part = config_->part;
  const double tool_r = config_->process.finishing.diameter_mm / 2;
  const double outside = part.blank_diameter_mm / 2 + tool_r;
  for (const auto& cut : ReportedCuts(*cycle_canon_)) {
    const Eigen::Vector3d a = ToW(*config_, cut.from, cut.c_rad);
    const Eigen::Vector3d b = ToW(*config_, cut.to, cut.c_rad);
    EXPECT_GE(a.head<2>().norm(), outside) << cut.feature;
    EXPECT_GE(b.head<2>().norm(), outside) << cut.feature;
    EXPECT_NEAR(a.z(), part.strip_floor_z_mm, kWrittenMm);
    EXPECT_NEAR(b.z(), part.strip_floor_z_mm, kWrittenMm);
    FeatureKind kind;
    Segment segment;
    int index;
    ASSERT_TRUE(ParseFeatureId(cut.feature, &kind, &segment, &index));
    const Eigen::Vector2d heading = (b - a).head<2>().normalized();
    if (kind == FeatureKind::kStrip) {
      EXPECT_NEAR(a.y(), StripY(part, index), kWrittenMm);
      EXPECT_NEAR(b.y(), StripY(part, index), kWrittenMm);
      EXPECT_NEAR(heading.x(), 1.0, 1e-9) << "strips run +X";
      continue;
    }
    const double phi = FacetPhiDeg(part, segment, index) * kDeg;
    const Eigen::Vector2d n(std::cos(phi), std::sin(phi));
    const double distance = part.facet_final_distance_mm + tool_r;
    EXPECT_NEAR(n.dot(a.head<2>()), distance, kWrittenMm) << cut.feature;
    EXPECT_NEAR(n.dot(b.head<2>()), distance, kWrittenMm) << cut.feature;
    // M3 turns clockwise seen from +Z: climb = material (-n) on the right.
    const Eigen::Vector2d right(heading.y(), -heading.x());
    EXPECT_NEAR(right.dot(-n), 1.0, 1e-6) << cut.feature;
    // The pass covers the whole facet (10.2 mm wide) with overrun.
    const Eigen::Vector2d t(-n.y(), n.x());
    const double half_width =
        part.facet_final_distance_mm * std::tan(part.facet_step_deg / 2 * kDeg);
    EXPECT_GT(std::max(t.dot(a.head<2>()), t.dot(b.head<2>())),
              half_width + tool_r);
    EXPECT_LT(std::min(t.dot(a.head<2>()), t.dot(b.head<2>())),
              -half_width - tool_r);
  }
}

// Spec directions in the machine frame (program XY): X1 tool on +X moving
// -Y, X2 on -X moving +Y, Y1 on +Y moving +X, Y2 on -Y moving -X.
TEST_F(ProgramsTest, TestCycleFacetSidesAndDirectionsFollowTheSpec) {
  const std::map<std::string, std::pair<Eigen::Vector2d, Eigen::Vector2d>>
      side_and_heading = {
          {"X1", {{1, 0}, {0, -1}}},
          {"X2", {{-1, 0}, {0, 1}}},
          {"Y1", {{0, 1}, {1, 0}}},
          {"Y2", {{0, -1}, {-1, 0}}},
      };
  for (const auto& cut : ReportedCuts(*cycle_canon_)) {
    if (cut.feature[0] == 'Z') continue;
    const auto& [side, heading] = side_and_heading.at(cut.feature.substr(0, 2));
    const Eigen::Vector2d a = cut.from.head<2>(), b = cut.to.head<2>();
    EXPECT_GT(a.dot(side), 100.0) << cut.feature;
    EXPECT_GT(b.dot(side), 100.0) << cut.feature;
    EXPECT_NEAR((b - a).normalized().dot(heading), 1.0, 1e-9) << cut.feature;
  }
}

// Z is set once before cycle 0 and never moves until the last cut; between
// cycles only C changes (and the strip's Y shift): the XY path of every
// cycle's facet passes is the same.
TEST_F(ProgramsTest, TestCycleNeverMovesZWhileCutting) {
  const auto& canon = *cycle_canon_;
  size_t first = 0, last = 0;
  for (size_t i = 0; i < canon.size(); ++i) {
    if (canon[i].kind == CanonKind::kComment && canon[i].text == "cycle 0")
      first = i;
    if (canon[i].kind == CanonKind::kReport) last = i;
  }
  ASSERT_GT(first, 0u);
  const double z = canon[first].end_mm.z();
  EXPECT_NEAR(z, config_->part.strip_floor_z_mm, kWrittenMm);
  int motions = 0;
  for (size_t i = first; i <= last; ++i) {
    if (!IsMotion(canon[i])) continue;
    ++motions;
    EXPECT_EQ(canon[i].end_mm.z(), z) << "line " << canon[i].source_line;
  }
  EXPECT_GT(motions, 9 * 5);
  const auto cuts = ReportedCuts(canon);
  for (size_t i = 5; i < cuts.size(); ++i) {
    if (cuts[i].feature[0] == 'Z') {
      EXPECT_EQ(cuts[i].from.x(), cuts[i % 5].from.x());
      EXPECT_EQ(cuts[i].to.x(), cuts[i % 5].to.x());
      continue;
    }
    EXPECT_EQ(cuts[i].from, cuts[i % 5].from) << cuts[i].feature;
    EXPECT_EQ(cuts[i].to, cuts[i % 5].to) << cuts[i].feature;
  }
}

TEST_F(ProgramsTest, TestCyclesStartOnTheHour) {
  std::vector<double> starts;
  for (const CanonStatement& s : *cycle_canon_)
    if (s.kind == CanonKind::kComment && s.text.rfind("cycle ", 0) == 0)
      starts.push_back(s.start_s);
  ASSERT_EQ(starts.size(), 9u);
  for (size_t k = 0; k < starts.size(); ++k)
    EXPECT_NEAR(starts[k] - starts[0], 3600.0 * k, 1e-3) << k;
  // And one hour after the last cycle's start the program has ended.
  EXPECT_LT(gcode::TotalDuration(*cycle_canon_), starts.back() + 3600.0);
}

// Warm-up (after cycles 0..3): C spins at c_max_rpm between cycles; cool-down
// (after cycles 4..7): C at 0, spindle stopped, no C turning.
TEST_F(ProgramsTest, WarmUpSpinsCAndCoolDownHoldsAtZero) {
  const auto& canon = *cycle_canon_;
  int cycle = -1;
  double spindle_rpm = 0;
  std::vector<int> spins_after(9, 0), dwells_after(9, 0);
  for (const CanonStatement& s : canon) {
    if (s.kind == CanonKind::kComment && s.text.rfind("cycle ", 0) == 0)
      cycle = std::stoi(s.text.substr(6));
    if (s.kind == CanonKind::kSpindle) spindle_rpm = s.value;
    if (cycle < 0) continue;
    if (s.kind == CanonKind::kCSpin && s.value > 0) {
      EXPECT_EQ(s.value, config_->machine.c_max_rpm);
      ++spins_after[cycle];
    }
    if (s.kind == CanonKind::kDwell) {
      ++dwells_after[cycle];
      EXPECT_EQ(spindle_rpm, 0.0) << "spindle stopped while waiting";
      EXPECT_GT(s.value, 3000.0);
      if (cycle >= 4) {
        EXPECT_EQ(s.end_c_rad, 0.0);
      }
    }
  }
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(spins_after[k], k < 4 ? 1 : 0) << k;
    EXPECT_EQ(dwells_after[k], 1) << k;
  }
  EXPECT_EQ(spins_after[8], 0);
  EXPECT_EQ(dwells_after[8], 0);
}

// No rapid below the blank's top comes nearer the C axis than the blank's
// radius plus the tool's radius (rapids never cross material), and every C
// index happens with the tool that far out, in both programs.
TEST_F(ProgramsTest, RapidsAndTableIndexingStayOutsideTheBlank) {
  std::map<int, double> tool_radius;
  for (const ToolSpec* t : config_->process.CuttingTools())
    tool_radius[t->number] = t->diameter_mm / 2;
  const double blank_r = config_->part.blank_diameter_mm / 2;
  const double blank_top = config_->part.face_depth_mm;
  for (const auto* canon : {pre_canon_, cycle_canon_}) {
    double r = 0;
    Eigen::Vector3d at = Eigen::Vector3d::Zero();
    double c = 0;
    int rapids_checked = 0;
    for (const CanonStatement& s : *canon) {
      if (s.kind == CanonKind::kToolChange) r = tool_radius.at(s.value);
      if (s.kind == CanonKind::kTraverse || s.kind == CanonKind::kFeed) {
        const bool low = std::min(at.z(), s.end_mm.z()) < blank_top;
        const bool c_moves = s.end_c_rad != c;
        // A retract straight up leaves along the tool's own cut.
        const bool retract =
            s.end_mm.head<2>() == at.head<2>() && s.end_mm.z() > at.z();
        if (s.kind == CanonKind::kTraverse && low && r > 0 && !retract) {
          ++rapids_checked;
          EXPECT_GE(SegmentDistanceFromOrigin(at.head<2>(), s.end_mm.head<2>()),
                    blank_r + r - 1e-6)
              << "rapid at line " << s.source_line;
        }
        // Turning (C feed) in the pre-machining is the exception: it cuts.
        if (c_moves && low && s.kind == CanonKind::kTraverse) {
          EXPECT_GE(at.head<2>().norm(), blank_r + r - 1e-6)
              << "C index at line " << s.source_line;
        }
      }
      if (IsMotion(s)) {
        at = s.end_mm;
        c = s.end_c_rad;
      }
    }
    EXPECT_GT(rapids_checked, 20);
  }
}

// Pre-machining: each reference cylinder is turned by one C revolution with
// the tool standing at radius d/2 + tool radius, tip at the band's bottom.
TEST_F(ProgramsTest, PreMachiningTurnsEachCylinderWithTheToolFixed) {
  const double r = config_->process.roughing.diameter_mm / 2;
  std::vector<std::pair<double, double>> turned;  // radius, tip z
  const auto& canon = *pre_canon_;
  for (size_t i = 1; i < canon.size(); ++i) {
    const CanonStatement& s = canon[i];
    if (s.kind != CanonKind::kFeed) continue;
    const CanonStatement& before = canon[i - 1];
    if (s.end_c_rad == before.end_c_rad) continue;
    EXPECT_EQ(s.end_mm, before.end_mm) << "linear axes fixed while turning";
    EXPECT_NEAR(std::abs(s.end_c_rad - before.end_c_rad), 2 * M_PI, 1e-9);
    turned.emplace_back(s.end_mm.head<2>().norm() - r, s.end_mm.z());
  }
  for (const RefCylinder& rc : config_->part.ref_cylinders) {
    bool found = false;
    for (const auto& [radius, z] : turned)
      if (std::abs(radius - rc.diameter_mm / 2) < kWrittenMm &&
          z <= rc.z_bottom_mm + kWrittenMm && z > rc.z_bottom_mm - 1.0)
        found = true;
    EXPECT_TRUE(found) << "cylinder " << rc.diameter_mm;
  }
  // Facing: at z = 0, rings down to the axis.
  double smallest_ring = 1e9;
  for (const auto& [radius, z] : turned)
    if (z == 0.0) smallest_ring = std::min(smallest_ring, radius + r);
  EXPECT_LE(smallest_ring, r);
}

// Pre-machining step 5: 36 passes at the pre-machined distance + tool radius
// along each facet normal, climb, down to the facet bottom; steps 3 and 4
// reach their floors with the walls at the drawing's width.
TEST_F(ProgramsTest, PreMachiningCutsFacetsAndNotchesAtTheirPlace) {
  const PartSpec& part = config_->part;
  const double r = config_->process.roughing.diameter_mm / 2;
  const auto& canon = *pre_canon_;
  std::map<std::string, int> facet_passes;
  bool small_floor = false, big_floor_wall_plus = false,
       big_floor_wall_minus = false, mark = false;
  int tool = 0;
  for (size_t i = 1; i < canon.size(); ++i) {
    const CanonStatement& s = canon[i];
    if (s.kind == CanonKind::kToolChange) tool = static_cast<int>(s.value);
    if (s.kind != CanonKind::kFeed) continue;
    const Eigen::Vector3d a = ToW(*config_, canon[i - 1].end_mm, s.end_c_rad);
    const Eigen::Vector3d b = ToW(*config_, s.end_mm, s.end_c_rad);
    if ((b - a).head<2>().norm() < 1e-9) continue;
    const Eigen::Vector2d h = (b - a).head<2>().normalized();
    if (tool == config_->process.roughing.number &&
        std::abs(a.z() - part.facet_bottom_z_mm) < kWrittenMm) {
      for (Segment seg : kSegments)
        for (int j = 1; j <= 9; ++j) {
          const double phi = FacetPhiDeg(part, seg, j) * kDeg;
          const Eigen::Vector2d n(std::cos(phi), std::sin(phi));
          if (std::abs(n.dot(a.head<2>()) - part.facet_pre_distance_mm - r) <
                  kWrittenMm &&
              std::abs(n.dot(b.head<2>()) - part.facet_pre_distance_mm - r) <
                  kWrittenMm) {
            ++facet_passes[FacetId(seg, j)];
            const Eigen::Vector2d right(h.y(), -h.x());
            EXPECT_NEAR(right.dot(-n), 1.0, 1e-6) << FacetId(seg, j);
          }
        }
    }
    if (tool == config_->process.notch.number &&
        std::abs(a.z() - part.small_notch_floor_z_mm) < kWrittenMm &&
        std::abs(std::abs(a.x()) + config_->process.notch.diameter_mm / 2 -
                 part.small_notch_half_width_mm) < kWrittenMm)
      small_floor = true;
    if (tool == config_->process.roughing.number &&
        std::abs(a.z() - part.big_notch_floor_z_mm) < kWrittenMm) {
      const double wall = part.big_notch_half_width_mm - r;
      // Climb: +Y wall moving -X, -Y wall moving +X.
      if (std::abs(a.y() - wall) < kWrittenMm && h.x() < 0)
        big_floor_wall_plus = true;
      if (std::abs(a.y() + wall) < kWrittenMm && h.x() > 0)
        big_floor_wall_minus = true;
    }
    if (tool == config_->process.engraver.number &&
        std::abs(a.z() + part.mark_depth_mm) < kWrittenMm &&
        std::abs(a.head<2>().norm() - part.mark_r_start_mm) < kWrittenMm &&
        std::abs(b.head<2>().norm() - part.mark_r_end_mm) < kWrittenMm &&
        std::abs(std::atan2(b.y(), b.x()) - part.mark_phi_deg * kDeg) < 1e-5)
      mark = true;
  }
  EXPECT_EQ(facet_passes.size(), 36u);
  for (const auto& [id, n] : facet_passes) EXPECT_EQ(n, 1) << id;
  EXPECT_TRUE(small_floor);
  EXPECT_TRUE(big_floor_wall_plus);
  EXPECT_TRUE(big_floor_wall_minus);
  EXPECT_TRUE(mark);
  // The NC hold closes the program.
  const CanonStatement* last_dwell = nullptr;
  for (const CanonStatement& s : canon)
    if (s.kind == CanonKind::kDwell) last_dwell = &s;
  ASSERT_NE(last_dwell, nullptr);
  EXPECT_EQ(last_dwell->value, config_->process.nc_hold_after_pre_min * 60);
}

TEST(ProgramsSenseTest, OppositeTableSenseStillCutsEveryFacetInPlace) {
  Config config;
  config.machine.c_sense = -1;
  const gcode::Program cycle = BuildTestCycleProgram(config);
  const auto canon = ReadBack(cycle, Dialect::kLinuxCnc, config);
  const double distance = config.part.facet_final_distance_mm +
                          config.process.finishing.diameter_mm / 2;
  int facets = 0;
  for (const auto& cut : ReportedCuts(canon)) {
    FeatureKind kind;
    Segment segment;
    int j;
    ASSERT_TRUE(ParseFeatureId(cut.feature, &kind, &segment, &j));
    if (kind != FeatureKind::kFacet) continue;
    ++facets;
    const double phi = FacetPhiDeg(config.part, segment, j) * kDeg;
    const Eigen::Vector2d n(std::cos(phi), std::sin(phi));
    EXPECT_NEAR(n.dot(ToW(config, cut.from, cut.c_rad).head<2>()), distance,
                kWrittenMm)
        << cut.feature;
    EXPECT_NEAR(n.dot(ToW(config, cut.to, cut.c_rad).head<2>()), distance,
                kWrittenMm)
        << cut.feature;
  }
  EXPECT_EQ(facets, 36);
}

// Bad configs give an InputError naming the field.
std::string FieldOfError(const Config& config,
                         gcode::Program (*build)(const Config&)) {
  try {
    build(config);
  } catch (const InputError& e) {
    return e.field();
  }
  return "(no error)";
}

TEST(ProgramsConfigTest, BadInputsNameTheField) {
  {
    Config c;
    c.process.notch.diameter_mm = 12;
    EXPECT_EQ(FieldOfError(c, &BuildPreMachiningProgram),
              "process.notch.diameter_mm");
  }
  {
    Config c;
    c.part.mark_depth_mm = -0.3;
    EXPECT_EQ(FieldOfError(c, &BuildPreMachiningProgram), "part.mark_depth_mm");
  }
  {
    // Fits the piece, but not the tool-change position at X = 300.
    Config c;
    c.machine.travel_x_mm = {-150.0, 150.0};
    EXPECT_EQ(FieldOfError(c, &BuildTestCycleProgram),
              "machine.tool_change_position_m_mm[0]");
    c.machine.tool_change_position_m_mm[0] = 140;
    EXPECT_EQ(FieldOfError(c, &BuildPreMachiningProgram), "(no error)");
  }
  {
    Config c;
    c.machine.travel_z_mm = {-10.0, 150.0};  // tool change at Z 450
    EXPECT_EQ(FieldOfError(c, &BuildPreMachiningProgram),
              "machine.tool_change_position_m_mm[2]");
  }
  {
    Config c;
    c.machine.waiting_position_w_mm = {100.0, 0.0, 50.0};
    EXPECT_EQ(FieldOfError(c, &BuildTestCycleProgram),
              "machine.waiting_position_w_mm");
  }
  {
    Config c;
    c.part.ref_cylinders = {{199.0, -24.0, -18.0}, {201.0, -18.0, -12.0}};
    EXPECT_EQ(FieldOfError(c, &BuildPreMachiningProgram), "part.ref_cylinders");
  }
  {
    Config c;
    c.process.cycle_period_s = 600;
    c.machine.positioning_feed_mm_min = 20;  // a cycle takes far longer
    EXPECT_EQ(FieldOfError(c, &BuildTestCycleProgram),
              "process.cycle_period_s");
  }
  {
    // 300 mm/min at 8000 rpm, 3 flutes: 0.0125 mm per tooth; at 0.1 mm
    // radial engagement the chip is 2.3 um: the edge rubs.
    Config c;
    c.process.finishing.feed_mm_min = 300;
    EXPECT_EQ(FieldOfError(c, &BuildTestCycleProgram),
              "process.finishing.feed_mm_min");
  }
}

TEST(ProgramsConfigTest, ProgramsFollowTheConfig) {
  Config c;
  // Closer facets, their outer corners still out of the notches.
  c.part.facet_final_distance_mm = 97.2;
  c.process.cycle_period_s = 1800;
  c.process.warmup_cycles = 2;
  const auto canon = ReadBack(BuildTestCycleProgram(c), Dialect::kFanuc, c);
  std::vector<double> starts;
  int spins = 0;
  for (const CanonStatement& s : canon) {
    if (s.kind == CanonKind::kComment && s.text.rfind("cycle ", 0) == 0)
      starts.push_back(s.start_s);
    if (s.kind == CanonKind::kCSpin && s.value > 0) ++spins;
  }
  ASSERT_EQ(starts.size(), 9u);
  EXPECT_NEAR(starts[8] - starts[0], 8 * 1800.0, 1e-3);
  EXPECT_EQ(spins, 2);
  const auto cuts = ReportedCuts(canon);
  ASSERT_EQ(cuts.size(), 45u);
  EXPECT_NEAR(
      cuts[1].from.x(),
      c.part.facet_final_distance_mm + c.process.finishing.diameter_mm / 2,
      kWrittenMm);
}

}  // namespace
}  // namespace ttp::cam

namespace ttp::cam {
namespace {

// The TALC run's R-test (thesis 5.2, 7.4): hourly, after each cycle's cuts;
// C standing and clamped while the probe measures the sphere at five table
// angles 90 deg apart; the probe stands over the sphere (its place from the
// frames of geometry at the angle the program commands) clear above it.
TEST(ProgramsRTestTest, HourlyRTestsMeasureTheSphereWithCStanding) {
  Config config;
  config.process.rtest_interval_s = 3600;
  const gcode::Program program = BuildTestCycleProgram(config);
  const auto canon = ReadBack(program, Dialect::kLinuxCnc, config);
  const MachineProfile& m = config.machine;
  const double phi = m.sphere_phi_deg * kDeg;
  const Eigen::Vector3d sphere_w(
      m.sphere_distance_mm * std::cos(phi),
      m.sphere_distance_mm * std::sin(phi),
      m.table_top_z_mm + m.sphere_height_mm - WorkpieceOriginHeightMm(config));
  bool clamped = false, c_spinning = false;
  int tool = 0, reports = 0;
  double last_dwell_s = -1, cycle_start_s = -1;
  std::vector<double> rtest_starts;
  for (const CanonStatement& s : canon) {
    if (s.kind == CanonKind::kClamp) clamped = s.value > 0;
    if (s.kind == CanonKind::kCSpin) c_spinning = s.value > 0;
    if (s.kind == CanonKind::kToolChange) tool = static_cast<int>(s.value);
    if (s.kind == CanonKind::kDwell) last_dwell_s = s.duration_s;
    if (s.kind == CanonKind::kComment && s.text.rfind("cycle ", 0) == 0)
      cycle_start_s = s.start_s;
    if (s.kind == CanonKind::kComment && s.text.rfind("R-test ", 0) == 0 &&
        s.text.find("done") == std::string::npos)
      rtest_starts.push_back(s.start_s);
    if (s.kind != CanonKind::kReport || s.text.rfind("rtest,", 0) != 0)
      continue;
    gcode::ReportText r;
    ASSERT_TRUE(gcode::ParseReportText(s.text, &r));
    const int n = reports / kRTestPositions, k = reports % kRTestPositions;
    EXPECT_EQ(r.feature, RTestPositionFeature(n, k + 1));
    EXPECT_NEAR(r.c_deg, std::fmod(90.0 * k, 360.0), 1e-9);
    EXPECT_NEAR(std::remainder(s.end_c_rad / kDeg - r.c_deg, 360.0), 0, 1e-9);
    EXPECT_TRUE(clamped && !c_spinning) << s.text;
    EXPECT_EQ(tool, config.process.probe.number) << s.text;
    EXPECT_NEAR(last_dwell_s, config.process.rtest_measure_s, 1e-9);
    // Probe tip over the sphere's centre, the ball's top below it.
    const Eigen::Vector3d tip_w = ToW(config, s.end_mm, s.end_c_rad);
    EXPECT_NEAR((tip_w - sphere_w).head<2>().norm(), 0.0, 1e-3) << s.text;
    const double gap = tip_w.z() - config.process.probe.diameter_mm / 2 -
                       (sphere_w.z() + m.sphere_radius_mm);
    EXPECT_GT(gap, 0.5) << s.text;
    EXPECT_LT(gap, 10.0) << s.text;
    // After the cycle's cuts: R-test n follows cycle n.
    EXPECT_GT(s.start_s, cycle_start_s);
    EXPECT_LT(s.start_s, cycle_start_s + 600);
    ++reports;
  }
  EXPECT_EQ(reports, (config.part.cycles() + 1) * kRTestPositions);
  ASSERT_EQ(rtest_starts.size(), static_cast<size_t>(config.part.cycles() + 1));
  // The cycles still start on the hour.
  std::vector<testing::ReportedCut> cuts;
  for (const auto& c : ReportedCuts(canon))
    if (c.feature[0] != 'R') cuts.push_back(c);
  Config plain = config;
  plain.process.rtest_interval_s = 0;
  const auto plain_cuts = ReportedCuts(
      ReadBack(BuildTestCycleProgram(plain), Dialect::kLinuxCnc, plain));
  ASSERT_EQ(cuts.size(), plain_cuts.size());
  for (size_t i = 0; i < cuts.size(); ++i) {
    EXPECT_EQ(cuts[i].feature, plain_cuts[i].feature);
    EXPECT_NEAR(cuts[i].start_s, plain_cuts[i].start_s, 2e-3);
  }
}

// rs274 reads the R-test program as our reader does; FANUC and LinuxCNC
// give the same toolpath and time.
TEST(ProgramsRTestTest, RTestProgramPassesRs274AndTwinsAgree) {
  Config config;
  config.part.facets_per_segment = 3;
  config.part.reference_index = 2;
  config.process.warmup_cycles = 1;
  config.process.cycle_period_s = 600;
  config.process.rtest_interval_s = 300;
  const gcode::Program program = BuildTestCycleProgram(config);
  const auto linuxcnc = ReadBack(program, Dialect::kLinuxCnc, config);
  const auto fanuc = ReadBack(program, Dialect::kFanuc, config);
  const auto twins = gcode::CompareToolpaths(fanuc, linuxcnc);
  EXPECT_TRUE(twins.same) << twins.what;
  EXPECT_NEAR(gcode::TotalDuration(fanuc), gcode::TotalDuration(linuxcnc),
              1e-6);
  if (!gcode::Rs274Available()) GTEST_SKIP() << "/usr/bin/rs274 missing";
  const gcode::Rs274Result rs = gcode::RunRs274(
      gcode::WriteProgram(program, Dialect::kLinuxCnc, config), config);
  const auto d = gcode::CompareToolpaths(linuxcnc, rs.statements);
  EXPECT_TRUE(d.same) << d.what << " at line " << d.line_a;
  EXPECT_NEAR(gcode::TotalDuration(linuxcnc),
              gcode::TotalDuration(rs.statements), 1e-6);
}

TEST(ProgramsRTestTest, IntervalShorterThanAnRTestIsRefused) {
  Config config;
  config.process.rtest_interval_s = 60;
  try {
    BuildTestCycleProgram(config);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("process.rtest_interval_s"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ttp::cam
