#include "ttp/inspect/dmis.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/limits.h"
#include "ttp/inspect/plane_result.h"
#include "ttp/plan/dmis_writer.h"

namespace ttp::inspect {
namespace {

struct Statement {
  int line = 0;
  std::string text;
};

// Joins `$` continuations, drops `$$` comments and blank lines.
std::vector<Statement> Statements(const std::string& text) {
  std::vector<Statement> out;
  std::istringstream in(text);
  std::string raw;
  int line = 0;
  Statement pending;
  bool continuing = false;
  while (std::getline(in, raw)) {
    ++line;
    std::string s = raw;
    if (const auto c = s.find("$$"); c != std::string::npos) s.erase(c);
    s = Trim(s);
    if (s.empty() && !continuing) continue;
    const bool continues = !s.empty() && s.back() == '$';
    if (continues) s = Trim(s.substr(0, s.size() - 1));
    if (!continuing) pending = Statement{line, ""};
    pending.text += (pending.text.empty() ? "" : " ") + s;
    continuing = continues;
    if (!continuing) out.push_back(pending);
  }
  if (continuing) out.push_back(pending);
  return out;
}

std::vector<std::string> SplitCommas(const std::string& s) {
  std::vector<std::string> out;
  std::string cell;
  std::istringstream in(s);
  while (std::getline(in, cell, ',')) out.push_back(Trim(cell));
  return out;
}

double Number(const std::string& word, const std::string& source, int line,
              const std::string& what) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(word, &used);
  } catch (...) {
    used = 0;
  }
  if (used != word.size() || word.empty() || !std::isfinite(v))
    throw InputError(source, line, what,
                     "'" + word + "' is not a finite number");
  if (std::abs(v) > limits::kMaxCoordinateMm)
    throw InputError(source, line, what,
                     "'" + word + "' is beyond the limit of " +
                         std::to_string(limits::kMaxCoordinateMm) +
                         " (a coordinate or vector component)");
  return v;
}

}  // namespace

DmisResults ParseDmisOutput(const std::string& text,
                            const std::string& source) {
  DmisResults out;
  out.source = source;
  double scale = 1.0;  // to mm
  bool any_statement = false;
  int first_meas_line = 0;
  for (const Statement& st : Statements(text)) {
    any_statement = true;
    const std::string up = Upper(st.text);
    if (first_meas_line == 0 && up.rfind("MEAS/", 0) == 0)
      first_meas_line = st.line;
    if (up.rfind("UNITS/", 0) == 0) {
      const auto words = SplitCommas(up.substr(6));
      if (words.empty())
        throw InputError(source, st.line, "UNITS", "no length unit");
      static const std::map<std::string, double> kLength = {{"MM", 1.0},
                                                            {"CM", 10.0},
                                                            {"METER", 1000.0},
                                                            {"INCH", 25.4},
                                                            {"FEET", 304.8}};
      auto it = kLength.find(words[0]);
      if (it == kLength.end())
        throw InputError(source, st.line, "UNITS",
                         "unknown length unit '" + words[0] + "'");
      scale = it->second;
      // The angle unit is only checked: the CART feature results read here
      // carry no angles.
      if (words.size() > 1 && words[1] != "ANGRAD" && words[1] != "ANGDEC" &&
          words[1] != "ANGDMS")
        throw InputError(source, st.line, "UNITS",
                         "unknown angle unit '" + words[1] + "'");
      continue;
    }
    // FA(label) = FEAT/TYPE, ...
    if (up.rfind("FA(", 0) != 0) continue;
    const auto close = st.text.find(')');
    const auto eq = st.text.find('=', close == std::string::npos ? 0 : close);
    if (close == std::string::npos || eq == std::string::npos)
      throw InputError(source, st.line, "FA", "expected FA(label) = FEAT/...");
    DmisFeature f;
    f.line = st.line;
    f.label = Trim(st.text.substr(3, close - 3));
    const std::string rhs = Trim(up.substr(eq + 1));
    if (rhs.rfind("FEAT/", 0) != 0) continue;  // e.g. tolerance results
    auto words = SplitCommas(rhs.substr(5));
    if (words.empty())
      throw InputError(source, st.line, "FEAT", "no feature type");
    f.type = words[0];
    static const std::map<std::string, int> kValues = {{"PLANE", 6},
                                                       {"POINT", 6},
                                                       {"CIRCLE", 7},
                                                       {"CYLNDR", 7},
                                                       {"SPHERE", 4}};
    auto kind = kValues.find(f.type);
    if (kind == kValues.end()) continue;  // other feature types: not used
    size_t i = 1;
    if (i < words.size() && (words[i] == "INNER" || words[i] == "OUTER")) ++i;
    if (i >= words.size())
      throw InputError(source, st.line, f.type, "missing coordinate type");
    if (words[i] == "POL")
      throw InputError(source, st.line, "POL",
                       "polar coordinates are not supported; write CART");
    if (words[i] != "CART")
      throw InputError(source, st.line, words[i], "expected CART coordinates");
    ++i;
    const int need = kind->second;
    if (words.size() < i + need)
      throw InputError(source, st.line, f.type,
                       "expected " + std::to_string(need) + " values, got " +
                           std::to_string(words.size() - i));
    std::vector<double> v;
    for (int k = 0; k < need; ++k)
      v.push_back(Number(words[i + k], source, st.line,
                         "FA(" + f.label + ") value " + std::to_string(k + 1)));
    f.point_mm = Eigen::Vector3d(v[0], v[1], v[2]) * scale;
    // A diameter is a size: a negative or zero one is a broken report, not a
    // feature to evaluate (the sign is not a convention in DMIS).
    const auto diameter = [&](double value) {
      if (!(value > 0))
        throw InputError(source, st.line,
                         "FA(" + f.label + ") value " + std::to_string(need),
                         words[i + static_cast<size_t>(need) - 1] +
                             ": a diameter must be positive");
      return value * scale;
    };
    if (f.type == "SPHERE") {
      f.diameter_mm = diameter(v[3]);
    } else {
      const Eigen::Vector3d dir(v[3], v[4], v[5]);
      if (dir.norm() < 1e-12)
        throw InputError(source, st.line, "FA(" + f.label + ")",
                         "direction vector is zero");
      f.direction = dir.normalized();
      if (need == 7) f.diameter_mm = diameter(v[6]);
    }
    out.features.push_back(f);
  }
  if (!any_statement) throw InputError(source, 0, "file", "is empty");
  if (out.features.empty() && first_meas_line > 0)
    throw InputError(source, first_meas_line, "MEAS",
                     "this is a DMIS program (it measures), not results: run "
                     "it on the CMM and inspect the file its OUTPUT "
                     "statements write (DEVICE/STOR)");
  return out;
}

