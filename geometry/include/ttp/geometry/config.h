// The part, machine and process descriptions. Every field has the default of
// shared/spec/test-piece.md; a user overrides any subset from a TOML or JSON
// file. Units: mm and degrees in these user-facing structs (they mirror the
// drawing); code converts angles to radians where it computes.
#pragma once

#include <array>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace ttp {

struct RefCylinder {
  double diameter_mm;
  double z_bottom_mm;
  double z_top_mm;
};

struct PartSpec {
  // Blank (before pre-machining), W frame after facing: top at z = 0.
  double blank_diameter_mm = 203.0;
  double blank_height_mm = 25.0;
  double face_depth_mm = 1.0;  // taken off the top in step 1
  std::string material = "EN AW-6082";
  double alpha_per_k = 23.4e-6;
  double bolt_circle_diameter_mm = 140.0;
  std::vector<double> bolt_phi_deg = {60.0, 180.0, 300.0};
  double bolt_hole_diameter_mm = 8.0;  // M8
  double bolt_hole_depth_mm = 8.0;

  // Step 1: reference cylinders and rim.
  std::vector<RefCylinder> ref_cylinders = {
      {199.0, -16.0, -12.0}, {200.0, -20.0, -16.0}, {201.0, -24.0, -20.0}};
  double rim_diameter_mm = 202.0;  // above z = -12, removed later
  // Datum band of the 199 cylinder used for the origin (section 5).
  double datum_circle_z_min_mm = -16.0;
  double datum_circle_z_max_mm = -14.0;

  // Step 3 and 4: notches.
  double small_notch_half_width_mm = 5.0;  // |x| <= 5
  double small_notch_floor_z_mm = -14.0;
  double big_notch_half_width_mm = 53.0;  // |y| <= 53
  double big_notch_floor_z_mm = -12.0;

  // Segments and facets.
  std::array<double, 4> segment_centre_deg = {60.0, 120.0, 240.0,
                                              300.0};  // X1, Y1, X2, Y2
  double segment_span_deg = 54.0;
  int facets_per_segment = 9;
  double facet_step_deg = 6.0;
  int reference_index = 5;  // facet j and strip k of cycle 0
  double facet_pre_distance_mm = 97.4;
  double facet_final_distance_mm = 97.3;
  double facet_bottom_z_mm = -12.1;

  // Z strips on the big-notch floor.
  double strip_pitch_mm = 11.75;
  double strip_width_mm = 12.0;
  double strip_floor_z_mm = -12.1;

  // Step 2: engraved mark.
  double mark_phi_deg = 60.0;
  double mark_r_start_mm = 70.0;
  double mark_r_end_mm = 90.0;
  double mark_depth_mm = 0.3;
  double mark_width_mm = 0.6;

  // Adapter between table and piece (same alloy as the piece).
  double adapter_diameter_mm = 180.0;
  double adapter_height_mm = 30.0;

  double height_mm() const { return blank_height_mm - face_depth_mm; }
  int cycles() const { return facets_per_segment - 1; }
};

struct ToolSpec {
  std::string name;
  int number = 1;  // T word and tool-table pocket
  double diameter_mm = 16.0;
  int flutes = 4;
  std::string material = "HSS";
  double length_mm = 60.0;        // gauge length, for the tool table
  double flute_length_mm = 32.0;  // cutting length
  double tip_angle_deg = 0.0;     // 0 = flat end; 90 for the engraver
  double spindle_rpm = 8000.0;
  double feed_mm_min = 600.0;
  // Holder geometry for the collision model: the cutter and its shank
  // (diameter_mm) reach stick_out_mm from the tip; above that the holder
  // (holder_diameter_mm) reaches up to the gauge line (length_mm).
  double stick_out_mm = 40.0;
  double holder_diameter_mm = 40.0;
};

// A clamp on the table (it turns with C): a box in the table frame at C = 0,
// radially from r_inner_mm to r_outer_mm along the direction phi_deg, width_mm
// across it, from the table top up to height_mm.
struct ClampSpec {
  double phi_deg = 0;
  double r_inner_mm = 0;
  double r_outer_mm = 0;
  double width_mm = 0;
  double height_mm = 0;
};

