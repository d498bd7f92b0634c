#include "ttp/geometry/config.h"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <tuple>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/geometry/rigid_table.h"

namespace ttp {
namespace {

using nlohmann::json;

// One list of fields per struct serves reading and writing.
template <class V>
void VisitRefCylinder(V& v, RefCylinder& c) {
  v("diameter_mm", c.diameter_mm);
  v("z_bottom_mm", c.z_bottom_mm);
  v("z_top_mm", c.z_top_mm);
}

template <class V>
void VisitClamp(V& v, ClampSpec& c) {
  v("phi_deg", c.phi_deg);
  v("r_inner_mm", c.r_inner_mm);
  v("r_outer_mm", c.r_outer_mm);
  v("width_mm", c.width_mm);
  v("height_mm", c.height_mm);
}

template <class V>
void VisitTool(V& v, ToolSpec& t) {
  v("name", t.name);
  v("number", t.number);
  v("diameter_mm", t.diameter_mm);
  v("flutes", t.flutes);
  v("material", t.material);
  v("length_mm", t.length_mm);
  v("flute_length_mm", t.flute_length_mm);
  v("tip_angle_deg", t.tip_angle_deg);
  v("spindle_rpm", t.spindle_rpm);
  v("feed_mm_min", t.feed_mm_min);
  v("stick_out_mm", t.stick_out_mm);
  v("holder_diameter_mm", t.holder_diameter_mm);
}

template <class V>
void VisitPart(V& v, PartSpec& p) {
  v("blank_diameter_mm", p.blank_diameter_mm);
  v("blank_height_mm", p.blank_height_mm);
  v("face_depth_mm", p.face_depth_mm);
  v("material", p.material);
  v("alpha_per_k", p.alpha_per_k);
  v("bolt_circle_diameter_mm", p.bolt_circle_diameter_mm);
  v("bolt_phi_deg", p.bolt_phi_deg);
  v("bolt_hole_diameter_mm", p.bolt_hole_diameter_mm);
  v("bolt_hole_depth_mm", p.bolt_hole_depth_mm);
  v("ref_cylinders", p.ref_cylinders);
  v("rim_diameter_mm", p.rim_diameter_mm);
  v("datum_circle_z_min_mm", p.datum_circle_z_min_mm);
  v("datum_circle_z_max_mm", p.datum_circle_z_max_mm);
  v("small_notch_half_width_mm", p.small_notch_half_width_mm);
  v("small_notch_floor_z_mm", p.small_notch_floor_z_mm);
  v("big_notch_half_width_mm", p.big_notch_half_width_mm);
  v("big_notch_floor_z_mm", p.big_notch_floor_z_mm);
  v("segment_centre_deg", p.segment_centre_deg);
  v("segment_span_deg", p.segment_span_deg);
  v("facets_per_segment", p.facets_per_segment);
  v("facet_step_deg", p.facet_step_deg);
  v("reference_index", p.reference_index);
  v("facet_pre_distance_mm", p.facet_pre_distance_mm);
  v("facet_final_distance_mm", p.facet_final_distance_mm);
  v("facet_bottom_z_mm", p.facet_bottom_z_mm);
  v("strip_pitch_mm", p.strip_pitch_mm);
  v("strip_width_mm", p.strip_width_mm);
  v("strip_floor_z_mm", p.strip_floor_z_mm);
  v("mark_phi_deg", p.mark_phi_deg);
  v("mark_r_start_mm", p.mark_r_start_mm);
  v("mark_r_end_mm", p.mark_r_end_mm);
  v("mark_depth_mm", p.mark_depth_mm);
  v("mark_width_mm", p.mark_width_mm);
  v("adapter_diameter_mm", p.adapter_diameter_mm);
  v("adapter_height_mm", p.adapter_height_mm);
}

template <class V>
void VisitMachine(V& v, MachineProfile& m) {
  v("name", m.name);
  v("travel_x_mm", m.travel_x_mm);
  v("travel_y_mm", m.travel_y_mm);
  v("travel_z_mm", m.travel_z_mm);
  v("rapid_mm_min", m.rapid_mm_min);
  v("max_feed_mm_min", m.max_feed_mm_min);
  v("c_index_deg_s", m.c_index_deg_s);
  v("c_max_rpm", m.c_max_rpm);
  v("c_spinup_s", m.c_spinup_s);
  v("max_spindle_rpm", m.max_spindle_rpm);
  v("c_sense", m.c_sense);
  v("m_c_turning_on", m.m_c_turning_on);
  v("m_c_turning_off", m.m_c_turning_off);
  v("m_table_clamp", m.m_table_clamp);
  v("m_table_unclamp", m.m_table_unclamp);
  v("program_number", m.program_number);
  v("table_top_z_mm", m.table_top_z_mm);
  v("sphere_distance_mm", m.sphere_distance_mm);
  v("sphere_height_mm", m.sphere_height_mm);
  v("rtest_u95_um", m.rtest_u95_um);
  v("rtest_u95_urad", m.rtest_u95_urad);
  v("sphere_phi_deg", m.sphere_phi_deg);
  v("sphere_radius_mm", m.sphere_radius_mm);
  v("sphere_stem_diameter_mm", m.sphere_stem_diameter_mm);
  v("table_diameter_mm", m.table_diameter_mm);
  v("clamps", m.clamps);
  v("waiting_position_w_mm", m.waiting_position_w_mm);
  v("tool_change_position_m_mm", m.tool_change_position_m_mm);
  v("rapid_semantics", m.rapid_semantics);
  v("rapid_axis_mm_min", m.rapid_axis_mm_min);
  v("positioning_feed_mm_min", m.positioning_feed_mm_min);
  v("c_rollover", m.c_rollover);
  v("m_b_clamp", m.m_b_clamp);
  v("m_b_unclamp", m.m_b_unclamp);
  v("linuxcnc_c_clamp_output", m.linuxcnc_c_clamp_output);
  v("linuxcnc_b_clamp_output", m.linuxcnc_b_clamp_output);
  v("fanuc_sync_block", m.fanuc_sync_block);
  v("m_probe_on", m.m_probe_on);
  v("m_probe_off", m.m_probe_off);
  v("linuxcnc_probe_output", m.linuxcnc_probe_output);
  v("fanuc_skip_variables", m.fanuc_skip_variables);
  v("linuxcnc_probe_variables", m.linuxcnc_probe_variables);
}

template <class V>
void VisitProcess(V& v, ProcessSpec& p) {
  v("roughing", p.roughing);
  v("engraver", p.engraver);
  v("notch", p.notch);
  v("finishing", p.finishing);
  v("probe", p.probe);
  v("roughing_step_down_mm", p.roughing_step_down_mm);
  v("finish_allowance_mm", p.finish_allowance_mm);
  v("turning_c_rpm", p.turning_c_rpm);
  v("nc_hold_after_pre_min", p.nc_hold_after_pre_min);
  v("cycle_period_s", p.cycle_period_s);
  v("warmup_cycles", p.warmup_cycles);
  v("rtest_interval_s", p.rtest_interval_s);
  v("rtest_measure_s", p.rtest_measure_s);
  v("coolant_in_test", p.coolant_in_test);
  v("coolant_in_pre", p.coolant_in_pre);
  v("safe_z_w_mm", p.safe_z_w_mm);
  v("clearance_mm", p.clearance_mm);
}

// ---- writing --------------------------------------------------------------

json ToJsonValue(const std::string& s) { return s; }
json ToJsonValue(double d) { return d; }
json ToJsonValue(int i) { return i; }
json ToJsonValue(bool b) { return b; }
json ToJsonValue(const RefCylinder& c);
json ToJsonValue(const ClampSpec& c);
json ToJsonValue(const ToolSpec& t);
template <class T>
json ToJsonValue(const std::vector<T>& v) {
  json a = json::array();
  for (const auto& e : v) a.push_back(ToJsonValue(e));
  return a;
}
template <class T, size_t N>
json ToJsonValue(const std::array<T, N>& v) {
  json a = json::array();
  for (const auto& e : v) a.push_back(ToJsonValue(e));
  return a;
}

struct Writer {
  json out = json::object();
  template <class T>
  void operator()(const char* key, T& value) {
    out[key] = ToJsonValue(value);
  }
};

json ToJsonValue(const RefCylinder& c) {
  Writer w;
  VisitRefCylinder(w, const_cast<RefCylinder&>(c));
  return w.out;
}
json ToJsonValue(const ClampSpec& c) {
  Writer w;
  VisitClamp(w, const_cast<ClampSpec&>(c));
  return w.out;
}
json ToJsonValue(const ToolSpec& t) {
  Writer w;
  VisitTool(w, const_cast<ToolSpec&>(t));
  return w.out;
}

// The keys a visitor names, in order.
struct KeyList {
  std::vector<std::string> keys;
  template <class T>
  void operator()(const char* key, T&) {
    keys.emplace_back(key);
  }
};

// ---- reading --------------------------------------------------------------

struct Reader;
void ReadValue(const json& j, std::string& out, const Reader& r,
               const std::string& path);
void ReadValue(const json& j, double& out, const Reader& r,
               const std::string& path);
void ReadValue(const json& j, int& out, const Reader& r,
               const std::string& path);
void ReadValue(const json& j, bool& out, const Reader& r,
               const std::string& path);
void ReadValue(const json& j, RefCylinder& out, const Reader& r,
               const std::string& path);
void ReadValue(const json& j, ToolSpec& out, const Reader& r,
               const std::string& path);
void ReadValue(const json& j, ClampSpec& out, const Reader& r,
               const std::string& path);
template <class T>
void ReadValue(const json& j, std::vector<T>& out, const Reader& r,
               const std::string& path);
template <class T, size_t N>
void ReadValue(const json& j, std::array<T, N>& out, const Reader& r,
               const std::string& path);

struct Reader {
  const json* obj;
  std::string prefix;
  std::string source;
  std::set<std::string>* seen;
  template <class T>
  void operator()(const char* key, T& value) const {
    if (!obj->contains(key)) return;
    seen->insert(key);
    ReadValue(obj->at(key), value, *this, prefix + key);
  }
  [[noreturn]] void Fail(const std::string& path,
                         const std::string& why) const {
    throw InputError(source, 0, path, why);
  }
};

void ReadValue(const json& j, std::string& out, const Reader& r,
               const std::string& path) {
  if (!j.is_string()) r.Fail(path, "expected a string");
  out = j.get<std::string>();
}
void ReadValue(const json& j, double& out, const Reader& r,
               const std::string& path) {
  if (!j.is_number()) r.Fail(path, "expected a number");
  out = j.get<double>();
  if (!std::isfinite(out)) r.Fail(path, "must be finite");
}
void ReadValue(const json& j, int& out, const Reader& r,
               const std::string& path) {
  if (!j.is_number_integer()) r.Fail(path, "expected an integer");
  out = j.get<int>();
}
void ReadValue(const json& j, bool& out, const Reader& r,
               const std::string& path) {
  if (!j.is_boolean()) r.Fail(path, "expected true or false");
  out = j.get<bool>();
}

void CheckKnownKeys(const json& j, const std::set<std::string>& seen,
                    const Reader& r, const std::string& path) {
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (!seen.count(it.key())) {
      r.Fail(path + it.key(), "unknown key");
    }
  }
}

template <class Visit, class T>
void ReadObject(const json& j, T& out, const Reader& parent,
                const std::string& path, Visit visit) {
  if (!j.is_object()) parent.Fail(path, "expected a table/object");
  std::set<std::string> seen;
  Reader r{&j, path + ".", parent.source, &seen};
  visit(r, out);
  CheckKnownKeys(j, seen, r, path + ".");
}

// A list entry (a cylinder, a clamp) has no default of its own: every
// field must be given.
template <class T, class Visit>
void ReadListEntry(const json& j, T& out, const Reader& r,
                   const std::string& path, Visit visit) {
  if (j.is_object()) {
    KeyList fields;
    visit(fields, out);
    for (const std::string& key : fields.keys)
      if (!j.contains(key)) r.Fail(path + "." + key, "missing");
  }
  ReadObject(j, out, r, path, [&](Reader& rr, T& o) { visit(rr, o); });
}
void ReadValue(const json& j, RefCylinder& out, const Reader& r,
               const std::string& path) {
  ReadListEntry(j, out, r, path,
                [](auto& v, RefCylinder& c) { VisitRefCylinder(v, c); });
}
void ReadValue(const json& j, ClampSpec& out, const Reader& r,
               const std::string& path) {
  ReadListEntry(j, out, r, path,
                [](auto& v, ClampSpec& c) { VisitClamp(v, c); });
}
void ReadValue(const json& j, ToolSpec& out, const Reader& r,
               const std::string& path) {
  ReadObject(j, out, r, path,
             [](Reader& rr, ToolSpec& t) { VisitTool(rr, t); });
}
template <class T>
void ReadValue(const json& j, std::vector<T>& out, const Reader& r,
               const std::string& path) {
  if (!j.is_array()) r.Fail(path, "expected an array");
  std::vector<T> values(j.size(), out.empty() ? T{} : out.front());
  for (size_t i = 0; i < j.size(); ++i) {
    ReadValue(j[i], values[i], r, path + "[" + std::to_string(i) + "]");
  }
  out = std::move(values);
}
template <class T, size_t N>
void ReadValue(const json& j, std::array<T, N>& out, const Reader& r,
               const std::string& path) {
  if (!j.is_array() || j.size() != N) {
    r.Fail(path, "expected an array of " + std::to_string(N) + " values");
  }
  for (size_t i = 0; i < N; ++i) {
    ReadValue(j[i], out[i], r, path + "[" + std::to_string(i) + "]");
  }
}

json TomlToJson(const toml::node& node) {
  if (const auto* t = node.as_table()) {
    json o = json::object();
    for (const auto& [k, v] : *t) o[std::string(k.str())] = TomlToJson(v);
    return o;
  }
  if (const auto* a = node.as_array()) {
    json arr = json::array();
    for (const auto& v : *a) arr.push_back(TomlToJson(v));
    return arr;
  }
  if (const auto* v = node.as_integer()) return v->get();
  if (const auto* v = node.as_floating_point()) return v->get();
  if (const auto* v = node.as_boolean()) return v->get();
  if (const auto* v = node.as_string()) return v->get();
  return json();  // dates and times: no field takes them, rejected later
}

void Require(bool ok, const std::string& source, const std::string& field,
             const std::string& why) {
  if (!ok) throw InputError(source, 0, field, why);
}

// Facet j and strip j lie j - reference_index steps from the reference: the
// most steps any facet or strip lies from it, on either side.
int StepsToFarthestFacet(const PartSpec& p) {
  return std::max(p.reference_index - 1,
                  p.facets_per_segment - p.reference_index);
}

// Where neighbouring facets at `distance_mm` from the axis meet.
double FacetCornerRadiusMm(const PartSpec& p, double distance_mm) {
  return distance_mm / std::cos(p.facet_step_deg / 2 * M_PI / 180);
}

void ValidateTool(const ToolSpec& t, const std::string& source,
                  const std::string& name, const MachineProfile& m) {
  const std::string f = "process." + name + ".";
  Require(t.number >= 1 && t.number <= 99, source, f + "number",
          "must be 1..99");
  Require(t.diameter_mm > 0, source, f + "diameter_mm", "must be positive");
  Require(t.flutes >= 1, source, f + "flutes", "must be at least 1");
  Require(t.length_mm > 0, source, f + "length_mm", "must be positive");
  Require(t.flute_length_mm > 0, source, f + "flute_length_mm",
          "must be positive");
  Require(t.tip_angle_deg >= 0 && t.tip_angle_deg < 180, source,
          f + "tip_angle_deg", "must be in [0, 180)");
  // The programs write S and F to a tenth at most: below 1 they would read
  // S0 / F0.0, which no controller runs.
  Require(t.spindle_rpm >= 1 && t.spindle_rpm <= m.max_spindle_rpm, source,
          f + "spindle_rpm", "must be in [1, machine.max_spindle_rpm]");
  Require(t.feed_mm_min >= 1 && t.feed_mm_min <= m.max_feed_mm_min, source,
          f + "feed_mm_min", "must be in [1, machine.max_feed_mm_min]");
  Require(t.stick_out_mm >= t.flute_length_mm && t.stick_out_mm < t.length_mm,
          source, f + "stick_out_mm",
          "must be in [flute_length_mm, length_mm): the holder holds the "
          "shank above the flutes and below the gauge line");
  Require(t.holder_diameter_mm >= t.diameter_mm, source,
          f + "holder_diameter_mm", "must not be smaller than diameter_mm");
}

// The features must fit the piece and each other: every later stage (the
// toolpaths, the dexel model, the probe layout) assumes so. Each rule names
// the field a user would change.
void ValidateFeatureFit(const PartSpec& p, const std::string& source) {
  const double blank_r = p.blank_diameter_mm / 2;
  const double facet_d = p.facet_final_distance_mm;
  Require(p.big_notch_half_width_mm < facet_d - 1.0, source,
          "part.big_notch_half_width_mm",
          "wider than the piece: the big notch must leave the segments "
          "(half width below facet_final_distance_mm - 1 mm)");
  Require(p.small_notch_half_width_mm < p.big_notch_half_width_mm, source,
          "part.small_notch_half_width_mm",
          "must be narrower than the big notch");
  Require(p.small_notch_half_width_mm < facet_d - 1.0, source,
          "part.small_notch_half_width_mm", "wider than the piece");
  Require(p.facets_per_segment * p.facet_step_deg <= p.segment_span_deg + 1e-9,
          source, "part.facet_step_deg",
          "facets_per_segment * facet_step_deg exceeds segment_span_deg");
  // Facet j's normal lies at (j - reference_index) x facet_step_deg from
  // its segment's centre; every facet must lie inside the segment.
  {
    const int farthest = StepsToFarthestFacet(p);
    Require(
        (farthest + 0.5) * p.facet_step_deg <= p.segment_span_deg / 2 + 1e-9,
        source, "part.reference_index",
        fmt::format("facets reach {:.3f} deg from the segment centre, "
                    "outside the segment (segment_span_deg/2 = {:.3f}): "
                    "the reference facet must leave room for the others "
                    "on both sides",
                    (farthest + 0.5) * p.facet_step_deg,
                    p.segment_span_deg / 2));
  }
  // Segments must not overlap each other nor reach into the notches.
  static const char* const kSegmentNames[] = {"X1", "Y1", "X2", "Y2"};
  for (size_t i = 0; i < p.segment_centre_deg.size(); ++i) {
    const std::string f = "part.segment_centre_deg[" + std::to_string(i) + "]";
    const double c = p.segment_centre_deg[i];
    Require(c > 0 && c < 360, source, f, "must be in (0, 360)");
    // The programs go round the piece X1, Y1, X2, Y2, one per quadrant,
    // and cut facet X1-j with X2-j (Y1-j with Y2-j) at one table angle.
    Require(std::floor(c / 90) == static_cast<double>(i), source, f,
            fmt::format("segment {} must lie in quadrant {} (centre between "
                        "{} and {} deg)",
                        kSegmentNames[i], i + 1, 90 * i, 90 * (i + 1)));
    if (i >= 2)
      Require(std::abs(c - p.segment_centre_deg[i - 2] - 180) < 1e-9, source, f,
              fmt::format("must be segment_centre_deg[{}] + 180 ({} opposite "
                          "{}): the test cycle cuts facets {}-j and {}-j at "
                          "one table angle",
                          i - 2, kSegmentNames[i], kSegmentNames[i - 2],
                          kSegmentNames[i - 2], kSegmentNames[i]));
    const double lo = (c - p.segment_span_deg / 2) * M_PI / 180;
    const double hi = (c + p.segment_span_deg / 2) * M_PI / 180;
    // The segment lies between the small notch (|x| <= xs) and the big
    // notch (|y| <= yb) at the facets' inscribed radius.
    for (double a : {lo, hi}) {
      const double x = facet_d * std::cos(a), y = facet_d * std::sin(a);
      Require(std::abs(y) >= p.big_notch_half_width_mm - 1.0 &&
                  std::abs(x) >= p.small_notch_half_width_mm - 1.0,
              source, f,
              "segment (centre +- segment_span_deg/2) reaches into a notch");
    }
    Require(
        std::floor(lo / (M_PI / 2)) == std::floor((hi - 1e-12) / (M_PI / 2)),
        source, f, "segment crosses a notch (it must lie in one quadrant)");
    // The outermost facets end at their outer corners (radius
    // facet_final_distance_mm / cos(facet_step_deg / 2)): a corner inside a
    // notch leaves that facet cut by the notch.
    const double corner_r = FacetCornerRadiusMm(p, facet_d);
    for (const int j : {1, p.facets_per_segment}) {
      const double side = j == 1 ? -0.5 : 0.5;
      const double a =
          (c + (j - p.reference_index + side) * p.facet_step_deg) * M_PI / 180;
      const double x = corner_r * std::cos(a), y = corner_r * std::sin(a);
      Require(std::abs(y) >= p.big_notch_half_width_mm - 1e-9 &&
                  std::abs(x) >= p.small_notch_half_width_mm - 1e-9,
              source, f,
              fmt::format("facet {} ends at W ({:.3f}, {:.3f}) mm, inside a "
                          "notch (|y| < big_notch_half_width_mm or |x| < "
                          "small_notch_half_width_mm): the notch would cut it",
                          j, x, y));
    }
  }
  // The mark (a groove mark_width_mm wide from mark_r_start_mm to
  // mark_r_end_mm along mark_phi_deg) must stay out of both notches: the
  // notches are slabs, so its four corners decide.
  {
    const double phi = p.mark_phi_deg * M_PI / 180;
    const double ux = std::cos(phi), uy = std::sin(phi);
    const double w = p.mark_width_mm / 2;
    for (double r : {p.mark_r_start_mm, p.mark_r_end_mm})
      for (double side : {-1.0, 1.0}) {
        const double x = r * ux - side * w * uy, y = r * uy + side * w * ux;
        Require(std::abs(y) >= p.big_notch_half_width_mm &&
                    std::abs(x) >= p.small_notch_half_width_mm,
                source, "part.mark_phi_deg",
                fmt::format("the mark reaches into a notch at W ({:.2f}, "
                            "{:.2f}) mm: move it (mark_phi_deg, "
                            "mark_r_start_mm, mark_r_end_mm) onto the "
                            "segment's top face",
                            x, y));
      }
  }
  // The mark lies on the top face of a segment.
  bool on_segment = false;
  for (double c : p.segment_centre_deg)
    if (std::abs(p.mark_phi_deg - c) <= p.segment_span_deg / 2)
      on_segment = true;
  Require(on_segment, source, "part.mark_phi_deg",
          "the mark must lie on a segment (within segment_span_deg/2 of a "
          "segment centre)");
  Require(p.big_notch_half_width_mm < blank_r, source,
          "part.big_notch_half_width_mm", "wider than the blank");
  Require(p.datum_circle_z_min_mm < p.datum_circle_z_max_mm, source,
          "part.datum_circle_z_min_mm", "must be below datum_circle_z_max_mm");
  Require(p.facet_bottom_z_mm < p.big_notch_floor_z_mm + 1e-9, source,
          "part.facet_bottom_z_mm",
          "must not be above the big-notch floor (facets reach it)");
}

}  // namespace

