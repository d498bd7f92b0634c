#include <fmt/format.h>

#include <cmath>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/limits.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

// n evenly spread values inside [lo, hi] (cell centres), or the middle.
std::vector<double> Spread(double lo, double hi, int n) {
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(lo + (hi - lo) * (i + 0.5) / n);
  return v;
}

// n points from lo to hi with the outer two at the ends (one point: the
// middle). For a test feature the touches measure a plane's tilt (a
// facet's angle, a strip's beta) as well as its position: the tilt's
// standard deviation goes with 1 / spread of the touches, and Spread's
// half-steps at either end would lose a third of it with three columns.
std::vector<double> SpreadToEnds(double lo, double hi, int n) {
  if (n == 1) return {(lo + hi) / 2};
  std::vector<double> v;
  for (int i = 0; i < n; ++i) v.push_back(lo + (hi - lo) * i / (n - 1));
  return v;
}

// A count in 1..limit (the limit keeps a plan from allocating without
// bound: 1e5 x 1e5 facet points would be tens of gigabytes).
void Positive(int value, const char* field, int limit = 1000) {
  if (value < 1)
    throw InputError("PlanOptions", 0, field,
                     fmt::format("must be >= 1, got {}", value));
  if (value > limit)
    throw InputError("PlanOptions", 0, field,
                     fmt::format("{} is beyond the limit of {}", value, limit));
}

}  // namespace

void PlanOptions::Validate() const {
  Positive(facet_columns, "facet_columns", limits::kMaxFacetColumns);
  Positive(facet_rows, "facet_rows", limits::kMaxFacetRows);
  Positive(strip_points_per_side, "strip_points_per_side",
           limits::kMaxStripPoints);
  Positive(flank_points, "flank_points", limits::kMaxStripPoints);
  Positive(top_points_per_segment, "top_points_per_segment",
           limits::kMaxStripPoints);
  Positive(cylinder_points, "cylinder_points", limits::kMaxStripPoints);
  if (cylinder_points < 3)
    throw InputError("PlanOptions", 0, "cylinder_points",
                     "a circle needs at least 3 points");
  if (!(edge_margin_mm >= 0 && edge_margin_mm < 4))
    throw InputError("PlanOptions", 0, "edge_margin_mm",
                     "must be in [0, 4) mm");
}

std::vector<PlannedPoint> PlanPoints(const PartSpec& part,
                                     const PlanOptions& options) {
  options.Validate();
  std::vector<PlannedPoint> out;
  const auto add = [&](const FeatureId& feature, const Eigen::Vector3d& p,
                       const Eigen::Vector3d& n) {
    PlannedPoint q;
    q.id = static_cast<int>(out.size()) + 1;
    q.feature = feature;
    q.point_w_mm = p;
    q.normal_w = n.normalized();
    out.push_back(q);
  };
  const double m = options.edge_margin_mm;
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();

  // TOP: on every segment, outside the big notch, inside the facets and
  // off the engraved mark.
  const double r_out = part.facet_final_distance_mm - 2 * m;
  const double y_min = part.big_notch_half_width_mm + 2 * m;
  for (double centre : part.segment_centre_deg) {
    const int n = options.top_points_per_segment;
    for (double offset : Spread(-8.0, 8.0, n)) {
      const double phi_deg = centre + offset;
      const double phi = phi_deg * kDeg;
      const double r_min = y_min / std::max(0.1, std::abs(std::sin(phi)));
      double r = std::min(r_out, (r_min + r_out) / 2);
      const bool on_mark =
          std::abs(std::remainder(phi_deg - part.mark_phi_deg, 360.0)) < 2.0 &&
          r > part.mark_r_start_mm - 2 && r < part.mark_r_end_mm + 2;
      if (on_mark) r = r_out;
      add(FeatureId::Top(),
          Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), 0), z);
    }
  }
  // Flanks: y = +-h, normal into the notch, between the small notch and the
  // facets, at mid height of the segment.
  for (int side : {+1, -1}) {
    const double h = part.big_notch_half_width_mm;
    const double x_max =
        std::sqrt(std::max(
            0.0, part.facet_final_distance_mm * part.facet_final_distance_mm -
                     h * h)) -
        2 * m;
    const double x_min = part.small_notch_half_width_mm + 2 * m;
    const double zc = part.big_notch_floor_z_mm / 2;
    const int n = options.flank_points;
    const int left = n / 2, right = n - left;
    std::vector<double> xs;
    for (double x : Spread(x_min, x_max, right)) xs.push_back(x);
    for (double x : Spread(x_min, x_max, left)) xs.push_back(-x);
    for (double x : xs)
      add(FeatureId::Flank(side), Eigen::Vector3d(x, side * h, zc),
          Eigen::Vector3d(0, -side, 0));
  }
  // The 199 datum circle, in the middle of its datum band.
  {
    const RefCylinder& c = part.ref_cylinders.front();
    const double r = c.diameter_mm / 2;
    const double zc =
        (part.datum_circle_z_min_mm + part.datum_circle_z_max_mm) / 2;
    const FeatureId id = FeatureId::Cylinder(c.diameter_mm);
    for (int i = 0; i < options.cylinder_points; ++i) {
      const double phi = (2 * kPi * (i + 0.5)) / options.cylinder_points;
      const Eigen::Vector3d n(std::cos(phi), std::sin(phi), 0);
      add(id, r * n + zc * z, n);
    }
  }
  // Test features: strips on both sides of the small notch, facets on a
  // grid inside their edges.
  for (const NominalFeature& f : TestFeatures(part)) {
    if (f.kind == FeatureKind::kStrip) {
      const double x_lo = part.small_notch_half_width_mm + 2 * m;
      const double x_hi = f.t_max_mm - 2 * m;
      const int n = options.strip_points_per_side;
      for (int side : {-1, +1})
        for (double x : SpreadToEnds(x_lo, x_hi, n))
          add(f.Key(), Eigen::Vector3d(side * x, f.point.y(), f.point.z()), z);
      continue;
    }
    const Eigen::Vector3d t = z.cross(f.normal);
    // Rows keep Spread's half-steps: a ball at the bottom margin would
    // meet the shoulder below the facets (the 199 cylinder at z = -12).
    for (double zz : Spread(f.z_min_mm + m, f.z_max_mm - m, options.facet_rows))
      for (double tt :
           SpreadToEnds(f.t_min_mm + m, f.t_max_mm - m, options.facet_columns))
        add(f.Key(), f.point + tt * t + zz * z, f.normal);
  }
  return out;
}

