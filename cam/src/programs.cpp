#include "ttp/cam/programs.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>

#include "toolpath.h"
#include "ttp/cam/cutting_data.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"

namespace ttp::cam {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr const char* kSource = "config";
// Fraction of the cutter diameter between neighbouring passes.
constexpr double kStepoverFraction = 0.75;

double BlankRadius(const Config& c) { return c.part.blank_diameter_mm / 2; }

// Tool change at the machine's tool-change position: spindle and coolant
// off, G49 G53 up to the tool-change height, then across (never over the
// piece with a tool below it), M6, G43 H with a Z word down to safe Z at
// the tool-change XY, spindle and coolant on again.
void ChangeTool(PathWriter& path, const Config& c, const ToolSpec& tool,
                bool coolant, bool spindle = true) {
  const MachineProfile& m = c.machine;
  const double origin_z = WorkpieceOriginHeightMm(c);
  path.Add(gcode::SpindleOff{});
  if (coolant) path.Add(gcode::Coolant{false});
  gcode::Axes up;
  up.z_mm = m.tool_change_position_m_mm[2];
  path.MachineRapid(up, origin_z);
  gcode::Axes across;
  across.x_mm = m.tool_change_position_m_mm[0];
  across.y_mm = m.tool_change_position_m_mm[1];
  path.MachineRapid(across, origin_z);
  path.Add(gcode::ToolChange{tool.number, tool.name});
  path.LengthOffset(tool.number, c.process.safe_z_w_mm);
  if (!spindle) return;  // a probe: no spindle, no coolant
  path.Add(gcode::SpindleOn{tool.spindle_rpm, true});
  if (coolant) path.Add(gcode::Coolant{true});
}

// Start of every program: B to 0 and clamped, C clamped, away to the
// tool-change height without a tool-length offset.
void ProgramStart(PathWriter& path, const Config& c) {
  gcode::Axes up;
  up.z_mm = c.machine.tool_change_position_m_mm[2];
  path.MachineRapid(up, WorkpieceOriginHeightMm(c));
  path.Add(gcode::BZeroClamp{});
  path.ClampC(true);
  // XY rapids are plain G0 only above the piece by the clearance.
  path.SetClearance(c.process.clearance_mm, c.machine.positioning_feed_mm_min);
}

// C feed (deg/min) that gives the tool's feed (mm/min) at radius r_mm: the
// table surface passes the cutter at the cutting feed.
double RotaryFeedDegMin(const Config& c, const ToolSpec& tool, double r_mm) {
  const double deg_min = tool.feed_mm_min / std::max(r_mm, 1e-3) * kRadToDeg;
  return std::min(deg_min, c.machine.c_index_deg_s * 60.0);
}

// Checks every commanded position against the machine's travel (tool tip
// in M; C turns the piece, not the tool, so program XY are machine XY).
void CheckTravel(const gcode::Program& program, const Config& c) {
  const MachineProfile& m = c.machine;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (const gcode::Statement& s : program.statements) {
    const gcode::Axes* axes = nullptr;
    if (const auto* r = std::get_if<gcode::Rapid>(&s)) axes = &r->to;
    if (const auto* f = std::get_if<gcode::Feed>(&s)) axes = &f->to;
    if (!axes) continue;
    if (axes->x_mm) p.x() = *axes->x_mm;
    if (axes->y_mm) p.y() = *axes->y_mm;
    if (axes->z_mm) p.z() = *axes->z_mm;
    const Eigen::Vector3d machine = ProgramToMachine(c, p);
    const auto check = [&](double v, const std::array<double, 2>& range,
                           const char* field, const char* axis) {
      if (v < range[0] - 1e-9 || v > range[1] + 1e-9)
        throw InputError(
            kSource, 0, field,
            fmt::format("the {} program moves {} to {:.3f} mm, outside the "
                        "travel [{}, {}]",
                        program.name, axis, v, range[0], range[1]));
    };
    check(machine.x(), m.travel_x_mm, "machine.travel_x_mm", "X");
    check(machine.y(), m.travel_y_mm, "machine.travel_y_mm", "Y");
    check(machine.z(), m.travel_z_mm, "machine.travel_z_mm", "Z");
  }
}

// Step 1: face by rings of C rotation, then turn the rim and the reference
// cylinders with the tool standing still while C turns one revolution.
void FaceAndTurn(PathWriter& path, const Config& c) {
  const PartSpec& part = c.part;
  const ToolSpec& tool = c.process.roughing;
  const double r = tool.diameter_mm / 2;
  const double route = BlankRadius(c) + r + c.process.clearance_mm;
  // Climb: the table surface must meet the tool's teeth head on, so the
  // piece turns against the machine's positive sense.
  const double revolution_deg = -360.0 * c.machine.c_sense;

  path.Add(gcode::Comment{"step 1: face the top, turn the profile by C"});
  path.RapidXY(Eigen::Vector2d(route, 0));
  path.IndexC(0);
  path.RapidZ(0);
  // Rings from the outside in; the last one covers the axis.
  const double step = kStepoverFraction * tool.diameter_mm;
  double ring = BlankRadius(c) + r;
  int ring_count = 0;
  do {
    ring = std::max(0.0, ring - step);
    path.ClampC(true);  // radial in-feed with C standing
    path.FeedXY(Eigen::Vector2d(ring, 0), tool.feed_mm_min);
    path.ClampC(false);
    path.FeedC(ring_count % 2 == 0 ? revolution_deg : -revolution_deg,
               RotaryFeedDegMin(c, tool, ring + r));
    ++ring_count;
  } while (ring > r);
  path.ClampC(true);
  path.FeedXY(Eigen::Vector2d(route, 0), tool.feed_mm_min);

  // Rim first (its band is above every cylinder), then the cylinders from
  // the bottom up. An end mill cuts everything above its tip to the same
  // radius, so each higher band must not be larger than the one below.
  struct Band {
    double radius_mm, tip_z_mm;
  };
  std::vector<RefCylinder> cylinders = part.ref_cylinders;
  std::sort(cylinders.begin(), cylinders.end(),
            [](const RefCylinder& a, const RefCylinder& b) {
              return a.z_bottom_mm < b.z_bottom_mm;
            });
  double rim_bottom = -part.height_mm();
  for (const RefCylinder& rc : cylinders)
    rim_bottom = std::max(rim_bottom, rc.z_top_mm);
  std::vector<Band> bands = {{part.rim_diameter_mm / 2, rim_bottom}};
  for (size_t i = 0; i < cylinders.size(); ++i) {
    const RefCylinder& rc = cylinders[i];
    if (i > 0 && rc.diameter_mm > cylinders[i - 1].diameter_mm + 1e-9)
      throw InputError(kSource, 0, "part.ref_cylinders",
                       "a cylinder larger than the one below it cannot be "
                       "turned with an end mill from the side");
    double tip = rc.z_bottom_mm;
    // The bottom band: go below the piece for a clean edge when the
    // adapter is well inside the cut.
    if (tip <= -part.height_mm() + 1e-9 &&
        part.adapter_diameter_mm / 2 < rc.diameter_mm / 2 - 1.0)
      tip -= 0.5;
    bands.push_back({rc.diameter_mm / 2, tip});
  }
  for (const Band& band : bands) {
    path.RapidZ(band.tip_z_mm);
    path.ClampC(true);
    path.FeedXY(Eigen::Vector2d(band.radius_mm + r, 0), tool.feed_mm_min);
    path.ClampC(false);
    path.FeedC(revolution_deg, RotaryFeedDegMin(c, tool, band.radius_mm));
    path.ClampC(true);
    path.FeedXY(Eigen::Vector2d(route, 0), tool.feed_mm_min);
  }
  path.RapidZ(c.process.safe_z_w_mm);
  path.IndexC(0);
}

void EngraveMark(PathWriter& path, const Config& c) {
  const PartSpec& part = c.part;
  const ToolSpec& tool = c.process.engraver;
  path.Add(gcode::Comment{"step 2: engrave the mark"});
  path.IndexC(0);
  const double phi = part.mark_phi_deg * kDeg;
  const Eigen::Vector2d dir(std::cos(phi), std::sin(phi));
  path.RapidXY(part.mark_r_start_mm * dir);
  path.RapidZ(c.process.clearance_mm);
  path.FeedZ(-part.mark_depth_mm, tool.feed_mm_min);
  path.FeedXY(part.mark_r_end_mm * dir, tool.feed_mm_min);
  path.RapidZ(c.process.safe_z_w_mm);
}

// A slot across the blank with `tool` along X (along = 0) or Y (1), roughed
// in steps of the roughing step-down.
SlotPass NotchSlot(const Config& c, const ToolSpec& tool, int along,
                   double half_width_mm, double floor_z_mm) {
  SlotPass slot;
  slot.along = along;
  slot.half_width_mm = half_width_mm;
  slot.floor_z_mm = floor_z_mm;
  slot.tool_radius_mm = tool.diameter_mm / 2;
  slot.length_mm =
      BlankRadius(c) + slot.tool_radius_mm + c.process.clearance_mm;
  slot.step_down_mm = c.process.roughing_step_down_mm;
  slot.stepover_mm = kStepoverFraction * tool.diameter_mm;
  slot.feed_mm_min = tool.feed_mm_min;
  slot.safe_z_mm = c.process.safe_z_w_mm;
  return slot;
}

void SmallNotch(PathWriter& path, const Config& c) {
  path.Add(gcode::Comment{"step 3: small notch"});
  MillSlot(path,
           NotchSlot(c, c.process.notch, 1, c.part.small_notch_half_width_mm,
                     c.part.small_notch_floor_z_mm));
}

void BigNotch(PathWriter& path, const Config& c) {
  path.Add(gcode::Comment{"step 4: big notch, rough"});
  SlotPass slot =
      NotchSlot(c, c.process.roughing, 0, c.part.big_notch_half_width_mm,
                c.part.big_notch_floor_z_mm);
  slot.allowance_mm = c.process.finish_allowance_mm;
  MillSlot(path, slot);
  path.Add(gcode::Comment{"step 4: big notch, finish"});
  slot.step_down_mm = 0;
  slot.allowance_mm = 0;
  MillSlot(path, slot);
}

// Step 5: every facet with its normal turned to +X, the tool on the +X
// side moving -Y (climb), down to the facet bottom.
void PreFacets(PathWriter& path, const Config& c) {
  const PartSpec& part = c.part;
  const ToolSpec& tool = c.process.roughing;
  const double r = tool.diameter_mm / 2;
  const double keep = BlankRadius(c) + r;
  const double route = keep + c.process.clearance_mm;
  const double x = part.facet_pre_distance_mm + r;
  const double y = std::sqrt(route * route - x * x);
  path.Add(gcode::Comment{"step 5: facets at the pre-machined distance"});
  path.RapidXY(Eigen::Vector2d(route, 0));
  path.RapidZ(part.facet_bottom_z_mm);
  for (Segment s : kSegments) {
    for (int j = 1; j <= part.facets_per_segment; ++j) {
      const double phi = FacetPhiDeg(part, s, j) * kDeg;
      path.IndexC(TableAngleFor(phi, 0.0, c.machine.c_sense) * kRadToDeg);
      path.RapidAround(Eigen::Vector2d(x, y), keep, route);
      path.FeedXY(Eigen::Vector2d(x, -y), tool.feed_mm_min);
    }
  }
  path.RapidZ(c.process.safe_z_w_mm);
}

}  // namespace