Config ConfigFromJson(const json& doc, const std::string& source) {
  Config c;
  if (!doc.is_object()) throw InputError(source, 0, "", "expected a table");
  std::set<std::string> seen;
  Reader top{&doc, "", source, &seen};
  auto section = [&](const char* key, auto visit, auto& target) {
    if (!doc.contains(key)) return;
    seen.insert(key);
    ReadObject(doc.at(key), target, top, key, visit);
  };
  section(
      "part", [](Reader& r, PartSpec& p) { VisitPart(r, p); }, c.part);
  section(
      "machine", [](Reader& r, MachineProfile& m) { VisitMachine(r, m); },
      c.machine);
  section(
      "process", [](Reader& r, ProcessSpec& p) { VisitProcess(r, p); },
      c.process);
  CheckKnownKeys(doc, seen, top, "");
  ValidateConfig(c, source);
  return c;
}

Config LoadConfig(const std::filesystem::path& path) {
  const std::string text = ReadTextFile(path);
  const std::string source = path.string();
  std::string ext = path.extension().string();
  for (auto& ch : ext) ch = static_cast<char>(std::tolower(ch));
  const bool looks_json =
      ext == ".json" ||
      (ext != ".toml" &&
       text.find_first_not_of(" \t\r\n") != std::string::npos &&
       text[text.find_first_not_of(" \t\r\n")] == '{');
  json doc;
  if (looks_json) {
    doc = ParseJsonText(text, source);
  } else {
    try {
      doc = TomlToJson(toml::parse(text, source));
    } catch (const toml::parse_error& e) {
      throw InputError(
          source, static_cast<int>(e.source().begin.line), "",
          std::string("not valid TOML: ") + std::string(e.description()));
    }
  }
  return ConfigFromJson(doc, source);
}