std::string PointsToCsv(const std::vector<PlannedPoint>& points) {
  std::string out =
      "point_id,feature,x_mm,y_mm,z_mm,approach_i,approach_j,approach_k\n";
  for (const PlannedPoint& p : points) {
    const Eigen::Vector3d a = -p.normal_w;
    out +=
        fmt::format("{},{},{:.6f},{:.6f},{:.6f},{:.9f},{:.9f},{:.9f}\n", p.id,
                    p.feature.ToString(), p.point_w_mm.x(), p.point_w_mm.y(),
                    p.point_w_mm.z(), a.x() + 0.0, a.y() + 0.0, a.z() + 0.0);
  }
  return out;
}

std::vector<PlannedPoint> PointsFromCsv(const std::string& text,
                                        const std::string& source) {
  const CsvTable t = ParseCsv(text, source);
  const int id = t.Require("point_id"), feature = t.Require("feature");
  const int x = t.Require("x_mm"), y = t.Require("y_mm"),
            zc = t.Require("z_mm");
  const int i = t.Require("approach_i"), j = t.Require("approach_j"),
            k = t.Require("approach_k");
  std::vector<PlannedPoint> out;
  for (const CsvRow& row : t.rows) {
    PlannedPoint p;
    const double idv = t.Number(row, id);
    if (!(idv >= 1 && idv <= 1e9) || idv != std::floor(idv))
      throw InputError(source, row.line, "point_id",
                       "must be a whole number from 1 to 1e9");
    p.id = static_cast<int>(idv);
    const std::string name = t.Text(row, feature);
    const std::optional<FeatureId> parsed = FeatureId::Parse(name);
    if (!parsed)
      throw InputError(source, row.line, "feature",
                       "'" + name +
                           "' is not a feature name (X1-1..Y2-9, "
                           "Z1..Z9, TOP, FLANK+Y, FLANK-Y, CYL<diameter>)");
    p.feature = *parsed;
    p.point_w_mm = {t.Number(row, x), t.Number(row, y), t.Number(row, zc)};
    const int coordinate[3] = {x, y, zc};
    for (int c = 0; c < 3; ++c)
      if (!(std::abs(p.point_w_mm[c]) <= limits::kMaxCoordinateMm))
        throw InputError(source, row.line,
                         t.columns[static_cast<size_t>(coordinate[c])],
                         "beyond " + std::to_string(limits::kMaxCoordinateMm) +
                             " mm: not a point of the piece");
    const Eigen::Vector3d a(t.Number(row, i), t.Number(row, j),
                            t.Number(row, k));
    if (std::abs(a.norm() - 1.0) > 1e-6)
      throw InputError(source, row.line, "approach_i",
                       "the approach vector must be a unit vector");
    p.normal_w = -a;
    out.push_back(p);
  }
  return out;
}

}  // namespace ttp::plan
