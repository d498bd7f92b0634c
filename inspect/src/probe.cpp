#include "ttp/inspect/probe.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <cerrno>
#include <cmath>
#include <limits>
#include <map>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/fit.h"
#include "ttp/geometry/frames.h"
#include "ttp/inspect/plane_result.h"
#include "ttp/plan/plan.h"

namespace ttp::inspect {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct Touch {
  Eigen::Vector3d w;  // surface point in W (nominal placement), mm
  const plan::PlannedPoint* planned = nullptr;
  int line = 0;
};

// Orthogonal plane through the points with in-plane axes u (the projection
// of hint_u) and v, and the covariance of (offset at the centroid, slope
// along u, slope along v) for a known point scatter sigma.
struct Plane {
  Eigen::Vector3d centroid, normal, u, v;
  Eigen::Matrix3d covariance;
  double rms_mm = 0;
  bool ok = false;
};

Plane FitPlaneKnownSigma(const std::vector<Eigen::Vector3d>& pts,
                         const Eigen::Vector3d& hint_n,
                         const Eigen::Vector3d& hint_u, double sigma_mm) {
  Plane pl;
  if (pts.size() < 3) return pl;
  Eigen::Matrix3Xd m(3, pts.size());
  for (size_t i = 0; i < pts.size(); ++i) m.col(i) = pts[i];
  fit::FitOptions fo;
  fo.compute_covariance = false;
  fit::PlaneFit f;
  try {
    f = fit::FitPlane(m, fo);
  } catch (const InputError&) {
    return pl;  // collinear
  }
  pl.centroid = f.point;
  pl.normal = f.normal.dot(hint_n) < 0 ? Eigen::Vector3d(-f.normal) : f.normal;
  pl.u = (hint_u - hint_u.dot(pl.normal) * pl.normal).normalized();
  pl.v = pl.normal.cross(pl.u);
  pl.rms_mm = f.summary.rms_mm;
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector3d d = p - pl.centroid;
    const Eigen::Vector3d a(1.0, d.dot(pl.u), d.dot(pl.v));
    ata += a * a.transpose();
  }
  Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
  if (lu.rank() < 3) return pl;
  pl.covariance = lu.inverse() * sigma_mm * sigma_mm;
  pl.ok = true;
  return pl;
}

}  // namespace

bool ProbeReadOptions::IsValid(std::string* error) const {
  if (!std::isfinite(repeatability_um) || repeatability_um < 0) {
    if (error)
      *error =
          "ProbeReadOptions.repeatability_um: must be a finite number >= 0";
    return false;
  }
  if (frame != ProbeFrame::kAuto && frame != ProbeFrame::kMachine &&
      frame != ProbeFrame::kProgram) {
    if (error) *error = "ProbeReadOptions.frame: unknown frame";
    return false;
  }
  return true;
}

void ProbeReadOptions::Validate() const {
  std::string error;
  if (IsValid(&error)) return;
  if (error.find("repeatability_um") != std::string::npos)
    throw InputError("--probe-repeatability-um", 0, "repeatability_um",
                     "must be a finite number >= 0");
  throw InputError("--probe-frame", 0, "frame", "unknown frame");
}

