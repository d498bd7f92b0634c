// The machine around the piece as the collision model sees it, and the
// checks that need only the executor's state (tool, spindle, C turning,
// clamps, positions of the canonical statements): tool and holder against
// the table, the clamps and the R-test sphere and its stem, for every move
// and under both rapid semantics; the ring the fixtures sweep while C turns;
// the tool-change position.
//
// Everything is computed in W (the table frame: fixtures stand still in it,
// the tool turns about the C axis as C moves). The tool is two coaxial
// vertical cylinders: cutter and shank (diameter_mm) from the tip up to
// stick_out_mm, holder (holder_diameter_mm) from there to the gauge line.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/geometry/config.h"
#include "ttp/verify/verify.h"

namespace ttp::verify {

// Axis position: program coordinates (mm) and table angle (rad).
struct AxisPoint {
  Eigen::Vector3d p_mm = Eigen::Vector3d::Zero();
  double c_rad = 0;
};

// Path of a rapid from `from` to `to`: straight (linear interpolation of
// all axes) or per axis (each axis at its own rate from
// machine.rapid_axis_mm_min and c_index_deg_s, all starting together: a
// dog-leg). Returns the corner points, from first, to last.
std::vector<AxisPoint> RapidPath(const AxisPoint& from, const AxisPoint& to,
                                 const MachineProfile& machine, bool per_axis);

// Deepest penetration (mm, > 0 = collision) of the tool body with tip at
// `tip_w` (W) into a fixture; `which` names it ("sphere", "stem",
// "clamp 2", "table").
double FixturePenetrationMm(const Config& config, const ToolSpec& tool,
                            const Eigen::Vector3d& tip_w, std::string* which);

// The machine checks over a program's canonical statements:
// "tool and holder clear the fixtures" (every move, rapids under both
// semantics), "clear of what C sweeps while turning" (the tool against the
// full ring of every fixture while C turns in turning mode),
// "tool change away from the piece" (the gauge line outside the blank's
// cylinder widened by the largest holder).
std::vector<Finding> CheckMachine(
    const std::vector<gcode::CanonStatement>& statements, const Config& config);

}  // namespace ttp::verify
