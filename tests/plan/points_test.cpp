#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::map<std::string, NominalFeature> Nominals(const PartSpec& part) {
  std::map<std::string, NominalFeature> out;
  for (const auto& f : BuildNominalFeatures(part, Stage::kFinished))
    out[f.id] = f;
  for (const auto& f : TestFeatures(part)) out[f.id] = f;
  return out;
}

// Is a top-face point on material: inside a segment's angular span, outside
// the big notch, inside the facets' inscribed circle, off the mark?
bool OnSegmentTop(const PartSpec& part, const Eigen::Vector3d& p) {
  const double r = p.head<2>().norm();
  if (std::abs(p.y()) <= part.big_notch_half_width_mm) return false;
  if (r >= part.facet_final_distance_mm) return false;
  const double phi = std::atan2(p.y(), p.x()) * 180 / kPi;
  bool in_span = false;
  for (double c : part.segment_centre_deg)
    in_span |=
        std::abs(std::remainder(phi - c, 360.0)) < part.segment_span_deg / 2;
  const bool on_mark =
      std::abs(std::remainder(phi - part.mark_phi_deg, 360.0)) * kPi / 180 * r <
          part.mark_width_mm &&
      r > part.mark_r_start_mm - 1 && r < part.mark_r_end_mm + 1;
  return in_span && !on_mark;
}

TEST(PlanPointsTest, EveryPointLiesOnItsNominalSurfaceInsideItsEdges) {
  const PartSpec part;
  const PlanOptions options;
  const auto points = PlanPoints(part, options);
  const auto nominal = Nominals(part);
  std::map<std::string, int> count;
  int expected_id = 1;
  for (const PlannedPoint& p : points) {
    EXPECT_EQ(p.id, expected_id++);
    const std::string name = p.feature.ToString();
    ++count[name];
    ASSERT_TRUE(nominal.count(name)) << name;
    const NominalFeature& f = nominal.at(name);
    EXPECT_EQ(f.Key(), p.feature);
    const Eigen::Vector3d& q = p.point_w_mm;
    EXPECT_NEAR(p.normal_w.norm(), 1.0, 1e-12);
    switch (f.kind) {
      case FeatureKind::kFacet: {
        EXPECT_NEAR(f.normal.dot(q), part.facet_final_distance_mm, 1e-9);
        EXPECT_NEAR((p.normal_w - f.normal).norm(), 0, 1e-12);
        const double t = Eigen::Vector3d::UnitZ().cross(f.normal).dot(q);
        EXPECT_LE(std::abs(t), f.t_max_mm - options.edge_margin_mm + 1e-9);
        EXPECT_GE(q.z(), f.z_min_mm + options.edge_margin_mm - 1e-9);
        EXPECT_LE(q.z(), f.z_max_mm - options.edge_margin_mm + 1e-9);
        break;
      }
      case FeatureKind::kStrip:
        EXPECT_NEAR(q.z(), part.strip_floor_z_mm, 1e-12);
        EXPECT_NEAR(q.y(), f.point.y(), 1e-12);
        EXPECT_GT(std::abs(q.x()), part.small_notch_half_width_mm);
        EXPECT_LT(std::abs(q.x()), f.t_max_mm);
        break;
      case FeatureKind::kTopFace:
        EXPECT_NEAR(q.z(), 0, 1e-12);
        EXPECT_TRUE(OnSegmentTop(part, q)) << q.transpose();
        break;
      case FeatureKind::kFlank:
        EXPECT_NEAR(std::abs(q.y()), part.big_notch_half_width_mm, 1e-12);
        EXPECT_NEAR((p.normal_w - f.normal).norm(), 0, 1e-12);
        EXPECT_GT(std::abs(q.x()), part.small_notch_half_width_mm);
        EXPECT_LT(q.head<2>().norm(), part.facet_final_distance_mm);
        EXPECT_LT(q.z(), 0);
        EXPECT_GT(q.z(), part.big_notch_floor_z_mm);
        break;
      case FeatureKind::kCylinder:
        EXPECT_NEAR(q.head<2>().norm(), f.size_mm / 2, 1e-9);
        EXPECT_GE(q.z(), part.datum_circle_z_min_mm);
        EXPECT_LE(q.z(), part.datum_circle_z_max_mm);
        break;
      default:
        ADD_FAILURE() << "unexpected feature " << p.feature;
    }
  }
  EXPECT_EQ(count["TOP"], 4 * options.top_points_per_segment);
  EXPECT_EQ(count["FLANK+Y"], options.flank_points);
  EXPECT_EQ(count["CYL199"], options.cylinder_points);
  EXPECT_EQ(count["X1-5"], options.facet_rows * options.facet_columns);
  EXPECT_EQ(count["Z5"], 2 * options.strip_points_per_side);
  EXPECT_EQ(count.size(), 4u + 45u);  // 4 datums + 36 facets + 9 strips
}

