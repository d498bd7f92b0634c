#include "ttp/plan/probe_program.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/limits.h"

namespace ttp::plan {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// C in (-180, 180] for a short index.
double ShortAngleDeg(double deg) {
  double c = std::remainder(deg, 360.0);
  if (c == -180.0) c = 180.0;
  return c + 0.0;  // no -0
}

// Distance from a ball centre (W) to the solid band of a reference
// cylinder (radius R for z in [bottom, top]), in the (radius, z) plane.
double BandDistanceMm(const Eigen::Vector3d& centre, const RefCylinder& c) {
  const double dr = std::max(0.0, centre.head<2>().norm() - c.diameter_mm / 2);
  const double dz =
      std::max({0.0, c.z_bottom_mm - centre.z(), centre.z() - c.z_top_mm});
  return std::hypot(dr, dz);
}

bool Vertical(const PlannedPoint& p) {
  return std::abs(p.normal_w.z()) > 0.999;
}

// Smallest clearance (mm, ball surface to obstacle) of a ball of radius r
// touching p, and what it comes closest to.
double BallClearanceMm(const PartSpec& part, const PlannedPoint& p, double r,
                       std::string* obstacle) {
  const Eigen::Vector3d centre = p.point_w_mm + r * p.normal_w;
  double best = 1e9;
  const auto consider = [&](double clearance, const std::string& what) {
    if (clearance < best) {
      best = clearance;
      *obstacle = what;
    }
  };
  if (Vertical(p)) {
    // Down onto a floor: the walls beside it (strips lie between the
    // big-notch flanks).
    if (p.feature.rfind("Z", 0) == 0)
      consider(part.big_notch_half_width_mm - std::abs(centre.y()) - r,
               "a big-notch flank");
    return best;
  }
  // Horizontal approach: the shoulders of the reference cylinders below or
  // beside the contact (other than the touched cylinder).
  for (const RefCylinder& c : part.ref_cylinders) {
    if (p.feature == CylinderId(c.diameter_mm)) continue;
    consider(BandDistanceMm(centre, c) - r,
             "the shoulder of " + CylinderId(c.diameter_mm));
  }
  if (p.feature.rfind("FLANK", 0) == 0) {
    const double floor =
        std::max(part.big_notch_floor_z_mm, part.strip_floor_z_mm);
    consider(centre.z() - r - floor, "the big-notch floor");
    consider(2 * part.big_notch_half_width_mm - 2 * r, "the opposite flank");
  }
  return best;
}

void Check(bool ok, const char* field, const std::string& problem) {
  if (!ok) throw InputError("ProbeOptions", 0, field, problem);
}

}  // namespace

const char* ProbePassName(ProbePass pass) {
  switch (pass) {
    case ProbePass::kQualify:
      return "qualify";
    case ProbePass::kMeasure:
      return "measure";
    case ProbePass::kDrift:
      return "drift";
  }
  return "?";
}

bool ProbeOptions::IsValid(std::string* error) const {
  try {
    Validate();
  } catch (const InputError& e) {
    if (error)
      *error = std::string("ProbeOptions.") + e.field() + ": " + e.problem();
    return false;
  }
  return true;
}

void ProbeOptions::Validate() const {
  Check(clearance_mm > 0 && clearance_mm <= 100, "clearance_mm",
        fmt::format("{:g} mm is not in (0, 100] mm", clearance_mm));
  // The probing move ends overtravel_mm beyond the nominal surface: on the
  // strips and the top face that is downwards, towards the table. A probe
  // overtravels a few millimetres at most before its stylus breaks.
  Check(overtravel_mm > 0 && overtravel_mm <= limits::kMaxOvertravelMm,
        "overtravel_mm",
        fmt::format("{:g} mm is not in (0, {:g}] mm (further would drive the "
                    "stylus through the piece towards the table)",
                    overtravel_mm, limits::kMaxOvertravelMm));
  Check(safe_z_mm > 0 && safe_z_mm <= 1000, "safe_z_mm",
        fmt::format("{:g} mm is not above the top face (> 0) and within "
                    "1000 mm",
                    safe_z_mm));
  // A missing touch leaves the skip position overtravel_mm beyond the
  // nominal: the window must be narrower to see it.
  Check(touch_window_mm > 0 && touch_window_mm < overtravel_mm &&
            touch_window_mm < clearance_mm,
        "touch_window_mm",
        fmt::format("{:g} mm is not in (0, min(overtravel_mm, clearance_mm))",
                    touch_window_mm));
  Check(min_ball_clearance_mm >= 0 && min_ball_clearance_mm <= 10,
        "min_ball_clearance_mm",
        fmt::format("{:g} mm is not in [0, 10] mm", min_ball_clearance_mm));
  Check(!log_file.empty() && log_file.size() <= 200 &&
            log_file.find_first_of(" \t,()\n\r") == std::string::npos,
        "log_file",
        "must be a file name of at most 200 characters without spaces, "
        "commas or parentheses");
}