namespace {

// The covariance of a plane w = a + b s + c h fitted by least squares
// through touches of unit variance at the coordinates (s, h) of each touch
// in the plane (and nullopt when they lie on a line, which leaves the
// plane undetermined across it).
std::optional<Eigen::Matrix3d> UnitTouchCovariance(
    const std::vector<Eigen::Vector2d>& sh) {
  if (sh.size() < 3) return std::nullopt;
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector2d& q : sh) {
    const Eigen::Vector3d row(1.0, q.x(), q.y());
    normal_matrix += row * row.transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(normal_matrix);
  const Eigen::Vector3d sv = svd.singularValues();
  if (!(sv(2) > 1e-9 * sv(0))) return std::nullopt;
  return normal_matrix.inverse();
}

// A feature's plane as the figures read it (test-piece.md section 4).
// Facets: the touches' normal distance w = a + b s + c h (s along the
// horizontal tangent, h = z): d (the plane's distance to W's origin) is a
// and the angle about Z is b, so the tilt c counts in d through the
// touches' height (d = n . p). Strips and the top face: z = a + b x +
// c (y - y_ref): a strip's depth at (0, y_k) is a, its angle b.
std::vector<Eigen::Vector2d> PlaneCoordinates(
    const NominalFeature& nominal,
    const std::vector<Eigen::Vector3d>& touches) {
  const Eigen::Vector3d tangent =
      Eigen::Vector3d(-nominal.normal.y(), nominal.normal.x(), 0).normalized();
  std::vector<Eigen::Vector2d> sh;
  for (const Eigen::Vector3d& q : touches)
    sh.push_back(nominal.kind == FeatureKind::kStrip
                     ? Eigen::Vector2d(q.x(), q.y() - nominal.point.y())
                     : Eigen::Vector2d(tangent.dot(q), q.z()));
  return sh;
}

}  // namespace

bool DmisImportOptions::IsValid(std::string* error) const {
  const auto fail = [&](const char* field, const char* problem) {
    if (error)
      *error = std::string("DmisImportOptions.") + field + ": " + problem;
    return false;
  };
  if (!std::isfinite(cmm_mpe_um) || cmm_mpe_um <= 0 || cmm_mpe_um > 1000)
    return fail("cmm_mpe_um", "must be a finite number in (0, 1000] um");
  if (!std::isfinite(cmm_mpe_l_mm) || cmm_mpe_l_mm <= 0)
    return fail("cmm_mpe_l_mm", "must be a positive finite length in mm");
  if (touches_per_plane != 0 &&
      (touches_per_plane < 3 || touches_per_plane > 100000))
    return fail("touches_per_plane",
                "must be 0 (from the point list) or 3 to 100000: a plane "
                "needs three touches");
  if (touches_per_plane != 0 && !points_csv_path.empty())
    return fail("touches_per_plane",
                "give either the touches per plane or the point list, not "
                "both");
  return true;
}

void DmisImportOptions::Validate() const {
  std::string error;
  if (IsValid(&error)) return;
  const std::string problem = error.substr(error.find(": ") + 2);
  if (error.find(".cmm_mpe_um:") != std::string::npos)
    throw InputError("--cmm-mpe-um", 0, "cmm_mpe_um", problem);
  if (error.find(".cmm_mpe_l_mm:") != std::string::npos)
    throw InputError("--cmm-mpe-l-mm", 0, "cmm_mpe_l_mm", problem);
  throw InputError("--cmm-touches", 0, "touches_per_plane", problem);
}