// A plane's tilt (a facet's angle, a strip's beta) has a standard
// deviation that goes with 1 / spread of its touches: across a facet and
// along a strip the outer touches must sit at the edge margin, not half a
// step inside it. The widths come from test-piece.md: a finished facet is
// 2 x 97.3 tan(3 deg) = 10.2 mm wide; a strip runs from the small notch
// (|x| = 5) to where the 199 cylinder leaves the floor at its outer edge.
TEST(PlanPointsTest, TouchesSpanTheFacetsWidthAndTheStripsLength) {
  const PartSpec part;
  for (int columns : {2, 3, 5}) {
    PlanOptions options;
    options.facet_columns = columns;
    options.strip_points_per_side = columns;
    const double m = options.edge_margin_mm;
    const double facet_half = 97.3 * std::tan(3.0 * kPi / 180);
    std::map<std::string, std::vector<double>> along;
    for (const PlannedPoint& p : PlanPoints(part, options)) {
      const std::string name = p.feature.ToString();
      if (name[0] == 'Z') {
        along[name].push_back(p.point_w_mm.x());
      } else if (name[0] == 'X' || name[0] == 'Y') {
        const Eigen::Vector3d t = Eigen::Vector3d::UnitZ().cross(p.normal_w);
        along[name].push_back(t.dot(p.point_w_mm));
      }
    }
    ASSERT_EQ(along.size(), 36u + 9u);
    for (auto& [name, v] : along) {
      std::sort(v.begin(), v.end());
      SCOPED_TRACE(name + " with " + std::to_string(columns) + " columns");
      if (name[0] == 'Z') {
        const int k = name[1] - '0';
        const double y_outer = std::abs((k - 5) * 11.75) + 6.0;
        const double x_end = std::sqrt(99.5 * 99.5 - y_outer * y_outer);
        // each side: from the notch's edge + 2 margins to the end - 2 margins
        ASSERT_EQ(v.size(), 2u * columns);
        EXPECT_NEAR(v.front(), -(x_end - 2 * m), 1e-6);
        EXPECT_NEAR(v.back(), x_end - 2 * m, 1e-6);
        EXPECT_NEAR(v[columns - 1], -(5.0 + 2 * m), 1e-6);
        EXPECT_NEAR(v[columns], 5.0 + 2 * m, 1e-6);
      } else {
        ASSERT_EQ(v.size(), static_cast<size_t>(columns * options.facet_rows));
        EXPECT_NEAR(v.front(), -(facet_half - m), 1e-6);
        EXPECT_NEAR(v.back(), facet_half - m, 1e-6);
      }
    }
  }
}

TEST(PlanPointsTest, CsvRoundTrips) {
  const auto points = PlanPoints(PartSpec{});
  const auto back = PointsFromCsv(PointsToCsv(points), "plan.csv");
  ASSERT_EQ(back.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(back[i].id, points[i].id);
    EXPECT_EQ(back[i].feature, points[i].feature);
    EXPECT_LT((back[i].point_w_mm - points[i].point_w_mm).norm(), 1e-6);
    EXPECT_LT((back[i].normal_w - points[i].normal_w).norm(), 1e-8);
  }
}

TEST(PlanPointsTest, BadOptionsAndFilesNameTheField) {
  PlanOptions o;
  o.cylinder_points = 2;
  try {
    PlanPoints(PartSpec{}, o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cylinder_points"), std::string::npos);
  }
  EXPECT_THROW(
      PointsFromCsv("point_id,feature,x_mm,y_mm,z_mm,approach_i,approach_j,"
                    "approach_k\n1,TOP,0,0,0,0,0,-2\n",
                    "p.csv"),
      InputError);
  // A feature name the piece does not have: refused, naming the column.
  try {
    PointsFromCsv(
        "point_id,feature,x_mm,y_mm,z_mm,approach_i,approach_j,"
        "approach_k\n1,X5-1,0,0,0,0,0,-1\n",
        "p.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "feature");
    EXPECT_EQ(e.line(), 2);
  }
  // Values no plan writes, each refused naming its column (the fuzzer's
  // point id of 2.2e73 once overflowed the int it is stored in).
  const std::string header =
      "point_id,feature,x_mm,y_mm,z_mm,approach_i,approach_j,approach_k\n";
  for (const auto& [row, field] :
       std::vector<std::pair<std::string, std::string>>{
           {"2.2e73,TOP,0,0,0,0,0,-1", "point_id"},
           {"1,TOP,1e300,0,0,0,0,-1", "x_mm"},
           {"1,TOP,0,0,-2e6,0,0,-1", "z_mm"}}) {
    try {
      PointsFromCsv(header + row + "\n", "p.csv");
      ADD_FAILURE() << row;
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), field) << row;
      EXPECT_EQ(e.line(), 2) << row;
    }
  }
}

}  // namespace
}  // namespace ttp::plan