std::vector<PlannedPoint> PlanProbePoints(const Config& config,
                                          const PlanOptions& plan,
                                          const ProbeOptions& probe) {
  probe.Validate();
  std::vector<PlannedPoint> points = PlanPoints(config.part, plan);
  const PartSpec& part = config.part;
  const double r = config.process.probe.diameter_mm / 2;
  const std::string datum = DatumCylinderId(part);
  // The datum circle's touches: the lowest height in its band where the
  // ball clears the shoulder below (a ball in the middle of a 2 mm band
  // reaches the next larger cylinder first).
  const double z_lo = part.datum_circle_z_min_mm;
  const double z_hi = part.datum_circle_z_max_mm;
  const double z_mid = (z_lo + z_hi) / 2;
  std::optional<double> z_ok;
  for (int i = 0; z_mid + 0.05 * i <= z_hi + 1e-9; ++i) {
    const double z = z_mid + 0.05 * i;
    bool ok = true;
    for (const PlannedPoint& p : points) {
      if (p.feature != datum) continue;
      PlannedPoint q = p;
      q.point_w_mm.z() = z;
      std::string what;
      ok = ok &&
           BallClearanceMm(part, q, r, &what) >= probe.min_ball_clearance_mm;
    }
    if (ok) {
      z_ok = z;
      break;
    }
  }
  if (!z_ok)
    throw InputError(
        "config", 0, "process.probe.diameter_mm",
        fmt::format("a {:g} mm ball cannot touch {} in its datum band z = "
                    "{:g}..{:g} mm (part.datum_circle_z_min_mm/_max_mm) "
                    "{:g} mm clear of the next cylinder's shoulder: use a "
                    "smaller stylus",
                    2 * r, datum, z_lo, z_hi, probe.min_ball_clearance_mm));
  for (PlannedPoint& p : points)
    if (p.feature == datum) p.point_w_mm.z() = *z_ok;
  CheckBallReach(config, points, probe);
  return points;
}

void CheckBallReach(const Config& config,
                    const std::vector<PlannedPoint>& points,
                    const ProbeOptions& options) {
  const double r = config.process.probe.diameter_mm / 2;
  for (const PlannedPoint& p : points) {
    std::string what;
    const double clearance = BallClearanceMm(config.part, p, r, &what);
    if (clearance < options.min_ball_clearance_mm)
      throw InputError(
          "config", 0, "process.probe.diameter_mm",
          fmt::format("a {:g} mm ball touching point {} on {} at ({:.3f}, "
                      "{:.3f}, {:.3f}) comes within {:.3f} mm of {} "
                      "(ProbeOptions.min_ball_clearance_mm = {:g}): it cannot "
                      "reach the feature; use a smaller stylus or move the "
                      "points (PlanOptions.edge_margin_mm)",
                      2 * r, p.id, p.feature, p.point_w_mm.x(),
                      p.point_w_mm.y(), p.point_w_mm.z(), clearance, what,
                      options.min_ball_clearance_mm));
  }
}

