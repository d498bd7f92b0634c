#include "ttp/plan/probe_program.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ttp/gcode/writer.h"
#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/limits.h"

namespace ttp::plan {
namespace {

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
    if (p.feature.kind == FeatureKind::kStrip)
      consider(part.big_notch_half_width_mm - std::abs(centre.y()) - r,
               "a big-notch flank");
    return best;
  }
  // Horizontal approach: the shoulders of the reference cylinders below or
  // beside the contact (other than the touched cylinder).
  for (const RefCylinder& c : part.ref_cylinders) {
    if (p.feature == FeatureId::Cylinder(c.diameter_mm)) continue;
    consider(BandDistanceMm(centre, c) - r,
             "the shoulder of " + CylinderId(c.diameter_mm));
  }
  if (p.feature.kind == FeatureKind::kFlank) {
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
  const FeatureId datum = FeatureId::DatumCylinder(part);
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
                    2 * r, datum.ToString(), z_lo, z_hi,
                    probe.min_ball_clearance_mm));
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
                      2 * r, p.id, p.feature.ToString(), p.point_w_mm.x(),
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
  FeatureId feature;
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
      if (p.feature.kind == FeatureKind::kCylinder || radial > 90.0)
        t.standoff_mm =
            std::max(t.standoff_mm, widest_radius_mm + 1.0 - radial);
    }
    out.push_back(t);
  }
  return out;
}

// The probing program as program IR statements, written by the gcode
// writer like the cycle programs.
class ProgramBuilder {
 public:
  ProgramBuilder(const Config& config, gcode::Dialect dialect,
                 const ProbeOptions& options, double travel_z_mm)
      : config_(config),
        dialect_(dialect),
        options_(options),
        travel_z_(travel_z_mm) {}

  gcode::Program Build(const std::vector<Touch>& touches, size_t n_points) {
    const MachineProfile& m = config_.machine;
    const ToolSpec& probe = config_.process.probe;
    program_.name = "probe";
    program_.number = m.program_number + 2;
    program_.title = "TTP ON-MACHINE PROBING OF THE FINISHED PIECE";
    program_.exact_stop = true;
    Comment(fmt::format(
        "touch probe T{}, ball {:.3f} mm; {} points; log: {}", probe.number,
        probe.diameter_mm, n_points,
        dialect_ == gcode::Dialect::kFanuc ? "DPRNT port" : options_.log_file));
    Add(gcode::BZeroClamp{});
    // Tool change at the tool-change position, away from piece and sphere.
    const auto& tc = m.tool_change_position_m_mm;
    Add(gcode::SpindleOff{});
    Add(gcode::MachineRapid{Z(tc[2])});
    Add(gcode::MachineRapid{XY(tc[0], tc[1])});
    Add(gcode::ToolChange{probe.number, probe.name});
    // The probe must not turn: spindle stopped and oriented.
    Add(gcode::SpindleOff{});
    Add(gcode::SpindleOrient{});
    Add(gcode::LengthOffset{probe.number, travel_z_});
    Add(gcode::ProbeSignal{true});
    Add(gcode::ProbeLog{true, options_.log_file});
    ProbePass pass = ProbePass::kMeasure;
    bool first = true;
    for (const Touch& t : touches) {
      if (first || t.pass != pass) {
        pass = t.pass;
        Comment(pass == ProbePass::kQualify
                    ? "stylus qualification on the R-test sphere"
                : pass == ProbePass::kMeasure
                    ? "measurement"
                    : "drift: reference facets again");
      }
      first = false;
      AddTouch(t);
    }
    Add(gcode::Rapid{Z(travel_z_)});
    Index(0.0);
    Add(gcode::ProbeSignal{false});
    Add(gcode::ProbeLog{false, options_.log_file});
    Add(gcode::MachineRapid{Z(tc[2])});
    Add(gcode::ProgramEnd{});
    return std::move(program_);
  }

 private:
  static gcode::Axes Z(double z) {
    gcode::Axes a;
    a.z_mm = z;
    return a;
  }
  static gcode::Axes XY(double x, double y) {
    gcode::Axes a;
    a.x_mm = x;
    a.y_mm = y;
    return a;
  }
  static gcode::Axes Along(int axis, double v) {
    gcode::Axes a;
    (axis == 0 ? a.x_mm : axis == 1 ? a.y_mm : a.z_mm) = v;
    return a;
  }
  void Add(gcode::Statement s) { program_.statements.push_back(std::move(s)); }
  void Comment(std::string text) { Add(gcode::Comment{std::move(text)}); }

  void Index(double c_deg) {
    if (c_ && std::abs(*c_ - c_deg) < 1e-9) return;
    // Absolute C: with roll-over the control takes the short way to the
    // angle; the reported C may then be the angle modulo 360.
    gcode::Axes c;
    c.c_deg = c_deg;
    Add(gcode::TableClamp{false});
    Add(gcode::Rapid{c});
    Add(gcode::TableClamp{true});
    c_ = c_deg;
  }

  void AddTouch(const Touch& t) {
    const Eigen::Vector3d start = t.contact + t.standoff_mm * t.normal;
    const Eigen::Vector3d end = t.contact - options_.overtravel_mm * t.normal;
    int axis = 0;
    for (int a = 1; a < 3; ++a)
      if (std::abs(t.normal[a]) > std::abs(t.normal[axis])) axis = a;
    Comment(fmt::format("{} {} on {}", ProbePassName(t.pass), t.id,
                        t.feature.ToString()));
    Add(gcode::Rapid{Z(travel_z_)});
    Index(t.c_deg);
    Add(gcode::Rapid{XY(start.x(), start.y())});
    Add(gcode::Rapid{Z(start.z())});
    gcode::Probe probe{Along(axis, end[axis]),
                       config_.process.probe.feed_mm_min, t.id};
    probe.feature = t.feature.ToString();  // NC text
    probe.pass = ProbePassName(t.pass);
    probe.nominal_mm = t.contact[axis];
    probe.touch_window_mm = options_.touch_window_mm;
    probe.alarm = t.pass == ProbePass::kQualify ? 2
                  : t.pass == ProbePass::kDrift ? 3
                                                : 1;
    Add(probe);
    // Back off along the approach before lifting: never drag the stylus.
    Add(gcode::Rapid{Along(axis, start[axis])});
  }

  const Config& config_;
  gcode::Dialect dialect_;
  const ProbeOptions& options_;
  double travel_z_;
  std::optional<double> c_;
  gcode::Program program_;
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
      t.feature = FeatureId::Sphere();
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
        if (p.feature == FeatureId::Facet(s, config.part.reference_index))
          reference.push_back(p);
    for (const Touch& t :
         PieceTouches(config, reference, options, ProbePass::kDrift))
      touches.push_back(t);
  }
  return gcode::WriteProgram(ProgramBuilder(config, dialect, options, travel_z)
                                 .Build(touches, points.size()),
                             dialect, config);
}

}  // namespace ttp::plan
