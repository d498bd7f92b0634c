// Small but complete programs written for the verify tests (independent of
// the cam module): a pre-machining program that cuts every feature of the
// drawing and a test-cycle program with the 9 cycles, as Program IR, plus
// a helper that writes and reads them back into canonical statements.
#pragma once

#include <cmath>
#include <vector>

#include "ttp/gcode/program.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"

namespace ttp::verify::testing {

using namespace ttp::gcode;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

inline Axes XYZ(double x, double y, double z) { return {x, y, z, {}}; }
inline Axes XYZC(double x, double y, double z, double c) {
  return {x, y, z, c};
}

// Feed along a path entered and left from safe height by rapids outside
// the piece.
inline void Pass(Program& p, const std::vector<Axes>& path, double feed,
                 double safe_z = 50) {
  auto& s = p.statements;
  s.push_back(Rapid{XYZ(*path.front().x_mm, *path.front().y_mm, safe_z)});
  s.push_back(Rapid{path.front()});
  for (size_t i = 1; i < path.size(); ++i) s.push_back(Feed{path[i], feed});
  s.push_back(Rapid{XYZ(*path.back().x_mm, *path.back().y_mm, safe_z)});
}

// Facet pass with a flat end mill of radius r: the tool centre runs along
// the facet at distance d + r from the axis, `overrun` beyond the facet's
// half width on both sides, entering radially from outside.
inline void FacetPass(Program& p, double phi_rad, double d, double r,
                      double half_len, double z, double feed) {
  const double cx = std::cos(phi_rad), cy = std::sin(phi_rad);
  const double tx = -cy, ty = cx;
  const double far = d + r + 15;
  Pass(p,
       {XYZ(far * cx - half_len * tx, far * cy - half_len * ty, z),
        XYZ((d + r) * cx - half_len * tx, (d + r) * cy - half_len * ty, z),
        XYZ((d + r) * cx + half_len * tx, (d + r) * cy + half_len * ty, z),
        XYZ(far * cx + half_len * tx, far * cy + half_len * ty, z)},
       feed);
}

// Tool change as the machine wants it: up and across to the tool-change
// position in machine coordinates, M6, G43 H with a Z word, spindle on.
inline void ChangeToolAtToolChangePosition(Program& p, const Config& config,
                                           const ToolSpec& tool) {
  const auto& tc = config.machine.tool_change_position_m_mm;
  auto& s = p.statements;
  s.push_back(SpindleOff{});
  Axes up;
  up.z_mm = tc[2];
  s.push_back(MachineRapid{up});
  Axes across;
  across.x_mm = tc[0];
  across.y_mm = tc[1];
  s.push_back(MachineRapid{across});
  s.push_back(ToolChange{tool.number, tool.name});
  s.push_back(LengthOffset{tool.number, 50.0});
  s.push_back(SpindleOn{tool.spindle_rpm, true});
}

// Options to break the programs on purpose.
struct PreFaults {
  std::string facet;          // facet id cut at a wrong distance
  double facet_error_mm = 0;  // + leaves material, - cuts too deep
  bool travel_exceeded = false;
  bool cut_adapter = false;
};

inline Program MakePreProgram(const Config& config,
                              const PreFaults& faults = {}) {
  const PartSpec& part = config.part;
  const ProcessSpec& proc = config.process;
  Program p;
  p.name = "pre";
  p.number = 1001;
  p.title = "verify test pre-machining";
  auto& s = p.statements;
  // Step 1: face 1 mm and turn the reference cylinders.
  const double r1 = proc.roughing.diameter_mm / 2;
  s.push_back(TableClamp{true});
  ChangeToolAtToolChangePosition(p, config, proc.roughing);
  for (double y = -108; y <= 108.1; y += 12)
    Pass(p, {XYZ(-120, y, 0), XYZ(120, y, 0)}, proc.roughing.feed_mm_min);
  for (const RefCylinder& rc : part.ref_cylinders) {
    const double x = rc.diameter_mm / 2 + r1;
    // Bottom band: the tool tip goes 0.5 mm below the piece (not into the
    // adapter, which is much smaller).
    const double z = rc.z_bottom_mm <= -part.height_mm() + 1e-9
                         ? rc.z_bottom_mm - 0.5
                         : rc.z_bottom_mm;
    // Approach 10 mm out: the holder stays inside the R-test sphere's ring.
    s.push_back(Rapid{XYZC(x + 10, 0, 50, 0)});
    s.push_back(Rapid{XYZ(x + 10, 0, z)});
    s.push_back(Feed{XYZ(x, 0, z), proc.roughing.feed_mm_min});
    s.push_back(TableClamp{false});
    s.push_back(Feed{XYZC(x, 0, z, 360), proc.turning_c_rpm * 360});
    s.push_back(TableClamp{true});
    s.push_back(Feed{XYZ(x + 10, 0, z), proc.roughing.feed_mm_min});
    s.push_back(Rapid{XYZC(x + 10, 0, 50, 0)});
  }
  if (faults.cut_adapter) {
    s.push_back(Rapid{XYZ(120, 0, -26)});
    s.push_back(Feed{XYZ(95, 0, -26), proc.roughing.feed_mm_min});
    s.push_back(Feed{XYZ(120, 0, -26), proc.roughing.feed_mm_min});
  }
  if (faults.travel_exceeded) s.push_back(Rapid{XYZ(400, 0, 50)});
  // Step 2: the mark with the engraver (cone tip).
  ChangeToolAtToolChangePosition(p, config, proc.engraver);
  const double mphi = part.mark_phi_deg * kDeg;
  const double ux = std::cos(mphi), uy = std::sin(mphi);
  Pass(p,
       {XYZ(part.mark_r_start_mm * ux, part.mark_r_start_mm * uy, 2),
        XYZ(part.mark_r_start_mm * ux, part.mark_r_start_mm * uy,
            -part.mark_depth_mm),
        XYZ(part.mark_r_end_mm * ux, part.mark_r_end_mm * uy,
            -part.mark_depth_mm),
        XYZ(part.mark_r_end_mm * ux, part.mark_r_end_mm * uy, 2)},
       proc.engraver.feed_mm_min);
  // Step 3: small notch, two passes along Y.
  const double r3 = proc.notch.diameter_mm / 2;
  ChangeToolAtToolChangePosition(p, config, proc.notch);
  for (double x : {-part.small_notch_half_width_mm + r3,
                   part.small_notch_half_width_mm - r3})
    Pass(p,
         {XYZ(x, -120, part.small_notch_floor_z_mm),
          XYZ(x, 120, part.small_notch_floor_z_mm)},
         proc.notch.feed_mm_min);
  // Step 4: big notch, passes along X.
  ChangeToolAtToolChangePosition(p, config, proc.roughing);
  const double yb = part.big_notch_half_width_mm - r1;
  for (double y :
       {-yb, -yb + 12, -yb + 24, -yb + 36, 0.0, yb - 36, yb - 24, yb - 12, yb})
    Pass(p,
         {XYZ(-125, y, part.big_notch_floor_z_mm),
          XYZ(125, y, part.big_notch_floor_z_mm)},
         proc.roughing.feed_mm_min);
  // Step 5: the 36 facets at the pre distance.
  const double half_len =
      part.facet_pre_distance_mm * std::tan(part.facet_step_deg / 2 * kDeg) +
      1.0;
  for (Segment seg : kSegments)
    for (int j = 1; j <= part.facets_per_segment; ++j) {
      double d = part.facet_pre_distance_mm;
      if (FacetId(seg, j) == faults.facet) d += faults.facet_error_mm;
      FacetPass(p, FacetPhiDeg(part, seg, j) * kDeg, d, r1, half_len,
                part.facet_bottom_z_mm, proc.roughing.feed_mm_min);
    }
  s.push_back(SpindleOff{});
  s.push_back(ProgramEnd{});
  return p;
}

struct CycleFaults {
  bool rapid_through_piece = false;
  // A G0 whose straight line keeps off the piece but whose per-axis
  // dog-leg runs through segment X1.
  bool dog_leg_rapid = false;
  // C turns at 1200 rpm with the tool waiting in the sphere's ring.
  bool spin_in_sphere_ring = false;
  // M6 with the spindle over the piece.
  bool tool_change_over_piece = false;
  // The strip of cycle 0 cut with C unclamped.
  bool unclamped_cut = false;
  int z_shift_cycle = -1;  // this cycle cuts 10 um higher
};

// Test cycle as the spec's section 3 describes it (no warm-up spin).
inline Program MakeCycleProgram(const Config& config,
                                const CycleFaults& faults = {}) {
  const PartSpec& part = config.part;
  const ToolSpec& tool = config.process.finishing;
  const double r = tool.diameter_mm / 2;
  Program p;
  p.name = "cycle";
  p.number = 1000;
  p.title = "verify test cycle";
  auto& s = p.statements;
  s.push_back(TableClamp{true});
  if (faults.tool_change_over_piece) {
    s.push_back(Rapid{XYZ(0, 0, 150)});
    s.push_back(ToolChange{tool.number, tool.name});
    s.push_back(LengthOffset{tool.number, 50.0});
    s.push_back(SpindleOn{tool.spindle_rpm, true});
  } else {
    ChangeToolAtToolChangePosition(p, config, tool);
  }
  if (faults.dog_leg_rapid) {
    s.push_back(Rapid{XYZC(150, -60, 50, 0)});
    s.push_back(Rapid{XYZ(150, -60, -5)});
    s.push_back(Rapid{XYZ(60, 150, -5)});
    s.push_back(Rapid{XYZ(60, 150, 50)});
  }
  if (faults.unclamped_cut) s.push_back(TableClamp{false});
  if (faults.rapid_through_piece) {
    // Across segments X1 and Y1 (y = 70 is outside the big notch).
    s.push_back(Rapid{XYZC(-120, 70, 50, 0)});
    s.push_back(Rapid{XYZ(-120, 70, -5)});
    s.push_back(Rapid{XYZ(120, 70, -5)});
  }
  const double d = part.facet_final_distance_mm + r;
  const double half_len =
      part.facet_final_distance_mm * std::tan(part.facet_step_deg / 2 * kDeg) +
      1.0;
  const double far = 30;  // y (or x) where a facet pass starts, outside
  for (int cycle = 0; cycle <= part.cycles(); ++cycle) {
    const int k = IndexForCycle(part, cycle);
    const double z =
        part.strip_floor_z_mm + (cycle == faults.z_shift_cycle ? 0.01 : 0.0);
    const double yk = StripY(part, k);
    s.push_back(Rapid{XYZC(-120, yk, 50, 0)});
    Pass(p, {XYZ(-120, yk, z), XYZ(120, yk, z)}, tool.feed_mm_min);
    s.push_back(Report{"cut", StripId(k), 0});
    const double c = FacetPhiDeg(part, Segment::kX1, k);
    s.push_back(Rapid{XYZC(d, far, 50, c)});
    Pass(p,
         {XYZ(d, far, z), XYZ(d, half_len, z), XYZ(d, -half_len, z),
          XYZ(d, -far, z)},
         tool.feed_mm_min);
    s.push_back(Report{"cut", FacetId(Segment::kX1, k), c});
    Pass(p,
         {XYZ(-d, -far, z), XYZ(-d, -half_len, z), XYZ(-d, half_len, z),
          XYZ(-d, far, z)},
         tool.feed_mm_min);
    s.push_back(Report{"cut", FacetId(Segment::kX2, k), c});
    s.push_back(Rapid{XYZC(-far, d, 50, c - 30)});
    Pass(p,
         {XYZ(-far, d, z), XYZ(-half_len, d, z), XYZ(half_len, d, z),
          XYZ(far, d, z)},
         tool.feed_mm_min);
    s.push_back(Report{"cut", FacetId(Segment::kY1, k), c - 30});
    Pass(p,
         {XYZ(far, -d, z), XYZ(half_len, -d, z), XYZ(-half_len, -d, z),
          XYZ(-far, -d, z)},
         tool.feed_mm_min);
    s.push_back(Report{"cut", FacetId(Segment::kY2, k), c - 30});
    const auto& w = config.machine.waiting_position_w_mm;
    s.push_back(Rapid{XYZ(w[0], w[1], w[2])});
    if (cycle == 0 && faults.spin_in_sphere_ring) {
      s.push_back(Rapid{XYZ(0, 150, 20)});
      s.push_back(CSpin{1200});
      s.push_back(Dwell{10});
      s.push_back(CSpin{0});
      s.push_back(Rapid{XYZ(w[0], w[1], w[2])});
    }
    if (faults.unclamped_cut && cycle == 0) s.push_back(TableClamp{true});
    if (cycle < part.cycles()) s.push_back(Dwell{3400});
  }
  s.push_back(SpindleOff{});
  s.push_back(ProgramEnd{});
  return p;
}

inline std::vector<CanonStatement> Canon(const Program& program,
                                         const Config& config,
                                         Dialect dialect = Dialect::kLinuxCnc) {
  const std::string text = WriteProgram(program, dialect, config);
  return ReadProgram(text, dialect, config, program.name);
}

}  // namespace ttp::verify::testing