void ShortenDwells(gcode::Program& program, double max_s) {
  for (gcode::Statement& s : program.statements)
    if (auto* d = std::get_if<gcode::Dwell>(&s))
      d->seconds = std::min(d->seconds, max_s);
}

std::string CycleCommentText(int cycle) {
  return fmt::format("cycle {}", cycle);
}

double XFacetTableAngleDeg(const Config& c, int j) {
  const double phi = FacetPhiDeg(c.part, Segment::kX1, j) * kDeg;
  return TableAngleFor(phi, 0.0, c.machine.c_sense) * kRadToDeg;
}

double YFacetTableAngleDeg(const Config& c, int j) {
  const double phi = FacetPhiDeg(c.part, Segment::kY1, j) * kDeg;
  return TableAngleFor(phi, M_PI / 2, c.machine.c_sense) * kRadToDeg;
}

TestCycleLayout ComputeTestCycleLayout(const Config& c) {
  const double r = c.process.finishing.diameter_mm / 2;
  TestCycleLayout l;
  l.cut_z_mm = c.part.strip_floor_z_mm;
  l.route_radius_mm = BlankRadius(c) + r + c.process.clearance_mm;
  l.facet_offset_mm = c.part.facet_final_distance_mm + r;
  l.facet_half_pass_mm = std::sqrt(l.route_radius_mm * l.route_radius_mm -
                                   l.facet_offset_mm * l.facet_offset_mm);
  l.strip_half_pass_mm = l.route_radius_mm;
  return l;
}

