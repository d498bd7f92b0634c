// The hidden-effect battery of issue 4: causes drawn at random by seed.
#include "ttp/diagnosis/battery.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

namespace ttp::diagnosis {
namespace {

TEST(Battery, NamesTheHiddenCauseAndNeverInventsOne) {
  const Config config;
  // 100 runs, each measured as a user measures: the twin's CMM cloud
  // (random pose, strays) -> InspectCloud -> inspection JSON -> diagnosis.
  BatteryOptions options;
  const BatteryResult result = RunBattery(config, options);
  std::cout << ConfusionText(result);
  for (const auto& r : result.runs)
    if (r.diagnosed != r.options.effect)
      std::cout << "missed: " << CauseName(r.options.effect) << " size "
                << r.options.size << " noise " << r.options.point_noise_um
                << " points " << r.options.cloud_points
                << (r.via_cloud ? " (cloud)" : "") << " -> "
                << CauseName(r.diagnosed) << " (best "
                << CauseName(r.best_cause) << ", delta BIC " << r.best_delta_bic
                << ")\n";
  double worst = 0;
  for (const auto& r : result.runs) worst = std::max(worst, r.chi2_per_dof);
  std::cout << "largest chi2 per degree of freedom: " << worst << "\n";
  EXPECT_GE(result.correct, 95);
  EXPECT_EQ(result.cloud_runs, 100);
  EXPECT_EQ(result.invented, 0);
  // The draw is random: every cause appears.
  for (int t = 0; t < 5; ++t) {
    int n = 0;
    for (int d = 0; d < 5; ++d) n += result.confusion[t][d];
    EXPECT_GT(n, 5) << CauseName(kAllCauses[t]);
  }
}

TEST(Battery, DrawsDependOnlyOnSeedAndIndexAndSpanTheRanges) {
  double lo = 1e9, hi = 0;
  for (int k = 0; k < 200; ++k) {
    const TwinOptions a = DrawBatteryRun(5, k), b = DrawBatteryRun(5, k);
    EXPECT_EQ(a.effect, b.effect);
    EXPECT_EQ(a.size, b.size);
    EXPECT_EQ(a.seed, b.seed);
    if (a.effect == Cause::kToolWear) {
      lo = std::min(lo, a.size);
      hi = std::max(hi, a.size);
      EXPECT_GE(a.size, BatterySizeRange(a.effect).first);
      EXPECT_LE(a.size, BatterySizeRange(a.effect).second);
    }
  }
  // Log-uniform over a decade: both ends are reached.
  EXPECT_LT(lo, 0.6);
  EXPECT_GT(hi, 3.0);
  EXPECT_NE(DrawBatteryRun(5, 0).seed, DrawBatteryRun(6, 0).seed);
}

TEST(Battery, ResultDoesNotDependOnThreads) {
  const Config config;
  BatteryOptions options;
  options.runs = 6;
  options.seed = 11;
  options.cloud_every = 3;
  options.threads = 1;
  const BatteryResult one = RunBattery(config, options);
  options.threads = 2;
  const BatteryResult two = RunBattery(config, options);
  ASSERT_EQ(one.runs.size(), two.runs.size());
  for (size_t k = 0; k < one.runs.size(); ++k) {
    EXPECT_EQ(one.runs[k].diagnosed, two.runs[k].diagnosed);
    EXPECT_EQ(one.runs[k].delta_bic, two.runs[k].delta_bic);
    EXPECT_EQ(one.runs[k].via_cloud, k % 3 == 2);
  }
}

}  // namespace
}  // namespace ttp::diagnosis
