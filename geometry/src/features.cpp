#include "ttp/geometry/features.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <ostream>
#include <regex>

#include "ttp/geometry/constants.h"

namespace ttp {

const char* SegmentName(Segment s) {
  switch (s) {
    case Segment::kX1:
      return "X1";
    case Segment::kY1:
      return "Y1";
    case Segment::kX2:
      return "X2";
    case Segment::kY2:
      return "Y2";
  }
  return "?";
}

double FacetPhiDeg(const PartSpec& part, Segment s, int j) {
  return part.segment_centre_deg[static_cast<int>(s)] +
         (j - part.reference_index) * part.facet_step_deg;
}

double StripY(const PartSpec& part, int k) {
  return (k - part.reference_index) * part.strip_pitch_mm;
}

int IndexForCycle(const PartSpec& part, int cycle) {
  if (cycle <= 0) return part.reference_index;
  return cycle < part.reference_index ? cycle : cycle + 1;
}

int CycleForIndex(const PartSpec& part, int index) {
  if (index < 1 || index > part.facets_per_segment) return -1;
  if (index == part.reference_index) return 0;
  return index < part.reference_index ? index : index - 1;
}

std::string FacetId(Segment s, int j) {
  return std::string(SegmentName(s)) + "-" + std::to_string(j);
}
std::string StripId(int k) { return "Z" + std::to_string(k); }

std::string CylinderId(double diameter_mm) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "CYL%g", diameter_mm);
  return buf;
}

std::string DatumCylinderId(const PartSpec& part) {
  return CylinderId(part.ref_cylinders.front().diameter_mm);
}

std::string FeatureId::ToString() const {
  switch (kind) {
    case FeatureKind::kFacet:
      return FacetId(segment, index);
    case FeatureKind::kStrip:
      return StripId(index);
    case FeatureKind::kTopFace:
      return "TOP";
    case FeatureKind::kFlank:
      return index < 0 ? "FLANK-Y" : "FLANK+Y";
    case FeatureKind::kCylinder:
      return CylinderId(index / 1000.0);
    case FeatureKind::kMark:
      return "MARK";
    case FeatureKind::kNotchFloor:
      return index == 0 ? "NOTCH_SMALL" : "NOTCH_BIG";
    case FeatureKind::kSphere:
      return "SPHERE";
  }
  return "?";
}

std::optional<FeatureId> FeatureId::Parse(const std::string& text) {
  static const std::regex facet(R"(^(X1|Y1|X2|Y2)-([1-9])$)");
  static const std::regex strip(R"(^Z([1-9])$)");
  static const std::regex cylinder(R"(^CYL([0-9]{1,4}(\.[0-9]{1,3})?)$)");
  std::smatch m;
  if (std::regex_match(text, m, facet)) {
    const std::string s = m[1];
    const Segment seg = s == "X1"   ? Segment::kX1
                        : s == "Y1" ? Segment::kY1
                        : s == "X2" ? Segment::kX2
                                    : Segment::kY2;
    return Facet(seg, m[2].str()[0] - '0');
  }
  if (std::regex_match(text, m, strip)) return Strip(m[1].str()[0] - '0');
  if (text == "TOP") return Datum(FeatureKind::kTopFace);
  if (text == "FLANK+Y") return Datum(FeatureKind::kFlank, +1);
  if (text == "FLANK-Y") return Datum(FeatureKind::kFlank, -1);
  if (text == "MARK") return Datum(FeatureKind::kMark);
  if (text == "NOTCH_SMALL") return Datum(FeatureKind::kNotchFloor, 0);
  if (text == "NOTCH_BIG") return Datum(FeatureKind::kNotchFloor, 1);
  if (text == "SPHERE") return Sphere();
  if (std::regex_match(text, m, cylinder)) {
    const long um = std::lround(std::stod(m[1]) * 1000);
    if (um > 0) return Datum(FeatureKind::kCylinder, static_cast<int>(um));
  }
  return std::nullopt;
}

FeatureId FeatureId::Cylinder(double diameter_mm) {
  return Datum(FeatureKind::kCylinder,
               static_cast<int>(std::lround(diameter_mm * 1000)));
}

FeatureId FeatureId::DatumCylinder(const PartSpec& part) {
  return Cylinder(part.ref_cylinders.front().diameter_mm);
}

std::ostream& operator<<(std::ostream& os, const FeatureId& id) {
  return os << id.ToString();
}