gcode::Program BuildPreMachiningProgram(const Config& c) {
  ValidateConfig(c, kSource);
  CheckCuttingData(c, kSource);
  gcode::Program program;
  program.name = "pre";
  program.number = c.machine.program_number + 1;
  program.title = "ttp pre-machining of the thermal test piece";
  PathWriter path(&program.statements);
  path.Add(gcode::Comment{"steps 1-5 of test-piece.md section 3, NC hold"});
  ProgramStart(path, c);
  const bool coolant = c.process.coolant_in_pre;
  ChangeTool(path, c, c.process.roughing, coolant);
  FaceAndTurn(path, c);

  ChangeTool(path, c, c.process.engraver, coolant);
  EngraveMark(path, c);

  ChangeTool(path, c, c.process.notch, coolant);
  SmallNotch(path, c);

  ChangeTool(path, c, c.process.roughing, coolant);
  BigNotch(path, c);
  PreFacets(path, c);

  path.Add(gcode::SpindleOff{});
  if (coolant) path.Add(gcode::Coolant{false});
  path.IndexC(0);
  if (c.process.nc_hold_after_pre_min > 0) {
    path.Add(gcode::Comment{"NC hold: let the machine settle"});
    path.Add(gcode::Dwell{c.process.nc_hold_after_pre_min * 60.0});
  }
  path.Add(gcode::ProgramEnd{});
  CheckTravel(program, c);
  return program;
}