json ConfigToJson(const Config& config) {
  Config c = config;
  Writer part, machine, process;
  VisitPart(part, c.part);
  VisitMachine(machine, c.machine);
  VisitProcess(process, c.process);
  return json{
      {"part", part.out}, {"machine", machine.out}, {"process", process.out}};
}

void ValidateConfig(const Config& c, const std::string& source) {
  const PartSpec& p = c.part;
  const MachineProfile& m = c.machine;
  const ProcessSpec& pr = c.process;
  auto positive = [&](double v, const char* field) {
    Require(v > 0, source, std::string("part.") + field, "must be positive");
  };
  positive(p.blank_diameter_mm, "blank_diameter_mm");
  positive(p.blank_height_mm, "blank_height_mm");
  Require(p.face_depth_mm >= 0 && p.face_depth_mm < p.blank_height_mm, source,
          "part.face_depth_mm", "must be in [0, blank_height_mm)");
  positive(p.alpha_per_k, "alpha_per_k");
  positive(p.rim_diameter_mm, "rim_diameter_mm");
  Require(p.rim_diameter_mm <= p.blank_diameter_mm, source,
          "part.rim_diameter_mm", "larger than the blank");
  Require(!p.ref_cylinders.empty(), source, "part.ref_cylinders",
          "at least one reference cylinder is needed");
  for (size_t i = 0; i < p.ref_cylinders.size(); ++i) {
    const auto& rc = p.ref_cylinders[i];
    const std::string f = "part.ref_cylinders[" + std::to_string(i) + "]";
    Require(rc.diameter_mm > 0, source, f + ".diameter_mm", "must be positive");
    Require(rc.diameter_mm <= p.blank_diameter_mm, source, f + ".diameter_mm",
            "larger than the blank: the part does not fit the blank");
    Require(rc.z_bottom_mm < rc.z_top_mm, source, f,
            "z_bottom_mm must be below z_top_mm");
    Require(rc.z_bottom_mm >= -p.height_mm() - 1e-9, source, f + ".z_bottom_mm",
            "below the bottom of the piece");
    for (size_t j = 0; j < i; ++j) {
      const auto& other = p.ref_cylinders[j];
      Require(rc.z_top_mm <= other.z_bottom_mm + 1e-9 ||
                  rc.z_bottom_mm >= other.z_top_mm - 1e-9,
              source, f,
              fmt::format("z [{:g}, {:g}] overlaps part.ref_cylinders[{}] "
                          "(z [{:g}, {:g}]): each height has one diameter",
                          rc.z_bottom_mm, rc.z_top_mm, j, other.z_bottom_mm,
                          other.z_top_mm));
    }
  }
  Require(p.big_notch_floor_z_mm < 0 && p.big_notch_floor_z_mm > -p.height_mm(),
          source, "part.big_notch_floor_z_mm", "must lie inside the piece");
  Require(
      p.small_notch_floor_z_mm < 0 && p.small_notch_floor_z_mm > -p.height_mm(),
      source, "part.small_notch_floor_z_mm", "must lie inside the piece");
  positive(p.small_notch_half_width_mm, "small_notch_half_width_mm");
  positive(p.big_notch_half_width_mm, "big_notch_half_width_mm");
  Require(p.facets_per_segment >= 3 && p.facets_per_segment % 2 == 1, source,
          "part.facets_per_segment", "must be odd and at least 3");
  Require(p.reference_index >= 1 && p.reference_index <= p.facets_per_segment,
          source, "part.reference_index", "must be a facet index");
  positive(p.facet_step_deg, "facet_step_deg");
  Require(p.facet_final_distance_mm > 0 &&
              p.facet_final_distance_mm < p.facet_pre_distance_mm,
          source, "part.facet_final_distance_mm",
          "must be positive and below facet_pre_distance_mm");
  Require(p.facet_pre_distance_mm < p.rim_diameter_mm / 2, source,
          "part.facet_pre_distance_mm", "outside the rim: nothing to cut");
  Require(p.facet_bottom_z_mm < 0 && p.facet_bottom_z_mm > -p.height_mm(),
          source, "part.facet_bottom_z_mm", "must lie inside the piece");
  positive(p.strip_pitch_mm, "strip_pitch_mm");
  positive(p.strip_width_mm, "strip_width_mm");
  // Strip k lies at (k - reference_index) x strip_pitch_mm.
  const double strip_reach =
      StepsToFarthestFacet(p) * p.strip_pitch_mm + p.strip_width_mm / 2;
  // Neighbouring strips overlap (0.25 mm on the drawing); each must keep a
  // band of its own floor that no later strip cuts.
  Require(2 * p.strip_pitch_mm - p.strip_width_mm > 0, source,
          "part.strip_pitch_mm",
          fmt::format("below half the strip width ({:g} mm): the neighbouring "
                      "strips would cut each strip away entirely",
                      p.strip_width_mm / 2));
  const bool reference_in_middle =
      2 * p.reference_index == p.facets_per_segment + 1;
  Require(strip_reach <= p.big_notch_half_width_mm + 1e-9, source,
          reference_in_middle ? "part.strip_pitch_mm" : "part.reference_index",
          "outer strips reach into the big-notch flanks (strip k lies at "
          "(k - reference_index) x strip_pitch_mm)");
  Require(p.strip_floor_z_mm < p.big_notch_floor_z_mm, source,
          "part.strip_floor_z_mm", "must be below the big-notch floor");
  // The notches cross at the axis: where they do, the deeper one's floor
  // is what remains, so the small notch's floor must be the deeper.
  Require(p.small_notch_floor_z_mm < p.big_notch_floor_z_mm, source,
          "part.small_notch_floor_z_mm",
          "must be below the big-notch floor (the notches cross at the "
          "axis)");
  // The reference cylinders are turned by C with an end mill from the side,
  // its flutes reaching over the segments above: a cylinder inside the
  // facets' corners would cut the segments away.
  {
    const double corner_mm = FacetCornerRadiusMm(p, p.facet_pre_distance_mm);
    for (size_t i = 0; i < p.ref_cylinders.size(); ++i)
      Require(p.ref_cylinders[i].diameter_mm / 2 > corner_mm, source,
              "part.ref_cylinders[" + std::to_string(i) + "].diameter_mm",
              fmt::format("inside the pre-cut facets' corners (radius {:.3f} "
                          "mm): turning it would cut the segments away",
                          corner_mm));
  }
  // The big notch runs across the whole piece: a reference cylinder above
  // its floor would be cut away inside the notch.
  for (size_t i = 0; i < p.ref_cylinders.size(); ++i)
    Require(p.ref_cylinders[i].z_top_mm <= p.big_notch_floor_z_mm + 1e-9,
            source, "part.ref_cylinders[" + std::to_string(i) + "].z_top_mm",
            "above the big-notch floor (the notch runs across the piece "
            "and would cut the cylinder away inside it)");
  Require(p.mark_r_start_mm > 0 && p.mark_r_start_mm < p.mark_r_end_mm &&
              p.mark_r_end_mm < p.facet_final_distance_mm,
          source, "part.mark_r_end_mm",
          "mark must run from mark_r_start_mm out to below the facets");
  positive(p.mark_depth_mm, "mark_depth_mm");
  positive(p.mark_width_mm, "mark_width_mm");
  positive(p.adapter_diameter_mm, "adapter_diameter_mm");
  positive(p.adapter_height_mm, "adapter_height_mm");
  Require(p.bolt_circle_diameter_mm + p.bolt_hole_diameter_mm <
              p.adapter_diameter_mm,
          source, "part.bolt_circle_diameter_mm", "bolts outside the adapter");

  ValidateFeatureFit(p, source);

  // Tools.
  ValidateTool(pr.roughing, source, "roughing", m);
  ValidateTool(pr.engraver, source, "engraver", m);
  ValidateTool(pr.notch, source, "notch", m);
  ValidateTool(pr.finishing, source, "finishing", m);
  // The roughing, notch and finishing cutters make floors with their end
  // (the top face, the notch floors, the strips): only a flat end does.
  for (const auto& [tool, name] :
       {std::pair{&pr.roughing, "roughing"}, std::pair{&pr.notch, "notch"},
        std::pair{&pr.finishing, "finishing"}})
    Require(tool->tip_angle_deg == 0, source,
            std::string("process.") + name + ".tip_angle_deg",
            "must be 0: this cutter makes floors with its end, which only a "
            "flat end mill cuts flat");
  Require(pr.probe.number >= 1 && pr.probe.number <= 99, source,
          "process.probe.number", "must be 1..99");
  {
    // Each tool has its own pocket and length offset (T and H numbers).
    const std::vector<std::pair<const char*, int>> numbers = {
        {"roughing", pr.roughing.number},
        {"engraver", pr.engraver.number},
        {"notch", pr.notch.number},
        {"finishing", pr.finishing.number},
        {"probe", pr.probe.number}};
    for (std::size_t i = 0; i < numbers.size(); ++i)
      for (std::size_t j = 0; j < i; ++j)
        Require(numbers[i].second != numbers[j].second, source,
                std::string("process.") + numbers[i].first + ".number",
                fmt::format("T{} is also process.{}.number: each tool needs "
                            "its own number (pocket and length offset H)",
                            numbers[i].second, numbers[j].first));
  }
  Require(pr.probe.diameter_mm > 0, source, "process.probe.diameter_mm",
          "must be positive (stylus ball diameter)");
  Require(pr.probe.length_mm > 0, source, "process.probe.length_mm",
          "must be positive");
  Require(
      pr.probe.feed_mm_min >= 1 && pr.probe.feed_mm_min <= m.max_feed_mm_min,
      source, "process.probe.feed_mm_min",
      "must be in [1, machine.max_feed_mm_min]");
  Require(pr.notch.diameter_mm <= 2 * p.small_notch_half_width_mm + 1e-9,
          source, "process.notch.diameter_mm",
          "tool larger than the small notch");
  Require(pr.roughing.diameter_mm <= 2 * p.big_notch_half_width_mm, source,
          "process.roughing.diameter_mm", "tool larger than the big notch");
  Require(std::abs(pr.finishing.diameter_mm - p.strip_width_mm) < 1e-9, source,
          "process.finishing.diameter_mm",
          "must equal part.strip_width_mm (a strip is one cutter wide)");
  Require(pr.finishing.flute_length_mm >= -p.facet_bottom_z_mm, source,
          "process.finishing.flute_length_mm", "shorter than the facet height");
  // Below 0.05 mm a roughing pass is not roughing, and the pass count of
  // the big notch (its depth over the step) grows without bound.
  Require(pr.roughing_step_down_mm >= 0.05, source,
          "process.roughing_step_down_mm", "must be at least 0.05 mm");
  Require(pr.finish_allowance_mm >= 0, source, "process.finish_allowance_mm",
          "must not be negative");
  Require(pr.turning_c_rpm > 0 && pr.turning_c_rpm <= m.c_max_rpm, source,
          "process.turning_c_rpm", "must be in (0, machine.c_max_rpm]");
  Require(pr.nc_hold_after_pre_min >= 0 && pr.nc_hold_after_pre_min <= 1440,
          source, "process.nc_hold_after_pre_min",
          "must be in [0, 1440] min (at most a day)");
  Require(pr.cycle_period_s >= 600 && pr.cycle_period_s <= 86400, source,
          "process.cycle_period_s",
          "must be in [600, 86400] s (one cycle must fit; at most a day)");
  Require(pr.warmup_cycles >= 0 && pr.warmup_cycles <= p.cycles(), source,
          "process.warmup_cycles", "must be in [0, cycles]");
  Require(pr.rtest_interval_s == 0 ||
              (pr.rtest_interval_s >= 60 && pr.rtest_interval_s <= 86400),
          source, "process.rtest_interval_s",
          "must be 0 (no R-test) or in [60, 86400] s");
  Require(pr.rtest_measure_s >= 0 && pr.rtest_measure_s <= 600, source,
          "process.rtest_measure_s", "must be in [0, 600] s");
  Require(pr.safe_z_w_mm > 0, source, "process.safe_z_w_mm",
          "must be above the top face");
  Require(pr.clearance_mm > 0, source, "process.clearance_mm",
          "must be positive");

  // Machine.
  auto range = [&](const std::array<double, 2>& r, const char* field) {
    Require(r[0] < r[1], source, std::string("machine.") + field,
            "min must be below max");
  };
  range(m.travel_x_mm, "travel_x_mm");
  range(m.travel_y_mm, "travel_y_mm");
  range(m.travel_z_mm, "travel_z_mm");
  Require(m.rapid_mm_min > 0, source, "machine.rapid_mm_min",
          "must be positive");
  Require(m.max_feed_mm_min > 0, source, "machine.max_feed_mm_min",
          "must be positive");
  Require(m.c_index_deg_s > 0, source, "machine.c_index_deg_s",
          "must be positive");
  Require(m.c_max_rpm > 0, source, "machine.c_max_rpm", "must be positive");
  Require(m.c_sense == 1 || m.c_sense == -1, source, "machine.c_sense",
          "must be 1 or -1");
  Require(m.sphere_distance_mm > 0, source, "machine.sphere_distance_mm",
          "must be positive");
  // (an R-test that uncertain cannot show thermal errors of a few um)
  for (size_t i = 0; i < m.rtest_u95_um.size(); ++i)
    Require(m.rtest_u95_um[i] > 0 && m.rtest_u95_um[i] <= 100, source,
            fmt::format("machine.rtest_u95_um[{}]", i),
            fmt::format("the {} R-test uncertainty must be in (0, 100] um",
                        kErrorNames[i]));
  for (size_t i = 0; i < m.rtest_u95_urad.size(); ++i)
    Require(m.rtest_u95_urad[i] > 0 && m.rtest_u95_urad[i] <= 1000, source,
            fmt::format("machine.rtest_u95_urad[{}]", i),
            fmt::format("the {} R-test uncertainty must be in (0, 1000] urad",
                        kErrorNames[4 + i]));
  Require(m.program_number >= 1 && m.program_number <= 9998, source,
          "machine.program_number", "must be 1..9998");
  // The piece must fit the travel: the tool reaches radius R + tool radius.
  const double reach =
      p.blank_diameter_mm / 2 + pr.roughing.diameter_mm / 2 + pr.clearance_mm;
  Require(m.travel_x_mm[0] <= -reach && m.travel_x_mm[1] >= reach, source,
          "machine.travel_x_mm", "the piece does not fit the X travel");
  Require(m.travel_y_mm[0] <= -reach && m.travel_y_mm[1] >= reach, source,
          "machine.travel_y_mm", "the piece does not fit the Y travel");
  const double w_origin_z =
      m.table_top_z_mm + p.adapter_height_mm + p.height_mm();
  Require(m.travel_z_mm[0] <= w_origin_z - p.height_mm() &&
              m.travel_z_mm[1] >= w_origin_z + pr.safe_z_w_mm,
          source, "machine.travel_z_mm",
          "the piece and safe height do not fit the Z travel");
  Require(m.rapid_semantics == "straight" || m.rapid_semantics == "per_axis",
          source, "machine.rapid_semantics", "must be straight or per_axis");
  for (int a = 0; a < 3; ++a)
    Require(m.rapid_axis_mm_min[a] > 0, source,
            "machine.rapid_axis_mm_min[" + std::to_string(a) + "]",
            "must be positive");
  Require(m.positioning_feed_mm_min >= 1 &&
              m.positioning_feed_mm_min <= m.max_feed_mm_min,
          source, "machine.positioning_feed_mm_min",
          "must be in [1, max_feed_mm_min]");
  Require(m.sphere_radius_mm > 0, source, "machine.sphere_radius_mm",
          "must be positive");
  Require(m.sphere_stem_diameter_mm > 0 &&
              m.sphere_stem_diameter_mm < 2 * m.sphere_radius_mm,
          source, "machine.sphere_stem_diameter_mm",
          "must be positive and below the ball diameter");
  Require(m.sphere_height_mm > m.sphere_radius_mm, source,
          "machine.sphere_height_mm", "the ball must sit above the table");
  Require(m.sphere_distance_mm - m.sphere_radius_mm >
              std::max(p.blank_diameter_mm, p.adapter_diameter_mm) / 2,
          source, "machine.sphere_distance_mm",
          "the sphere must stand outside the blank and the adapter");
  Require(m.table_diameter_mm / 2 >= m.sphere_distance_mm, source,
          "machine.table_diameter_mm", "the sphere must stand on the table");
  for (size_t i = 0; i < m.clamps.size(); ++i) {
    const ClampSpec& k = m.clamps[i];
    const std::string f = "machine.clamps[" + std::to_string(i) + "]";
    Require(k.r_inner_mm >= 0 && k.r_inner_mm < k.r_outer_mm, source,
            f + ".r_inner_mm", "must be in [0, r_outer_mm)");
    Require(k.width_mm > 0, source, f + ".width_mm", "must be positive");
    Require(k.height_mm > 0 && k.height_mm < p.adapter_height_mm, source,
            f + ".height_mm",
            "must be positive and below the adapter top (the clamps hold "
            "the adapter, not the piece)");
    Require(k.r_outer_mm <= m.table_diameter_mm / 2, source, f + ".r_outer_mm",
            "beyond the table");
  }
  for (const auto& [a, field, range] :
       {std::tuple{0, "machine.tool_change_position_m_mm[0]", m.travel_x_mm},
        std::tuple{1, "machine.tool_change_position_m_mm[1]", m.travel_y_mm},
        std::tuple{2, "machine.tool_change_position_m_mm[2]", m.travel_z_mm}})
    Require(m.tool_change_position_m_mm[a] >= range[0] &&
                m.tool_change_position_m_mm[a] <= range[1],
            source, field, "outside the travel");
  {
    double longest = 0;
    for (const ToolSpec* t : pr.Tools())
      longest = std::max(longest, t->length_mm);
    const double top = m.table_top_z_mm + p.adapter_height_mm + p.height_mm();
    Require(m.tool_change_position_m_mm[2] - longest >
                std::max(top, m.table_top_z_mm + m.sphere_height_mm +
                                  m.sphere_radius_mm) +
                    pr.clearance_mm,
            source, "machine.tool_change_position_m_mm[2]",
            "the longest tool would not clear the piece and the sphere");
  }
  Require(m.fanuc_sync_block == "G53" ||
              (m.fanuc_sync_block.size() > 1 && m.fanuc_sync_block[0] == 'M' &&
               m.fanuc_sync_block.find_first_not_of("0123456789", 1) ==
                   std::string::npos),
          source, "machine.fanuc_sync_block", "must be G53 or M<number>");
  {
    // The FANUC programs switch each machine function with the profile's
    // M-code and the reader tells the functions apart by it: two functions
    // on one code, or one on a standard M-code (which the control reads
    // with its standard meaning: M8 is coolant on), would make a program
    // that does something else on the machine than it says.
    const std::map<int, std::string> standard = {
        {0, "program stop"},
        {1, "optional stop"},
        {2, "program end"},
        {3, "spindle on clockwise"},
        {4, "spindle on counter-clockwise"},
        {5, "spindle stop"},
        {6, "tool change"},
        {8, "coolant on"},
        {9, "coolant off"},
        {19, "spindle orientation"},
        {30, "program end and rewind"},
        {98, "subprogram call"},
        {99, "subprogram return"}};
    std::vector<std::pair<std::string, int>> codes = {
        {"machine.m_table_clamp", m.m_table_clamp},
        {"machine.m_table_unclamp", m.m_table_unclamp},
        {"machine.m_b_clamp", m.m_b_clamp},
        {"machine.m_b_unclamp", m.m_b_unclamp},
        {"machine.m_c_turning_on", m.m_c_turning_on},
        {"machine.m_c_turning_off", m.m_c_turning_off},
        {"machine.m_probe_on", m.m_probe_on},
        {"machine.m_probe_off", m.m_probe_off}};
    // An M sync block (its form checked above) of at most 8 digits, which
    // any int holds; a longer one is no code of this profile's functions.
    if (m.fanuc_sync_block != "G53" && m.fanuc_sync_block.size() < 10)
      codes.emplace_back("machine.fanuc_sync_block",
                         std::stoi(m.fanuc_sync_block.substr(1)));
    for (std::size_t i = 0; i < codes.size(); ++i) {
      const auto& [field, code] = codes[i];
      Require(code >= 0, source, field, "must be an M-code >= 0");
      const auto it = standard.find(code);
      Require(it == standard.end(), source, field,
              fmt::format("M{} is {}, a standard M-code: give the "
                          "machine's own M-code for this function",
                          code, it == standard.end() ? "" : it->second));
      for (std::size_t j = 0; j < i; ++j)
        Require(codes[j].second != code, source, field,
                fmt::format("M{} is also {}: each machine function needs "
                            "its own M-code",
                            code, codes[j].first));
    }
  }
  Require(m.linuxcnc_c_clamp_output >= 0 && m.linuxcnc_b_clamp_output >= 0 &&
              m.linuxcnc_c_clamp_output != m.linuxcnc_b_clamp_output,
          source, "machine.linuxcnc_b_clamp_output",
          "must be distinct outputs >= 0");
  Require(m.linuxcnc_probe_output >= 0 &&
              m.linuxcnc_probe_output != m.linuxcnc_c_clamp_output &&
              m.linuxcnc_probe_output != m.linuxcnc_b_clamp_output,
          source, "machine.linuxcnc_probe_output",
          "must be an output >= 0 other than the C and B clamps'");
  for (int a = 0; a < 4; ++a) {
    Require(
        m.fanuc_skip_variables[a] >= 5061 && m.fanuc_skip_variables[a] <= 5068,
        source, "machine.fanuc_skip_variables[" + std::to_string(a) + "]",
        "must be a skip position variable #5061..#5068");
    Require(m.linuxcnc_probe_variables[a] >= 5061 &&
                m.linuxcnc_probe_variables[a] <= 5069,
            source,
            "machine.linuxcnc_probe_variables[" + std::to_string(a) + "]",
            "must be a probe position parameter #5061..#5069");
  }
  {
    // The waiting tool (finishing cutter and holder) must stay out of the
    // ring the R-test sphere sweeps while C turns.
    const double wr =
        std::hypot(m.waiting_position_w_mm[0], m.waiting_position_w_mm[1]);
    const double reach = pr.finishing.holder_diameter_mm / 2;
    const double ring_in = m.sphere_distance_mm - m.sphere_radius_mm;
    const double ring_out = m.sphere_distance_mm + m.sphere_radius_mm;
    Require(wr + reach + pr.clearance_mm <= ring_in ||
                wr - reach - pr.clearance_mm >= ring_out,
            source, "machine.waiting_position_w_mm",
            "in the ring the R-test sphere sweeps while C turns (tool holder "
            "within clearance_mm of radius sphere_distance_mm +- "
            "sphere_radius_mm)");
  }
}

}  // namespace ttp
