#include "ttp/plan/setup_sheet.h"

#include <fmt/format.h>

#include <cmath>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"

namespace ttp::plan {
namespace {

std::array<double, 3> Arr(const Eigen::Vector3d& v) {
  return {v.x() + 0.0, v.y() + 0.0, v.z() + 0.0};
}

// Text for HTML (names come from the config).
std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '"')
      out += "&quot;";
    else
      out += c;
  }
  return out;
}

// A cell holding a number, named for readers of the page.
std::string Cell(const std::string& key, double v, int decimals = 3) {
  return fmt::format("<td class=num data-key=\"{}\">{:.{}f}</td>", Escape(key),
                     v + 0.0, decimals);
}
std::string CellInt(const std::string& key, int v) {
  return fmt::format("<td class=num data-key=\"{}\">{}</td>", Escape(key), v);
}

}  // namespace

SetupSheet BuildSetupSheet(const Config& config) {
  ValidateConfig(config, "config");
  const PartSpec& part = config.part;
  const MachineProfile& m = config.machine;
  SetupSheet s;
  s.machine_name = m.name;
  s.g54_m_mm = Arr(ProgramToMachine(config, Eigen::Vector3d::Zero()));
  s.table_top_z_m_mm = m.table_top_z_mm;
  s.blank_top_z_m_mm = s.g54_m_mm[2] + part.face_depth_mm;
  s.adapter_diameter_mm = part.adapter_diameter_mm;
  s.adapter_height_mm = part.adapter_height_mm;
  s.bolt_circle_diameter_mm = part.bolt_circle_diameter_mm;
  s.bolt_hole_diameter_mm = part.bolt_hole_diameter_mm;
  s.bolt_phi_deg = part.bolt_phi_deg;
  for (const ClampSpec& c : m.clamps)
    s.clamps.push_back({c.phi_deg, c.r_inner_mm, c.r_outer_mm, c.width_mm,
                        m.table_top_z_mm + c.height_mm});
  const ProcessSpec& p = config.process;
  const std::pair<const char*, const ToolSpec*> tools[] = {
      {"roughing", &p.roughing},
      {"engraver", &p.engraver},
      {"notch", &p.notch},
      {"finishing", &p.finishing},
      {"probe", &p.probe}};
  for (const auto& [role, t] : tools) {
    SetupTool x;
    x.role = role;
    x.name = t->name;
    x.t = x.h = t->number;
    x.diameter_mm = t->diameter_mm;
    x.flutes = t->flutes;
    x.material = t->material;
    x.gauge_length_mm = t->length_mm;
    x.stick_out_mm = t->stick_out_mm;
    x.flute_length_mm = t->flute_length_mm;
    x.holder_diameter_mm = t->holder_diameter_mm;
    x.tip_angle_deg = t->tip_angle_deg;
    const bool probe = t == &p.probe;
    x.spindle_rpm = probe ? 0 : t->spindle_rpm;
    x.feed_mm_min = t->feed_mm_min;
    s.tools.push_back(x);
  }
  // The sphere turns with the table: its place at C = 0.
  const double phi = m.sphere_phi_deg * kDeg;
  const Eigen::Vector3d sphere_w(
      m.sphere_distance_mm * std::cos(phi),
      m.sphere_distance_mm * std::sin(phi),
      m.table_top_z_mm + m.sphere_height_mm - WorkpieceOriginHeightMm(config));
  s.sphere_w_mm = Arr(sphere_w);
  s.sphere_m_mm = Arr(WorkpieceToMachine(config, sphere_w, 0.0));
  s.sphere_radius_mm = m.sphere_radius_mm;
  s.sphere_stem_diameter_mm = m.sphere_stem_diameter_mm;
  s.sphere_phi_deg = m.sphere_phi_deg;
  s.sphere_distance_mm = m.sphere_distance_mm;
  s.tool_change_m_mm = m.tool_change_position_m_mm;
  s.waiting_w_mm = m.waiting_position_w_mm;
  s.c_sense = m.c_sense;

  // Dial gauge: facets with their normal turned to machine +X (the gauge
  // on the +X side, plunger along -X, at mid height of the facet); strips
  // at C = 0 with the gauge vertical at x = +20 mm (W).
  for (const NominalFeature& f : BuildNominalFeatures(part, Stage::kFinished)) {
    SetupDialPosition d;
    d.feature = f.Key();
    if (f.kind == FeatureKind::kFacet) {
      d.zero_on = FeatureId::Facet(*f.segment, part.reference_index);
      const double phi_f = std::atan2(f.normal.y(), f.normal.x());
      double c = TableAngleFor(phi_f, 0.0, m.c_sense);
      d.c_deg = std::fmod(std::fmod(c / kDeg, 360.0) + 360.0, 360.0);
      if (d.c_deg >= 359.9995) d.c_deg = 0;
      const Eigen::Vector3d on =
          f.size_mm * f.normal +
          Eigen::Vector3d(0, 0, (f.z_min_mm + f.z_max_mm) / 2);
      d.contact_m_mm = Arr(WorkpieceToMachine(config, on, d.c_deg * kDeg));
      d.direction = "-X";
    } else if (f.kind == FeatureKind::kStrip) {
      d.zero_on = FeatureId::Strip(part.reference_index);
      d.c_deg = 0;
      const Eigen::Vector3d on(20.0, f.point.y(), f.point.z());
      d.contact_m_mm = Arr(WorkpieceToMachine(config, on, 0.0));
      d.direction = "-Z";
    } else {
      continue;
    }
    s.dial.push_back(d);
  }
  return s;
}

