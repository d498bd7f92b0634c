// On-machine probing program (measurements.md section 2) and the log it
// writes, which `ttp inspect` reads as it is.
//
// The program, per dialect:
// - safety block, B at 0 and clamped, tool change at the profile's
//   tool-change position, spindle stopped (M5) and oriented (M19), length
//   offset `G43 H<probe> Z<safe>`, probe switched on (FANUC
//   machine.m_probe_on / m_probe_off, LinuxCNC M64 / M65 P
//   machine.linuxcnc_probe_output) and off at the end;
// - the stylus qualified on the R-test sphere of the profile (top, then
//   +X, -X, +Y, -Y at its equator): `ttp inspect` fits a sphere through
//   these touches and uses (fitted radius - sphere radius) as the
//   effective ball radius;
// - every planned point: table indexed (unclamp, index, clamp) so that the
//   approach runs along one linear axis (-X for horizontal normals, -Z for
//   vertical ones), probe move (FANUC G31, LinuxCNC G38.2), touch check,
//   one log row;
// - at the end the points of the reference facets (j = part.reference_index)
//   again, as `drift` rows.
// Touch check: FANUC `IF [ABS[#<skip var>-<nominal>] GT <window>] THEN
// #3000=<n> (...)`: a G31 that ends without a skip signal leaves the skip
// variable at the move's end (overtravel beyond the nominal contact, more
// than the window), and a touch off by more than the window (an obstacle, a
// wrong set-up) stops the program too. LinuxCNC: G38.2 itself stops the
// program with an error when the move ends without contact (and when the
// probe is already tripped at its start); #5070 (1 = tripped) matters only
// for G38.3/G38.5, which the program does not use.
// Log: one row per touch, columns point_id, x, y, z (stylus centre at the
// trigger, program frame G54), c_deg, feature, pass (qualify | measure |
// drift), and on FANUC the control's clock (hhmmss, #3012).
//   LinuxCNC: (LOGOPEN,<file>) ...
//   (LOG,<id>,#5061,#5062,#5063,#5066,<feature>,<pass>)
//   ... (LOGCLOSE): the file is CSV with the header
//   `point_id,x,y,z,c_deg,feature,pass`.
//   FANUC: POPEN, DPRNT[TTP*PROBE*LOG*O<n>*D#3011[80]*T#3012[60]], then
//   DPRNT[<PASS>*<id>*<feature>*X#5061[44]*Y#5062[44]*Z#5063[44]*C#5065[33]*T#3012[60]]
//   per touch, PCLOS: the port output (lines `TTP PROBE LOG ...`,
//   `MEASURE 12 X1-5 X ... Y ... Z ... C ... T ...`).
// The program is program IR (gcode/program.h: Probe, ProbeLog,
// ProbeSignal, SpindleOrient beside the cycle programs' statements),
// written by gcode::WriteProgram like every other program.
// The skip variables are the profile's (machine.fanuc_skip_variables,
// machine.linuxcnc_probe_variables: C is #5065 on a FANUC XYZBC machine,
// #5066 on LinuxCNC).
#pragma once

#include <string>
#include <vector>

#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {

// The probe itself (tool number, stylus ball diameter, probing feed, gauge
// length) is config.process.probe.
struct ProbeOptions {
  double clearance_mm = 4.0;   // start of the probing move off the surface
  double overtravel_mm = 2.0;  // the move ends this far beyond the surface
  double safe_z_mm = 20.0;     // program Z for moves between points
  // FANUC: a touch further than this from its nominal contact (or none)
  // raises alarm 3001; must be below overtravel_mm and clearance_mm.
  double touch_window_mm = 1.0;
  // Clearance the ball keeps at its contact from every surface other than
  // the touched one (shoulders of the reference cylinders, notch floor,
  // flanks).
  double min_ball_clearance_mm = 0.2;
  bool qualify = true;  // stylus qualification on the R-test sphere
  bool drift = true;    // re-probe the reference facets at the end
  // LinuxCNC (LOGOPEN,...) file, relative to the controller's working
  // folder unless absolute; no spaces, commas or parentheses.
  std::string log_file = "ttp-probe-log.csv";
  // Ceres style: false with "ProbeOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
  // Throws InputError("ProbeOptions", 0, field, ...).
  void Validate() const;
};

// Pass of a touch in the log.
enum class ProbePass { kQualify, kMeasure, kDrift };
const char* ProbePassName(ProbePass pass);  // "qualify", "measure", "drift"

// The points the probing program touches: PlanPoints, with the datum
// circle's touches placed in its band (part.datum_circle_z_min_mm ..
// _max_mm) at the lowest height where the ball clears the next reference
// cylinder's shoulder below by min_ball_clearance_mm (the middle of the
// band when that is higher). Then CheckBallReach. `ttp inspect` uses this
// list by default.
std::vector<PlannedPoint> PlanProbePoints(const Config& config,
                                          const PlanOptions& plan = {},
                                          const ProbeOptions& probe = {});

// Refuses (InputError naming process.probe.diameter_mm, with the point and
// the feature) a plan whose ball cannot reach a point: at its contact the
// ball must keep min_ball_clearance_mm from the reference cylinders other
// than the touched one, from the big-notch floor (flank touches) and from
// the flanks (strip touches), and be able to reach the floor of a strip
// between its neighbours.
void CheckBallReach(const Config& config,
                    const std::vector<PlannedPoint>& points,
                    const ProbeOptions& options = {});

// The qualification touches on the R-test sphere, in order: top (-Z), then
// +X, -X, +Y, -Y sides at the equator. Centre and outward normals in the
// program frame at table angle `c_deg` (the sphere turned onto machine +X).
struct SphereTouch {
  int id = 0;  // 1..5
  Eigen::Vector3d normal_m = Eigen::Vector3d::UnitZ();
};
struct SphereQualification {
  double c_deg = 0;
  Eigen::Vector3d centre_program_mm = Eigen::Vector3d::Zero();
  double radius_mm = 0;
  std::vector<SphereTouch> touches;
};
SphereQualification PlanSphereQualification(const Config& config);

// The probing program text in `dialect` for `points` (PlanProbePoints).
// Throws InputError when an option or a point cannot be probed (a normal
// that is neither horizontal nor vertical, a ball that does not reach).
std::string WriteProbeProgram(const Config& config,
                              const std::vector<PlannedPoint>& points,
                              gcode::Dialect dialect,
                              const ProbeOptions& options = {});

}  // namespace ttp::plan
