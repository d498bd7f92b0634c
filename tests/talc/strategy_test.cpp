#include "ttp/talc/strategy.h"

#include <gtest/gtest.h>

#include <fstream>

#include "test_dir.h"
#include "ttp/geometry/error.h"

namespace ttp::talc {
namespace {

TEST(Strategy, ReadsTomlAndJsonAlike) {
  const auto dir = ttp::test::TestDir("talc");
  std::ofstream(dir / "s.toml")
      << "mode = \"adaptive\"\nthreshold_um = 3\n"
         "calibration_h = 6\nspeed_lags_s = [900, 3600]\n"
         "temperatures = [\"T_t1\", \"T_t2\"]\n"
         "ng_measurements = 6\n";
  std::ofstream(dir / "s.json")
      << R"({"mode": "adaptive", "threshold_um": 3, "calibration_s": 21600,
             "speed_lags_s": [900, 3600], "temperatures": ["T_t1", "T_t2"],
             "ng_measurements": 6})";
  const Strategy a = ReadStrategy(dir / "s.toml");
  const Strategy b = ReadStrategy(dir / "s.json");
  EXPECT_EQ(a.mode, IntervalMode::kAdaptive);
  EXPECT_EQ(a.calibration_s, 21600);
  EXPECT_EQ(a.ng_measurements, 6);
  EXPECT_EQ(a.regressors.speed_lags_s, (std::vector<double>{900, 3600}));
  EXPECT_EQ(StrategyToJson(a), StrategyToJson(b));
  // The JSON form reads back to the same strategy.
  EXPECT_EQ(StrategyToJson(StrategyFromJson(StrategyToJson(a), "x")),
            StrategyToJson(a));
}

TEST(Strategy, ABadFieldIsNamed) {
  auto field_of = [](const nlohmann::json& j) {
    try {
      StrategyFromJson(j, "s.json");
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), "s.json");
      return e.field();
    }
    return std::string("(accepted)");
  };
  EXPECT_EQ(field_of({{"interval_s", -5}}), "interval_s");
  EXPECT_EQ(field_of({{"interval_s", "1h"}}), "interval_s");
  EXPECT_EQ(field_of({{"forgetting_per_h", 1.5}}), "forgetting_per_h");
  EXPECT_EQ(field_of({{"mode", "sometimes"}}), "mode");
  EXPECT_EQ(field_of({{"intervall_s", 60}}), "intervall_s");
  EXPECT_EQ(field_of({{"speed_lags_s", {100, "x"}}}), "speed_lags_s[1]");
  EXPECT_EQ(field_of({{"min_interval_s", 7200}, {"max_interval_s", 3600}}),
            "max_interval_s");
  EXPECT_EQ(field_of({{"ng_measurements", 2.5}}), "ng_measurements");
  EXPECT_EQ(field_of({{"calibration_s", 7200}, {"calibration_h", 1}}),
            "calibration_h");
  EXPECT_EQ(field_of({{"interval_s", 60}}), "(accepted)");
}

TEST(Strategy, ATomlSyntaxErrorNamesTheLine) {
  const auto dir = ttp::test::TestDir("talc");
  std::ofstream(dir / "bad.toml") << "interval_s = 60\nmode = = 3\n";
  try {
    ReadStrategy(dir / "bad.toml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
  }
}

}  // namespace
}  // namespace ttp::talc