SphereQualification PlanSphereQualification(const Config& config) {
  const MachineProfile& m = config.machine;
  SphereQualification q;
  q.radius_mm = m.sphere_radius_mm;
  // Sphere onto machine +X: outside the piece, reached along X.
  q.c_deg = ShortAngleDeg(
      TableAngleFor(m.sphere_phi_deg * kDeg, 0.0, m.c_sense) / kDeg);
  q.centre_program_mm = MachineToProgram(
      config, Eigen::Vector3d(m.sphere_distance_mm, 0,
                              m.table_top_z_mm + m.sphere_height_mm));
  const Eigen::Vector3d dirs[5] = {
      Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(),
      -Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
      -Eigen::Vector3d::UnitY()};
  for (int i = 0; i < 5; ++i) q.touches.push_back({i + 1, dirs[i]});
  return q;
}

namespace {

// One probing move in the program frame: the stylus centre at the nominal
// contact, the outward normal (an axis direction) and where the move
// starts.
struct Touch {
  ProbePass pass = ProbePass::kMeasure;
  int id = 0;
  std::string feature;
  double c_deg = 0;
  Eigen::Vector3d contact = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double standoff_mm = 0;
};

std::vector<Touch> PieceTouches(const Config& config,
                                const std::vector<PlannedPoint>& points,
                                const ProbeOptions& options, ProbePass pass) {
  const double r = config.process.probe.diameter_mm / 2;
  const int sense = config.machine.c_sense;
  // Horizontal start positions clear the piece's widest part below the
  // point.
  double widest_radius_mm = 0;
  for (const RefCylinder& c : config.part.ref_cylinders)
    widest_radius_mm = std::max(widest_radius_mm, c.diameter_mm / 2);
  std::vector<Touch> out;
  for (const PlannedPoint& p : points) {
    const Eigen::Vector3d& n = p.normal_w;
    const bool vertical = Vertical(p);
    if (!vertical && std::abs(n.z()) > 1e-9)
      throw InputError("plan", p.id, "normal",
                       "only horizontal and vertical normals can be probed "
                       "with one linear axis");
    if (vertical && n.z() < 0)
      throw InputError("plan", p.id, "normal",
                       "a downward normal cannot be probed from above");
    // Horizontal normals along machine +X.
    Touch t;
    t.pass = pass;
    t.id = p.id;
    t.feature = p.feature;
    t.c_deg =
        vertical
            ? 0.0
            : ShortAngleDeg(
                  TableAngleFor(std::atan2(n.y(), n.x()), 0.0, sense) / kDeg);
    const double c_rad = t.c_deg * kDeg;
    t.normal = vertical ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    t.contact = MachineToProgram(
                    config, WorkpieceToMachine(config, p.point_w_mm, c_rad)) +
                r * t.normal;
    t.standoff_mm = options.clearance_mm;
    if (!vertical) {
      const double radial = p.point_w_mm.head<2>().norm();
      if (p.feature.rfind("CYL", 0) == 0 || radial > 90.0)
        t.standoff_mm =
            std::max(t.standoff_mm, widest_radius_mm + 1.0 - radial);
    }
    out.push_back(t);
  }
  return out;
}

class ProgramText {
 public:
  ProgramText(const Config& config, gcode::Dialect dialect,
              const ProbeOptions& options)
      : config_(config),
        fanuc_(dialect == gcode::Dialect::kFanuc),
        options_(options) {}

