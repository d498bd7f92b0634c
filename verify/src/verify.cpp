#include "ttp/verify/verify.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "ttp/gcode/execution.h"
#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"
#include "ttp/verify/dexel.h"
#include "ttp/verify/machine.h"

namespace ttp::verify {
namespace {

using gcode::CanonKind;
using gcode::CanonStatement;
// Removal below this (mm) along a ray is numerical noise, not a cut.
constexpr double kCutEpsMm = 1e-6;
// A tool-length offset within this of the tool's length is that tool's.
constexpr double kLengthOffsetEpsMm = 1e-6;
// Probe rays start this far inside the nominal surface and reach
// kProbeOutsideMm outside it.
constexpr double kProbeInsideMm = 1.0;
constexpr double kProbeOutsideMm = 2.0;
// Probes keep this distance from feature edges (corners are ambiguous).
constexpr double kEdgeMarginMm = 0.5;
// Combined C + linear moves are cut in straight pieces of at most this
// table rotation (chord error < 0.05 um at r = 100 mm).
constexpr double kMaxPieceRad = 0.1 * kDeg;

struct Probe {
  std::string id;
  std::vector<int> rays;
};

ToolShape ShapeOf(const ToolSpec& tool) {
  ToolShape shape;
  shape.radius_mm = tool.diameter_mm / 2;
  shape.length_mm = tool.length_mm;
  shape.tan_half_angle =
      tool.tip_angle_deg > 0 ? std::tan(tool.tip_angle_deg / 2 * kDeg) : 0.0;
  return shape;
}

class ProbeBuilder {
 public:
  ProbeBuilder(DexelModel* model, std::vector<Probe>* probes)
      : model_(model), probes_(probes) {}

  void Begin(const std::string& id) { probes_->push_back({id, {}}); }
  // A probe ray: origin on the nominal surface at p, outward normal n.
  void Add(const Eigen::Vector3d& surface_point, const Eigen::Vector3d& n) {
    Ray ray;
    ray.origin = surface_point - kProbeInsideMm * n;
    ray.direction = n;
    ray.length_mm = kProbeInsideMm + kProbeOutsideMm;
    ray.probe = static_cast<int>(probes_->size()) - 1;
    probes_->back().rays.push_back(model_->AddRay(std::move(ray)));
  }