ProbeImport ReadProbeResults(const Config& config, const std::string& csv_text,
                             const std::string& source,
                             const ProbeReadOptions& options) {
  options.Validate();
  const PartSpec& part = config.part;
  const std::vector<plan::PlannedPoint> planned =
      options.points_csv_path.empty()
          ? plan::PlanPoints(part)
          : plan::PointsFromCsv(ReadTextFile(options.points_csv_path),
                                options.points_csv_path);
  std::map<int, const plan::PlannedPoint*> by_id;
  for (const auto& p : planned) by_id[p.id] = &p;

  const CsvTable table = ParseCsv(csv_text, source);
  const int c_id = table.Require("point_id");
  const int c_x = table.Require("x");
  const int c_y = table.Require("y");
  const int c_z = table.Require("z");
  const int c_c = table.Require("c_deg");
  const double r_stylus = config.process.probe.diameter_mm / 2;
  std::map<int, int> seen;  // id -> line
  ProbeImport out;
  bool frame_decided = false, program_frame = false;
  std::map<std::string, std::vector<Touch>> by_feature;
  for (const CsvRow& row : table.rows) {
    const std::string& id_text = table.Text(row, c_id);
    char* end = nullptr;
    errno = 0;
    const long id = std::strtol(id_text.c_str(), &end, 10);
    if (id_text.empty() || *end != '\0' || errno == ERANGE || id < 0 ||
        id > std::numeric_limits<int>::max())
      throw InputError(source, row.line, "point_id",
                       "'" + id_text + "' is not a point number");
    auto it = by_id.find(static_cast<int>(id));
    if (it == by_id.end())
      throw InputError(source, row.line, "point_id",
                       "point " + id_text + " is not in the point list (" +
                           std::to_string(planned.size()) + " points)");
    if (auto [pos, fresh] = seen.emplace(static_cast<int>(id), row.line);
        !fresh)
      throw InputError(source, row.line, "point_id",
                       "point " + id_text + " is given twice (first on line " +
                           std::to_string(pos->second) + ")");
    const Eigen::Vector3d xyz(table.Number(row, c_x), table.Number(row, c_y),
                              table.Number(row, c_z));
    const double c_deg = table.Number(row, c_c);
    if (std::abs(c_deg) > 3600.0)
      throw InputError(
          source, row.line, "c_deg",
          table.Text(row, c_c) + " deg is beyond the limit of +-3600 deg");
    const plan::PlannedPoint& pp = *it->second;
    // Stylus centre -> W; the surface is one stylus radius further along
    // the approach (-outward normal). Returns the offsets from the plan.
    const auto to_w = [&](bool program_frame, double* off, double* along) {
      const Eigen::Vector3d m =
          program_frame ? ProgramToMachine(config, xyz) : xyz;
      const Eigen::Vector3d w =
          MachineToWorkpiece(config, m, c_deg * kDeg) - r_stylus * pp.normal_w;
      *off = (w - pp.point_w_mm).dot(pp.normal_w);
      *along = (w - pp.point_w_mm - *off * pp.normal_w).norm();
      return w;
    };
    double off = 0, along = 0;
    if (!frame_decided) {
      frame_decided = true;
      if (options.frame == ProbeFrame::kProgram) {
        program_frame = true;
      } else if (options.frame == ProbeFrame::kAuto) {
        double off_m, along_m, off_p, along_p;
        to_w(false, &off_m, &along_m);
        to_w(true, &off_p, &along_p);
        const bool m_ok = std::abs(off_m) <= 1.0 && along_m <= 2.0;
        const bool p_ok = std::abs(off_p) <= 1.0 && along_p <= 2.0;
        if (!m_ok && p_ok) {
          program_frame = true;
          out.warnings.push_back(
              "x, y, z read as program-frame (work offset, G54) positions, "
              "as the probing program prints them; measurements.md asks for "
              "the machine frame");
        }
      }
    }
    const Eigen::Vector3d w = to_w(program_frame, &off, &along);
    if (std::abs(off) > 1.0 || along > 2.0)
      throw InputError(
          source, row.line, "x,y,z",
          "point " + id_text + " (" + pp.feature + ") lands " +
              std::to_string(std::abs(off) > 1.0 ? off : along) +
              " mm from where the plan puts it: machine frame (M), c_deg and "
              "the point list must match the probing program");
    by_feature[pp.feature].push_back(Touch{w, &pp, row.line});
  }
  if (table.rows.empty())
    throw InputError(source, table.header_line, "", "no probe results");

  const double sigma = options.repeatability_um * 1e-3;
  auto points_of = [&](const std::string& id) {
    std::vector<Eigen::Vector3d> v;
    auto it = by_feature.find(id);
    if (it != by_feature.end())
      for (const Touch& t : it->second) v.push_back(t.w);
    return v;
  };

  // W from the measured datums (test-piece.md section 5), as for a CMM:
  // top face -> Z and z = 0, flanks -> Y, the 199 circle -> origin.
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();  // w' = rot * w + shift
  Eigen::Matrix2d origin_cov = Eigen::Matrix2d::Zero();
  double var_top_mm2 = 0;
  {
    const auto top = points_of("TOP");
    const auto fp = points_of("FLANK+Y");
    const auto fm = points_of("FLANK-Y");
    const auto cyl = points_of(DatumCylinderId(config.part));
    const Plane pt = FitPlaneKnownSigma(top, Eigen::Vector3d::UnitZ(),
                                        Eigen::Vector3d::UnitX(), sigma);
    // The flanks are probed at one height: lines in the top face's plane.
    // y = a + b x for each (they run along X), so W's X is at atan(b).
    if (pt.ok && fp.size() >= 2 && fm.size() >= 2 && cyl.size() >= 3) {
      const Eigen::Vector3d z = pt.normal;
      const Eigen::Vector3d x1 =
          (Eigen::Vector3d::UnitX() - z.x() * z).normalized();
      const Eigen::Vector3d y1 = z.cross(x1);
      double slope = 0;
      for (const auto* flank : {&fp, &fm}) {
        Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
        Eigen::Vector2d aty = Eigen::Vector2d::Zero();
        for (const auto& p : *flank) {
          const Eigen::Vector2d a(1.0, p.dot(x1));
          ata += a * a.transpose();
          aty += a * p.dot(y1);
        }
        slope += ata.fullPivLu().solve(aty)(1) / 2;
      }
      const double theta = std::atan(slope);
      const Eigen::Vector3d x = std::cos(theta) * x1 + std::sin(theta) * y1;
      const Eigen::Vector3d y = z.cross(x);
      rot.row(0) = x.transpose();
      rot.row(1) = y.transpose();
      rot.row(2) = z.transpose();
      Eigen::Matrix2Xd c2(2, cyl.size());
      for (size_t i = 0; i < cyl.size(); ++i)
        c2.col(i) = (rot * cyl[i]).head<2>();
      fit::FitOptions fo;
      fo.compute_covariance = false;
      const fit::CircleFit2D circle = fit::FitCircle2D(c2, fo);
      // A circle that did not converge or that the touches do not
      // determine gives no origin: refused, not used.
      if (!circle.summary.Usable())
        throw InputError(source, 0, DatumCylinderId(part),
                         std::string("the datum circle's touches give no "
                                     "circle (") +
                             fit::FitStatusName(circle.summary.status) + ": " +
                             circle.summary.message + ")");
      const double top_h = z.dot(pt.centroid);
      shift = -Eigen::Vector3d(circle.centre.x(), circle.centre.y(), top_h);
      // Centre of n points evenly on a circle: var = 2 sigma^2 / n per axis.
      origin_cov = Eigen::Matrix2d::Identity() * 2 * sigma * sigma /
                   static_cast<double>(cyl.size());
      var_top_mm2 = pt.covariance(0, 0);
      const double r_nominal = part.ref_cylinders.front().diameter_mm / 2;
      if (std::abs(circle.radius_mm - r_nominal) > 0.05)
        out.warnings.push_back("the datum circle's diameter is " +
                               std::to_string(2 * circle.radius_mm) +
                               " mm, not " + std::to_string(2 * r_nominal) +
                               " mm");
    } else {
      out.warnings.push_back(
          "datums TOP, FLANK+Y, FLANK-Y and " + DatumCylinderId(part) +
          " not all probed: W is taken from the machine frame and the "
          "piece's nominal placement");
    }
  }

  for (const NominalFeature& nominal : TestFeatures(part)) {
    std::vector<Eigen::Vector3d> pts = points_of(nominal.id);
    if (pts.empty()) continue;
    if (pts.size() < 3) {
      out.warnings.push_back(nominal.id + " has " + std::to_string(pts.size()) +
                             " points: at least 3 are needed for a plane");
      continue;
    }
    for (auto& p : pts) p = rot * p + shift;
    const bool strip = nominal.kind == FeatureKind::kStrip;
    if (strip) {
      // Probed along its length: the line z = a + b x gives the depth at
      // x = 0 (-a) and beta = atan(b).
      Eigen::Matrix2d ata = Eigen::Matrix2d::Zero();
      Eigen::Vector2d atz = Eigen::Vector2d::Zero();
      double ss = 0;
      for (const auto& p : pts) {
        const Eigen::Vector2d a(1.0, p.x());
        ata += a * a.transpose();
        atz += a * p.z();
      }
      Eigen::FullPivLU<Eigen::Matrix2d> lu(ata);
      if (lu.rank() < 2) {
        out.warnings.push_back(nominal.id + ": its points are all at one x");
        continue;
      }
      const Eigen::Vector2d ab = lu.solve(atz);
      for (const auto& p : pts)
        ss += std::pow(p.z() - ab(0) - ab(1) * p.x(), 2);
      const Eigen::Vector3d n(-ab(1), 0.0, 1.0);
      FeatureResult r = FeatureResultFromPlane(
          nominal, PlaneInW{Eigen::Vector3d(0.0, nominal.point.y(), ab(0)),
                            n.normalized()});
      const Eigen::Matrix2d cov = lu.inverse() * sigma * sigma;
      r.var_d_mm2 = cov(0, 0) + var_top_mm2;
      r.var_angle_rad2 = cov(1, 1);
      r.points = static_cast<int>(pts.size());
      r.rms_mm = std::sqrt(ss / pts.size());
      out.results[nominal.Key()] = r;
      continue;
    }
    const Eigen::Vector3d hint_u =
        strip ? Eigen::Vector3d::UnitX()
              : Eigen::Vector3d::UnitZ().cross(nominal.normal).normalized();
    const Plane pl = FitPlaneKnownSigma(pts, nominal.normal, hint_u, sigma);
    if (!pl.ok) {
      out.warnings.push_back(nominal.id +
                             ": its points do not span a plane (collinear)");
      continue;
    }
    // d is the plane's offset at W's origin.
    FeatureResult r =
        FeatureResultFromPlane(nominal, PlaneInW{pl.centroid, pl.normal});
    r.points = static_cast<int>(pts.size());
    r.rms_mm = pl.rms_mm;
    const Eigen::Vector3d lever = -pl.centroid;
    const Eigen::Vector3d g(1.0, lever.dot(pl.u), lever.dot(pl.v));
    const Eigen::Vector2d n2 = pl.normal.head<2>();
    r.var_d_mm2 = g.dot(pl.covariance * g) + n2.dot(origin_cov * n2);
    r.var_angle_rad2 = pl.covariance(1, 1);
    out.results[nominal.Key()] = r;
  }
  return out;
}

}  // namespace ttp::inspect