nlohmann::json SetupSheetToJson(const SetupSheet& s) {
  nlohmann::json j;
  j["machine"] = s.machine_name;
  j["g54_m_mm"] = s.g54_m_mm;
  j["table_top_z_m_mm"] = s.table_top_z_m_mm;
  j["blank_top_z_m_mm"] = s.blank_top_z_m_mm;
  j["adapter"] = {{"diameter_mm", s.adapter_diameter_mm},
                  {"height_mm", s.adapter_height_mm},
                  {"bolt_circle_diameter_mm", s.bolt_circle_diameter_mm},
                  {"bolt_hole_diameter_mm", s.bolt_hole_diameter_mm},
                  {"bolt_phi_deg", s.bolt_phi_deg}};
  nlohmann::json clamps = nlohmann::json::array();
  for (const SetupClamp& c : s.clamps)
    clamps.push_back({{"phi_deg", c.phi_deg},
                      {"r_inner_mm", c.r_inner_mm},
                      {"r_outer_mm", c.r_outer_mm},
                      {"width_mm", c.width_mm},
                      {"top_z_m_mm", c.top_z_m_mm}});
  j["clamps"] = clamps;
  nlohmann::json tools = nlohmann::json::array();
  for (const SetupTool& t : s.tools)
    tools.push_back({{"role", t.role},
                     {"name", t.name},
                     {"t", t.t},
                     {"h", t.h},
                     {"diameter_mm", t.diameter_mm},
                     {"flutes", t.flutes},
                     {"material", t.material},
                     {"gauge_length_mm", t.gauge_length_mm},
                     {"stick_out_mm", t.stick_out_mm},
                     {"flute_length_mm", t.flute_length_mm},
                     {"holder_diameter_mm", t.holder_diameter_mm},
                     {"tip_angle_deg", t.tip_angle_deg},
                     {"spindle_rpm", t.spindle_rpm},
                     {"feed_mm_min", t.feed_mm_min}});
  j["tools"] = tools;
  j["sphere"] = {{"centre_m_mm", s.sphere_m_mm},
                 {"centre_w_mm", s.sphere_w_mm},
                 {"phi_deg", s.sphere_phi_deg},
                 {"distance_mm", s.sphere_distance_mm},
                 {"radius_mm", s.sphere_radius_mm},
                 {"stem_diameter_mm", s.sphere_stem_diameter_mm}};
  j["tool_change_m_mm"] = s.tool_change_m_mm;
  j["waiting_w_mm"] = s.waiting_w_mm;
  j["c_sense"] = s.c_sense;
  nlohmann::json dial = nlohmann::json::array();
  for (const SetupDialPosition& d : s.dial)
    dial.push_back({{"feature", d.feature.ToString()},
                    {"zero_on", d.zero_on.ToString()},
                    {"c_deg", d.c_deg},
                    {"contact_m_mm", d.contact_m_mm},
                    {"direction", d.direction}});
  j["dial"] = dial;
  return j;
}

