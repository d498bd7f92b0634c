#include "ttp/geometry/config.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "test_dir.h"
#include "ttp/geometry/error.h"

namespace ttp {
namespace {

std::filesystem::path WriteTemp(const std::string& name,
                                const std::string& text) {
  auto path = test::TestDir("config") / name;
  std::ofstream(path) << text;
  return path;
}

TEST(Config, DefaultsAreValidAndMatchTheDrawing) {
  Config c;
  EXPECT_NO_THROW(ValidateConfig(c, "defaults"));
  EXPECT_DOUBLE_EQ(c.part.height_mm(), 24.0);
  EXPECT_EQ(c.part.cycles(), 8);
  EXPECT_DOUBLE_EQ(c.process.finishing.diameter_mm, 12.0);
}

TEST(Config, JsonRoundTripKeepsEveryField) {
  Config c;
  c.part.facet_final_distance_mm = 97.25;
  c.machine.c_sense = -1;
  c.process.finishing.feed_mm_min = 250;
  const Config back = ConfigFromJson(ConfigToJson(c), "roundtrip");
  EXPECT_EQ(ConfigToJson(back), ConfigToJson(c));
}

TEST(Config, TomlOverridesSubset) {
  auto path = WriteTemp("ttp_cfg_ok.toml",
                        "[part]\nfacet_final_distance_mm = 97.2\n"
                        "[process.finishing]\nfeed_mm_min = 200.0\n");
  const Config c = LoadConfig(path);
  EXPECT_DOUBLE_EQ(c.part.facet_final_distance_mm, 97.2);
  EXPECT_DOUBLE_EQ(c.process.finishing.feed_mm_min, 200.0);
  EXPECT_DOUBLE_EQ(c.part.blank_diameter_mm, 203.0);  // untouched default
}

struct BadCase {
  const char* name;
  const char* text;
  const char* field;  // expected in the message
};

class ConfigBad : public ::testing::TestWithParam<BadCase> {};

TEST_P(ConfigBad, NamesTheField) {
  const BadCase& bc = GetParam();
  auto path = WriteTemp(std::string("ttp_cfg_") + bc.name + ".toml", bc.text);
  try {
    LoadConfig(path);
    FAIL() << "accepted " << bc.text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bc.field), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Cases, ConfigBad,
    ::testing::Values(
        BadCase{"negative", "[part]\nblank_diameter_mm = -5.0\n",
                "part.blank_diameter_mm"},
        BadCase{"too_big", "[part]\nrim_diameter_mm = 250.0\n",
                "part.rim_diameter_mm"},
        BadCase{"notch_tool", "[process.notch]\ndiameter_mm = 12.0\n",
                "process.notch.diameter_mm"},
        BadCase{"travel", "[machine]\ntravel_x_mm = [-50.0, 50.0]\n",
                "machine.travel_x_mm"},
        BadCase{"unknown", "[part]\nblank_diameterr_mm = 200.0\n",
                "part.blank_diameterr_mm"},
        BadCase{"type", "[part]\nblank_diameter_mm = \"big\"\n",
                "part.blank_diameter_mm"},
        BadCase{"syntax", "[part\nblank_diameter_mm = 1\n", "TOML"},
        BadCase{"sense", "[machine]\nc_sense = 0\n", "machine.c_sense"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(Config, UnreadableFileIsInputError) {
  EXPECT_THROW(LoadConfig("/nonexistent/ttp.toml"), InputError);
}

}  // namespace
}  // namespace ttp