struct MachineProfile {
  std::string name = "generic 5-axis machining centre, C-axis table";
  // Travel of the tool tip in M (mm): origin where C meets the table.
  std::array<double, 2> travel_x_mm = {-365.0, 365.0};
  std::array<double, 2> travel_y_mm = {-255.0, 255.0};
  std::array<double, 2> travel_z_mm = {-10.0, 500.0};
  double rapid_mm_min = 30000.0;
  double max_feed_mm_min = 20000.0;
  double c_index_deg_s = 360.0;  // rapid C indexing speed
  double c_max_rpm = 1200.0;     // turning mode maximum
  double c_spinup_s = 5.0;       // ramp to/from c_max_rpm
  double max_spindle_rpm = 18000.0;
  // +1: a positive C command turns the table clockwise seen from +Z (ISO
  // 841, C'), so a W direction at phi points along M angle phi - c.
  int c_sense = 1;
  // Builder M-codes (FANUC dialect); LinuxCNC uses spindle 1 for turning.
  int m_c_turning_on = 600;
  int m_c_turning_off = 601;
  int m_table_clamp = 10;
  int m_table_unclamp = 11;
  int program_number = 1000;  // O-number of the test cycle, pre = +1
  double table_top_z_mm = 0.0;
  double sphere_distance_mm = 160.0;  // R-test sphere, d/2
  double sphere_height_mm = 80.0;     // centre above the table top
  // The R-test's expanded uncertainty (k = 2) per error, as the lab
  // measured it (thesis 5.3: the cycle repeated at one table angle):
  // EX0C, EY0C, EZ0T, ER0T in um and EA0C, EB0C, EC0C in urad (um/m).
  // Thesis table 5.4 by default. The machine-error estimator takes half of
  // it as the R-tests' noise.
  std::array<double, 4> rtest_u95_um = {0.4, 0.5, 0.4, 0.6};
  std::array<double, 3> rtest_u95_urad = {2.3, 2.5, 2.6};
  // R-test sphere on the table (turns with C): its direction at C = 0 in
  // the table frame, ball radius, and the stem from the table up to the
  // ball.
  double sphere_phi_deg = 0.0;
  double sphere_radius_mm = 12.7;
  double sphere_stem_diameter_mm = 12.0;
  // Round table (turns with C), top at table_top_z_mm.
  double table_diameter_mm = 500.0;
  // Clamps holding the adapter on the table.
  std::vector<ClampSpec> clamps = {{60.0, 85.0, 125.0, 24.0, 20.0},
                                   {180.0, 85.0, 125.0, 24.0, 20.0},
                                   {300.0, 85.0, 125.0, 24.0, 20.0}};
  // Waiting position of the tool tip in W (mm) between cycles: inside the
  // circle the R-test sphere sweeps while C turns, outside the piece.
  std::array<double, 3> waiting_position_w_mm = {120.0, 0.0, 50.0};
  // Tool-change position: machine coordinates (M, mm) of the gauge line,
  // reached with G53 after G49; away from the piece and the sphere.
  std::array<double, 3> tool_change_position_m_mm = {300.0, 0.0, 450.0};
  // Rapid (G0) semantics: "straight" (linear interpolation, FANUC parameter
  // 1401 bit 1 = 1, LinuxCNC) or "per_axis" (each axis at its own rate, the
  // FANUC default): a diagonal G0 is then a dog-leg.
  std::string rapid_semantics = "per_axis";
  std::array<double, 3> rapid_axis_mm_min = {30000.0, 30000.0, 24000.0};
  // Feed of positioning moves near the piece (G1: straight on every
  // control), mm/min.
  double positioning_feed_mm_min = 6000.0;
  // C axis with roll-over: absolute C commands take the short way (FANUC)
  // or the sign's direction (LinuxCNC wrapped rotary); programs index C
  // incrementally.
  bool c_rollover = true;
  // B axis (tilting): programs hold it at 0 and clamped.
  int m_b_clamp = 12;
  int m_b_unclamp = 13;
  // LinuxCNC digital outputs (M64/M65 P<n>) of the C and B clamps.
  int linuxcnc_c_clamp_output = 0;
  int linuxcnc_b_clamp_output = 1;
  // FANUC block that stops buffering so that a DPRNT after it runs when the
  // motion before it has ended ("G53" or a parameter-3411 M-code, "M100").
  std::string fanuc_sync_block = "G53";
  // Touch probe on/off M-codes.
  int m_probe_on = 80;
  int m_probe_off = 81;
  // LinuxCNC: digital output (M64/M65 P<n>) that switches the probe on.
  int linuxcnc_probe_output = 2;
  // System variables of the skip / probe position of X, Y, Z and C: on an
  // XYZBC machine FANUC numbers the axes X Y Z B C (#5061.. #5065), LinuxCNC
  // uses fixed letters (#5061 X .. #5066 C; #5070 = 1 when the probe
  // tripped).
  std::array<int, 4> fanuc_skip_variables = {5061, 5062, 5063, 5065};
  std::array<int, 4> linuxcnc_probe_variables = {5061, 5062, 5063, 5066};
};