namespace {

// One cycle of the test: strip at C = 0, X1 and X2 at the X angle, Y1 and
// Y2 at the Y angle, back to the waiting position with C at 0.
void TestCycle(PathWriter& path, const Config& c, int cycle) {
  const PartSpec& part = c.part;
  const ToolSpec& tool = c.process.finishing;
  const TestCycleLayout l = ComputeTestCycleLayout(c);
  const double keep = BlankRadius(c) + tool.diameter_mm / 2;
  const double route = l.route_radius_mm;
  const double xf = l.facet_offset_mm, yf = l.facet_half_pass_mm;
  const double feed = tool.feed_mm_min;
  const int j = IndexForCycle(part, cycle);
  const Eigen::Vector2d waiting(c.machine.waiting_position_w_mm[0],
                                c.machine.waiting_position_w_mm[1]);
  const auto report = [&](const std::string& feature) {
    path.Add(gcode::Report{"cut", feature, path.c_deg_normalised()});
  };
  const auto index_table = [&](double c_deg) { path.IndexC(c_deg); };

  path.Add(gcode::Comment{CycleCommentText(cycle)});
  path.Add(gcode::SpindleOn{tool.spindle_rpm, true});
  if (c.process.coolant_in_test) path.Add(gcode::Coolant{true});
  index_table(0.0);
  // Strip: from the -X side, moving +X along y_j.
  const double y = StripY(part, j);
  path.RapidAround(Eigen::Vector2d(-route, 0), keep, route);
  path.RapidXY(Eigen::Vector2d(-l.strip_half_pass_mm, y));
  path.FeedXY(Eigen::Vector2d(l.strip_half_pass_mm, y), feed);
  report(StripId(j));
  path.RapidXY(Eigen::Vector2d(route, 0));

  index_table(XFacetTableAngleDeg(c, j));
  // X1 normal along +X: tool on the +X side moving -Y.
  path.RapidAround(Eigen::Vector2d(xf, yf), keep, route);
  path.FeedXY(Eigen::Vector2d(xf, -yf), feed);
  report(FacetId(Segment::kX1, j));
  // X2 normal along -X: tool on the -X side moving +Y.
  path.RapidAround(Eigen::Vector2d(-xf, -yf), keep, route);
  path.FeedXY(Eigen::Vector2d(-xf, yf), feed);
  report(FacetId(Segment::kX2, j));

  index_table(YFacetTableAngleDeg(c, j));
  // Y1 normal along +Y: tool on the +Y side moving +X.
  path.RapidAround(Eigen::Vector2d(-yf, xf), keep, route);
  path.FeedXY(Eigen::Vector2d(yf, xf), feed);
  report(FacetId(Segment::kY1, j));
  // Y2 normal along -Y: tool on the -Y side moving -X.
  path.RapidAround(Eigen::Vector2d(yf, -xf), keep, route);
  path.FeedXY(Eigen::Vector2d(-yf, -xf), feed);
  report(FacetId(Segment::kY2, j));

  path.IndexC(0.0);
  path.RapidAround(waiting, keep, route);
  path.Add(gcode::SpindleOff{});
  if (c.process.coolant_in_test) path.Add(gcode::Coolant{false});
}

void CheckTestCycleConfig(const Config& c) {
  const TestCycleLayout l = ComputeTestCycleLayout(c);
  if (std::abs(c.part.facet_bottom_z_mm - c.part.strip_floor_z_mm) > 1e-9)
    throw InputError(kSource, 0, "part.facet_bottom_z_mm",
                     "must equal part.strip_floor_z_mm: Z is set once in the "
                     "test cycle");
  const Eigen::Vector2d waiting(c.machine.waiting_position_w_mm[0],
                                c.machine.waiting_position_w_mm[1]);
  if (waiting.norm() < l.route_radius_mm)
    throw InputError(
        kSource, 0, "machine.waiting_position_w_mm",
        fmt::format("the waiting position must be at least {:.3f} mm from "
                    "the C axis (blank + tool radius + clearance)",
                    l.route_radius_mm));
}

// R-test n (thesis 5.2, figure 5.2): probe in, the sphere measured at five
// table angles 90 deg apart, starting with the sphere on the machine's +X
// axis (the fifth repeats the first: a repeatability check), probe out and
// the finishing tool back at the waiting position at the cutting height.
// Every position: over the sphere at the R-test's safe height, down to the
// approach height, the measurement (a dwell of rtest_measure_s standing for
// the probe's sphere cycle), the report with the control's clock, up again.
void RTest(PathWriter& path, const Config& c, int n) {
  const RTestLayout l = ComputeRTestLayout(c);
  path.Add(gcode::Comment{RTestCommentText(n)});
  path.IndexC(0.0);
  ChangeTool(path, c, c.process.probe, false, /*spindle=*/false);
  path.RapidZ(l.safe_z_mm);
  for (int k = 1; k <= kRTestPositions; ++k) {
    const double c_deg = l.c_deg[k - 1];
    path.IndexC(c_deg);
    const Eigen::Vector2d over = SpherePositionProgramXY(c, c_deg);
    path.RapidXY(over);
    path.RapidZ(l.approach_z_mm);
    path.Add(gcode::Dwell{c.process.rtest_measure_s});
    path.Add(gcode::Report{"rtest", RTestPositionFeature(n, k),
                           path.c_deg_normalised()});
    path.RapidZ(l.safe_z_mm);
  }
  path.IndexC(0.0);
  // Each cycle starts the spindle and the coolant itself.
  ChangeTool(path, c, c.process.finishing, false, /*spindle=*/false);
  path.RapidXY(Eigen::Vector2d(c.machine.waiting_position_w_mm[0],
                               c.machine.waiting_position_w_mm[1]));
  path.RapidZ(ComputeTestCycleLayout(c).cut_z_mm);
  path.Add(gcode::Comment{RTestDoneCommentText(n)});
}

// Time kept free around an R-test: C stops before it and spins up after
// it in the warm-up.
double RTestMarginS(const Config& c) { return 2 * c.machine.c_spinup_s + 2.0; }

// Which R-tests run in the wait after each cycle, and the program time each
// starts at.
struct WaitPlan {
  std::vector<std::vector<int>> rtests_after;  // [cycle] -> R-test numbers
  std::vector<double> rtest_start_s;           // [R-test number]
  // Due while the tool was busy: starts as soon as it waits, no dwell.
  std::vector<bool> immediate;  // [R-test number]
};

// A dwell of the waits and the comment whose program time it sets.
struct Anchor {
  size_t dwell_statement;
  std::string comment;
  double target_s;
};

// Times (program seconds) of the comments of a written program.
std::map<std::string, double> CommentTimes(const gcode::Program& program,
                                           const Config& c) {
  const std::string text =
      gcode::WriteProgram(program, gcode::Dialect::kLinuxCnc, c);
  const auto canon =
      gcode::ReadProgram(text, gcode::Dialect::kLinuxCnc, c, "cycle");
  std::map<std::string, double> times;
  for (const gcode::CanonStatement& s : canon)
    if (s.kind == gcode::CanonKind::kComment) times.emplace(s.text, s.start_s);
  return times;
}

double TimeOf(const std::map<std::string, double>& times,
              const std::string& comment) {
  const auto it = times.find(comment);
  if (it == times.end())
    throw std::logic_error("comment lost in the written program: " + comment);
  return it->second;
}

// The program with placeholder dwells; `anchors` gets every wait's dwell
// with the comment it leads to (targets filled by the caller).
constexpr double kPlaceholderS = 1.0;
gcode::Program AssembleTestCycle(const Config& c, const WaitPlan& plan,
                                 std::vector<Anchor>* anchors) {
  const PartSpec& part = c.part;
  const ProcessSpec& pr = c.process;
  const bool rtests = pr.rtest_interval_s > 0;
  gcode::Program program;
  program.name = "cycle";
  program.number = c.machine.program_number;
  program.title = "ttp thermal test cycle";
  PathWriter path(&program.statements);
  path.Add(gcode::Comment{"test cycle of test-piece.md section 3"});
  ProgramStart(path, c);
  ChangeTool(path, c, pr.finishing, pr.coolant_in_test);
  path.Add(gcode::SpindleOff{});  // each cycle starts the spindle
  if (pr.coolant_in_test) path.Add(gcode::Coolant{false});
  path.RapidXY(Eigen::Vector2d(c.machine.waiting_position_w_mm[0],
                               c.machine.waiting_position_w_mm[1]));
  path.IndexC(0);
  path.Add(gcode::Comment{"Z is set here and not moved until the end"});
  path.RapidZ(ComputeTestCycleLayout(c).cut_z_mm);

  const auto dwell_before = [&](const std::string& comment) {
    anchors->push_back({program.statements.size(), comment, 0.0});
    path.Add(gcode::Dwell{kPlaceholderS});
  };
  const int cycles = part.cycles();
  for (int k = 0; k <= cycles; ++k) {
    TestCycle(path, c, k);
    if (rtests) path.Add(gcode::Comment{CycleEndCommentText(k)});
    const std::vector<int>& tests = plan.rtests_after[k];
    if (k == cycles) {
      for (int n : tests) RTest(path, c, n);
      break;
    }
    if (k < pr.warmup_cycles) {
      path.Add(gcode::Comment{"warm-up: C at maximum speed"});
      const auto spin = [&] {
        path.ClampC(false);
        path.Add(gcode::CSpin{c.machine.c_max_rpm});
      };
      const auto stop = [&] {
        path.Add(gcode::CSpin{0});
        // Back in positioning mode the table's angle is not known: absolute.
        path.RapidCAbsolute(0);
      };
      for (int n : tests) {
        if (!plan.immediate[n]) {
          spin();
          dwell_before(RTestCommentText(n));
          stop();
        }
        RTest(path, c, n);
      }
      spin();
      dwell_before(CycleCommentText(k + 1));
      stop();
    } else {
      path.Add(gcode::Comment{"cool-down: NC hold, C at 0"});
      path.ClampC(true);
      for (int n : tests) {
        if (!plan.immediate[n]) dwell_before(RTestCommentText(n));
        RTest(path, c, n);
      }
      dwell_before(CycleCommentText(k + 1));
    }
  }
  path.RapidZ(pr.safe_z_w_mm);
  path.ClampC(true);
  path.Add(gcode::ProgramEnd{});
  CheckTravel(program, c);
  return program;
}

// R-test n is due n * rtest_interval_s after the reference cycle's start
// (n = 0 .. while due by the last cycle's start) and runs at the first
// moment at or after that when the tool waits and the whole R-test, with
// the margin for stopping and restarting C, fits before the next cycle;
// one due during a cycle runs after it.
WaitPlan PlanRTests(const Config& c, double cycle0_s,
                    const std::vector<double>& cycle_duration_s,
                    double rtest_s) {
  const ProcessSpec& pr = c.process;
  const int cycles = c.part.cycles();
  WaitPlan plan;
  plan.rtests_after.assign(cycles + 1, {});
  if (pr.rtest_interval_s <= 0) return plan;
  const double margin = RTestMarginS(c);
  const auto start_of = [&](int k) { return cycle0_s + k * pr.cycle_period_s; };
  const auto end_of = [&](int k) { return start_of(k) + cycle_duration_s[k]; };
  double free_from = cycle0_s;
  for (int n = 0;; ++n) {
    const double due = cycle0_s + n * pr.rtest_interval_s;
    if (due > start_of(cycles) + 1e-6) break;
    double t = std::max(due, free_from);
    int after = cycles;
    for (int k = 0; k <= cycles; ++k) {
      if (t < end_of(k) + margin) t = std::max(t, end_of(k) + margin);
      if (k == cycles || t + rtest_s + margin <= start_of(k + 1)) {
        after = k;
        break;
      }
    }
    // Due while the tool was busy: right after, without stopping C's
    // warm-up in between (the C stop and restart are the margin).
    const bool immediate = t > due + 1e-6;
    if (immediate) t = t - margin;
    plan.rtests_after[after].push_back(n);
    plan.rtest_start_s.push_back(t);
    plan.immediate.push_back(immediate);
    free_from = t + rtest_s + margin;
  }
  return plan;
}

}  // namespace

