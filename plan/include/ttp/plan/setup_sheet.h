// The machine setup sheet of a test run: everything the operator sets up
// before the programs run, taken from the config (machine profile, part,
// process), as one printable, self-contained HTML page and as JSON with
// the same numbers.
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"

namespace ttp::plan {

struct SetupTool {
  std::string role;  // "roughing", "engraver", "notch", "finishing", "probe"
  std::string name;
  int t = 0;  // T word (pocket)
  int h = 0;  // G43 H register (the programs use H = T)
  double diameter_mm = 0;
  int flutes = 0;
  std::string material;
  double gauge_length_mm = 0;  // gauge line to the tip (to the ball centre
                               // for the probe)
  double stick_out_mm = 0;     // free length out of the holder
  double flute_length_mm = 0;
  double holder_diameter_mm = 0;
  double tip_angle_deg = 0;
  double spindle_rpm = 0;  // 0 for the probe
  double feed_mm_min = 0;
};

struct SetupClamp {
  double phi_deg = 0;  // W, at C = 0
  double r_inner_mm = 0, r_outer_mm = 0, width_mm = 0;
  double top_z_m_mm = 0;  // machine Z of its top
};

// A dial-gauge reading position: the table angle that brings the feature
// under the gauge and where the gauge touches, in machine coordinates.
struct SetupDialPosition {
  FeatureId feature;    // a facet or a strip
  FeatureId zero_on;    // the reference feature the gauge is zeroed on
  double c_deg = 0;     // commanded C (absolute, [0, 360))
  std::array<double, 3> contact_m_mm = {0, 0, 0};
  std::string direction;  // "-X" (radial, towards the axis) or "-Z"
};

struct SetupSheet {
  std::string machine_name;
  // G54: W's origin at C = 0 in machine coordinates.
  std::array<double, 3> g54_m_mm = {0, 0, 0};
  double table_top_z_m_mm = 0;
  double blank_top_z_m_mm = 0;  // before facing (G54 Z + face depth)
  double adapter_diameter_mm = 0, adapter_height_mm = 0;
  double bolt_circle_diameter_mm = 0, bolt_hole_diameter_mm = 0;
  std::vector<double> bolt_phi_deg;
  std::vector<SetupClamp> clamps;
  std::vector<SetupTool> tools;  // program order, the probe last
  // R-test sphere centre at C = 0.
  std::array<double, 3> sphere_m_mm = {0, 0, 0};
  std::array<double, 3> sphere_w_mm = {0, 0, 0};
  double sphere_radius_mm = 0, sphere_stem_diameter_mm = 0;
  double sphere_phi_deg = 0, sphere_distance_mm = 0;
  std::array<double, 3> tool_change_m_mm = {0, 0, 0};
  std::array<double, 3> waiting_w_mm = {0, 0, 0};
  int c_sense = 1;
  std::vector<SetupDialPosition> dial;
};

// Throws InputError (via ValidateConfig) for a config that cannot be set up.
SetupSheet BuildSetupSheet(const Config& config);
// One self-contained printable page (no scripts, no external files). Every
// number sits in a cell with a data-key attribute naming it
// ("g54-z", "tool-4-h", "sphere-m-x", "dial-X1-3-c", ...).
std::string SetupSheetHtml(const SetupSheet& sheet);
nlohmann::json SetupSheetToJson(const SetupSheet& sheet);

}  // namespace ttp::plan