  std::string Build(const std::vector<Touch>& touches, size_t n_points) {
    const MachineProfile& m = config_.machine;
    const ToolSpec& probe = config_.process.probe;
    const int number = m.program_number + 2;
    const std::string title = "TTP ON-MACHINE PROBING OF THE FINISHED PIECE";
    Line("%");
    if (fanuc_) {
      Line(fmt::format("O{} ({})", number, title));
      Line("G17 G21 G40 G49 G69 G80 G90 G94");
    } else {
      Line(fmt::format("({})", title));
      // Exact stop: every move ends where it is programmed.
      Line("G17 G21 G40 G49 G80 G90 G94 G61");
    }
    Line("G54");
    Line(fmt::format("(touch probe T{}, ball {:.3f} mm; {} points; log: {})",
                     probe.number, probe.diameter_mm, n_points,
                     fanuc_ ? "DPRNT port" : options_.log_file));
    // B at 0 and clamped.
    if (fanuc_) {
      Line(fmt::format("M{}", m.m_b_unclamp));
      Line("G0 B0.000");
      Line(fmt::format("M{}", m.m_b_clamp));
    } else {
      Line(fmt::format("M65 P{}", m.linuxcnc_b_clamp_output));
      Line("G0 B0.000");
      Line(fmt::format("M64 P{}", m.linuxcnc_b_clamp_output));
    }
    // Tool change at the tool-change position, away from piece and sphere.
    const auto& tc = m.tool_change_position_m_mm;
    Line("M5");
    Line(fmt::format("G49 G53 G0 Z{}", Mm(tc[2])));
    Line(fmt::format("G53 G0 X{} Y{}", Mm(tc[0]), Mm(tc[1])));
    Line(fmt::format("(T{} {})", probe.number, Safe(probe.name)));
    Line(fmt::format("T{} M6", probe.number));
    // The probe must not turn: spindle stopped and oriented.
    Line("M5");
    Line(fmt::format("M19{}", fanuc_ ? "" : " R0"));
    Line(fmt::format("G0 G43 H{} Z{}", probe.number, Mm(travel_z_)));
    Line(fanuc_ ? fmt::format("M{}", m.m_probe_on)
                : fmt::format("M64 P{}", m.linuxcnc_probe_output));
    if (fanuc_) {
      Line("POPEN");
      Line(fmt::format("DPRNT[TTP*PROBE*LOG*O{}*D#3011[80]*T#3012[60]]",
                       number));
    } else {
      Line(fmt::format("(LOGOPEN,{})", options_.log_file));
      Line("(LOG,point_id,x,y,z,c_deg,feature,pass)");
    }
    ProbePass pass = ProbePass::kMeasure;
    bool first = true;
    for (const Touch& t : touches) {
      if (first || t.pass != pass) {
        pass = t.pass;
        Line(fmt::format("({})", pass == ProbePass::kQualify
                                     ? "stylus qualification on the R-test "
                                       "sphere"
                                 : pass == ProbePass::kMeasure
                                     ? "measurement"
                                     : "drift: reference facets again"));
      }
      first = false;
      Emit(t);
    }
    Line(fmt::format("G0 Z{}", Mm(travel_z_)));
    Index(0.0);
    Line(fanuc_ ? fmt::format("M{}", m.m_probe_off)
                : fmt::format("M65 P{}", m.linuxcnc_probe_output));
    Line(fanuc_ ? "PCLOS" : "(LOGCLOSE)");
    Line(fmt::format("G49 G53 G0 Z{}", Mm(tc[2])));
    Line("M30");
    Line("%");
    return out_;
  }

  void SetTravelZ(double z) { travel_z_ = z; }

 private:
  static std::string Mm(double v) {
    if (!std::isfinite(v))
      throw InputError("probe program", 0, "coordinate", "not finite");
    return fmt::format("{:.4f}", v + 0.0);
  }
  static std::string Safe(std::string text) {
    for (char& ch : text)
      if (ch == '(' || ch == ')' || ch == '\n' || ch == '\r') ch = ' ';
    return text;
  }
  void Line(const std::string& text) { out_ += text + "\n"; }

  void Index(double c_deg) {
    if (c_ && std::abs(*c_ - c_deg) < 1e-9) return;
    const MachineProfile& m = config_.machine;
    // Absolute C: with roll-over the control takes the short way to the
    // angle; the reported C may then be the angle modulo 360.
    if (fanuc_) {
      Line(fmt::format("M{}", m.m_table_unclamp));
      Line(fmt::format("G0 C{:.3f}", c_deg));
      Line(fmt::format("M{}", m.m_table_clamp));
    } else {
      Line(fmt::format("M65 P{}", m.linuxcnc_c_clamp_output));
      Line(fmt::format("G0 C{:.3f}", c_deg));
      Line(fmt::format("M64 P{}", m.linuxcnc_c_clamp_output));
    }
    c_ = c_deg;
  }