DmisImport DmisToFeatureResults(const DmisResults& dmis, const PartSpec& part,
                                const DmisImportOptions& options) {
  options.Validate();
  DmisImport out;
  std::map<FeatureId, const DmisFeature*> by_id;
  // The two points of the half-turn check (not features of their own).
  const DmisFeature* mark_point = nullptr;
  const DmisFeature* opposite_point = nullptr;
  for (const DmisFeature& f : dmis.features) {
    const std::string up = Upper(Trim(f.label));
    const std::optional<FeatureId> id = FeatureIdForDmisLabel(f.label);
    const DmisFeature** slot = up == "MARK"       ? &mark_point
                               : up == "MARK_OPP" ? &opposite_point
                               : id               ? &by_id[*id]
                                                  : nullptr;
    if (!slot) continue;  // another feature: not a result
    if (*slot)
      throw InputError(dmis.source, f.line, "FA(" + f.label + ")",
                       (id ? id->ToString() : up) +
                           " is reported twice (first on line " +
                           std::to_string((*slot)->line) + ")");
    *slot = &f;
  }

  // W from the datums (test-piece.md section 5), if all are there.
  Eigen::Isometry3d to_w = Eigen::Isometry3d::Identity();
  double top_z_mm = 0.0;
  const FeatureId datum = FeatureId::DatumCylinder(part);
  const auto of_type = [](const DmisFeature* f,
                          std::initializer_list<const char*> t) {
    if (!f) return false;
    for (const char* type : t)
      if (f->type == type) return true;
    return false;
  };
  const auto has = [&](const FeatureId& id,
                       std::initializer_list<const char*> t) {
    auto it = by_id.find(id);
    return it != by_id.end() && of_type(it->second, t);
  };
  if (has(FeatureId::Top(), {"PLANE"}) &&
      has(FeatureId::Flank(+1), {"PLANE"}) &&
      has(FeatureId::Flank(-1), {"PLANE"}) &&
      has(datum, {"CIRCLE", "CYLNDR"})) {
    const DmisFeature& top = *by_id[FeatureId::Top()];
    const Eigen::Vector3d z = top.direction.z() >= 0
                                  ? top.direction
                                  : Eigen::Vector3d(-top.direction);
    // The flanks are parallel: W's Y is their common normal, oriented from
    // the -Y flank towards the +Y flank (the reported normals' signs vary).
    const DmisFeature& plus = *by_id[FeatureId::Flank(+1)];
    const DmisFeature& minus = *by_id[FeatureId::Flank(-1)];
    const Eigen::Vector3d across = plus.point_mm - minus.point_mm;
    const auto towards = [&](const Eigen::Vector3d& n) -> Eigen::Vector3d {
      return n.dot(across) >= 0 ? n : Eigen::Vector3d(-n);
    };
    Eigen::Vector3d y = towards(plus.direction) + towards(minus.direction);
    y = (y - y.dot(z) * z).normalized();
    const Eigen::Vector3d x = y.cross(z);
    Eigen::Matrix3d r;
    r.row(0) = x.transpose();
    r.row(1) = y.transpose();
    r.row(2) = z.transpose();
    // Origin: circle centre in XY, top face at z = 0.
    const Eigen::Vector3d c = by_id[datum]->point_mm;
    const double top_height = z.dot(top.point_mm);
    Eigen::Vector3d origin = c - (z.dot(c) - top_height) * z;
    to_w.linear() = r;
    to_w.translation() = -r * origin;
    out.aligned_from_datums = true;
  } else {
    out.warnings.push_back(
        "datums TOP, FLANK+Y, FLANK-Y and " + datum.ToString() +
        " not all reported: the reported coordinates are taken as the "
        "workpiece frame W");
    if (has(FeatureId::Top(), {"PLANE"})) {
      const DmisFeature& top = *by_id[FeatureId::Top()];
      top_z_mm = top.point_mm.z();
    }
  }

  // The half-turn from the engraved mark.
  if (out.aligned_from_datums) {
    if (of_type(mark_point, {"POINT"}) && of_type(opposite_point, {"POINT"})) {
      constexpr double kMinDepthMm = 0.005;
      const DmisFeature& m = *mark_point;
      const double depth =
          (to_w * opposite_point->point_mm).z() - (to_w * m.point_mm).z();
      if (depth <= -kMinDepthMm)
        throw InputError(
            dmis.source, m.line, "FA(" + m.label + ")",
            fmt::format("the engraved mark was found {:.1f} um deep at "
                        "MARK_OPP, not at MARK: the piece was aligned turned "
                        "by 180 deg (X1 measured as X2, Y1 as Y2); put the "
                        "mark towards +X and measure again",
                        -depth * 1e3));
      if (depth < kMinDepthMm)
        out.warnings.push_back(fmt::format(
            "the engraved mark was not seen (MARK {:.1f} um below MARK_OPP, "
            "at least 5 um expected): the half-turn rests on the CMM "
            "operator's placing",
            depth * 1e3));
    }
  }

  // The touches the CMM program took per feature, in W: its point list, or
  // the program of `ttp plan cmm` (whose pattern --cmm-touches repeats;
  // none when that program cannot be planned for this part).
  std::map<FeatureId, std::vector<Eigen::Vector3d>> touches;
  if (!options.points_csv_path.empty()) {
    for (const plan::PlannedPoint& q : plan::PointsFromCsv(
             ReadTextFile(options.points_csv_path), options.points_csv_path))
      touches[q.feature].push_back(q.point_w_mm);
  } else {
    try {
      for (const plan::PlannedPoint& q : plan::CmmPoints(part))
        touches[q.feature].push_back(q.point_w_mm);
    } catch (const InputError& e) {
      touches.clear();
      out.warnings.push_back(
          std::string("the CMM program of ttp plan cmm cannot be planned for "
                      "this part (") +
          e.what() + "): each DMIS plane is taken as " +
          (options.touches_per_plane > 0
               ? std::to_string(options.touches_per_plane) +
                     " touches without their pattern"
               : std::string("one touch")));
    }
  }
  // A touch's standard uncertainty: MPE = a + L/b as a uniform bound.
  const auto touch_u_mm = [&](double reach_mm) {
    return (options.cmm_mpe_um + reach_mm / options.cmm_mpe_l_mm) * 1e-3 /
           std::sqrt(3.0);
  };
  // The mean of a plane's touches' variances, each touch's MPE for its own
  // length from W's origin (a strip's touches reach 80-95 mm out while its
  // centre lies near the axis).
  const auto mean_touch_var_mm2 =
      [&](const std::vector<Eigen::Vector3d>& plane_touches) {
        double sum = 0;
        for (const Eigen::Vector3d& q : plane_touches)
          sum += std::pow(touch_u_mm(q.norm()), 2);
        return sum / static_cast<double>(plane_touches.size());
      };
  // A program of one's own: n touches in the plan's pattern.
  const auto own_program_scale = [&](size_t planned) {
    return options.touches_per_plane > 0
               ? static_cast<double>(planned) / options.touches_per_plane
               : 1.0;
  };
  // W's Z is the top face's normal: its tilt about X, from the top face's
  // touches, moves a strip's depth at (0, y_k) by tilt * y_k (W's origin
  // lies on the datum circle's axis).
  double top_tilt_var_rad2 = 0;
  if (out.aligned_from_datums) {
    auto top = touches.find(FeatureId::Top());
    if (top != touches.end()) {
      std::vector<Eigen::Vector2d> xy;
      for (const Eigen::Vector3d& q : top->second)
        xy.emplace_back(q.x(), q.y());
      if (const auto cov = UnitTouchCovariance(xy))
        top_tilt_var_rad2 = mean_touch_var_mm2(top->second) * (*cov)(2, 2) *
                            own_program_scale(top->second.size());
    }
  }
  std::vector<std::string> reversed;
  for (const NominalFeature& nominal : TestFeatures(part)) {
    auto it = by_id.find(nominal.Key());
    if (it == by_id.end()) continue;
    const DmisFeature& f = *it->second;
    if (f.type != "PLANE")
      throw InputError(dmis.source, f.line, "FA(" + f.label + ")",
                       nominal.id + " must be a PLANE, not " + f.type);
    PlaneInW plane{to_w * f.point_mm, to_w.linear() * f.direction};
    // CMM software reports a plane's normal either way round: the same
    // plane. Taken outward, and said so.
    if (plane.normal.dot(nominal.normal) < 0) reversed.push_back(f.label);
    FeatureResult r = FeatureResultFromPlane(nominal, plane, top_z_mm);
    // A feature far from its nominal place is not this piece measured in
    // these units and this frame: refused, never turned into figures.
    const double nominal_d = nominal.kind == FeatureKind::kStrip
                                 ? -part.strip_floor_z_mm
                                 : nominal.size_mm;
    if (!(std::abs(r.d_mm - nominal_d) <= limits::kMaxFeatureDeviationMm) ||
        !(std::abs(r.angle_rad) <= limits::kMaxFeatureAngleRad))
      throw InputError(
          dmis.source, f.line, "FA(" + f.label + ")",
          nominal.id + " lies " + std::to_string(r.d_mm - nominal_d) +
              " mm and " + std::to_string(r.angle_rad) +
              " rad from its nominal place (limits " +
              std::to_string(limits::kMaxFeatureDeviationMm) + " mm, " +
              std::to_string(limits::kMaxFeatureAngleRad) +
              " rad): the units (UNITS/) or the frame do not fit the "
              "piece's size" +
              (out.aligned_from_datums
                   ? std::string()
                   : "; the datums TOP, FLANK+Y, FLANK-Y and " +
                         datum.ToString() +
                         " were not all reported, so the coordinates were "
                         "taken as the workpiece frame W: report them, or "
                         "the features in W"));
    // The variance of a least-squares plane through independent touches
    // (DmisImportOptions), at the mean of their variances.
    auto planned = touches.find(nominal.Key());
    const double u_mm = planned != touches.end() && !planned->second.empty()
                            ? std::sqrt(mean_touch_var_mm2(planned->second))
                            : touch_u_mm(nominal.point.norm());
    const std::optional<Eigen::Matrix3d> cov =
        planned == touches.end()
            ? std::nullopt
            : UnitTouchCovariance(PlaneCoordinates(nominal, planned->second));
    if (cov) {
      const double scale = own_program_scale(planned->second.size());
      r.var_d_mm2 = u_mm * u_mm * (*cov)(0, 0) * scale;
      r.var_angle_rad2 = u_mm * u_mm * (*cov)(1, 1) * scale;
    } else {
      // No pattern: the distance as from n touches (one by default), the
      // angle as from two at the feature's ends.
      const double n = std::max(1, options.touches_per_plane);
      const double extent_mm =
          std::max(1.0, nominal.t_max_mm - nominal.t_min_mm);
      r.var_d_mm2 = u_mm * u_mm / n;
      r.var_angle_rad2 = 2.0 * u_mm * u_mm / (n * extent_mm * extent_mm);
    }
    if (nominal.kind == FeatureKind::kStrip)
      r.var_d_mm2 += top_tilt_var_rad2 * nominal.point.y() * nominal.point.y();
    r.points = 0;
    out.results[nominal.Key()] = r;
  }
  if (!reversed.empty()) {
    std::string list;
    for (size_t k = 0; k < reversed.size() && k < 5; ++k)
      list += (k ? ", " : "") + reversed[k];
    if (reversed.size() > 5) list += ", ...";
    out.warnings.push_back(std::to_string(reversed.size()) +
                           " plane normals reported pointing into the piece (" +
                           list + "): taken as the outward normal");
  }
  return out;
}

}  // namespace ttp::inspect

// ------------------------------------------------------------ programs

