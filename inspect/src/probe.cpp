#include "ttp/inspect/probe.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <limits>
#include <map>
#include <regex>
#include <sstream>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/fit.h"
#include "ttp/geometry/frames.h"
#include "ttp/inspect/plane_result.h"
#include "ttp/plan/plan.h"
#include "ttp/plan/probe_program.h"

namespace ttp::inspect {
namespace {

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

// One touch of the results file, whatever its form.
struct LogRow {
  int line = 0;
  plan::ProbePass pass = plan::ProbePass::kMeasure;
  std::string id_text;
  std::string feature;  // empty when the file does not say
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  double c_deg = 0;
};

plan::ProbePass ParsePass(const std::string& text, const std::string& source,
                          int line) {
  const std::string t = Lower(Trim(text));
  if (t == "qualify") return plan::ProbePass::kQualify;
  if (t == "measure") return plan::ProbePass::kMeasure;
  if (t == "drift") return plan::ProbePass::kDrift;
  throw InputError(source, line, "pass",
                   "'" + text + "' is not qualify, measure or drift");
}

// The FANUC program's DPRNT output: `TTP PROBE LOG ...` and then
// `<PASS> <id> <feature> X<x> Y<y> Z<z> C<c> T<clock>`.
bool IsFanucLog(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    const std::string t = Upper(Trim(line));
    if (t.empty() || t == "%") continue;
    return t.rfind("TTP PROBE LOG", 0) == 0;
  }
  return false;
}

std::vector<LogRow> ReadFanucLog(const std::string& text,
                                 const std::string& source) {
  std::vector<LogRow> rows;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  // DPRNT prints a letter, then the value with leading blanks (and its
  // sign, perhaps apart from the digits).
  static const std::regex kValue(R"(([XYZCT])\s*([+-]?)\s*(\d*\.?\d+)\.?)");
  while (std::getline(in, line)) {
    ++number;
    const std::string t = Upper(Trim(line));
    if (t.empty() || t == "%" || t.rfind("TTP PROBE LOG", 0) == 0) continue;
    std::istringstream words(t);
    std::string pass, id, feature;
    words >> pass >> id >> feature;
    LogRow row;
    row.line = number;
    row.pass = ParsePass(pass, source, number);
    row.id_text = id;
    row.feature = feature;
    std::string rest;
    std::getline(words, rest);
    std::map<char, double> values;
    for (auto it = std::sregex_iterator(rest.begin(), rest.end(), kValue);
         it != std::sregex_iterator(); ++it) {
      const char letter = (*it)[1].str()[0];
      const std::string number_text = (*it)[2].str() + (*it)[3].str();
      values[letter] = ParseFiniteNumber(number_text, source, number,
                                         std::string(1, letter));
    }
    for (char letter : {'X', 'Y', 'Z', 'C'})
      if (!values.count(letter))
        throw InputError(source, number, std::string(1, letter),
                         "missing in the probe log line");
    row.xyz = Eigen::Vector3d(values['X'], values['Y'], values['Z']);
    row.c_deg = values['C'];
    rows.push_back(row);
  }
  return rows;
}

std::vector<LogRow> ReadCsvRows(const std::string& text,
                                const std::string& source, int* header_line,
                                bool* has_pass) {
  const CsvTable table = ParseCsv(text, source);
  *header_line = table.header_line;
  const int c_id = table.Require("point_id");
  const int c_x = table.Require("x");
  const int c_y = table.Require("y");
  const int c_z = table.Require("z");
  const int c_c = table.Require("c_deg");
  const int c_feature = table.Has("feature") ? table.Require("feature") : -1;
  const int c_pass = table.Has("pass") ? table.Require("pass") : -1;
  *has_pass = c_pass >= 0;
  std::vector<LogRow> rows;
  for (const CsvRow& r : table.rows) {
    LogRow row;
    row.line = r.line;
    row.id_text = table.Text(r, c_id);
    row.xyz = Eigen::Vector3d(table.Number(r, c_x), table.Number(r, c_y),
                              table.Number(r, c_z));
    row.c_deg = table.Number(r, c_c);
    if (c_feature >= 0) row.feature = Trim(table.Text(r, c_feature));
    if (c_pass >= 0)
      row.pass = ParsePass(table.Text(r, c_pass), source, r.line);
    rows.push_back(row);
  }
  return rows;
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
          ? plan::PlanProbePoints(config)
          : plan::PointsFromCsv(ReadTextFile(options.points_csv_path),
                                options.points_csv_path);
  std::map<int, const plan::PlannedPoint*> by_id;
  for (const auto& p : planned) by_id[p.id] = &p;

  int header_line = 1;
  // The probing program's own logs hold program-frame (G54) positions.
  bool program_log = IsFanucLog(csv_text);
  const std::vector<LogRow> rows =
      program_log ? ReadFanucLog(csv_text, source)
                  : ReadCsvRows(csv_text, source, &header_line, &program_log);
  ProbeImport out;

  // Stylus qualification: a sphere through the ball centres at the five
  // sphere touches; effective radius = its radius - the sphere's.
  double r_stylus = config.process.probe.diameter_mm / 2;
  std::string qualification_warning;  // after the rows' own warnings
  {
    std::vector<Eigen::Vector3d> q;
    int last_line = 0;
    for (const LogRow& row : rows)
      if (row.pass == plan::ProbePass::kQualify) {
        q.push_back(row.xyz);
        last_line = row.line;
      }
    if (q.size() >= 5) {
      Eigen::Matrix3Xd m(3, q.size());
      for (size_t i = 0; i < q.size(); ++i) m.col(i) = q[i];
      fit::FitOptions fo;
      fo.compute_covariance = false;
      fit::SphereFit sf;
      try {
        sf = fit::FitSphere(m, fo);
      } catch (const InputError& e) {
        throw InputError(
            source, last_line, "qualify",
            "the sphere touches give no sphere (" + e.problem() + ")");
      }
      const double r_eff = sf.radius_mm - config.machine.sphere_radius_mm;
      if (!sf.summary.Usable() || !(std::abs(r_eff - r_stylus) <= 0.1))
        throw InputError(
            source, last_line, "qualify",
            "the sphere touches give an effective stylus radius of " +
                std::to_string(r_eff) + " mm against " +
                std::to_string(r_stylus) +
                " mm nominal: the sphere (machine.sphere_radius_mm) or the "
                "stylus (process.probe.diameter_mm) is not the one the "
                "profile describes");
      r_stylus = r_eff;
      out.qualified = true;
      out.qualification_rms_um = sf.summary.rms_mm * 1e3;
    } else {
      qualification_warning =
          (q.empty() ? "no stylus qualification in the results: the nominal "
                       "ball radius is used"
                     : "fewer than 5 sphere touches: the stylus is not "
                       "qualified, the nominal ball radius is used");
    }
  }
  out.stylus_radius_mm = r_stylus;

  std::map<int, int> seen;                    // id -> line (measure)
  std::map<int, int> seen_drift;              // id -> line (drift)
  std::map<int, Eigen::Vector3d> measured_w;  // id -> surface point in W
  bool frame_decided = false, program_frame = false;
  std::map<FeatureId, std::vector<Touch>> by_feature;
  std::map<FeatureId, std::vector<double>> drift_um;
  for (const LogRow& row : rows) {
    if (row.pass == plan::ProbePass::kQualify) continue;
    const std::string& id_text = row.id_text;
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
    const bool drift = row.pass == plan::ProbePass::kDrift;
    if (auto [pos, fresh] =
            (drift ? seen_drift : seen).emplace(static_cast<int>(id), row.line);
        !fresh)
      throw InputError(source, row.line, "point_id",
                       "point " + id_text + " is given twice (first on line " +
                           std::to_string(pos->second) + ")");
    const plan::PlannedPoint& pp = *it->second;
    // Names are compared case-blind (FANUC prints upper case).
    if (!row.feature.empty() &&
        FeatureId::Parse(Upper(row.feature)) != pp.feature)
      throw InputError(source, row.line, "feature",
                       "point " + id_text + " is " + row.feature +
                           " in the results but " + pp.feature.ToString() +
                           " in the point list (--probe-points must be the "
                           "list the program was written for)");
    const Eigen::Vector3d xyz = row.xyz;
    const double c_deg = row.c_deg;
    if (std::abs(c_deg) > 3600.0)
      throw InputError(
          source, row.line, "c_deg",
          std::to_string(c_deg) + " deg is beyond the limit of +-3600 deg");
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
      if (options.frame == ProbeFrame::kProgram ||
          (options.frame == ProbeFrame::kAuto && program_log)) {
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
          "point " + id_text + " (" + pp.feature.ToString() + ") lands " +
              std::to_string(std::abs(off) > 1.0 ? off : along) +
              " mm from where the plan puts it: machine frame (M), c_deg and "
              "the point list must match the probing program");
    if (drift) {
      auto m = measured_w.find(static_cast<int>(id));
      if (m == measured_w.end())
        throw InputError(
            source, row.line, "point_id",
            "drift row of point " + id_text + " before its measurement");
      drift_um[pp.feature].push_back((w - m->second).dot(pp.normal_w) * 1e3);
      continue;
    }
    measured_w[static_cast<int>(id)] = w;
    by_feature[pp.feature].push_back(Touch{w, &pp, row.line});
  }
  if (by_feature.empty())
    throw InputError(source, header_line, "", "no probe results");

  if (!drift_um.empty()) {
    std::string text =
        "probe drift over the run (reference facets probed again at the "
        "end, along their normals):";
    double worst = 0;
    // Reported in name order (X1-5, X2-5, Y1-5, Y2-5).
    std::vector<std::pair<std::string, FeatureId>> named;
    for (const auto& entry : drift_um)
      named.emplace_back(entry.first.ToString(), entry.first);
    std::sort(named.begin(), named.end());
    for (const auto& [name, feature] : named) {
      const std::vector<double>& values = drift_um.at(feature);
      ProbeDrift d;
      d.feature = feature;
      d.points = static_cast<int>(values.size());
      for (double v : values) {
        d.mean_um += v / values.size();
        d.max_abs_um = std::max(d.max_abs_um, std::abs(v));
      }
      worst = std::max(worst, d.max_abs_um);
      text += fmt::format(" {} {:+.2f} um;", name, d.mean_um);
      out.drift.push_back(d);
    }
    text += fmt::format(" largest |drift| {:.2f} um", worst);
    out.warnings.push_back(text);
  }

  const double sigma = options.repeatability_um * 1e-3;
  auto points_of = [&](const FeatureId& id) {
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
    const auto top = points_of(FeatureId::Top());
    const auto fp = points_of(FeatureId::Flank(+1));
    const auto fm = points_of(FeatureId::Flank(-1));
    const auto cyl = points_of(FeatureId::DatumCylinder(config.part));
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
    std::vector<Eigen::Vector3d> pts = points_of(nominal.Key());
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
  if (!qualification_warning.empty())
    out.warnings.push_back(qualification_warning);
  return out;
}

}  // namespace ttp::inspect