  void Emit(const Touch& t) {
    const MachineProfile& m = config_.machine;
    const Eigen::Vector3d start = t.contact + t.standoff_mm * t.normal;
    const Eigen::Vector3d end = t.contact - options_.overtravel_mm * t.normal;
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(t.normal[a]) > std::abs(t.normal[axis])) axis = a;
    const char letters[3] = {'X', 'Y', 'Z'};
    Line(fmt::format("({} {} on {})", ProbePassName(t.pass), t.id, t.feature));
    Line(fmt::format("G0 Z{}", Mm(travel_z_)));
    Index(t.c_deg);
    Line(fmt::format("G0 X{} Y{}", Mm(start.x()), Mm(start.y())));
    Line(fmt::format("G0 Z{}", Mm(start.z())));
    const std::string feed =
        fmt::format("{:.1f}", config_.process.probe.feed_mm_min);
    Line(fmt::format("{} {}{} F{}", fanuc_ ? "G31" : "G38.2", letters[axis],
                     Mm(end[axis]), feed));
    const char* pass = ProbePassName(t.pass);
    if (fanuc_) {
      const auto& v = m.fanuc_skip_variables;
      const int alarm = t.pass == ProbePass::kQualify ? 2
                        : t.pass == ProbePass::kDrift ? 3
                                                      : 1;
      // #var - nominal with the sign folded into the operator (no "--").
      const double nominal = t.contact[axis] + 0.0;
      Line(
          fmt::format("IF [ABS[#{}{}{}] GT {:.4f}] THEN #3000={} (NO TOUCH "
                      "{} {})",
                      v[axis], nominal < 0 ? "+" : "-", Mm(std::abs(nominal)),
                      options_.touch_window_mm, alarm, Upper(pass), t.id));
      Line(
          fmt::format("DPRNT[{}*{}*{}*X#{}[44]*Y#{}[44]*Z#{}[44]*C#{}[33]*"
                      "T#3012[60]]",
                      Upper(pass), t.id, t.feature, v[0], v[1], v[2], v[3]));
    } else {
      const auto& v = m.linuxcnc_probe_variables;
      Line(fmt::format("(LOG,{},#{},#{},#{},#{},{},{})", t.id, v[0], v[1], v[2],
                       v[3], t.feature, pass));
    }
    // Back off along the approach before lifting: never drag the stylus.
    Line(fmt::format("G0 {}{}", letters[axis], Mm(start[axis])));
  }

  static std::string Upper(std::string s) {
    for (char& ch : s) ch = static_cast<char>(std::toupper(ch));
    return s;
  }

  const Config& config_;
  bool fanuc_;
  const ProbeOptions& options_;
  double travel_z_ = 0;
  std::optional<double> c_;
  std::string out_;
};

}  // namespace

std::string WriteProbeProgram(const Config& config,
                              const std::vector<PlannedPoint>& points,
                              gcode::Dialect dialect,
                              const ProbeOptions& options) {
  options.Validate();
  CheckBallReach(config, points, options);
  const double r = config.process.probe.diameter_mm / 2;
  std::vector<Touch> touches;
  // Moves across happen above the piece and above the R-test sphere (it
  // turns with C).
  const SphereQualification sphere = PlanSphereQualification(config);
  double travel_z = options.safe_z_mm;
  const double sphere_top = sphere.centre_program_mm.z() + sphere.radius_mm +
                            r + options.clearance_mm;
  travel_z = std::max(travel_z, sphere_top);
  if (options.qualify) {
    for (const SphereTouch& s : sphere.touches) {
      Touch t;
      t.pass = ProbePass::kQualify;
      t.id = s.id;
      t.feature = "SPHERE";
      t.c_deg = sphere.c_deg;
      t.normal = s.normal_m;
      t.contact =
          sphere.centre_program_mm + (sphere.radius_mm + r) * s.normal_m;
      t.standoff_mm = options.clearance_mm;
      touches.push_back(t);
    }
  }
  for (const Touch& t :
       PieceTouches(config, points, options, ProbePass::kMeasure))
    touches.push_back(t);
  if (options.drift) {
    std::vector<PlannedPoint> reference;
    for (const PlannedPoint& p : points)
      for (Segment s : kSegments)
        if (p.feature == FacetId(s, config.part.reference_index))
          reference.push_back(p);
    for (const Touch& t :
         PieceTouches(config, reference, options, ProbePass::kDrift))
      touches.push_back(t);
  }
  ProgramText text(config, dialect, options);
  text.SetTravelZ(travel_z);
  return text.Build(touches, points.size());
}

}  // namespace ttp::plan
