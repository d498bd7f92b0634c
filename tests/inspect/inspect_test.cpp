#include "ttp/inspect/inspect.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "feature_ids.h"
#include "synth_piece.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"

namespace ttp::inspect {
namespace {

using sim::SynthPiece;
using test::RandomSynthPiece;

struct Figure {
  const char* name;
  double CycleFigures::*value;
  double CycleFigures::*u;
  double scale;  // to um or um/m
};
const Figure kFigures[] = {
    {"E_X", &CycleFigures::e_x_mm, &CycleFigures::u_x_mm, 1e3},
    {"E_Y", &CycleFigures::e_y_mm, &CycleFigures::u_y_mm, 1e3},
    {"E_Z", &CycleFigures::e_z_mm, &CycleFigures::u_z_mm, 1e3},
    {"E_B", &CycleFigures::e_b_rad, &CycleFigures::u_b_rad, 1e6},
    {"E_TTP", &CycleFigures::e_ttp_mm, &CycleFigures::u_ttp_mm, 1e3},
};

std::string CloudErrorOf(const PointCloud& cloud) {
  try {
    InspectCloud(PartSpec{}, cloud);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The accuracy asked of the inspection: 20,000 points, 0.5 um noise, 0.2 % strays, random pose: the
// figures within 0.2 um (linear) and 3 um/m (E_B) of the truth.
TEST(InspectCloudTest, FiguresFromASyntheticCloudInAnyPose) {
  const PartSpec part;
  for (uint32_t seed : {1u, 2u, 3u}) {
    const SynthPiece s = RandomSynthPiece(seed);
    const InspectionResult r = InspectCloud(part, s.cloud);
    EXPECT_TRUE(r.alignment.mark_found) << seed;
    // The alignment undoes the pose.
    EXPECT_NEAR(
        (r.alignment.rotation * s.rotation - Eigen::Matrix3d::Identity())
            .norm(),
        0.0, 1e-4)
        << seed;
    ASSERT_EQ(r.figures.size(), s.truth.figures.size());
    for (size_t c = 0; c < r.figures.size(); ++c) {
      for (const Figure& f : kFigures) {
        const double got = r.figures[c].*f.value * f.scale;
        const double want = s.truth.figures[c].*f.value * f.scale;
        EXPECT_NEAR(got, want, f.scale == 1e6 ? 3.0 : 0.2)
            << f.name << " cycle " << c + 1 << " seed " << seed;
      }
      EXPECT_NEAR(r.extras[c].e_c_rad * 1e6, s.truth.extras[c].e_c_rad * 1e6,
                  4 * r.extras[c].u_c_rad * 1e6 + 1.0);
    }
    // Strays are found (0.2 % of 20,000 = 40 points, some far from any
    // feature region) and nothing is missing.
    EXPECT_GT(r.points_rejected, 0);
    for (const auto& d : r.diagnostics) EXPECT_NE(d.status, "missing") << d.id;
  }
}

// The stated U (k = 2, fit covariance only: no instrument term, so that the
// statement is tested and not swamped by the CMM's MPE) holds the truth in
// at least 95 % of the figures of 80 seeded pieces.
TEST(InspectCloudTest, UncertaintyCoversTheTruth) {
  const PartSpec part;
  InspectOptions io;
  io.instrument = Instrument::kNone;
  int inside = 0, total = 0;
  std::map<std::string, int> misses;
  for (uint32_t seed = 100; seed < 180; ++seed) {
    const SynthPiece s = RandomSynthPiece(seed, 20000);
    const InspectionResult r = InspectCloud(part, s.cloud, io);
    for (size_t c = 0; c < r.figures.size(); ++c) {
      for (const Figure& f : kFigures) {
        const double err = r.figures[c].*f.value - s.truth.figures[c].*f.value;
        const double u = 2 * r.figures[c].*f.u;
        ++total;
        if (std::abs(err) <= u)
          ++inside;
        else
          ++misses[f.name];
      }
    }
  }
  const double coverage = static_cast<double>(inside) / total;
  std::string by;
  for (const auto& [k, v] : misses) by += fmt::format(" {}:{}", k, v);
  EXPECT_GE(coverage, 0.95) << "misses by figure:" << by;
  // U is not inflated either: a k = 2 interval that held every value of
  // 3200 would be far wider than the scatter.
  EXPECT_LE(coverage, 0.995) << "misses by figure:" << by;
  std::printf("coverage %.4f of %d (misses:%s)\n", coverage, total, by.c_str());
}

// Each facet's own scatter (`scatter_var_d_mm2`, what the diagnosis judges
// a fitted feature by) holds its distance's error: d is taken at W's
// origin, above the facet's points, so the fitted tilt's scatter moves it
// and rms / sqrt(points) alone covers far less. Datum and instrument terms
// are not in it; the datum's error, common to all facets, is small here.
TEST(InspectCloudTest, FacetScatterCoversItsDistanceError) {
  const PartSpec part;
  InspectOptions io;
  io.instrument = Instrument::kNone;
  int inside = 0, inside_naive = 0, total = 0;
  for (uint32_t seed = 200; seed < 230; ++seed) {
    const SynthPiece s = RandomSynthPiece(seed, 20000);
    const InspectionResult r = InspectCloud(part, s.cloud, io);
    for (const auto& [id, got] : r.features) {
      if (id.kind != FeatureKind::kFacet || !got.present) continue;
      const FeatureResult& want = s.truth.features.at(id);
      const double err = std::abs(got.d_mm - want.d_mm);
      ASSERT_GT(got.scatter_var_d_mm2, 0) << id.ToString();
      ASSERT_LE(got.scatter_var_d_mm2, got.var_d_mm2) << id.ToString();
      ++total;
      inside += err <= 2 * std::sqrt(got.scatter_var_d_mm2);
      inside_naive += err <= 2 * got.rms_mm / std::sqrt(got.points);
    }
  }
  const double coverage = static_cast<double>(inside) / total;
  const double naive = static_cast<double>(inside_naive) / total;
  EXPECT_GE(coverage, 0.93);
  EXPECT_LE(coverage, 0.995);
  EXPECT_LT(naive, 0.85);
  std::printf("facet scatter coverage %.4f of %d (rms / sqrt(points): %.4f)\n",
              coverage, total, naive);
}

// Missing features: their figures are null (NaN), everything else is still
// computed and accurate; the diagnostics say which are missing.
TEST(InspectCloudTest, MissingFeaturesLeaveTheRestComputed) {
  const PartSpec part;
  const int j = IndexForCycle(part, 3);
  const std::string facet = FacetId(Segment::kY1, j), strip = StripId(j);
  const SynthPiece s = RandomSynthPiece(21, 20000, {facet, strip});
  const InspectionResult r = InspectCloud(part, s.cloud);
  int missing = 0;
  for (const auto& d : r.diagnostics) {
    if (d.status != "missing") continue;
    ++missing;
    EXPECT_TRUE(d.id == facet || d.id == strip) << d.id;
  }
  EXPECT_EQ(missing, 2);
  EXPECT_FALSE(r.features.at(test::Fid(facet)).present);
  const nlohmann::json doc = InspectionToJson(r);
  for (size_t c = 0; c < r.figures.size(); ++c) {
    const bool hit = r.figures[c].cycle == 3;
    EXPECT_EQ(std::isnan(r.figures[c].e_y_mm), hit);
    EXPECT_EQ(std::isnan(r.figures[c].e_z_mm), hit);
    EXPECT_EQ(std::isnan(r.figures[c].e_ttp_mm), hit);
    EXPECT_EQ(doc["figures"][c]["E_Y"].is_null(), hit);
    EXPECT_NEAR(r.figures[c].e_x_mm, s.truth.figures[c].e_x_mm, 0.2e-3);
    if (!hit) {
      EXPECT_NEAR(r.figures[c].e_y_mm, s.truth.figures[c].e_y_mm, 0.2e-3);
      EXPECT_NEAR(r.figures[c].e_z_mm, s.truth.figures[c].e_z_mm, 0.2e-3);
    }
  }
  EXPECT_TRUE(doc["facets"][facet]["distance_mm"].is_null());
  EXPECT_EQ(doc["segmentation"]["missing"].size(), 2u);
}

// Clouds that are not a test piece in millimetres.
TEST(InspectCloudTest, BadCloudsNameTheProblem) {
  const SynthPiece s = RandomSynthPiece(5, 5000);
  PointCloud metres = s.cloud;
  metres.xyz_mm *= 1e-3;
  EXPECT_NE(CloudErrorOf(metres).find("looks like metres"), std::string::npos);
  PointCloud inches = s.cloud;
  inches.xyz_mm /= 25.4;
  EXPECT_NE(CloudErrorOf(inches).find("looks like inches"), std::string::npos);

  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PointCloud sphere, box, empty;
  sphere.source = "sphere.ply";
  box.source = "box.ply";
  sphere.xyz_mm.resize(3, 20000);
  box.xyz_mm.resize(3, 20000);
  for (int i = 0; i < 20000; ++i) {
    // A 200 mm sphere (an R-test ball, scaled) and a 203 x 203 x 24 box:
    // both the piece's size, neither its shape.
    const Eigen::Vector3d d(g(rng), g(rng), g(rng));
    sphere.xyz_mm.col(i) = 100.0 * d.normalized();
    Eigen::Vector3d b(101.5 * u(rng), 101.5 * u(rng), 12.0 * u(rng));
    b(i % 3) = (i % 2 ? 1 : -1) * (i % 3 == 2 ? 12.0 : 101.5);
    box.xyz_mm.col(i) = b;
  }
  EXPECT_NE(CloudErrorOf(sphere).find("sphere.ply:"), std::string::npos);
  EXPECT_NE(CloudErrorOf(sphere).find("no test piece"), std::string::npos);
  EXPECT_NE(CloudErrorOf(box).find("no test piece"), std::string::npos);
  empty.source = "empty.ply";
  EXPECT_NE(CloudErrorOf(empty).find("no points"), std::string::npos);
}

}  // namespace
}  // namespace ttp::inspect