namespace ttp::inspect {
namespace {

// Splits at commas outside quotes and parentheses.
std::vector<std::string> SplitArgs(const std::string& s,
                                   const std::string& source, int line) {
  std::vector<std::string> out;
  std::string cell;
  bool quoted = false;
  int depth = 0;
  for (char c : s) {
    if (c == '\'') quoted = !quoted;
    if (!quoted && c == '(') ++depth;
    if (!quoted && c == ')') --depth;
    if (!quoted && depth == 0 && c == ',') {
      out.push_back(Trim(cell));
      cell.clear();
      continue;
    }
    cell += c;
  }
  if (quoted)
    throw InputError(source, line, "statement", "a quote is not closed");
  if (depth != 0)
    throw InputError(source, line, "statement", "parentheses do not match");
  if (!Trim(cell).empty() || !out.empty()) out.push_back(Trim(cell));
  return out;
}

// Upper case outside quotes.
std::string UpperOutsideQuotes(const std::string& s) {
  std::string out = s;
  bool quoted = false;
  for (char& c : out) {
    if (c == '\'') quoted = !quoted;
    if (!quoted)
      c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  return out;
}

bool IsNumber(const std::string& w) {
  if (w.empty()) return false;
  char* end = nullptr;
  const double v = std::strtod(w.c_str(), &end);
  return end == w.c_str() + w.size() && std::isfinite(v);
}

bool IsWord(const std::string& w) {
  if (w.empty() || !std::isalpha(static_cast<unsigned char>(w[0])))
    return false;
  for (char c : w)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  return true;
}

// "FA(TOP)" -> {"FA", "TOP"}; empty type when w is not a label reference.
std::pair<std::string, std::string> LabelRef(const std::string& w) {
  const auto open = w.find('(');
  if (open == std::string::npos || w.back() != ')' || open == 0) return {};
  const std::string type = w.substr(0, open);
  if (!IsWord(type)) return {};
  return {type, Trim(w.substr(open + 1, w.size() - open - 2))};
}

}  // namespace

DmisProgram ParseDmisProgram(const std::string& text,
                             const std::string& source) {
  DmisProgram out;
  out.source = source;
  {
    std::istringstream in(text);
    int n = 0;
    for (std::string raw; std::getline(in, raw);) {
      ++n;
      if (!raw.empty() && raw.back() == '\r') raw.pop_back();
      if (raw.size() > 80) out.long_lines.push_back(n);
    }
  }
  for (const Statement& st : Statements(text)) {
    if (st.text.size() > 256) out.long_statements.push_back(st.line);
    DmisStatement s;
    s.line = st.line;
    const std::string up = UpperOutsideQuotes(st.text);
    // The major word ends at the first '/' outside quotes (ENDMES, ENDFIL
    // have none).
    size_t slash = std::string::npos;
    bool quoted = false;
    for (size_t i = 0; i < up.size(); ++i) {
      if (up[i] == '\'') quoted = !quoted;
      if (!quoted && up[i] == '/') {
        slash = i;
        break;
      }
    }
    std::string head = slash == std::string::npos ? up : up.substr(0, slash);
    const std::string rest =
        slash == std::string::npos ? "" : up.substr(slash + 1);
    if (const auto eq = head.find('='); eq != std::string::npos) {
      const auto ref = LabelRef(Trim(head.substr(0, eq)));
      if (ref.first.empty())
        throw InputError(source, st.line, "label",
                         "expected a label such as F(name) before '='");
      s.label_type = ref.first;
      s.label = ref.second;
      head = head.substr(eq + 1);
    }
    s.major = Trim(head);
    if (!IsWord(s.major))
      throw InputError(source, st.line, "statement",
                       "'" + s.major + "' is not a DMIS major word");
    s.args = SplitArgs(rest, source, st.line);
    out.statements.push_back(std::move(s));
  }
  if (out.statements.empty())
    throw InputError(source, 0, "file", "holds no statement");
  return out;
}

namespace {

// ---- the statement table (DMIS 5.x forms) ----
// A form is a space-separated pattern: `n` a number, `i` a whole number,
// `s` a quoted string, `F()` a label reference of that type, WORD a minor
// word, `A|B` alternatives of any of these, `[ ... ]` optional,
// `[ ... ]*` zero or more, `[ ... ]+` one or more.
struct StatementForm {
  const char* major;
  const char* lhs;  // label types allowed left of '=', "" none
  bool lhs_required;
  std::vector<const char*> forms;
};

const std::vector<StatementForm>& Table() {
  static const std::vector<StatementForm> kTable = {
      {"DMISMN", "", false, {"s [n]"}},
      {"FILNAM", "", false, {"s [n]"}},
      {"ENDFIL", "", false, {""}},
      {"UNITS",
       "",
       false,
       {"MM|CM|METER|INCH|FEET ANGDEC|ANGDMS|ANGRAD [TEMPC|TEMPF]"}},
      {"PRCOMP", "", false, {"ON|OFF"}},
      {"DISPLY", "", false, {"OFF", "TERM|STOR|PRINT|COMM DMIS|V()"}},
      {"DEVICE", "DID", true, {"STOR|PRINT|TERM|COMM|INCR s"}},
      {"OPEN", "", false, {"DID() FDATA DMIS|V() INPUT|OUTPUT|APPEND|OVERWR"}},
      {"CLOSE", "", false, {"DID() [KEEP|DELETE|END]"}},
      {"MODE", "", false, {"MAN", "PROG MAN", "AUTO PROG MAN"}},
      {"TEXT", "", false, {"MAN|OPER|OUTFIL s"}},
      {"SNSMNT", "", false, {"XVEC n n n ZVEC n n n MNTLEN n n n"}},
      {"SNSDEF",
       "S",
       true,
       {"PROBE FIXED|INDEX CART|POL n n n n n n n",
        "PROBE FIXED|INDEX VEC n n n n n"}},
      {"SNSLCT", "", false, {"S()|SA()"}},
      {"SNSET",
       "",
       false,
       {"APPRCH|RETRCT|SEARCH|DEPTH n", "CLRSRF F()|FA()|DAT() n",
        "CLRSRF|DEPTH OFF"}},
      {"FEDRAT", "", false, {"POSVEL|MESVEL|SCNVEL MPM|MMPS|IPM|IPS|PCENT n"}},
      {"ACLRAT",
       "",
       false,
       {"POSACL|MESACL|SCNACL MPMM|MMPSS|IPMM|IPSS|PCENT n"}},
      {"GOTO", "", false, {"n n n"}},
      {"FEAT",
       "F|FA",
       true,
       {"PLANE CART n n n n n n", "POINT CART n n n n n n",
        "CIRCLE INNER|OUTER CART n n n n n n n",
        "CYLNDR INNER|OUTER CART n n n n n n n [n]",
        "SPHERE INNER|OUTER CART n n n n", "LINE UNBND CART n n n n n n n n n",
        "LINE BND CART n n n n n n n n n"}},
      {"MEAS", "", false, {"PLANE|POINT|CIRCLE|CYLNDR|SPHERE|LINE F() i"}},
      {"PTMEAS", "", false, {"CART n n n [n n n]"}},
      {"ENDMES", "", false, {""}},
      {"CONST",
       "",
       false,
       {"PLANE F() MIDPL FA() FA()", "LINE|POINT|CIRCLE F() INTOF FA() FA()",
        "PLANE|LINE|CIRCLE|POINT|CYLNDR|SPHERE F() BF FA() FA() [FA()]*"}},
      {"DATDEF", "", false, {"FA()|F() DAT()"}},
      {"DATSET",
       "D",
       true,
       {"MCS", "DA()",
        "DAT() XDIR|YDIR|ZDIR|MXDIR|MYDIR|MZDIR|XORIG|YORIG|ZORIG "
        "[XDIR|YDIR|ZDIR|MXDIR|MYDIR|MZDIR|XORIG|YORIG|ZORIG]* "
        "[DAT() XDIR|YDIR|ZDIR|MXDIR|MYDIR|MZDIR|XORIG|YORIG|ZORIG "
        "[XDIR|YDIR|ZDIR|MXDIR|MYDIR|MZDIR|XORIG|YORIG|ZORIG]*]*"}},
      {"TRANS",
       "D",
       true,
       {"XORIG|YORIG|ZORIG n|FA()|DAT() [XORIG|YORIG|ZORIG n|FA()|DAT()]*"}},
      {"ROTATE",
       "D",
       true,
       {"XAXIS|YAXIS|ZAXIS n",
        "XAXIS|YAXIS|ZAXIS FA()|DAT() XDIR|YDIR|ZDIR|MXDIR|MYDIR|MZDIR"}},
      {"SAVE", "", false, {"DA()|SA()"}},
      {"RECALL", "", false, {"DA()|SA()"}},
      {"TOL",
       "T",
       true,
       {"FLAT n", "CYLCTY n", "CIRLTY n", "DIAM n n", "DISTB n n",
        "POS 2D|3D n [RFS|MMC|LMC] [DAT()]*", "PARLEL n [DAT()]",
        "PERP n [DAT()]"}},
      {"OUTPUT", "", false, {"FA()|F()|DA() [TA()|T()]*"}},
  };
  return kTable;
}

struct Pattern {
  enum Kind { kTerm, kOpt, kStar, kPlus } kind = kTerm;
  std::vector<std::string> alts;  // kTerm
  std::vector<Pattern> seq;       // the others
};

std::vector<Pattern> ParsePattern(const std::vector<std::string>& words,
                                  size_t& i) {
  std::vector<Pattern> out;
  while (i < words.size()) {
    const std::string& w = words[i++];
    if (w == "[") {
      Pattern p;
      p.seq = ParsePattern(words, i);
      const std::string& close = words[i - 1];
      p.kind = close == "]*"   ? Pattern::kStar
               : close == "]+" ? Pattern::kPlus
                               : Pattern::kOpt;
      out.push_back(std::move(p));
    } else if (w == "]" || w == "]*" || w == "]+") {
      return out;
    } else {
      Pattern p;
      std::stringstream ss(w);
      std::string alt;
      while (std::getline(ss, alt, '|')) p.alts.push_back(alt);
      out.push_back(std::move(p));
    }
  }
  return out;
}

std::vector<Pattern> CompileForm(const char* form) {
  std::string s = form;
  // Brackets as words of their own.
  std::string spaced;
  for (size_t k = 0; k < s.size(); ++k) {
    if (s[k] == '[') {
      spaced += " [ ";
    } else if (s[k] == ']') {
      spaced += " ]";
      if (k + 1 < s.size() && (s[k + 1] == '*' || s[k + 1] == '+'))
        spaced += s[++k];
      spaced += ' ';
    } else {
      spaced += s[k];
    }
  }
  std::vector<std::string> words;
  std::istringstream in(spaced);
  for (std::string w; in >> w;) words.push_back(w);
  size_t i = 0;
  return ParsePattern(words, i);
}

bool TermMatches(const std::vector<std::string>& alts, const std::string& w) {
  for (const std::string& a : alts) {
    if (a == "n" && IsNumber(w)) return true;
    if (a == "i" && IsNumber(w) && w.find_first_of(".eE-") == std::string::npos)
      return true;
    if (a == "s" && w.size() >= 2 && w.front() == '\'' && w.back() == '\'')
      return true;
    if (a.size() > 2 && a.compare(a.size() - 2, 2, "()") == 0) {
      const auto ref = LabelRef(w);
      if (!ref.first.empty() && ref.first == a.substr(0, a.size() - 2) &&
          !ref.second.empty())
        return true;
      continue;
    }
    if (a == w) return true;
  }
  return false;
}

using Cont = std::function<bool(size_t)>;
bool MatchSeq(const std::vector<Pattern>& items, size_t i,
              const std::vector<std::string>& args, size_t pos,
              const Cont& cont) {
  if (i == items.size()) return cont(pos);
  const Pattern& p = items[i];
  const Cont next = [&](size_t q) {
    return MatchSeq(items, i + 1, args, q, cont);
  };
  switch (p.kind) {
    case Pattern::kTerm:
      return pos < args.size() && TermMatches(p.alts, args[pos]) &&
             next(pos + 1);
    case Pattern::kOpt:
      return MatchSeq(p.seq, 0, args, pos, next) || next(pos);
    case Pattern::kStar:
    case Pattern::kPlus: {
      // One more round (making progress), or stop (kStar, or after one).
      std::function<bool(size_t, int)> rounds = [&](size_t q, int done) {
        if ((p.kind == Pattern::kStar || done > 0) && next(q)) return true;
        return MatchSeq(p.seq, 0, args, q,
                        [&](size_t r) { return r > q && rounds(r, done + 1); });
      };
      return rounds(pos, 0);
    }
  }
  return false;
}

// No DMIS statement has more arguments than this (a FEAT/LINE has 12);
// longer ones are not matched (the matcher recurses per argument).
constexpr size_t kMaxArgs = 256;

bool FormMatches(const char* form, const std::vector<std::string>& args) {
  if (args.size() > kMaxArgs) return false;
  const std::vector<Pattern> items = CompileForm(form);
  return MatchSeq(items, 0, args, 0,
                  [&](size_t q) { return q == args.size(); });
}

const StatementForm* FindForm(const std::string& major) {
  for (const StatementForm& f : Table())
    if (major == f.major) return &f;
  return nullptr;
}

std::string JoinArgs(const std::vector<std::string>& args) {
  std::string s;
  for (size_t k = 0; k < args.size(); ++k) s += (k ? "," : "") + args[k];
  return s;
}

}  // namespace

std::vector<std::string> DmisKnownStatements() {
  std::vector<std::string> out;
  for (const StatementForm& f : Table()) out.push_back(f.major);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<DmisFinding> CheckDmisStandard(const DmisProgram& program) {
  std::vector<DmisFinding> out;
  const auto add = [&](int line, const char* check, const std::string& what) {
    out.push_back({line, check, what});
  };
  const auto& st = program.statements;
  for (int line : program.long_lines)
    add(line, "structure", "the line is longer than 80 characters");
  for (int line : program.long_statements)
    add(line, "structure", "the statement is longer than 256 characters");
  // Statements and their forms.
  for (const DmisStatement& s : st) {
    const StatementForm* form = FindForm(s.major);
    if (!form) {
      add(s.line, "statement",
          s.major + " is not in the DMIS 5 statement table of this reader");
      continue;
    }
    const std::string lhs = form->lhs;
    if (!s.label_type.empty()) {
      bool ok = false;
      std::stringstream ss(lhs);
      for (std::string t; std::getline(ss, t, '|');)
        ok = ok || t == s.label_type;
      if (!ok)
        add(s.line, "statement",
            s.major + " does not take a label " + s.label_type + "(...) =");
    } else if (form->lhs_required) {
      add(s.line, "statement",
          s.major + " needs a label " + lhs.substr(0, lhs.find('|')) +
              "(name) = before it");
    }
    bool matched = false;
    for (const char* f : form->forms)
      matched = matched || FormMatches(f, s.args);
    if (!matched) {
      std::string forms;
      for (const char* f : form->forms)
        forms += std::string(forms.empty() ? "" : " | ") + f;
      add(s.line, "statement",
          s.major + "/" + JoinArgs(s.args) + " matches none of its forms (" +
              forms + ")");
    }
  }
  // File structure.
  const bool is_program = st.front().major == "DMISMN";
  if (!is_program && st.front().major != "FILNAM")
    add(st.front().line, "structure",
        "a DMIS file starts with DMISMN (program) or FILNAM (output)");
  if (st.back().major != "ENDFIL")
    add(st.back().line, "structure", "the last statement is not ENDFIL");
  for (size_t k = 0; k + 1 < st.size(); ++k)
    if (st[k].major == "ENDFIL")
      add(st[k].line, "structure", "statements after ENDFIL");
  // Measurement blocks and labels (programs: an output file reports
  // results, in any order).
  if (!is_program) return out;
  std::map<std::string, std::string> features;  // F label -> type
  std::set<std::string> actual, datums, frames, sensors, devices, open,
      tolerances;
  int meas_line = 0, declared = 0, taken = 0;
  std::string meas_label;
  const auto need = [&](const DmisStatement& s, const std::string& word) {
    // Plain copies, not a structured binding: a lambda may not capture a
    // binding in C++17 (clang refuses it).
    const auto ref = LabelRef(word);
    const std::string type = ref.first, name = ref.second;
    if (type.empty()) return;
    const auto missing = [&](const std::set<std::string>& set,
                             const std::string& what) {
      if (!set.count(name))
        add(s.line, "labels", s.major + " uses " + word + " before " + what);
    };
    if (type == "FA") missing(actual, "it is measured or constructed");
    if (type == "DAT") missing(datums, "DATDEF defines it");
    if (type == "DA") missing(frames, "it is defined");
    if (type == "S") missing(sensors, "SNSDEF defines it");
    if (type == "DID") missing(devices, "DEVICE defines it");
    if (type == "TA" || type == "T") missing(tolerances, "TOL defines it");
    if (type == "F" && !features.count(name))
      add(s.line, "labels",
          s.major + " uses " + word + " before FEAT defines it");
  };
  for (const DmisStatement& s : st) {
    const std::string& m = s.major;
    if (meas_line && m != "PTMEAS" && m != "GOTO" && m != "ENDMES")
      add(s.line, "structure",
          m + " inside the MEAS block of line " + std::to_string(meas_line));
    if (m == "FEAT") features[s.label] = s.args.empty() ? "" : s.args[0];
    if (m == "DATSET" || m == "TRANS" || m == "ROTATE") frames.insert(s.label);
    if (m == "SNSDEF") sensors.insert(s.label);
    if (m == "DEVICE") devices.insert(s.label);
    if (m == "TOL") tolerances.insert(s.label);
    if (m == "MEAS") {
      if (meas_line)
        add(s.line, "structure",
            "MEAS inside the MEAS block of line " + std::to_string(meas_line));
      meas_line = s.line;
      taken = 0;
      declared = 0;
      if (s.args.size() > 2 && IsNumber(s.args[2])) {
        const double n = std::strtod(s.args[2].c_str(), nullptr);
        declared = std::abs(n) < 1e9 ? static_cast<int>(n) : -1;
      }
      meas_label.clear();
      if (s.args.size() > 1) {
        need(s, s.args[1]);
        meas_label = LabelRef(s.args[1]).second;
        auto it = features.find(meas_label);
        if (it != features.end() && it->second != s.args[0])
          add(s.line, "labels",
              "MEAS/" + s.args[0] + " of F(" + meas_label + "), a " +
                  it->second);
      }
      continue;
    }
    if (m == "PTMEAS") {
      if (!meas_line) add(s.line, "structure", "PTMEAS outside a MEAS block");
      ++taken;
      continue;
    }
    if (m == "ENDMES") {
      if (!meas_line) {
        add(s.line, "structure", "ENDMES without MEAS");
        continue;
      }
      if (taken != declared)
        add(meas_line, "structure",
            "MEAS declares " + std::to_string(declared) +
                " points, its block "
                "holds " +
                std::to_string(taken) + " PTMEAS");
      actual.insert(meas_label);
      meas_line = 0;
      continue;
    }
    // Uses: every label reference in the arguments.
    if (m == "CONST") {
      for (size_t k = 2; k < s.args.size(); ++k) need(s, s.args[k]);
      if (s.args.size() > 1) {
        need(s, s.args[1]);
        actual.insert(LabelRef(s.args[1]).second);
      }
      continue;
    }
    if (m == "DATDEF" && s.args.size() == 2) {
      need(s, s.args[0]);
      datums.insert(LabelRef(s.args[1]).second);
      continue;
    }
    if (m == "OPEN" && !s.args.empty()) {
      need(s, s.args[0]);
      open.insert(LabelRef(s.args[0]).second);
      continue;
    }
    if (m == "CLOSE" && !s.args.empty()) {
      if (!open.count(LabelRef(s.args[0]).second))
        add(s.line, "labels", "CLOSE of " + s.args[0] + ", which is not open");
      continue;
    }
    if (m == "FEAT" || m == "DEVICE" || m == "SNSDEF" || m == "TOL") continue;
    for (const std::string& w : s.args) need(s, w);
  }
  if (meas_line) add(meas_line, "structure", "MEAS block without ENDMES");
  return out;
}

// ------------------------------------------------------------ run checks

namespace {

// What the stylus must not touch: the finished piece (its mesh), the
// adapter under it (their distance from a point) and the table the adapter
// stands on (its height) (W frame, mm). The piece's distance is unsigned: the
// sign of the closest triangle's normal is wrong beside convex edges. A path
// that starts outside (above the top face) and never comes closer than a
// positive distance to any surface cannot have entered the material.
class Obstacles {
 public:
  Obstacles(const PartSpec& part, const PartMesh& mesh)
      : query_(mesh),
        adapter_r_(part.adapter_diameter_mm / 2),
        adapter_top_(-part.height_mm()),
        table_z_(-part.height_mm() - part.adapter_height_mm) {}
  // Distance to the piece and the adapter, the bounded obstacles (the
  // table's is a plane: TraceMove takes its least along a move exactly).
  double BoundedDistance(const Eigen::Vector3d& p) const {
    // Finite cylinder about Z.
    const double dr = std::hypot(p.x(), p.y()) - adapter_r_;
    const double dz = std::max(p.z() - adapter_top_, table_z_ - p.z());
    const double adapter =
        dr > 0 && dz > 0 ? std::hypot(dr, dz) : std::max(dr, dz);
    return std::min(adapter, (p - query_.Closest(p).point).norm());
  }
  double table_z() const { return table_z_; }

 private:
  PartQuery query_;
  double adapter_r_, adapter_top_, table_z_;
};

struct MoveResult {
  double min_excess_mm = 1e300;  // clearance beyond what is required
  Eigen::Vector3d where = Eigen::Vector3d::Zero();
};

// Sphere tracing along a straight move of the ball centre: the distance is
// 1-Lipschitz, so from a point with excess e the next e millimetres are
// clear; steps of at least min_step (a violation is then seen within it).
// Inside the adapter (its signed distance below zero, beyond what any
// clearance requires) the step is that depth: the move fails already, and
// the reported depth stays within a factor two of the deepest; a stylus
// grazing a surface keeps steps of min_step, so where it comes closest is
// found as before. The table is not traced: the least clearance above a
// plane along a straight move is at its lower end (traced, a move along
// the table took steps of min_step the whole way: minutes for a hostile
// program's 300 km).
MoveResult TraceMove(const Obstacles& obs, const Eigen::Vector3d& a,
                     const Eigen::Vector3d& b, double ball_required_mm,
                     double shaft_required_mm, double shaft_length_mm) {
  MoveResult r;
  const double length = (b - a).norm();
  // Shaft: points every 2 mm above the ball; the half-spacing is added to
  // what each must clear.
  const auto excess_at = [&](const Eigen::Vector3d& c) {
    double e = obs.BoundedDistance(c) - ball_required_mm;
    for (double h = 2.0; h <= shaft_length_mm + 1e-9; h += 2.0)
      e = std::min(e, obs.BoundedDistance(c + Eigen::Vector3d(0, 0, h)) -
                          shaft_required_mm - 1.0);
    return e;
  };
  // The table, a plane under everything: the least clearance along a
  // straight move is at its lower end, exactly (tracing a move that runs
  // along the table would take steps of the minimum the whole way).
  {
    const Eigen::Vector3d& low = a.z() <= b.z() ? a : b;
    double e = low.z() - obs.table_z() - ball_required_mm;
    for (double h = 2.0; h <= shaft_length_mm + 1e-9; h += 2.0)
      e = std::min(e, low.z() + h - obs.table_z() - shaft_required_mm - 1.0);
    r.min_excess_mm = e;
    r.where = low;
  }
  double s = 0;
  constexpr double kMinStep = 0.05;
  // At most this many samples per move (a safety net: the piece and the
  // adapter are bounded, so a move can graze them only along their size,
  // and far from them the steps grow with the distance): beyond it the
  // move counts as not shown clear.
  constexpr int kMaxSamples = 2'000'000;
  int samples = 0;
  while (true) {
    if (++samples > kMaxSamples) {
      r.min_excess_mm = std::min(r.min_excess_mm, -1e-9);
      break;
    }
    const Eigen::Vector3d c =
        length > 0 ? Eigen::Vector3d(a + (b - a) * (s / length)) : a;
    const double e = excess_at(c);
    if (e < r.min_excess_mm) {
      r.min_excess_mm = e;
      r.where = c;
    }
    if (s >= length) break;
    const double depth =
        -e - std::max(ball_required_mm, shaft_required_mm + 1.0);
    s = std::min(length, s + std::max({kMinStep, e, depth}));
  }
  return r;
}

// Spread of points in their second principal direction (planes).
double SecondSpan(const std::vector<Eigen::Vector3d>& pts) {
  if (pts.size() < 3) return 0;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) cov += (p - c) * (p - c).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Vector3d dir = es.eigenvectors().col(1);  // middle eigenvalue
  double lo = 1e300, hi = -1e300;
  for (const auto& p : pts) {
    lo = std::min(lo, dir.dot(p - c));
    hi = std::max(hi, dir.dot(p - c));
  }
  return hi - lo;
}

// Angle covered by points about an axis through a centre (360 minus the
// largest gap), degrees.
double AngularSpanDeg(const std::vector<Eigen::Vector3d>& pts,
                      const Eigen::Vector3d& centre,
                      const Eigen::Vector3d& axis) {
  if (pts.size() < 2) return 0;
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  std::vector<double> a;
  for (const auto& p : pts)
    a.push_back(std::atan2(v.dot(p - centre), u.dot(p - centre)) *
                57.29577951308232);
  std::sort(a.begin(), a.end());
  double gap = a.front() + 360 - a.back();
  for (size_t k = 1; k < a.size(); ++k) gap = std::max(gap, a[k] - a[k - 1]);
  return 360 - gap;
}

// The numbers among the arguments (coordinates beyond the limit are left
// out: no machine reaches them).
std::vector<double> Numbers(const std::vector<std::string>& args, size_t from) {
  std::vector<double> v;
  for (size_t k = from; k < args.size(); ++k)
    if (IsNumber(args[k])) {
      const double x = std::strtod(args[k].c_str(), nullptr);
      if (std::abs(x) <= limits::kMaxCoordinateMm) v.push_back(x);
    }
  return v;
}

}  // namespace

bool DmisPathOptions::IsValid(std::string* error) const {
  const auto bad = [&](const char* field, const char* why) {
    if (error) *error = std::string("DmisPathOptions.") + field + ": " + why;
    return false;
  };
  if (!(margin_mm >= 0 && margin_mm < 50))
    return bad("margin_mm", "must be in [0, 50)");
  if (!(shaft_length_mm >= 0 && shaft_length_mm <= 500))
    return bad("shaft_length_mm", "must be in [0, 500]");
  if (!(shaft_diameter_mm >= 0 && shaft_diameter_mm < 50))
    return bad("shaft_diameter_mm", "must be in [0, 50)");
  if (!(min_plane_span_mm > 0)) return bad("min_plane_span_mm", "must be > 0");
  if (!(min_circle_span_deg > 0 && min_circle_span_deg <= 360))
    return bad("min_circle_span_deg", "must be in (0, 360]");
  return true;
}

bool DmisProgramCheck::Passed() const {
  for (const DmisRunCheck& c : checks)
    if (!c.passed) return false;
  return true;
}

DmisProgramCheck CheckDmisProgram(const DmisProgram& program,
                                  const PartSpec& part,
                                  const PartMesh& finished,
                                  const DmisPathOptions& options) {
  std::string why;
  if (!options.IsValid(&why))
    throw InputError(
        "DmisPathOptions", 0,
        why.substr(why.find('.') + 1, why.find(": ") - why.find('.') - 1),
        why.substr(why.find(": ") + 2));
  DmisProgramCheck out;
  const char* kNames[] = {"DMIS 5 statements and labels",
                          "sensor, feeds and distances set before measuring",
                          "part aligned from measured datums before moving",
                          "point patterns not degenerate",
                          "moves clear the piece, adapter and table"};
  for (const char* n : kNames) out.checks.push_back({n, true, {}});
  const auto fail = [&](int k, int line, const std::string& what) {
    out.checks[k].passed = false;
    out.checks[k].findings.push_back({line, out.checks[k].name, what});
  };
  for (const DmisFinding& f : CheckDmisStandard(program))
    fail(0, f.line, f.check + ": " + f.problem);

  const Obstacles obs(part, finished);
  std::map<std::string, double> sensor_diameter;
  std::map<std::string, std::vector<double>> nominal;  // F label -> numbers
  std::map<std::string, std::string> nominal_type;
  double ball_r = -1;
  std::optional<double> appr, retr;
  bool pos_feed = false, meas_feed = false, automatic = true, aligned = false;
  std::optional<Eigen::Vector3d> pos;  // ball centre, W
  struct Block {
    int line = 0;
    std::string label, type;
    bool automatic = true;
    std::vector<Eigen::Vector3d> points;
  } block;
  bool in_block = false;
  out.min_clearance_mm = 1e300;
  const auto move = [&](int line, const Eigen::Vector3d& to, bool probing,
                        const char* what) {
    if (!options.check_path) {
      pos = to;
      return;
    }
    const double shaft_r = options.shaft_diameter_mm / 2;
    const MoveResult m =
        probing
            ? TraceMove(obs, *pos, to, ball_r - 0.01, 0, 0)
            : TraceMove(obs, *pos, to, ball_r + options.margin_mm,
                        shaft_r + options.margin_mm, options.shaft_length_mm);
    ++out.moves;
    out.path_length_mm += (to - *pos).norm();
    const double clearance =
        m.min_excess_mm + (probing ? -0.01 : options.margin_mm);
    if (!probing && clearance < out.min_clearance_mm) {
      out.min_clearance_mm = clearance;
      out.min_clearance_where = "line " + std::to_string(line);
    }
    if (m.min_excess_mm < 0)
      fail(4, line,
           fmt::format(
               "{} from ({:.3f}, {:.3f}, {:.3f}) to ({:.3f}, {:.3f}, "
               "{:.3f}): the stylus comes within {:.3f} mm of the "
               "material (ball radius {:.3f} + {:.3f} mm required) "
               "near ({:.3f}, {:.3f}, {:.3f})",
               what, pos->x(), pos->y(), pos->z(), to.x(), to.y(), to.z(),
               m.min_excess_mm + ball_r + (probing ? -0.01 : options.margin_mm),
               ball_r, probing ? 0.0 : options.margin_mm, m.where.x(),
               m.where.y(), m.where.z()));
    pos = to;
  };
  for (const DmisStatement& s : program.statements) {
    const std::string& m = s.major;
    const auto& a = s.args;
    if (m == "MODE") {
      automatic = a.empty() || a[0] != "MAN";
      if (!automatic) pos.reset();  // the operator moves the probe
    } else if (m == "SNSDEF") {
      const auto v = Numbers(a, 0);
      if (!v.empty()) sensor_diameter[s.label] = v.back();
    } else if (m == "SNSLCT" && !a.empty()) {
      auto it = sensor_diameter.find(LabelRef(a[0]).second);
      if (it != sensor_diameter.end()) ball_r = it->second / 2;
    } else if (m == "SNSET" && a.size() == 2 && IsNumber(a[1])) {
      if (a[0] == "APPRCH") appr = std::stod(a[1]);
      if (a[0] == "RETRCT") retr = std::stod(a[1]);
    } else if (m == "FEDRAT" && !a.empty()) {
      pos_feed = pos_feed || a[0] == "POSVEL";
      meas_feed = meas_feed || a[0] == "MESVEL";
    } else if (m == "DATSET") {
      aligned = !a.empty() && LabelRef(a[0]).first == "DAT";
    } else if (m == "FEAT") {
      nominal[s.label] = Numbers(a, 0);
      nominal_type[s.label] = a.empty() ? "" : a[0];
    } else if (m == "GOTO" && automatic) {
      const auto v = Numbers(a, 0);
      if (v.size() != 3) continue;
      if (!aligned) {
        fail(2, s.line, "GOTO before the part is aligned from its datums");
        continue;
      }
      if (ball_r < 0) {
        fail(1, s.line, "GOTO before a sensor is selected (SNSLCT)");
        continue;
      }
      const Eigen::Vector3d to(v[0], v[1], v[2]);
      if (!pos) {
        // From wherever the operator left the probe: the target must lie
        // above the piece.
        if (to.z() < ball_r + options.margin_mm)
          fail(4, s.line,
               fmt::format("first automatic move goes to z = {:.3f}, not "
                           "above the piece (top face z = 0)",
                           to.z()));
        pos = to;
        continue;
      }
      move(s.line, to, false, "GOTO");
    } else if (m == "MEAS") {
      in_block = true;
      block = Block{};
      block.line = s.line;
      block.type = a.empty() ? "" : a[0];
      block.label = a.size() > 1 ? LabelRef(a[1]).second : "";
      block.automatic = automatic;
      if (ball_r < 0) fail(1, s.line, "MEAS before a sensor is selected");
      if (automatic) {
        if (!pos_feed || !meas_feed)
          fail(1, s.line,
               "automatic MEAS before FEDRAT/POSVEL and FEDRAT/MESVEL");
        if (!appr || !retr)
          fail(1, s.line,
               "automatic MEAS before SNSET/APPRCH and SNSET/RETRCT");
        if (!aligned)
          fail(2, s.line, "automatic MEAS before the part is aligned");
      }
    } else if (m == "PTMEAS" && in_block) {
      const auto v = Numbers(a, 1);
      if (v.size() < 3) continue;
      const Eigen::Vector3d p(v[0], v[1], v[2]);
      block.points.push_back(p);
      if (!block.automatic) continue;
      ++out.probe_points;
      if (v.size() < 6) {
        fail(1, s.line, "PTMEAS without its approach vector");
        continue;
      }
      if (!aligned || ball_r < 0 || !appr || !retr) continue;
      const Eigen::Vector3d n = Eigen::Vector3d(v[3], v[4], v[5]).normalized();
      if (!pos) {
        fail(4, s.line, "PTMEAS from an unknown position (GOTO first)");
        pos = p + n * (ball_r + *appr);
      }
      move(s.line, p + n * (ball_r + *appr), false, "approach");
      move(s.line, p + n * ball_r, true, "probing move");
      move(s.line, p + n * (ball_r + *retr), true, "retract");
    } else if (m == "ENDMES" && in_block) {
      in_block = false;
      const std::string& t = block.type;
      const auto nom = nominal[block.label];
      const std::string where = t + " F(" + block.label + ")";
      if (t == "PLANE") {
        const double span = SecondSpan(block.points);
        if (block.points.size() < 3 || span < options.min_plane_span_mm)
          fail(3, block.line,
               fmt::format("{}: {} points spanning {:.3f} mm in their second "
                           "direction (at least 3 points and {:.1f} mm: "
                           "points on a line do not define a plane)",
                           where, block.points.size(), span,
                           options.min_plane_span_mm));
      } else if ((t == "CIRCLE" || t == "CYLNDR") && nom.size() >= 6) {
        const Eigen::Vector3d c(nom[0], nom[1], nom[2]);
        const Eigen::Vector3d axis =
            Eigen::Vector3d(nom[3], nom[4], nom[5]).normalized();
        const double span = AngularSpanDeg(block.points, c, axis);
        if (block.points.size() < 3 || span < options.min_circle_span_deg)
          fail(3, block.line,
               fmt::format("{}: {} points spanning {:.1f} deg (at least 3 "
                           "points over {:.0f} deg)",
                           where, block.points.size(), span,
                           options.min_circle_span_deg));
      }
    }
  }
  if (out.moves == 0) out.min_clearance_mm = 0;
  if (out.probe_points == 0)
    fail(3, 0, "no automatic PTMEAS: nothing is measured by the program");
  return out;
}

nlohmann::json DmisProgramCheckToJson(const DmisProgramCheck& check) {
  nlohmann::json j;
  j["passed"] = check.Passed();
  j["moves"] = check.moves;
  j["probe_points"] = check.probe_points;
  j["min_clearance_mm"] = check.min_clearance_mm;
  j["min_clearance_where"] = check.min_clearance_where;
  j["path_length_mm"] = check.path_length_mm;
  nlohmann::json checks = nlohmann::json::array();
  for (const DmisRunCheck& c : check.checks) {
    nlohmann::json f = nlohmann::json::array();
    for (const DmisFinding& x : c.findings)
      f.push_back({{"line", x.line}, {"problem", x.problem}});
    checks.push_back({{"name", c.name}, {"passed", c.passed}, {"findings", f}});
  }
  j["checks"] = checks;
  return j;
}

}  // namespace ttp::inspect
