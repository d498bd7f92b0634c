// Building blocks of the CAM programs: a statement emitter that tracks the
// tool position, routes around the piece and through-slot pocketing.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "ttp/gcode/program.h"

namespace ttp::cam {

// Way from `from` to `to` (XY, mm) whose straight segments keep at least
// keep_radius_mm from the origin (the tool centre's distance from the C
// axis). Both ends must lie at or outside route_radius_mm (> keep); extra
// points lie on the route circle, at bisecting angles. Returns the points
// after `from`, ending with `to`.
std::vector<Eigen::Vector2d> RouteAround(const Eigen::Vector2d& from,
                                         const Eigen::Vector2d& to,
                                         double keep_radius_mm,
                                         double route_radius_mm);

// Smallest distance of the segment a-b from the origin.
double SegmentDistanceFromOrigin(const Eigen::Vector2d& a,
                                 const Eigen::Vector2d& b);

// Heading of a climb-milling pass (M3, material on the right) along a wall
// whose material lies in direction material_dir from the tool.
Eigen::Vector2d ClimbHeading(const Eigen::Vector2d& material_dir);

// Emits statements and keeps the position the program leaves the tool at
// (program coordinates, C in degrees).
class PathWriter {
 public:
  explicit PathWriter(std::vector<gcode::Statement>* out) : out_(out) {}

  const Eigen::Vector3d& position() const { return position_mm_; }
  double c_deg() const { return c_deg_; }
  // Sets the tracked position without a move (after a tool change's G43).
  void Assume(const Eigen::Vector3d& p, double c_deg) {
    position_mm_ = p;
    c_deg_ = c_deg;
  }

  // Rapids near the piece: below clearance_z_mm an XY rapid is written as a
  // straight G1 at positioning_feed (a G0 with per-axis rapids is a
  // dog-leg), and a rapid that changes Z and XY is split: up first, then
  // across; across first, then down. Without SetClearance: plain G0.
  void SetClearance(double clearance_z_mm, double positioning_feed_mm_min) {
    clearance_z_mm_ = clearance_z_mm;
    positioning_feed_mm_min_ = positioning_feed_mm_min;
  }
  // C is indexed incrementally by the short way (roll-over safe); the
  // tracked angle is continuous. RapidCAbsolute writes an absolute C (after
  // C turning mode, when the table's angle is not known).
  void Rapid(const Eigen::Vector3d& to);
  void RapidXY(const Eigen::Vector2d& to);
  void RapidZ(double z_mm);
  void RapidC(double c_deg);
  void RapidCAbsolute(double c_deg);
  // C unclamp, index, clamp (no codes when already there and clamped).
  void IndexC(double c_deg);
  void ClampC(bool clamp);
  // Tracked C in [0, 360).
  double c_deg_normalised() const;
  // Tool-change move (G49 G53 G0) in machine coordinates, then the tracked
  // position is the gauge line's in program coordinates.
  void MachineRapid(const gcode::Axes& to, double origin_z_mm);
  // G0 G43 H<tool> Z<z> after a tool change.
  void LengthOffset(int tool, double z_mm);
  void Feed(const Eigen::Vector3d& to, double feed_mm_min);
  void FeedXY(const Eigen::Vector2d& to, double feed_mm_min);
  void FeedZ(double z_mm, double feed_mm_min);
  // C by delta_deg (incremental G91 G1 C), feed in deg/min.
  void FeedC(double delta_deg, double feed_deg_min);
  // Rapid around the piece at the current Z (see RouteAround).
  void RapidAround(const Eigen::Vector2d& to, double keep_radius_mm,
                   double route_radius_mm);
  void Add(gcode::Statement s) { out_->push_back(std::move(s)); }

 private:
  std::vector<gcode::Statement>* out_;
  void StraightRapid(const Eigen::Vector3d& to);
  Eigen::Vector3d position_mm_ = Eigen::Vector3d::Zero();
  double c_deg_ = 0;
  double clearance_z_mm_ = -1e300;
  double positioning_feed_mm_min_ = 0;
  bool c_clamped_ = false;
  bool length_offset_on_ = false;
};

// A slot through the whole piece along axis `along` (0 = X, 1 = Y), walls
// at cross coordinate +-half_width_mm, floor at floor_z_mm, from the top
// face z = 0. Passes run the full length from -length_mm to +length_mm
// (outside the piece), zig-zag, the outermost passes climb-milling their
// wall. Levels go down by at most step_down_mm to floor + allowance; the
// walls get the allowance too. Enters and leaves at safe_z_mm.
struct SlotPass {
  int along = 0;
  double half_width_mm = 0;
  double floor_z_mm = 0;
  double tool_radius_mm = 0;
  double length_mm = 0;
  double step_down_mm = 0;  // <= 0: one level at the floor
  double allowance_mm = 0;
  double stepover_mm = 0;
  double feed_mm_min = 0;
  double safe_z_mm = 0;
};
void MillSlot(PathWriter& path, const SlotPass& slot);

}  // namespace ttp::cam
