// The two NC programs of test-piece.md section 3, as dialect-free program IR
// (gcode/program.h): the pre-machining (steps 1-5, then an NC hold) and the
// 8-hour test cycle. Every number comes from the Config; nothing of the
// drawing is hard-coded.
//
// Conventions of both programs:
// - Program coordinates are W at C = 0 (G54); the table turns the piece, so
//   a tool position is a machine position (shifted in Z).
// - Every C index and every move between cuts happens with the tool outside
//   the blank's cylinder (radius blank + tool radius + clearance); rapids
//   never cross material. Cuts start and end outside the material.
// - Facets and big-notch walls are climb-milled with M3 (material on the
//   right of the tool's heading).
// - Tool changes happen at tool_change_z (above safe Z by the longest tool),
//   so the tool tip stays above the piece across G43.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>

#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"

namespace ttp::cam {

// Steps 1-5 and the NC hold. Throws InputError naming the field when the
// config is invalid (ValidateConfig) or a move leaves the machine's travel.
gcode::Program BuildPreMachiningProgram(const Config& config);

// The test cycle: cycle 0 (reference) then cycles 1..8 one cycle period
// apart (dwells computed with the gcode reader's time model), warm-up with
// C spinning at c_max_rpm between cycles 0..warmup_cycles, cool-down with C
// at 0 and the spindle stopped; a Report after each cut. Z is set once at
// the strip floor before cycle 0 and never moves until the end. A comment
// "cycle <k>" opens each cycle (its time is the cycle's start).
gcode::Program BuildTestCycleProgram(const Config& config);

// Geometry of the test-cycle passes, shared with the tests and the
// schedule: tool tip height during the whole test, the radius outside which
// the tool moves between cuts, the tool centre's distance from the axis
// during a facet pass and the half length of a facet pass.
struct TestCycleLayout {
  double cut_z_mm;            // tool tip (program Z), = strip floor
  double route_radius_mm;     // tool centre radius for moves between cuts
  double facet_offset_mm;     // finished facet distance + tool radius
  double facet_half_pass_mm;  // pass runs from +half to -half
  double strip_half_pass_mm;  // strip pass from -half to +half in X
};
TestCycleLayout ComputeTestCycleLayout(const Config& config);

// Commanded table angles (deg) of the X facets and the Y facets of facet
// index j (TableAngleFor with the machine's C sense).
double XFacetTableAngleDeg(const Config& config, int j);
double YFacetTableAngleDeg(const Config& config, int j);

// R-test of the TALC run (thesis 5.2 and 7.4; process.rtest_interval_s >
// 0): R-test n is due n * interval after the reference cycle's start (n = 0
// while due by the last cycle's start) and runs at the first moment after
// that when the tool waits and it fits before the next cycle (C stopped,
// then restarted in the warm-up). It changes to the probe, measures the
// sphere at five table angles (c_deg[0..4], 90 deg apart, the sphere on the
// machine's +X axis first, the fifth a repeat of the first), reports each
// position (`rtest,R<n>-P<k>,<C deg>` with the control's clock) and brings
// the finishing tool back to the waiting position. Comments "R-test <n>"
// and "R-test <n> done" open and close it.
constexpr int kRTestPositions = 5;
struct RTestLayout {
  std::array<double, kRTestPositions> c_deg{};  // commanded, continuous
  double sphere_centre_z_mm = 0;  // program Z of the ball's centre
  double approach_z_mm = 0;       // probe tip over the ball: measuring
  double safe_z_mm = 0;           // probe tip while indexing
};
RTestLayout ComputeRTestLayout(const Config& config);
// Program XY of the sphere's centre with the table at c_deg.
Eigen::Vector2d SpherePositionProgramXY(const Config& config, double c_deg);
std::string RTestCommentText(int n);
std::string RTestDoneCommentText(int n);
// "end of cycle <k>" (written when R-tests are on).
std::string CycleEndCommentText(int cycle);
// Feature of a position's report, "R<n>-P<k>"; the parser is its inverse.
std::string RTestPositionFeature(int n, int position);
bool ParseRTestPositionFeature(const std::string& feature, int* n,
                               int* position);

// Dry run: every dwell longer than max_s becomes max_s; nothing else
// changes (a trial on a controller keeps the moves, feeds and reports).
void ShortenDwells(gcode::Program& program, double max_s);

// Text of the cycle comment, "cycle <k>".
std::string CycleCommentText(int cycle);

}  // namespace ttp::cam
