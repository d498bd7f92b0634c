// The nominal features of the piece in the workpiece frame W (mm), named as
// in talc-log.md section 5 (Z1..Z9, X1-1..Y2-9) plus the datums. Shared by
// CAM (what to cut), inspection (what to fit) and the thermal model (what
// moves).
#pragma once

#include <Eigen/Core>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"

namespace ttp {

enum class Segment { kX1 = 0, kY1 = 1, kX2 = 2, kY2 = 3 };
constexpr Segment kSegments[4] = {Segment::kX1, Segment::kY1, Segment::kX2,
                                  Segment::kY2};
const char* SegmentName(Segment s);

enum class FeatureKind {
  kFacet,       // plane, outward normal radial
  kStrip,       // plane on the big-notch floor, normal +Z
  kTopFace,     // datum plane z = 0 (all four segments)
  kFlank,       // datum planes y = +-53, normal into the notch
  kCylinder,    // reference cylinders (axis Z)
  kNotchFloor,  // big-notch floor outside the strips; small-notch floor
  kMark,        // engraved line
  kSphere,      // the R-test sphere on the table (stylus qualification):
                // a feature of the setup, not of the piece
};

enum class Stage { kBlank, kPreMachined, kFinished };

struct FeatureId;

struct NominalFeature {
  std::string id;  // "X1-5", "Z3", "TOP", "FLANK+Y", "CYL199", ...
  FeatureKind kind;
  Eigen::Vector3d point;   // a point on the surface (facet: foot point of
                           // the normal from W's origin at z = 0; strip:
                           // (0, y_k, floor); cylinder: (0,0,z mid))
  Eigen::Vector3d normal;  // outward unit normal, or the axis for cylinders
  double size_mm = 0;      // facet distance, cylinder diameter, strip width
  // Extent on the surface, in the feature's own terms: facets and flanks
  // use tangential [t_min, t_max] and z range; strips x range (with the
  // small notch cut out) and y range; cylinders z range.
  double t_min_mm = 0, t_max_mm = 0, z_min_mm = 0, z_max_mm = 0;
  // Segment and index for facets (1..9) and strips (index only).
  std::optional<Segment> segment;
  int index = 0;
  int cycle = -1;  // test cycle that cuts it (0 = reference), -1 = none

  // The typed identity that results are keyed by (`id` is its name):
  // facets and strips from segment and index, datums from the name.
  FeatureId Key() const;
};

// Facet normal angle phi(S, j) in W, degrees.
double FacetPhiDeg(const PartSpec& part, Segment s, int j);
// Strip centre line y_k in W, mm.
double StripY(const PartSpec& part, int k);
// Index j (facets) / k (strip) cut in test cycle i (0..8): 5, 1,2,3,4, 6..9.
int IndexForCycle(const PartSpec& part, int cycle);
// Inverse: the cycle cutting index j, or -1 (none).
int CycleForIndex(const PartSpec& part, int index);

std::string FacetId(Segment s, int j);       // "X1-5"
std::string StripId(int k);                  // "Z5"
std::string CylinderId(double diameter_mm);  // "CYL199"
// The datum circle's cylinder: the first reference cylinder ("CYL199").
std::string DatumCylinderId(const PartSpec& part);

// A feature's identity as typed data: a facet (segment, index 1..9), a
// strip (index 1..9) or a datum (the top face; a flank, index +1 / -1 for
// FLANK+Y / FLANK-Y; a reference cylinder, index = its diameter in um; the
// mark; a notch floor, index 0 small / 1 big) or the R-test sphere. Code
// keys and compares features by this; the name of talc-log.md section 5
// ("X1-5", "Z3", "TOP", "FLANK+Y", "CYL199", "MARK", "NOTCH_BIG", "SPHERE")
// is its form in files and messages only (ToString / Parse).
struct FeatureId {
  FeatureKind kind = FeatureKind::kFacet;
  Segment segment = Segment::kX1;  // facets only
  int index = 0;

  static FeatureId Facet(Segment s, int j) {
    return {FeatureKind::kFacet, s, j};
  }
  static FeatureId Strip(int k) { return {FeatureKind::kStrip, Segment::kX1, k}; }
  static FeatureId Datum(FeatureKind kind, int index = 0) {
    return {kind, Segment::kX1, index};
  }
  static FeatureId Top() { return Datum(FeatureKind::kTopFace); }
  // side +1: FLANK+Y, -1: FLANK-Y.
  static FeatureId Flank(int side) {
    return Datum(FeatureKind::kFlank, side < 0 ? -1 : +1);
  }
  static FeatureId Cylinder(double diameter_mm);
  // The datum circle's cylinder: the first reference cylinder ("CYL199").
  static FeatureId DatumCylinder(const PartSpec& part);
  static FeatureId Sphere() { return Datum(FeatureKind::kSphere); }
  bool IsTestFeature() const {
    return kind == FeatureKind::kFacet || kind == FeatureKind::kStrip;
  }
  std::string ToString() const;
  // The id named by `text`, or nothing when it names no feature (the caller
  // reports it with its file and line).
  static std::optional<FeatureId> Parse(const std::string& text);

  bool operator==(const FeatureId& o) const {
    return kind == o.kind && index == o.index &&
           (kind != FeatureKind::kFacet || segment == o.segment);
  }
  bool operator!=(const FeatureId& o) const { return !(*this == o); }
  bool operator<(const FeatureId& o) const;
};
// Writes the name (messages, test failures).
std::ostream& operator<<(std::ostream& os, const FeatureId& id);

// A feature's label in DMIS programs and outputs (letters, digits, '_'):
// "X1_5", "Z3", "TOP", "FLANK_PY", "FLANK_NY", "CYL199".
std::string DmisLabel(const FeatureId& id);
// The test feature or datum a DMIS label stands for, case-blind: DmisLabel's
// forms, the names ("X1-5", "FLANK+Y") and "STRIP_3" for Z3, "FLANKPY" /
// "FLANKNY". Nothing for any other label (the mark's points MARK and
// MARK_OPP are read by their labels).
std::optional<FeatureId> FeatureIdForDmisLabel(const std::string& label);

// Parses a test feature's name (a facet or a strip) of talc-log.md section
// 5. Returns false if it is not one (the caller reports it). Equivalent to
// FeatureId::Parse restricted to facets and strips.
bool ParseFeatureId(const std::string& id, FeatureKind* kind, Segment* segment,
                    int* index);

// All nominal features of the piece at a stage. Facets are at the pre
// distance for kPreMachined, at the final distance for kFinished. Strips
// and facets exist only from kPreMachined (strips only when kFinished).
std::vector<NominalFeature> BuildNominalFeatures(const PartSpec& part,
                                                 Stage stage);

// The 36 facets and 9 strips of the finished piece, in cycle order.
std::vector<NominalFeature> TestFeatures(const PartSpec& part);

}  // namespace ttp
