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
        BadCase{"sense", "[machine]\nc_sense = 0\n", "machine.c_sense"},
        // Features that do not fit the piece or each other.
        BadCase{"big_notch_wide", "[part]\nbig_notch_half_width_mm = 200.0\n",
                "part.big_notch_half_width_mm"},
        BadCase{"big_notch_past_facets",
                "[part]\nbig_notch_half_width_mm = 97.0\n",
                "part.big_notch_half_width_mm"},
        BadCase{"small_notch_wide",
                "[part]\nsmall_notch_half_width_mm = 60.0\n",
                "part.small_notch_half_width_mm"},
        BadCase{"facets_overflow", "[part]\nfacet_step_deg = 7.0\n",
                "part.facet_step_deg"},
        BadCase{"segment_in_notch",
                "[part]\nsegment_centre_deg = [40.0, 120.0, 240.0, 300.0]\n",
                "part.segment_centre_deg[0]"},
        BadCase{"mark_off_segment", "[part]\nmark_phi_deg = 0.0\n",
                "part.mark_phi_deg"},
        BadCase{"facet_above_floor", "[part]\nfacet_bottom_z_mm = -11.0\n",
                "part.facet_bottom_z_mm"},
        // Machine profile.
        BadCase{"rapids", "[machine]\nrapid_semantics = \"diagonal\"\n",
                "machine.rapid_semantics"},
        BadCase{"waiting_in_sphere_ring",
                "[machine]\nwaiting_position_w_mm = [160.0, 0.0, 50.0]\n",
                "machine.waiting_position_w_mm"},
        BadCase{"sphere_on_piece", "[machine]\nsphere_distance_mm = 100.0\n",
                "machine.sphere_distance_mm"},
        BadCase{"clamp_high",
                "[[machine.clamps]]\nphi_deg = 0.0\nr_inner_mm = 90.0\n"
                "r_outer_mm = 120.0\nwidth_mm = 20.0\nheight_mm = 40.0\n",
                "machine.clamps[0].height_mm"},
        BadCase{"clamp_missing_key", "[[machine.clamps]]\nphi_deg = 0.0\n",
                "machine.clamps[0].r_inner_mm"},
        BadCase{"tool_change_low",
                "[machine]\ntool_change_position_m_mm = [300.0, 0.0, 100.0]\n",
                "machine.tool_change_position_m_mm[2]"},
        BadCase{"sync_block", "[machine]\nfanuc_sync_block = \"G04\"\n",
                "machine.fanuc_sync_block"},
        BadCase{"skip_var",
                "[machine]\nfanuc_skip_variables = [5061, 5062, 5063, 5099]\n",
                "machine.fanuc_skip_variables[3]"},
        BadCase{"stick_out", "[process.finishing]\nstick_out_mm = 10.0\n",
                "process.finishing.stick_out_mm"},
        // Values a program cannot carry: a step down whose pass count
        // explodes, a feed written as F0.0, a dwell of 1e12 min, a cycle
        // period of more digits than a block holds.
        BadCase{"step_down_tiny", "[process]\nroughing_step_down_mm = 6e-9\n",
                "process.roughing_step_down_mm"},
        BadCase{"feed_tiny", "[process.engraver]\nfeed_mm_min = 1e-9\n",
                "process.engraver.feed_mm_min"},
        BadCase{"hold_huge", "[process]\nnc_hold_after_pre_min = 1e12\n",
                "process.nc_hold_after_pre_min"},
        BadCase{"cycle_huge", "[process]\ncycle_period_s = 1e15\n",
                "process.cycle_period_s"},
        BadCase{"rtest_interval_huge", "[process]\nrtest_interval_s = 1e15\n",
                "process.rtest_interval_s"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(Config, UnreadableFileIsInputError) {
  EXPECT_THROW(LoadConfig("/nonexistent/ttp.toml"), InputError);
}

}  // namespace
}  // namespace ttp