std::string RTestCommentText(int n) { return fmt::format("R-test {}", n); }
std::string RTestDoneCommentText(int n) {
  return fmt::format("R-test {} done", n);
}
std::string CycleEndCommentText(int cycle) {
  return fmt::format("end of cycle {}", cycle);
}
std::string RTestPositionFeature(int n, int position) {
  return fmt::format("R{}-P{}", n, position);
}
bool ParseRTestPositionFeature(const std::string& feature, int* n,
                               int* position) {
  int a = -1, b = -1;
  char tail = 0;
  if (std::sscanf(feature.c_str(), "R%d-P%d%c", &a, &b, &tail) != 2 || a < 0 ||
      b < 1 || b > kRTestPositions || feature != RTestPositionFeature(a, b))
    return false;
  *n = a;
  *position = b;
  return true;
}

RTestLayout ComputeRTestLayout(const Config& c) {
  const MachineProfile& m = c.machine;
  const ToolSpec& probe = c.process.probe;
  RTestLayout l;
  // Sphere on the machine's +X axis first, then C by +90 deg each.
  const double c1 =
      TableAngleFor(m.sphere_phi_deg * kDeg, 0.0, m.c_sense) * kRadToDeg;
  for (int k = 0; k < kRTestPositions; ++k) l.c_deg[k] = c1 + 90.0 * k;
  l.sphere_centre_z_mm =
      m.table_top_z_mm + m.sphere_height_mm - WorkpieceOriginHeightMm(c);
  // The stylus ball (tip at program Z) clear above the ball by the
  // clearance; the safe height also clears the piece.
  l.approach_z_mm = l.sphere_centre_z_mm + m.sphere_radius_mm +
                    probe.diameter_mm / 2 + c.process.clearance_mm;
  l.safe_z_mm =
      std::max(c.process.safe_z_w_mm, l.approach_z_mm + c.process.clearance_mm);
  return l;
}