FeatureId NominalFeature::Key() const {
  if (kind == FeatureKind::kFacet && segment)
    return FeatureId::Facet(*segment, index);
  if (kind == FeatureKind::kStrip) return FeatureId::Strip(index);
  return FeatureId::Parse(id).value_or(FeatureId::Datum(kind, index));
}

std::string DmisLabel(const FeatureId& id) {
  if (id.kind == FeatureKind::kFlank)
    return id.index < 0 ? "FLANK_NY" : "FLANK_PY";
  std::string s = id.ToString();
  for (char& c : s)
    if (c == '-' || c == '+') c = '_';
  return s;
}

std::optional<FeatureId> FeatureIdForDmisLabel(const std::string& label) {
  const size_t b = label.find_first_not_of(" \t");
  const size_t e = label.find_last_not_of(" \t");
  std::string s = b == std::string::npos ? "" : label.substr(b, e - b + 1);
  for (char& c : s)
    c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (s == "FLANK_PY" || s == "FLANKPY") return FeatureId::Flank(+1);
  if (s == "FLANK_NY" || s == "FLANKNY") return FeatureId::Flank(-1);
  const std::string strip = "STRIP_";
  if (s.compare(0, strip.size(), strip) == 0) s = "Z" + s.substr(strip.size());
  std::replace(s.begin(), s.end(), '_', '-');
  const std::optional<FeatureId> id = FeatureId::Parse(s);
  if (id &&
      (id->IsTestFeature() || id->kind == FeatureKind::kTopFace ||
       id->kind == FeatureKind::kFlank || id->kind == FeatureKind::kCylinder))
    return id;
  return std::nullopt;
}

bool FeatureId::operator<(const FeatureId& o) const {
  if (kind != o.kind) return kind < o.kind;
  if (kind == FeatureKind::kFacet && segment != o.segment)
    return segment < o.segment;
  return index < o.index;
}

bool ParseFeatureId(const std::string& id, FeatureKind* kind, Segment* segment,
                    int* index) {
  const std::optional<FeatureId> f = FeatureId::Parse(id);
  if (!f || !f->IsTestFeature()) return false;
  *kind = f->kind;
  if (f->kind == FeatureKind::kFacet) *segment = f->segment;
  *index = f->index;
  return true;
}

namespace {

NominalFeature MakeFacet(const PartSpec& p, Segment s, int j, double distance) {
  NominalFeature f;
  f.id = FacetId(s, j);
  f.kind = FeatureKind::kFacet;
  const double phi = FacetPhiDeg(p, s, j) * kDeg;
  f.normal = Eigen::Vector3d(std::cos(phi), std::sin(phi), 0.0);
  f.point = distance * f.normal;
  f.size_mm = distance;
  // Neighbouring facets at the same distance meet at +-d tan(step/2).
  const double half = distance * std::tan(p.facet_step_deg / 2 * kDeg);
  f.t_min_mm = -half;
  f.t_max_mm = half;
  f.z_min_mm = p.facet_bottom_z_mm;
  f.z_max_mm = 0.0;
  f.segment = s;
  f.index = j;
  f.cycle = CycleForIndex(p, j);
  return f;
}

NominalFeature MakeStrip(const PartSpec& p, int k) {
  NominalFeature f;
  f.id = StripId(k);
  f.kind = FeatureKind::kStrip;
  f.point = Eigen::Vector3d(0.0, StripY(p, k), p.strip_floor_z_mm);
  f.normal = Eigen::Vector3d::UnitZ();
  f.size_mm = p.strip_width_mm;
  // Along X the strip runs to the 199 cylinder under the floor.
  const double r = p.ref_cylinders.front().diameter_mm / 2;
  const double y = std::abs(StripY(p, k)) + p.strip_width_mm / 2;
  const double x_end = std::sqrt(std::max(0.0, r * r - y * y));
  f.t_min_mm = -x_end;
  f.t_max_mm = x_end;
  f.z_min_mm = f.z_max_mm = p.strip_floor_z_mm;
  f.index = k;
  f.cycle = CycleForIndex(p, k);
  return f;
}

}  // namespace

std::vector<NominalFeature> TestFeatures(const PartSpec& p) {
  std::vector<NominalFeature> out;
  for (int cycle = 0; cycle <= p.cycles(); ++cycle) {
    const int j = IndexForCycle(p, cycle);
    out.push_back(MakeStrip(p, j));
    for (Segment s : kSegments) {
      out.push_back(MakeFacet(p, s, j, p.facet_final_distance_mm));
    }
  }
  return out;
}

