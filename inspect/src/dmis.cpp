#include "ttp/inspect/dmis.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/limits.h"
#include "ttp/inspect/plane_result.h"

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
  for (const Statement& st : Statements(text)) {
    any_statement = true;
    const std::string up = Upper(st.text);
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
    if (f.type == "SPHERE") {
      f.diameter_mm = v[3] * scale;
    } else {
      const Eigen::Vector3d dir(v[3], v[4], v[5]);
      if (dir.norm() < 1e-12)
        throw InputError(source, st.line, "FA(" + f.label + ")",
                         "direction vector is zero");
      f.direction = dir.normalized();
      if (need == 7) f.diameter_mm = v[6] * scale;
    }
    out.features.push_back(f);
  }
  if (!any_statement) throw InputError(source, 0, "file", "is empty");
  return out;
}

std::string TestFeatureIdForDmisLabel(const std::string& label) {
  std::string s = Upper(Trim(label));
  if (s == "TOP") return "TOP";
  if (s == "FLANK_PY" || s == "FLANK+Y" || s == "FLANKPY") return "FLANK+Y";
  if (s == "FLANK_NY" || s == "FLANK-Y" || s == "FLANKNY") return "FLANK-Y";
  if (s.rfind("CYL", 0) == 0) return s;  // a reference cylinder, "CYL199"
  if (s.rfind("STRIP_", 0) == 0) s = "Z" + s.substr(6);
  std::replace(s.begin(), s.end(), '_', '-');
  const std::optional<FeatureId> id = FeatureId::Parse(s);
  return id && id->IsTestFeature() ? id->ToString() : "";
}

DmisImport DmisToFeatureResults(const DmisResults& dmis, const PartSpec& part) {
  DmisImport out;
  std::map<std::string, const DmisFeature*> by_id;
  for (const DmisFeature& f : dmis.features) {
    const std::string id = TestFeatureIdForDmisLabel(f.label);
    if (id.empty()) continue;  // a datum or another feature: not a result
    if (by_id.count(id))
      throw InputError(dmis.source, f.line, "FA(" + f.label + ")",
                       id + " is reported twice (first on line " +
                           std::to_string(by_id[id]->line) + ")");
    by_id[id] = &f;
  }

  // W from the datums (test-piece.md section 5), if all are there.
  Eigen::Isometry3d to_w = Eigen::Isometry3d::Identity();
  double top_z_mm = 0.0;
  const std::string datum = DatumCylinderId(part);
  const auto has = [&](const std::string& id,
                       std::initializer_list<const char*> t) {
    auto it = by_id.find(id);
    if (it == by_id.end()) return false;
    for (const char* type : t)
      if (it->second->type == type) return true;
    return false;
  };
  if (has("TOP", {"PLANE"}) && has("FLANK+Y", {"PLANE"}) &&
      has("FLANK-Y", {"PLANE"}) && has(datum, {"CIRCLE", "CYLNDR"})) {
    const DmisFeature& top = *by_id["TOP"];
    const Eigen::Vector3d z = top.direction.z() >= 0
                                  ? top.direction
                                  : Eigen::Vector3d(-top.direction);
    // The flanks are parallel: W's Y is their common normal, oriented from
    // the -Y flank towards the +Y flank (the reported normals' signs vary).
    const DmisFeature& plus = *by_id["FLANK+Y"];
    const DmisFeature& minus = *by_id["FLANK-Y"];
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
        "datums TOP, FLANK+Y, FLANK-Y and " + datum +
        " not all reported: the reported coordinates are taken as the "
        "workpiece frame W");
    if (has("TOP", {"PLANE"})) {
      const DmisFeature& top = *by_id["TOP"];
      top_z_mm = top.point_mm.z();
    }
  }

  std::vector<std::string> reversed;
  for (const NominalFeature& nominal : TestFeatures(part)) {
    auto it = by_id.find(nominal.id);
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
              "piece's size");
    // MPE = 1.2 um + L/400 (L in mm) bounds each point; as a uniform bound
    // its standard uncertainty is MPE/sqrt(3). The angle over the feature's
    // extent L_f: two independent ends.
    const double reach_mm = nominal.point.norm();
    const double u_mm = (1.2 + reach_mm / 400.0) * 1e-3 / std::sqrt(3.0);
    const double extent_mm = std::max(1.0, nominal.t_max_mm - nominal.t_min_mm);
    r.var_d_mm2 = u_mm * u_mm;
    r.var_angle_rad2 = 2.0 * u_mm * u_mm / (extent_mm * extent_mm);
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