Eigen::Vector2d SpherePositionProgramXY(const Config& c, double c_deg) {
  const MachineProfile& m = c.machine;
  const double phi = m.sphere_phi_deg * kDeg;
  const Eigen::Vector3d w(m.sphere_distance_mm * std::cos(phi),
                          m.sphere_distance_mm * std::sin(phi), 0.0);
  Eigen::Vector2d xy =
      (WorkpieceToMachineRotation(c_deg * kDeg, m.c_sense) * w).head<2>();
  // No "-0.0000" in the program for a rounding residue.
  for (int a = 0; a < 2; ++a)
    if (std::abs(xy[a]) < 1e-9) xy[a] = 0.0;
  return xy;
}

gcode::Program BuildTestCycleProgram(const Config& c) {
  ValidateConfig(c, kSource);
  CheckCuttingData(c, kSource);
  CheckTestCycleConfig(c);
  const ProcessSpec& pr = c.process;
  const int cycles = c.part.cycles();

  // First the cycles' and an R-test's durations, from a program with one
  // R-test after the reference cycle (or none).
  WaitPlan plan;
  plan.rtests_after.assign(cycles + 1, {});
  if (pr.rtest_interval_s > 0) {
    plan.rtests_after[0] = {0};
    plan.immediate = {true};
  }
  std::vector<Anchor> anchors;
  gcode::Program program = AssembleTestCycle(c, plan, &anchors);
  if (pr.rtest_interval_s > 0) {
    const auto times = CommentTimes(program, c);
    const double cycle0_s = TimeOf(times, CycleCommentText(0));
    std::vector<double> cycle_duration_s;
    for (int k = 0; k <= cycles; ++k)
      cycle_duration_s.push_back(TimeOf(times, CycleEndCommentText(k)) -
                                 TimeOf(times, CycleCommentText(k)));
    const double rtest_s = TimeOf(times, RTestDoneCommentText(0)) -
                           TimeOf(times, RTestCommentText(0));
    const double margin = RTestMarginS(c);
    if (rtest_s + margin > pr.rtest_interval_s)
      throw InputError(
          kSource, 0, "process.rtest_interval_s",
          fmt::format("an R-test takes {:.0f} s and {:.0f} s to stop and "
                      "restart C: more than the interval",
                      rtest_s, margin));
    plan = PlanRTests(c, cycle0_s, cycle_duration_s, rtest_s);
    anchors.clear();
    program = AssembleTestCycle(c, plan, &anchors);
  }

  // Dwells from the reader's time model on the written text, so that the
  // program, the schedule and a log agree to the written precision: each
  // sets the time of the comment it leads to.
  const auto times = CommentTimes(program, c);
  const double cycle0_s = TimeOf(times, CycleCommentText(0));
  for (Anchor& a : anchors) {
    for (int k = 1; k <= cycles; ++k)
      if (a.comment == CycleCommentText(k))
        a.target_s = cycle0_s + k * pr.cycle_period_s;
    for (size_t n = 0; n < plan.rtest_start_s.size(); ++n)
      if (a.comment == RTestCommentText(static_cast<int>(n)))
        a.target_s = plan.rtest_start_s[n];
  }
  double added_s = 0;  // dwell time added before the current anchor
  for (const Anchor& a : anchors) {
    const double now = TimeOf(times, a.comment) + added_s;
    // Whole milliseconds: the writers keep 3 decimals of seconds.
    const double dwell =
        std::round((kPlaceholderS + a.target_s - now) * 1000.0) / 1000.0;
    if (dwell < 0)
      throw InputError(kSource, 0, "process.cycle_period_s",
                       fmt::format("the test cannot reach '{}' at {:.0f} s: "
                                   "a cycle (with its R-tests) takes longer "
                                   "than the period",
                                   a.comment, a.target_s));
    std::get<gcode::Dwell>(program.statements[a.dwell_statement]).seconds =
        dwell;
    added_s += dwell - kPlaceholderS;
  }
  return program;
}

}  // namespace ttp::cam