std::vector<NominalFeature> BuildNominalFeatures(const PartSpec& p,
                                                 Stage stage) {
  std::vector<NominalFeature> out;
  if (stage == Stage::kBlank) {
    NominalFeature top{"TOP", FeatureKind::kTopFace,
                       Eigen::Vector3d(0, 0, p.face_depth_mm),
                       Eigen::Vector3d::UnitZ(), p.blank_diameter_mm};
    out.push_back(top);
    NominalFeature cyl{"CYL_BLANK", FeatureKind::kCylinder,
                       Eigen::Vector3d(0, 0, -p.height_mm() / 2),
                       Eigen::Vector3d::UnitZ(), p.blank_diameter_mm};
    cyl.z_min_mm = -p.height_mm();
    cyl.z_max_mm = p.face_depth_mm;
    out.push_back(cyl);
    return out;
  }
  // Datums.
  NominalFeature top{"TOP", FeatureKind::kTopFace, Eigen::Vector3d::Zero(),
                     Eigen::Vector3d::UnitZ(), 0.0};
  out.push_back(top);
  for (int side : {+1, -1}) {
    NominalFeature flank;
    flank.id = side > 0 ? "FLANK+Y" : "FLANK-Y";
    flank.kind = FeatureKind::kFlank;
    flank.point = Eigen::Vector3d(0, side * p.big_notch_half_width_mm, -6.0);
    flank.normal = Eigen::Vector3d(0, -side, 0);  // material -> notch
    flank.size_mm = p.big_notch_half_width_mm;
    const double r = p.facet_pre_distance_mm;
    flank.t_min_mm = -r;
    flank.t_max_mm = r;
    flank.z_min_mm = p.big_notch_floor_z_mm;
    flank.z_max_mm = 0.0;
    out.push_back(flank);
  }
  for (const RefCylinder& rc : p.ref_cylinders) {
    NominalFeature cyl;
    cyl.id = CylinderId(rc.diameter_mm);
    cyl.kind = FeatureKind::kCylinder;
    cyl.point = Eigen::Vector3d(0, 0, (rc.z_bottom_mm + rc.z_top_mm) / 2);
    cyl.normal = Eigen::Vector3d::UnitZ();
    cyl.size_mm = rc.diameter_mm;
    cyl.z_min_mm = rc.z_bottom_mm;
    cyl.z_max_mm = rc.z_top_mm;
    out.push_back(cyl);
  }
  NominalFeature small{"NOTCH_SMALL", FeatureKind::kNotchFloor,
                       Eigen::Vector3d(0, 0, p.small_notch_floor_z_mm),
                       Eigen::Vector3d::UnitZ(),
                       2 * p.small_notch_half_width_mm};
  out.push_back(small);
  NominalFeature floor{"NOTCH_BIG", FeatureKind::kNotchFloor,
                       Eigen::Vector3d(0, 0, p.big_notch_floor_z_mm),
                       Eigen::Vector3d::UnitZ(), 2 * p.big_notch_half_width_mm};
  out.push_back(floor);
  NominalFeature mark;
  mark.id = "MARK";
  mark.kind = FeatureKind::kMark;
  const double phi = p.mark_phi_deg * kDeg;
  const Eigen::Vector3d dir(std::cos(phi), std::sin(phi), 0);
  mark.point = (p.mark_r_start_mm + p.mark_r_end_mm) / 2 * dir +
               Eigen::Vector3d(0, 0, -p.mark_depth_mm);
  mark.normal = dir;  // direction of the line
  mark.size_mm = p.mark_width_mm;
  mark.t_min_mm = p.mark_r_start_mm;
  mark.t_max_mm = p.mark_r_end_mm;
  mark.z_min_mm = -p.mark_depth_mm;
  mark.z_max_mm = 0.0;
  out.push_back(mark);

  // Facets: all 36 at the pre distance; finished ones at the final one.
  for (Segment s : kSegments) {
    for (int j = 1; j <= p.facets_per_segment; ++j) {
      out.push_back(MakeFacet(p, s, j,
                              stage == Stage::kFinished
                                  ? p.facet_final_distance_mm
                                  : p.facet_pre_distance_mm));
    }
  }
  if (stage == Stage::kFinished) {
    for (int k = 1; k <= p.facets_per_segment; ++k) {
      out.push_back(MakeStrip(p, k));
    }
  }
  return out;
}

}  // namespace ttp
