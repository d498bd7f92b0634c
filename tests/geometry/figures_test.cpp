#include "ttp/geometry/figures.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ttp/geometry/features.h"

namespace ttp {
namespace {

// A rigid shift of the table by (sx, sy) at every cut: facets on +X move in
// by sx, on -X out by sx, so E_X = sx (test-piece.md section 4).
TEST(Figures, RigidShiftGivesTheShift) {
  PartSpec p;
  FeatureResults r;
  for (const auto& f : TestFeatures(p)) {
    FeatureResult fr;
    fr.present = true;
    fr.var_d_mm2 = 1e-8;
    const double shift_x = f.cycle * 1e-3, shift_y = -f.cycle * 2e-3;
    if (f.kind == FeatureKind::kFacet) {
      // Machine direction of the normal at cut time: X1 +X, X2 -X, Y1 +Y,
      // Y2 -Y. The cut surface moves by -n . dP.
      const Segment s = *f.segment;
      const double n_dot = s == Segment::kX1   ? shift_x
                           : s == Segment::kX2 ? -shift_x
                           : s == Segment::kY1 ? shift_y
                                               : -shift_y;
      fr.d_mm = f.size_mm - n_dot;
    } else {
      fr.d_mm = 12.1 + 0.5e-3 * f.cycle;
      fr.angle_rad = 1e-6 * f.cycle;
    }
    r[f.Key()] = fr;
  }
  auto figs = ComputeFigures(p, r);
  ASSERT_EQ(figs.size(), 8u);
  for (const auto& f : figs) {
    EXPECT_NEAR(f.e_x_mm, f.cycle * 1e-3, 1e-12);
    EXPECT_NEAR(f.e_y_mm, -f.cycle * 2e-3, 1e-12);
    EXPECT_NEAR(f.e_ttp_mm, 0, 1e-12);
    EXPECT_NEAR(f.e_z_mm, 0.5e-3 * f.cycle, 1e-12);
    EXPECT_NEAR(f.e_b_rad, 1e-6 * f.cycle, 1e-15);
    EXPECT_NEAR(f.u_x_mm, std::sqrt(4 * 0.25 * 1e-8), 1e-12);
  }
}

TEST(Figures, GrowthIsPositiveTtp) {
  PartSpec p;
  FeatureResults r;
  for (const auto& f : TestFeatures(p)) {
    FeatureResult fr;
    fr.present = true;
    // A hotter piece at cut time ends up smaller when cold.
    fr.d_mm = f.size_mm - (f.kind == FeatureKind::kFacet ? 1e-3 * f.cycle : 0);
    r[f.Key()] = fr;
  }
  for (const auto& f : ComputeFigures(p, r)) {
    EXPECT_NEAR(f.e_ttp_mm, 1e-3 * f.cycle, 1e-12);
  }
}

TEST(Figures, MissingFeatureGivesNaNOnlyWhereNeeded) {
  PartSpec p;
  FeatureResults r;
  for (const auto& f : TestFeatures(p)) r[f.Key()] = {true, f.size_mm};
  r.erase(FeatureId::Facet(Segment::kX1, 3));
  auto figs = ComputeFigures(p, r);
  EXPECT_TRUE(std::isnan(figs[2].e_x_mm));
  EXPECT_TRUE(std::isnan(figs[2].e_ttp_mm));
  EXPECT_FALSE(std::isnan(figs[2].e_y_mm));
  EXPECT_FALSE(std::isnan(figs[1].e_x_mm));
  auto j = FiguresToJson(figs);
  EXPECT_TRUE(j["figures"][2]["E_X"].is_null());
  EXPECT_EQ(j["figures"][2]["cycle"], 3);
}

TEST(Figures, TemperatureFromGrowth) {
  EXPECT_NEAR(TemperatureChangeK(97.3 * 23.4e-6, 23.4e-6, 97.3), 1.0, 1e-12);
}

}  // namespace
}  // namespace ttp