 private:
  DexelModel* model_;
  std::vector<Probe>* probes_;
};

// Inclusive steps from lo to hi at about pitch (at least one, centred when
// the range is shorter than the pitch).
std::vector<double> Steps(double lo, double hi, double pitch) {
  if (hi < lo) return {};
  const int n = std::max(1, static_cast<int>(std::floor((hi - lo) / pitch)));
  std::vector<double> out;
  if (hi - lo < pitch) return {(lo + hi) / 2};
  for (int i = 0; i <= n; ++i) out.push_back(lo + (hi - lo) * i / n);
  return out;
}

// Probe rays along the normals of every feature present at the target
// stage (pre-machined or finished).
void BuildProbes(const PartSpec& p, Stage stage, double pitch,
                 DexelModel* model, std::vector<Probe>* probes) {
  ProbeBuilder b(model, probes);
  const double m = kEdgeMarginMm;
  const double xs = p.small_notch_half_width_mm;
  const double yb = p.big_notch_half_width_mm;
  const double facet_d = stage == Stage::kFinished ? p.facet_final_distance_mm
                                                   : p.facet_pre_distance_mm;
  // Points of the top of the segments lie inside the facets' inscribed
  // circle of the finished piece.
  const double r_top = p.facet_final_distance_mm - m;
  const Eigen::Vector2d mark_dir(std::cos(p.mark_phi_deg * kDeg),
                                 std::sin(p.mark_phi_deg * kDeg));
  const Eigen::Vector2d mark_a = p.mark_r_start_mm * mark_dir;
  const Eigen::Vector2d mark_b = p.mark_r_end_mm * mark_dir;
  double r_floor = p.rim_diameter_mm / 2;  // radius of the cylinder at -12
  for (const RefCylinder& rc : p.ref_cylinders)
    if (rc.z_top_mm >= p.big_notch_floor_z_mm - 1e-9)
      r_floor = std::min(r_floor, rc.diameter_mm / 2);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();

  b.Begin("TOP");
  for (double x : Steps(-r_top, r_top, 2 * pitch))
    for (double y : Steps(-r_top, r_top, 2 * pitch)) {
      const Eigen::Vector2d q(x, y);
      if (std::abs(x) < xs + m || std::abs(y) < yb + m || q.norm() > r_top)
        continue;
      if (SegmentDistance(q, mark_a, mark_b) < p.mark_width_mm + 2 * m)
        continue;
      b.Add(Eigen::Vector3d(x, y, 0), up);
    }

  for (int side : {+1, -1}) {
    b.Begin(side > 0 ? "FLANK+Y" : "FLANK-Y");
    const double x_max = std::sqrt(r_top * r_top - yb * yb);
    for (double x : Steps(-x_max, x_max, pitch)) {
      if (std::abs(x) < xs + m) continue;
      for (double z : Steps(p.big_notch_floor_z_mm + m, -m, pitch))
        b.Add(Eigen::Vector3d(x, side * yb, z), Eigen::Vector3d(0, -side, 0));
    }
  }

  for (const RefCylinder& rc : p.ref_cylinders) {
    b.Begin(fmt::format("CYL{:g}", rc.diameter_mm));
    const double r = rc.diameter_mm / 2;
    const int n = static_cast<int>(std::ceil(2 * kPi * r / (2 * pitch)));
    for (double z : Steps(rc.z_bottom_mm + m, rc.z_top_mm - m, pitch))
      for (int i = 0; i < n; ++i) {
        const double a = 2 * kPi * i / n;
        const Eigen::Vector3d dir(std::cos(a), std::sin(a), 0);
        if (z > p.small_notch_floor_z_mm - m && std::abs(r * dir.x()) < xs + m)
          continue;
        b.Add(r * dir + Eigen::Vector3d(0, 0, z), dir);
      }
  }

  // Floors end where the facets' planes (cut down to facet_bottom_z_mm)
  // reach them.
  r_floor = std::min(r_floor, p.facet_pre_distance_mm);
  b.Begin("NOTCH_SMALL");
  for (double x : Steps(-xs + m, xs - m, pitch))
    for (double y : Steps(-r_floor, r_floor, 2 * pitch)) {
      if (std::hypot(x, y) > r_floor - m) continue;
      b.Add(Eigen::Vector3d(x, y, p.small_notch_floor_z_mm), up);
    }

  if (stage == Stage::kPreMachined) {
    b.Begin("NOTCH_BIG");
    for (double x : Steps(-r_floor, r_floor, 2 * pitch))
      for (double y : Steps(-yb + m, yb - m, 2 * pitch)) {
        if (std::abs(x) < xs + m || std::hypot(x, y) > r_floor - m) continue;
        b.Add(Eigen::Vector3d(x, y, p.big_notch_floor_z_mm), up);
      }
  } else {
    for (int k = 1; k <= p.facets_per_segment; ++k) {
      b.Begin(StripId(k));
      const double yk = StripY(p, k);
      for (double x : Steps(-r_floor, r_floor, 2 * pitch))
        for (double y : Steps(yk - p.strip_width_mm / 2 + m,
                              yk + p.strip_width_mm / 2 - m, pitch)) {
          if (std::abs(x) < xs + m || std::hypot(x, y) > r_floor - m) continue;
          b.Add(Eigen::Vector3d(x, y, p.strip_floor_z_mm), up);
        }
    }
  }

  b.Begin("MARK");
  for (double r : Steps(p.mark_r_start_mm + 1, p.mark_r_end_mm - 1, pitch)) {
    const Eigen::Vector2d q = r * mark_dir;
    b.Add(Eigen::Vector3d(q.x(), q.y(), -p.mark_depth_mm), up);
  }

  const double half_width = facet_d * std::tan(p.facet_step_deg / 2 * kDeg) - m;
  for (Segment s : kSegments)
    for (int j = 1; j <= p.facets_per_segment; ++j) {
      b.Begin(FacetId(s, j));
      const double phi = FacetPhiDeg(p, s, j) * kDeg;
      const Eigen::Vector3d n(std::cos(phi), std::sin(phi), 0);
      const Eigen::Vector3d t(-std::sin(phi), std::cos(phi), 0);
      for (double u : Steps(-half_width, half_width, pitch))
        for (double z : Steps(p.big_notch_floor_z_mm + m, -m, pitch))
          b.Add(facet_d * n + u * t + Eigen::Vector3d(0, 0, z), n);
    }
}

void AddCoarseGrid(const PartSpec& p, double pitch, DexelModel* model) {
  const double r = p.blank_diameter_mm / 2;
  const double z0 = -p.height_mm(), z1 = p.face_depth_mm;
  for (double x : Steps(-r, r, pitch))
    for (double y : Steps(-r, r, pitch)) {
      if (std::hypot(x, y) > r) continue;
      Ray ray;
      ray.origin = Eigen::Vector3d(x, y, z0);
      ray.direction = Eigen::Vector3d::UnitZ();
      ray.length_mm = z1 - z0;
      model->AddRay(std::move(ray));
    }
}

// Blank, and for the test cycle the ideal pre-machined piece of the drawing.
void InitialiseStock(const Config& config, VerifyStage stage,
                     DexelModel* model) {
  const PartSpec& p = config.part;
  for (Ray& ray : model->mutable_rays()) {
    ray.material.clear();
    for (auto [a, b] : InsideCylinderIntervals(
             p.blank_diameter_mm / 2, -p.height_mm(), p.face_depth_mm, ray)) {
      a = std::max(a, 0.0);
      b = std::min(b, ray.length_mm);
      if (b > a) ray.material.emplace_back(a, b);
    }
  }
  if (stage == VerifyStage::kPre) return;
  using Planes = std::vector<std::pair<Eigen::Vector3d, double>>;
  const double big = 1e6;
  const Eigen::Vector3d ex = Eigen::Vector3d::UnitX(),
                        ey = Eigen::Vector3d::UnitY(),
                        ez = Eigen::Vector3d::UnitZ();
  std::vector<Planes> boxes;
  boxes.push_back({{-ez, 0.0}});  // facing: z >= 0
  boxes.push_back({{ex, p.small_notch_half_width_mm},
                   {-ex, p.small_notch_half_width_mm},
                   {-ez, -p.small_notch_floor_z_mm}});
  boxes.push_back({{ey, p.big_notch_half_width_mm},
                   {-ey, p.big_notch_half_width_mm},
                   {-ez, -p.big_notch_floor_z_mm}});
  for (Segment s : kSegments)
    for (int j = 1; j <= p.facets_per_segment; ++j) {
      const double phi = FacetPhiDeg(p, s, j) * kDeg;
      const Eigen::Vector3d n(std::cos(phi), std::sin(phi), 0);
      boxes.push_back({{-n, -p.facet_pre_distance_mm},
                       {-ez, -p.facet_bottom_z_mm},
                       {ez, big}});
    }
  const ToolShape engraver = ShapeOf(config.process.engraver);
  const double mark_phi = p.mark_phi_deg * kDeg;
  const Eigen::Vector3d mark_dir(std::cos(mark_phi), std::sin(mark_phi), 0);
  const Sweep mark = Sweep::Straight(
      engraver, p.mark_r_start_mm * mark_dir - p.mark_depth_mm * ez,
      p.mark_r_end_mm * mark_dir - p.mark_depth_mm * ez);
  double top_of_cylinders = -p.height_mm();
  for (const RefCylinder& rc : p.ref_cylinders)
    top_of_cylinders = std::max(top_of_cylinders, rc.z_top_mm);
  model->SubtractEach([&](const Ray& ray) {
    std::vector<std::pair<double, double>> out;
    for (const Planes& box : boxes)
      for (const auto& iv : ConvexIntervals(box, ray)) out.push_back(iv);
    for (const RefCylinder& rc : p.ref_cylinders)
      for (const auto& iv : OutsideCylinderIntervals(
               rc.diameter_mm / 2, rc.z_bottom_mm, rc.z_top_mm, ray))
        out.push_back(iv);
    for (const auto& iv : OutsideCylinderIntervals(p.rim_diameter_mm / 2,
                                                   top_of_cylinders, big, ray))
      out.push_back(iv);
    for (const auto& iv : SweepIntervals(mark, ray)) out.push_back(iv);
    return out;
  });
}

struct Cut {
  int statement;
  double start_s, end_s;
  Eigen::Vector3d from, to;  // program coordinates
};

Finding MakeFinding(std::string check, double measured, double limit,
                    std::string unit) {
  Finding f;
  f.check = std::move(check);
  f.measured = measured;
  f.limit = limit;
  f.unit = std::move(unit);
  f.pass = measured <= limit;
  return f;
}

void SetWhere(Finding* f, const std::vector<CanonStatement>& statements,
              int index) {
  f->statement = index;
  f->source_line = index >= 0 && index < static_cast<int>(statements.size())
                       ? statements[index].source_line
                       : 0;
}

// Excess of v beyond [lo, hi] (0 inside).
double Excess(double v, const std::array<double, 2>& range) {
  return std::max({0.0, range[0] - v, v - range[1]});
}

}  // namespace

const char* StageName(VerifyStage stage) {
  return stage == VerifyStage::kPre ? "pre" : "cycle";
}

VerifyStage ParseStage(const std::string& name, const std::string& source) {
  if (name == "pre") return VerifyStage::kPre;
  if (name == "cycle") return VerifyStage::kCycle;
  throw InputError(source, 0, "stage",
                   "'" + name + "' is not a stage (pre, cycle or auto)");
}

VerifyStage DetectStage(const std::vector<CanonStatement>& statements) {
  for (const CanonStatement& s : statements)
    if (s.kind == CanonKind::kReport && s.text.rfind("cut,", 0) == 0)
      return VerifyStage::kCycle;
  return VerifyStage::kPre;
}

bool VerifyReport::AllPassed() const {
  for (const Finding& f : findings)
    if (!f.pass) return false;
  return true;
}

const Finding* VerifyReport::Find(const std::string& check) const {
  for (const Finding& f : findings)
    if (f.check == check) return &f;
  return nullptr;
}

std::vector<const Finding*> VerifyReport::Failed() const {
  std::vector<const Finding*> out;
  for (const Finding& f : findings)
    if (!f.pass) out.push_back(&f);
  return out;
}

namespace {

// Stage 1: the dexel model of the target stage (feature probe rays, coarse
// Z grid) holding the initial stock.
struct SimulationModel {
  DexelModel model;
  std::vector<Probe> probes;
  int probe_rays = 0;
  int rays = 0;
};

void BuildSimulationModel(const Config& config, const VerifyOptions& options,
                          SimulationModel* out) {
  BuildProbes(config.part,
              options.stage == VerifyStage::kPre ? Stage::kPreMachined
                                                 : Stage::kFinished,
              options.probe_pitch_mm, &out->model, &out->probes);
  out->probe_rays = static_cast<int>(out->model.rays().size());
  AddCoarseGrid(config.part, options.coarse_pitch_mm, &out->model);
  out->rays = static_cast<int>(out->model.rays().size());
  out->model.Finalize();
  // Test cycle after a given pre-machining program: blank, then that
  // program; otherwise the ideal stock of the stage.
  InitialiseStock(config, options.after ? VerifyStage::kPre : options.stage,
                  &out->model);
}

// Stage 2: where one move takes the tool, as sweeps in W: the straight
// move of the axes (feeds, and rapids under straight semantics), and for a
// rapid the per-axis dog-leg after them.
struct MoveSweeps {
  Eigen::Vector3d from, to;  // program coordinates
  double c_from = 0, c_to = 0;
  std::vector<Sweep> sweeps;
  size_t straight_pieces = 0;  // sweeps[0, straight_pieces) = straight path
};

MoveSweeps SweepsOfMove(const CanonStatement& st,
                        const gcode::ExecutionState& before,
                        const ToolShape& tool, const Config& config) {
  const MachineProfile& machine = config.machine;
  MoveSweeps m;
  m.from = before.position_mm;
  m.c_from = before.c_rad;
  if (!before.tool_position_known) {
    // After a tool change the tool comes down from the top of the travel
    // above its first target.
    m.from = st.end_mm;
    m.from.z() = machine.travel_z_mm[1] - WorkpieceOriginHeightMm(config);
    m.c_from = st.end_c_rad;
  }
  m.to = st.end_mm;
  m.c_to = st.end_c_rad;
  // The return type is explicit: an Eigen product of a temporary rotation
  // returned as `auto` would dangle.
  const auto to_w = [&](const Eigen::Vector3d& p_prog,
                        double c) -> Eigen::Vector3d {
    return WorkpieceToMachineRotation(c, machine.c_sense).transpose() * p_prog;
  };
  const auto add_straight = [&](const Eigen::Vector3d& p0, double c0,
                                const Eigen::Vector3d& p1, double c1) {
    const double dc = c1 - c0;
    if ((p1 - p0).norm() < 1e-12 && std::abs(dc) > 0) {
      const double rho = p0.head<2>().norm();
      const double theta0 = std::atan2(p0.y(), p0.x());
      m.sweeps.push_back(Sweep::Rotation(tool, rho, p0.z(),
                                         theta0 + machine.c_sense * c0,
                                         theta0 + machine.c_sense * c1));
      return;
    }
    const int n =
        std::max(1, static_cast<int>(std::ceil(std::abs(dc) / kMaxPieceRad)));
    for (int k = 0; k < n; ++k) {
      const double f0 = double(k) / n, f1 = double(k + 1) / n;
      m.sweeps.push_back(
          Sweep::Straight(tool, to_w(p0 + f0 * (p1 - p0), c0 + f0 * dc),
                          to_w(p0 + f1 * (p1 - p0), c0 + f1 * dc)));
    }
  };
  add_straight(m.from, m.c_from, m.to, m.c_to);
  m.straight_pieces = m.sweeps.size();
  if (st.kind == CanonKind::kTraverse) {
    const auto corners =
        RapidPath({m.from, m.c_from}, {m.to, m.c_to}, machine, true);
    if (corners.size() > 2)
      for (size_t k = 0; k + 1 < corners.size(); ++k)
        add_straight(corners[k].p_mm, corners[k].c_rad, corners[k + 1].p_mm,
                     corners[k + 1].c_rad);
  }
  return m;
}

// Penetration (mm) of a sweep into the adapter, a cylinder about the C axis
// below the piece (so the table angle does not matter); nullopt when the
// sweep stays above or below it.
std::optional<double> AdapterPenetrationMm(const Sweep& sw,
                                           const ToolShape& tool,
                                           const PartSpec& part) {
  const double adapter_top = -part.height_mm();
  const double adapter_bottom = adapter_top - part.adapter_height_mm;
  const Eigen::Vector3d a = sw.start_w, b = sw.end_w;
  double ta = 0, tb = 1;
  const double dz = b.z() - a.z();
  if (std::abs(dz) < 1e-12) {
    if (a.z() >= adapter_top || a.z() + tool.length_mm <= adapter_bottom)
      return std::nullopt;
  } else {
    double t0 = (adapter_bottom - tool.length_mm - a.z()) / dz;
    double t1 = (adapter_top - a.z()) / dz;
    if (t0 > t1) std::swap(t0, t1);
    ta = std::max(0.0, t0);
    tb = std::min(1.0, t1);
    if (ta >= tb) return std::nullopt;
  }
  double closest;
  if (sw.kind == Sweep::Kind::kRotation) {
    closest = sw.radius_mm;
  } else {
    const Eigen::Vector2d pa = (a + ta * (b - a)).head<2>();
    const Eigen::Vector2d pb = (a + tb * (b - a)).head<2>();
    closest = SegmentDistance(Eigen::Vector2d::Zero(), pa, pb);
  }
  const double z_low = std::min(a.z(), b.z());
  const double reach =
      tool.RadiusAt(std::min(tool.length_mm, adapter_top - z_low));
  if (reach <= 0) return std::nullopt;
  return part.adapter_diameter_mm / 2 + reach - closest;
}

// The largest value of a check over the statements and where it was.
struct Worst {
  double value = 0;
  int statement = -1;
  void Take(double v, int i) {
    if (v > value) {
      value = v;
      statement = i;
    }
  }
};

// Stage 2b: where the tool tip really is. A statement gives the controlled
// point, which is the tip only when the tool-length offset in effect is the
// length of the tool in the spindle (G43 H of that tool): the spindle's
// gauge line stands at the point plus the offset, the tip a tool length
// below it. Without G43, or with another tool's H, every cut runs lower or
// higher by the difference, and the simulation cuts there.
struct TipPath {
  std::vector<CanonStatement> statements;
  Worst offset;  // |offset - tool length| (mm) over feeds and probe moves
  std::string detail;
};

TipPath ToolTipPath(const std::vector<CanonStatement>& program,
                    const Config& config) {
  TipPath out;
  out.statements = program;
  int tool = -1;
  for (int i = 0; i < static_cast<int>(out.statements.size()); ++i) {
    CanonStatement& st = out.statements[i];
    if (st.kind == CanonKind::kToolChange) {
      tool = static_cast<int>(std::lround(st.value));
      continue;
    }
    const ToolSpec* spec = config.process.ToolByNumber(tool);
    if (!spec) continue;  // judged by "tools in the process"
    const double shift = st.length_offset_mm - spec->length_mm;
    st.end_mm.z() += shift;
    if (st.kind != CanonKind::kFeed && st.kind != CanonKind::kProbe) continue;
    if (std::abs(shift) <= kLengthOffsetEpsMm ||
        std::abs(shift) <= out.offset.value)
      continue;
    out.offset.Take(std::abs(shift), i);
    out.detail =
        st.length_offset_tool < 0 && st.length_offset_mm == 0
            ? fmt::format(
                  "feed without tool-length compensation (no G43) on T{} "
                  "({:.3f} mm long): the tip runs {:.3f} mm below the "
                  "programmed point",
                  tool, spec->length_mm, spec->length_mm)
            : fmt::format(
                  "feed with the length offset of H{} ({:.3f} mm) on T{} "
                  "({:.3f} mm long): the tip runs {:.3f} mm {} the "
                  "programmed point",
                  st.length_offset_tool, st.length_offset_mm, tool,
                  spec->length_mm, std::abs(shift),
                  shift < 0 ? "below" : "above");
  }
  return out;
}

// Stage 3: the tool swept along a program through the model, with the
// checks of each move.
struct MoveChecks {
  Worst rapid, rapid_per_axis, travel, adapter, no_spindle, unclamped;
  std::vector<int> unknown_tools;  // statements changing to such a tool
  std::vector<Cut> cuts;           // moves that removed material
};

// `record` false: only removes material (the pre-machining before a test
// cycle), no checks.
void CutProgram(const std::vector<CanonStatement>& program,
                const Config& config, bool record, DexelModel* model,
                MoveChecks* checks) {
  const MachineProfile& machine = config.machine;
  const auto states = gcode::ExecutionStates(program);
  for (int i = 0; i < static_cast<int>(program.size()); ++i) {
    const CanonStatement& st = program[i];
    const gcode::ExecutionState& before = states[i];
    const gcode::ExecutionState& after = states[i + 1];
    if (st.kind == CanonKind::kToolChange) {
      if (record && !config.process.ToolByNumber(after.tool))
        checks->unknown_tools.push_back(i);
      continue;
    }
    if (st.kind != CanonKind::kTraverse && st.kind != CanonKind::kFeed &&
        st.kind != CanonKind::kProbe)
      continue;
    // Travel of the tool tip in M (straight in XYZ: the end points bound it).
    const Eigen::Vector3d m = ProgramToMachine(config, st.end_mm);
    if (record)
      checks->travel.Take(std::max({Excess(m.x(), machine.travel_x_mm),
                                    Excess(m.y(), machine.travel_y_mm),
                                    Excess(m.z(), machine.travel_z_mm)}),
                          i);
    const ToolSpec* spec = config.process.ToolByNumber(before.tool);
    if (!spec) continue;
    const ToolShape tool = ShapeOf(*spec);
    const MoveSweeps move = SweepsOfMove(st, before, tool, config);
    double removed = 0, removed_per_axis = 0;
    for (size_t piece = 0; piece < move.sweeps.size(); ++piece) {
      const Sweep& sw = move.sweeps[piece];
      const double r = model->Cut(sw, record ? i : -1, nullptr);
      if (piece < move.straight_pieces)
        removed = std::max(removed, r);
      else
        removed_per_axis = std::max(removed_per_axis, r);
      if (!record) continue;
      if (const auto pen = AdapterPenetrationMm(sw, tool, config.part))
        checks->adapter.Take(*pen, i);
    }
    if (!record) continue;
    checks->rapid_per_axis.Take(removed_per_axis, i);
    if (removed <= kCutEpsMm) continue;
    if (st.kind == CanonKind::kTraverse) {
      checks->rapid.Take(removed, i);
      continue;
    }
    checks->cuts.push_back(
        {i, st.start_s, st.start_s + st.duration_s, move.from, move.to});
    // A cut with C standing still needs the table clamped; a turning cut
    // (C moving) needs it unclamped.
    const bool turning = std::abs(move.c_to - move.c_from) > 1e-12;
    if (before.c_clamped == turning) checks->unclamped.Take(removed, i);
    if (before.spindle_rpm <= 0) checks->no_spindle.Take(removed, i);
  }
}

// Stage 4: the move checks as findings, with the collision model's.
void AddMoveFindings(const MoveChecks& c,
                     const std::vector<CanonStatement>& statements,
                     const Config& config, std::vector<Finding>* out) {
  {
    Finding f = MakeFinding("tools in the process",
                            static_cast<double>(c.unknown_tools.size()), 0, "");
    if (!c.unknown_tools.empty()) {
      SetWhere(&f, statements, c.unknown_tools.front());
      f.detail = "tool change to a tool that is not in the process";
    }
    out->push_back(f);
  }
  const auto add = [&](const char* check, const Worst& w, double limit,
                       const char* unit, const char* detail) {
    Finding f = MakeFinding(check, w.value, limit, unit);
    SetWhere(&f, statements, w.statement);
    if (!f.pass && detail) f.detail = detail;
    out->push_back(f);
  };
  add("rapid cuts no material (straight rapids)", c.rapid, kCutEpsMm, "mm",
      "material removed by a rapid move");
  add("rapid cuts no material (per-axis rapids)", c.rapid_per_axis, kCutEpsMm,
      "mm",
      "material removed by a rapid when each axis runs at its own rate "
      "(dog-leg)");
  add("C clamped while cutting, free while turning", c.unclamped, kCutEpsMm,
      "mm",
      "a cut with C standing and unclamped, or a turning cut "
      "with C clamped");
  for (Finding& f : CheckMachine(statements, config)) out->push_back(f);
  add("spindle turns while cutting", c.no_spindle, kCutEpsMm, "mm", nullptr);
  add("within machine travel", c.travel, 0, "mm",
      "tool tip beyond the travel of the machine");
  add("adapter not cut", c.adapter, 0, "mm",
      "tool enters the adapter below the piece");
}

// Stage 5: every probe ray must end its first material interval at the
// nominal surface (s = kProbeInsideMm).
void AddSurfaceFindings(const SimulationModel& sim,
                        const std::vector<CanonStatement>& statements,
                        const VerifyOptions& options,
                        std::vector<Finding>* out) {
  const auto& rays = sim.model.rays();
  for (const Probe& probe : sim.probes) {
    double worst = 0, signed_worst = 0;
    int worst_ray = -1;
    for (int index : probe.rays) {
      const Ray& ray = rays[index];
      // The outermost material boundary along the outward normal (a ray
      // may start in a neighbouring notch); nothing left: below the start.
      const double surface =
          ray.material.empty() ? 0.0 : ray.material.back().second;
      const double dev = surface - kProbeInsideMm;
      if (worst_ray < 0 || std::abs(dev) > worst) {
        worst = std::abs(dev);
        signed_worst = dev;
        worst_ray = index;
      }
    }
    Finding f = MakeFinding("surface " + probe.id, worst * 1000,
                            options.surface_tolerance_mm * 1000, "um");
    if (worst_ray >= 0) {
      const Ray& ray = rays[worst_ray];
      SetWhere(&f, statements, ray.last_cut_statement);
      const Eigen::Vector3d at = ray.origin + kProbeInsideMm * ray.direction;
      if (std::abs(signed_worst) * 1000 < 0.05)
        f.detail = fmt::format("{} rays; all within 0.05 um of nominal",
                               probe.rays.size());
      else
        f.detail = fmt::format(
            "{} rays; worst {:+.1f} um ({}) at W ({:.2f}, {:.2f}, {:.2f})",
            probe.rays.size(), signed_worst * 1000,
            signed_worst > 0 ? "material left" : "cut too deep", at.x(), at.y(),
            at.z());
      if (ray.last_cut_statement < 0 && !f.pass) f.detail += ", never cut";
    }
    out->push_back(f);
  }
}

// Stage 6 (test cycle): Z fixed while cutting, the cycle count, and every
// cycle's feed moves repeating cycle 0's but for the strip's Y shift.
void AddCycleFindings(const std::vector<Cut>& cuts,
                      const std::vector<CanonStatement>& statements,
                      const Config& config, const VerifyOptions& options,
                      std::vector<Finding>* out) {
  const PartSpec& part = config.part;
  const MachineProfile& machine = config.machine;
  // Z fixed while cutting.
  double worst_z = 0;
  int z_at = -1;
  for (const Cut& c : cuts) {
    const double dz = std::max(std::abs(c.from.z() - cuts.front().from.z()),
                               std::abs(c.to.z() - cuts.front().from.z()));
    if (dz > worst_z) {
      worst_z = dz;
      z_at = c.statement;
    }
  }
  Finding fz = MakeFinding("Z fixed while cutting", worst_z,
                           options.axis_tolerance_mm, "mm");
  SetWhere(&fz, statements, z_at);
  out->push_back(fz);

  // Cycles: groups of cuts separated by long pauses.
  std::vector<std::vector<Cut>> cycles;
  for (const Cut& c : cuts) {
    if (cycles.empty() || c.start_s - cycles.back().back().end_s >
                              config.process.cycle_period_s / 4)
      cycles.emplace_back();
    cycles.back().push_back(c);
  }
  Finding fc = MakeFinding(
      "cycle count",
      std::abs(static_cast<double>(cycles.size()) - (part.cycles() + 1)), 0,
      "");
  fc.detail = fmt::format("{} groups of cuts, {} expected", cycles.size(),
                          part.cycles() + 1);
  out->push_back(fc);

  // Every feed move inside a cycle's time window (first to last cut)
  // must repeat cycle 0's, up to the strip's Y shift.
  std::vector<std::vector<int>> feeds(cycles.size());
  for (size_t k = 0; k < cycles.size(); ++k)
    for (int i = cycles[k].front().statement; i <= cycles[k].back().statement;
         ++i)
      // Positioning moves (G1 at the profile's positioning feed between
      // cuts) may differ; every other feed must repeat.
      if (statements[i].kind == CanonKind::kFeed &&
          std::abs(statements[i].feed_per_min -
                   machine.positioning_feed_mm_min) > 1e-6)
        feeds[k].push_back(i);
  const auto start_of = [&](int i) {
    for (int j = i - 1; j >= 0; --j)
      if (statements[j].kind != CanonKind::kToolChange)
        return statements[j].end_mm;
    return Eigen::Vector3d(Eigen::Vector3d::Zero());
  };
  double worst_axes = 0;
  int axes_at = -1;
  std::string axes_detail;
  for (size_t k = 1; k < cycles.size(); ++k) {
    const auto& ref = feeds.front();
    const auto& cyc = feeds[k];
    if (cyc.size() != ref.size()) {
      worst_axes = std::numeric_limits<double>::infinity();
      axes_at = cyc.empty() ? -1 : cyc.front();
      axes_detail = fmt::format("cycle {} has {} feed moves, cycle 0 {}", k,
                                cyc.size(), ref.size());
      break;
    }
    const int cycle = std::min<int>(static_cast<int>(k), part.cycles());
    const double shift = StripY(part, IndexForCycle(part, cycle)) -
                         StripY(part, IndexForCycle(part, 0));
    for (size_t i = 0; i < cyc.size(); ++i)
      for (const auto& [p, q] :
           {std::pair{start_of(cyc[i]), start_of(ref[i])},
            std::pair{statements[cyc[i]].end_mm, statements[ref[i]].end_mm}}) {
        const Eigen::Vector3d d = p - q;
        const double dev =
            std::max({std::abs(d.x()), std::abs(d.z()),
                      std::min(std::abs(d.y()), std::abs(d.y() - shift))});
        if (dev > worst_axes) {
          worst_axes = dev;
          axes_at = cyc[i];
          axes_detail = fmt::format("cycle {} vs cycle 0", k);
        }
      }
  }
  Finding fa = MakeFinding("only C changes between cycles", worst_axes,
                           options.axis_tolerance_mm, "mm");
  SetWhere(&fa, statements, axes_at);
  fa.detail = axes_detail;
  out->push_back(fa);
}

}  // namespace

VerifyReport VerifyStatements(const std::vector<CanonStatement>& statements,
                              const Config& config,
                              const VerifyOptions& options,
                              const std::string& source) {
  VerifyReport report;
  report.stage = options.stage;
  report.source = source;
  report.statements = static_cast<int>(statements.size());
  SimulationModel sim;
  BuildSimulationModel(config, options, &sim);
  report.probe_rays = sim.probe_rays;
  report.rays = sim.rays;
  MoveChecks checks;
  if (options.after)
    CutProgram(ToolTipPath(*options.after, config).statements, config, false,
               &sim.model, &checks);
  const TipPath tip = ToolTipPath(statements, config);
  {
    Finding f = MakeFinding("tool-length offset of the tool in the spindle",
                            tip.offset.value, kLengthOffsetEpsMm, "mm");
    SetWhere(&f, tip.statements, tip.offset.statement);
    if (!f.pass) f.detail = tip.detail;
    report.findings.push_back(f);
  }
  CutProgram(tip.statements, config, true, &sim.model, &checks);
  AddMoveFindings(checks, tip.statements, config, &report.findings);
  AddSurfaceFindings(sim, tip.statements, options, &report.findings);
  if (options.stage == VerifyStage::kCycle)
    AddCycleFindings(checks.cuts, tip.statements, config, options,
                     &report.findings);
  return report;
}

nlohmann::json ReportToJson(const VerifyReport& report) {
  nlohmann::json doc;
  doc["source"] = report.source;
  doc["stage"] = StageName(report.stage);
  doc["statements"] = report.statements;
  doc["rays"] = report.rays;
  doc["probe_rays"] = report.probe_rays;
  doc["passed"] = report.AllPassed();
  nlohmann::json list = nlohmann::json::array();
  for (const Finding& f : report.findings) {
    nlohmann::json j;
    j["check"] = f.check;
    j["pass"] = f.pass;
    j["measured"] = std::isfinite(f.measured) ? nlohmann::json(f.measured)
                                              : nlohmann::json(nullptr);
    j["limit"] = f.limit;
    j["unit"] = f.unit;
    j["statement"] = f.statement;
    j["line"] = f.source_line;
    j["detail"] = f.detail;
    list.push_back(j);
  }
  doc["findings"] = list;
  return doc;
}

std::string FormatReportTable(const VerifyReport& report, bool verbose) {
  const auto failed = report.Failed();
  int surfaces = 0;
  for (const Finding& f : report.findings)
    if (f.check.rfind("surface ", 0) == 0) ++surfaces;
  std::string out = fmt::format(
      "verify {} (stage {}): {} statements; {} of {} checks passed\n"
      "  checked: {} feature surfaces against the drawing ({} probe rays), "
      "rapids under straight and per-axis semantics, tool and holder against "
      "the table, clamps, adapter and R-test sphere and stem, what C sweeps "
      "while turning, tool changes, C clamping, spindle, travel\n",
      report.source, StageName(report.stage), report.statements,
      report.findings.size() - failed.size(), report.findings.size(), surfaces,
      report.probe_rays);
  for (const Finding* f : failed) {
    out += fmt::format("  FAIL {}: {:.4f} {} (limit {:.4f})", f->check,
                       f->measured, f->unit, f->limit);
    if (f->source_line > 0)
      out += fmt::format(", line {} of {}", f->source_line, report.source);
    if (!f->detail.empty()) out += "; " + f->detail;
    out += "\n";
  }
  out += failed.empty() ? "  all checks passed\n"
                        : fmt::format("  {} check(s) failed\n", failed.size());
  if (!verbose) return out;
  out +=
      fmt::format("{:<4} {:<44} {:>12} {:>10} {:<3} {:>6} {:>6}  {}\n", "",
                  "check", "measured", "limit", "", "stmt", "line", "detail");
  std::vector<const Finding*> order = failed;
  for (const Finding& f : report.findings)
    if (f.pass) order.push_back(&f);
  for (const Finding* f : order) {
    out += fmt::format(
        "{:<4} {:<44} {:>12.4f} {:>10.4f} {:<3} {:>6} {:>6}  {}\n",
        f->pass ? "ok" : "FAIL", f->check, f->measured, f->limit, f->unit,
        f->statement >= 0 ? std::to_string(f->statement) : "-",
        f->source_line > 0 ? std::to_string(f->source_line) : "-", f->detail);
  }
  return out;
}

}  // namespace ttp::verify