std::string SetupSheetHtml(const SetupSheet& s) {
  std::string tools;
  for (const SetupTool& t : s.tools) {
    const std::string k = "tool-" + std::to_string(t.t) + "-";
    tools += fmt::format(
        "<tr data-tool=\"{}\">{}{}<td>{}</td>{}<td>{}</td>{}{}{}{}{}{}</tr>\n",
        t.t, CellInt(k + "t", t.t), CellInt(k + "h", t.h), Escape(t.name),
        Cell(k + "diameter", t.diameter_mm), Escape(t.material),
        Cell(k + "gauge-length", t.gauge_length_mm),
        Cell(k + "stick-out", t.stick_out_mm),
        Cell(k + "holder-diameter", t.holder_diameter_mm),
        Cell(k + "flute-length", t.flute_length_mm),
        Cell(k + "rpm", t.spindle_rpm, 0), Cell(k + "feed", t.feed_mm_min, 0));
  }
  std::string clamps;
  for (size_t i = 0; i < s.clamps.size(); ++i) {
    const SetupClamp& c = s.clamps[i];
    const std::string k = "clamp-" + std::to_string(i + 1) + "-";
    clamps += fmt::format(
        "<tr><td>{}</td>{}{}{}{}{}</tr>\n", i + 1,
        Cell(k + "phi", c.phi_deg, 1), Cell(k + "r-inner", c.r_inner_mm, 1),
        Cell(k + "r-outer", c.r_outer_mm, 1), Cell(k + "width", c.width_mm, 1),
        Cell(k + "top-z", c.top_z_m_mm, 1));
  }
  std::string bolts;
  for (double b : s.bolt_phi_deg)
    bolts += fmt::format("{}{:.0f}&deg;", bolts.empty() ? "" : ", ", b);
  std::string dial;
  for (const SetupDialPosition& d : s.dial) {
    const std::string name = d.feature.ToString();
    const std::string k = "dial-" + name + "-";
    dial += fmt::format(
        "<tr><td>{}</td><td>{}</td>{}<td><code>G90 G0 C{:.3f}</code></td>{}{}"
        "{}<td>{}</td></tr>\n",
        name, d.zero_on.ToString(), Cell(k + "c", d.c_deg), d.c_deg,
        Cell(k + "x", d.contact_m_mm[0]), Cell(k + "y", d.contact_m_mm[1]),
        Cell(k + "z", d.contact_m_mm[2]), d.direction);
  }
  const auto row3 = [](const std::string& key, const std::array<double, 3>& v) {
    return Cell(key + "-x", v[0]) + Cell(key + "-y", v[1]) +
           Cell(key + "-z", v[2]);
  };
  return fmt::format(
      R"(<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Thermal test piece: machine setup sheet</title>
<style>
body {{ font-family: sans-serif; margin: 2em; }}
table {{ border-collapse: collapse; margin-bottom: 1em; }}
td, th {{ border: 1px solid #444; padding: 3px 8px; }}
td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}
td.tick {{ width: 3em; }}
@media print {{ body {{ margin: 0.5cm; }} h2 {{ page-break-after: avoid; }}
  table {{ page-break-inside: avoid; }} }}
</style></head><body>
<h1>Thermal test piece &mdash; machine setup sheet</h1>
<p>Machine: <span data-key="machine">{}</span>. Machine coordinates M:
origin where the C axis meets the table top at X = Y = 0; C positive turns
the table {} seen from +Z. All lengths in mm.</p>

<h2>1. Adapter and piece</h2>
<table><tr><th>adapter diameter</th><th>adapter height</th>
<th>bolt circle</th><th>bolt holes</th></tr>
<tr>{}{}{}{}</tr></table>
<p>Adapter centred on the C axis on the table; the blank sits on it, bolted
from below through the adapter into its blind tapped holes (M{:.0f}) at
{} on the bolt circle. The piece's +X (segments X1 and X2 along the big
notch) is along machine +X at C = 0.</p>

<h2>2. Clamps (on the table, holding the adapter)</h2>
<table><tr><th>#</th><th>direction &phi; (deg, C = 0)</th><th>from r</th>
<th>to r</th><th>width</th><th>top Z (M)</th></tr>
{}</table>

<h2>3. Work offset G54</h2>
<table><tr><th></th><th>X</th><th>Y</th><th>Z</th></tr>
<tr><td>G54 (M)</td>{}</tr></table>
<p>X and Y: the C axis. Set them by clocking the adapter's outside diameter
with a dial gauge in the spindle while turning C by hand; the runout is
below 5 um when the spindle is on the axis. Z: the top face after facing,
table top Z <span data-key="table-top-z">{:.3f}</span> + adapter + piece;
the blank's top before facing is at Z <span data-key="blank-top-z">{:.3f}</span>
(touch it with the probe, T{}, and set G54 Z that much lower by the facing
depth).</p>

<h2>4. Tools</h2>
<table><tr><th>T</th><th>H</th><th>tool</th><th>diameter</th><th>material</th>
<th>gauge length</th><th>stick-out</th><th>holder diameter</th>
<th>flute length</th><th>rpm</th><th>feed mm/min</th></tr>
{}</table>
<p>Each program calls <code>T&lt;n&gt; M6</code> then <code>G43 H&lt;n&gt;</code>:
measure the gauge length of every tool into its H register; stick-out is the
free length out of the holder that the collision check assumes (set it no
longer). Tool changes at the tool-change position M = ({:.1f}, {:.1f},
{:.1f}).</p>

<h2>5. R-test sphere</h2>
<table><tr><th></th><th>X</th><th>Y</th><th>Z</th></tr>
<tr><td>centre, M at C = 0</td>{}</tr>
<tr><td>centre, W (G54) at C = 0</td>{}</tr></table>
<p>On the table at &phi; = <span data-key="sphere-phi">{:.1f}</span> deg,
<span data-key="sphere-distance">{:.3f}</span> mm from the C axis; ball
radius <span data-key="sphere-radius">{:.3f}</span>, stem diameter
<span data-key="sphere-stem">{:.3f}</span>. The tool waits between cycles at
W = ({:.1f}, {:.1f}, {:.1f}), between the piece and the ring the sphere
sweeps while C turns.</p>

<h2>6. Dial-gauge positions</h2>
<p>Facets: gauge on the +X side, plunger horizontal along &minus;X through
the contact point, zero on the reference facet of the segment, then turn
the table with the C command shown and read (positive towards the axis).
Strips: C = 0, gauge vertical, zero on the reference strip (positive
deeper).</p>
<table><tr><th>feature</th><th>zero on</th><th>C (deg)</th><th>command</th>
<th>X (M)</th><th>Y (M)</th><th>Z (M)</th><th>plunger</th></tr>
{}</table>
</body></html>
)",
      Escape(s.machine_name), s.c_sense > 0 ? "clockwise" : "counter-clockwise",
      Cell("adapter-diameter", s.adapter_diameter_mm),
      Cell("adapter-height", s.adapter_height_mm),
      Cell("bolt-circle", s.bolt_circle_diameter_mm),
      Cell("bolt-hole", s.bolt_hole_diameter_mm), s.bolt_hole_diameter_mm,
      bolts, clamps, row3("g54", s.g54_m_mm), s.table_top_z_m_mm,
      s.blank_top_z_m_mm, s.tools.back().t, tools, s.tool_change_m_mm[0],
      s.tool_change_m_mm[1], s.tool_change_m_mm[2],
      row3("sphere-m", s.sphere_m_mm), row3("sphere-w", s.sphere_w_mm),
      s.sphere_phi_deg, s.sphere_distance_mm, s.sphere_radius_mm,
      s.sphere_stem_diameter_mm, s.waiting_w_mm[0], s.waiting_w_mm[1],
      s.waiting_w_mm[2], dial);
}

}  // namespace ttp::plan
