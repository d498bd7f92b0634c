// The causes as model extensions: each shows where diagnosis.md says.
#include "ttp/diagnosis/effects.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <map>

#include "feature_ids.h"
#include "ttp/geometry/features.h"
#include "ttp/sim/twin.h"

namespace ttp::diagnosis {
namespace {

EffectContext Context(const Config& config) {
  std::vector<CutState> cuts;
  const PartSpec& part = config.part;
  for (int cycle = 0; cycle <= part.cycles(); ++cycle) {
    const int j = IndexForCycle(part, cycle);
    const double t = 320 + 3600 * cycle;
    const double c = FacetPhiDeg(part, Segment::kX1, j) * M_PI / 180;
    cuts.push_back(MakeCutState(config, FeatureId::Strip(j), t, 0));
    cuts.push_back(
        MakeCutState(config, FeatureId::Facet(Segment::kX1, j), t + 10, c));
    cuts.push_back(
        MakeCutState(config, FeatureId::Facet(Segment::kY1, j), t + 20, c));
  }
  EffectContext ctx = MakeEffectContext(config, cuts);
  ctx.grid_step_s = 10;
  for (int i = 0; i < 3600; ++i)  // machine warms 2 K over 10 h
    ctx.machine_dT_K.push_back(2.0 * (1 - std::exp(-i * 10.0 / 7200)));
  return ctx;
}

TEST(Effects, LagFilterOfAStepIsTheExponential) {
  std::vector<double> step(500, 1.0);
  step[0] = 0;
  const auto out = LagFilter(step, 10, 600);
  for (int i : {10, 60, 200})
    EXPECT_NEAR(out[i], 1 - std::exp(-(i * 10.0 - 10) / 600), 0.01) << i;
}

TEST(Effects, EachCauseShowsWhereTheSpecSays) {
  const Config config;
  const EffectContext ctx = Context(config);
  const auto wear = PredictEffect(Cause::kToolWear, {2.0}, ctx);
  const auto clamp = PredictEffect(Cause::kClampingDistortion, {1, 0.5}, ctx);
  const auto index = PredictEffect(Cause::kCAxisIndexing, {100, 50}, ctx);
  const auto wp = PredictEffect(Cause::kWorkpieceExpansion, {2000, 1.0}, ctx);
  double last_wear = -1;
  for (const CutState& s : ctx.cuts) {
    if (!s.is_facet) {
      EXPECT_EQ(wear.at(s.id).d_mm, 0) << s.id;  // radial only
      EXPECT_EQ(index.at(s.id).angle_rad, 0);
      EXPECT_GT(wp.at(s.id).d_mm, 0);  // hot adapter: strip deeper
      continue;
    }
    // Tool wear: grows with every cut, no angle.
    EXPECT_GT(wear.at(s.id).d_mm, last_wear);
    last_wear = wear.at(s.id).d_mm;
    EXPECT_NEAR(wear.at(s.id).d_mm, 2e-3 * s.cut_length_mid_m, 1e-12);
    // Clamping: three lobes in the facet's angle, and the turn about Z
    // their slope across the facet implies (-du/dphi / R).
    EXPECT_NEAR(
        clamp.at(s.id).d_mm,
        1e-3 * (std::cos(3 * s.phi_w_rad) + 0.5 * std::sin(3 * s.phi_w_rad)),
        1e-12);
    const double h = 1e-6;
    auto u = [&](double phi) {
      return 1e-3 * (std::cos(3 * phi) + 0.5 * std::sin(3 * phi));
    };
    EXPECT_NEAR(clamp.at(s.id).angle_rad,
                -(u(s.phi_w_rad + h) - u(s.phi_w_rad - h)) / (2 * h) /
                    s.radius_mm,
                1e-9);
    // C indexing: normals turned, distances unchanged.
    EXPECT_EQ(index.at(s.id).d_mm, 0);
    EXPECT_NEAR(
        index.at(s.id).angle_rad,
        ctx.c_sense * 1e-6 * (100 * std::cos(s.c_rad) + 50 * std::sin(s.c_rad)),
        1e-15);
  }
  EXPECT_EQ(PredictEffect(Cause::kNone, {}, ctx).at(test::Fid("X1-1")).d_mm, 0);
}

// C indexing: a sum of harmonics of the table angle, their number from the
// parameters' count.
TEST(Effects, CAxisIndexingIsASumOfHarmonics) {
  const Config config;
  const EffectContext ctx = Context(config);
  const std::vector<double> p = {10, 0, 0, 20, 0, 0, 5, -5};  // 1, 2, 4
  const auto index = PredictEffect(Cause::kCAxisIndexing, p, ctx);
  for (const CutState& s : ctx.cuts) {
    if (!s.is_facet) continue;
    const double c = s.c_rad;
    EXPECT_NEAR(index.at(s.id).angle_rad,
                ctx.c_sense * 1e-6 *
                    (10 * std::cos(c) + 20 * std::sin(2 * c) +
                     5 * std::cos(4 * c) - 5 * std::sin(4 * c)),
                1e-15);
  }
  EXPECT_EQ(CAxisParameterNames({1, 2}),
            (std::vector<std::string>{"cos1_urad", "sin1_urad", "cos2_urad",
                                      "sin2_urad"}));
}

// Against the twin (the effects written from the spec's physics, the piece
// cut by the geometric simulation): a C stop error turns the facets cut at
// one table angle alike (X1-j, X2-j and Y1-(j+5), Y2-(j+5) share it), moves
// no distance, and the model's harmonics of the table angle (K = 4, plus
// the piece's unknown yaw) reproduce the turns to well below a facet's
// measurement noise (about 12 urad).
TEST(Effects, CAxisIndexingTurnsFacetsCutAtOneTableAngleAlike) {
  const Config config;
  const PartSpec& part = config.part;
  sim::TwinOptions o;
  o.seed = 21;
  const sim::TwinRun plain = sim::RunTwin(config, o);
  o.c_indexing_amplitude_urad = 200;
  const sim::TwinRun indexed = sim::RunTwin(config, o);
  std::map<FeatureId, double> turn_urad;
  for (const auto& [id, r] : indexed.true_results) {
    if (id.kind != FeatureKind::kFacet) continue;
    // (a few nm from second-order terms; a cloud fit resolves ~30 nm)
    EXPECT_NEAR(r.d_mm, plain.true_results.at(id).d_mm, 1e-5) << id.ToString();
    turn_urad[id] = (r.angle_rad - plain.true_results.at(id).angle_rad) * 1e6;
  }
  for (int j = 1; j <= 4; ++j) {
    const double x = turn_urad.at(FeatureId::Facet(Segment::kX1, j));
    EXPECT_NEAR(turn_urad.at(FeatureId::Facet(Segment::kX2, j)), x, 0.05);
    EXPECT_NEAR(turn_urad.at(FeatureId::Facet(Segment::kY1, j + 5)), x, 0.05);
    EXPECT_NEAR(turn_urad.at(FeatureId::Facet(Segment::kY2, j + 5)), x, 0.05);
  }
  // Least squares of the model's columns (and a constant) on the turns.
  const int harmonics = 4;
  const int n = static_cast<int>(turn_urad.size());
  Eigen::MatrixXd a(n, 2 * harmonics + 1);
  Eigen::VectorXd y(n);
  int row = 0;
  double spread = 0, mean = 0;
  for (const auto& [id, turn] : turn_urad) mean += turn / n;
  for (const auto& [id, turn] : turn_urad) {
    const double c_deg =
        FacetPhiDeg(part, Segment::kX1, id.index) -
        (id.segment == Segment::kY1 || id.segment == Segment::kY2 ? 30 : 0);
    std::vector<CutState> cut = {
        MakeCutState(config, id, 0, c_deg * M_PI / 180)};
    const EffectContext ctx = MakeEffectContext(config, cut);
    a(row, 0) = 1;
    for (int k = 0; k < 2 * harmonics; ++k) {
      std::vector<double> p(2 * harmonics, 0.0);
      p[k] = 1;
      a(row, k + 1) =
          PredictEffect(Cause::kCAxisIndexing, p, ctx).at(id).angle_rad * 1e6;
    }
    y[row++] = turn;
    spread += (turn - mean) * (turn - mean) / n;
  }
  const Eigen::VectorXd fit = a.colPivHouseholderQr().solve(y);
  const double rms = std::sqrt((y - a * fit).squaredNorm() / n);
  EXPECT_GT(std::sqrt(spread), 5.0);  // the turns vary over the cut angles
  EXPECT_LT(rms, 1.0);
}

TEST(Effects, NamesRoundTripAndUnknownIsRejected) {
  for (Cause c : kAllCauses) EXPECT_EQ(CauseFromName(CauseName(c)), c);
  EXPECT_THROW(CauseFromName("spindle_growth"), std::invalid_argument);
  EXPECT_EQ(CauseParameterNames(Cause::kWorkpieceExpansion),
            (std::vector<std::string>{"tau_wp_s", "gain_K_per_K"}));
}

}  // namespace
}  // namespace ttp::diagnosis