struct ProcessSpec {
  ToolSpec roughing = {"16 mm 4-flute HSS end mill",
                       1,
                       16.0,
                       4,
                       "HSS",
                       60.0,
                       32.0,
                       0.0,
                       3000.0,
                       960.0,
                       40.0,
                       40.0};
  ToolSpec engraver = {"90 deg engraving cutter",
                       2,
                       6.0,
                       1,
                       "carbide",
                       50.0,
                       5.0,
                       90.0,
                       12000.0,
                       300.0,
                       20.0,
                       32.0};
  ToolSpec notch = {"8 mm carbide end mill",
                    3,
                    8.0,
                    3,
                    "carbide",
                    55.0,
                    20.0,
                    0.0,
                    8000.0,
                    960.0,
                    25.0,
                    32.0};
  ToolSpec finishing = {"12 mm 3-flute carbide finishing end mill",
                        4,
                        12.0,
                        3,
                        "carbide",
                        60.0,
                        26.0,
                        0.0,
                        8000.0,
                        1440.0,
                        35.0,
                        40.0};
  // Touch-trigger probe for on-machine measurement (ttp plan probe):
  // diameter = stylus ball diameter, length = gauge length to the ball
  // centre; flutes, speeds and feeds are not used.
  ToolSpec probe = {"touch-trigger probe, 3 mm ruby stylus",
                    20,
                    3.0,
                    1,
                    "ruby",
                    100.0,
                    30.0,
                    0.0,
                    1.0,
                    100.0,
                    50.0,
                    25.0};
  double roughing_step_down_mm = 3.0;  // big notch roughing
  double finish_allowance_mm = 0.2;    // big notch wall/floor finish pass
  double turning_c_rpm = 20.0;         // C speed while turning cylinders
  double nc_hold_after_pre_min = 30.0;
  double cycle_period_s = 3600.0;
  int warmup_cycles = 4;  // C spins between cycles 0..4, holds after
  // R-test of the TALC run (thesis 5.2, 7.4): every rtest_interval_s after
  // the reference cycle's start (0 = none) C stops and the probe measures
  // the sphere at five table angles, rtest_measure_s at each.
  double rtest_interval_s = 0.0;
  double rtest_measure_s = 10.0;
  bool coolant_in_test = false;
  bool coolant_in_pre = true;
  double safe_z_w_mm = 50.0;  // retract height above the top face
  double clearance_mm = 3.0;  // approach clearance outside material

  // The tools that cut, in program order; with the probe, every tool.
  std::array<const ToolSpec*, 4> CuttingTools() const {
    return {&roughing, &engraver, &notch, &finishing};
  }
  std::array<const ToolSpec*, 5> Tools() const {
    return {&roughing, &engraver, &notch, &finishing, &probe};
  }
  // By T number; nullptr when none has it.
  const ToolSpec* CuttingToolByNumber(int number) const {
    for (const ToolSpec* t : CuttingTools())
      if (t->number == number) return t;
    return nullptr;
  }
  const ToolSpec* ToolByNumber(int number) const {
    for (const ToolSpec* t : Tools())
      if (t->number == number) return t;
    return nullptr;
  }
};

struct Config {
  PartSpec part;
  MachineProfile machine;
  ProcessSpec process;
};

// Loads a config file (.toml or .json; the extension decides, else content
// sniffing). Keys are the field names above, in tables [part], [machine],
// [process] (tools as [process.finishing] etc.); any subset. Unknown keys,
// wrong types and invalid values throw InputError naming file and field.
Config LoadConfig(const std::filesystem::path& path);

// Same from an in-memory JSON document (source names it in errors).
Config ConfigFromJson(const nlohmann::json& doc, const std::string& source);

nlohmann::json ConfigToJson(const Config& config);

// Checks every field and the combination (part fits the blank, tools fit
// their notches, features inside the machine's travel...). Throws
// InputError(source, 0, "part.xxx", why) on the first problem.
void ValidateConfig(const Config& config, const std::string& source);

}  // namespace ttp
