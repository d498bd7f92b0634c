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
        // The R-test's stated uncertainty (U, k = 2) per error.
        BadCase{"rtest_u_zero",
                "[machine]\nrtest_u95_um = [0.4, 0.5, 0.0, 0.6]\n",
                "machine.rtest_u95_um[2]: the EZ0T R-test uncertainty"},
        BadCase{"rtest_u_short", "[machine]\nrtest_u95_urad = [2.3, 2.5]\n",
                "machine.rtest_u95_urad"},
        BadCase{"rtest_u_huge",
                "[machine]\nrtest_u95_urad = [2.3, 2.5, 2000.0]\n",
                "machine.rtest_u95_urad[2]: the EC0C R-test uncertainty"},
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
        // A smaller piece whose last facets' corners fall in the small
        // notch (77.41 mm at 87 deg: |x| = 4.05 mm < 5 mm).
        BadCase{"facet_corner_in_notch",
                "[part]\nblank_diameter_mm = 163.0\nrim_diameter_mm = 162.0\n"
                "facet_pre_distance_mm = 77.4\nfacet_final_distance_mm = 77.3\n"
                "big_notch_half_width_mm = 42.0\nstrip_pitch_mm = 9.0\n"
                "mark_r_start_mm = 52.0\nmark_r_end_mm = 70.0\n"
                "[[part.ref_cylinders]]\ndiameter_mm = 161.0\n"
                "z_bottom_mm = -24.0\nz_top_mm = -12.0\n",
                "part.segment_centre_deg[0]: facet 9 ends at W (4.051, "
                "77.300) mm, inside a notch"},
        // The programs go round X1, Y1, X2, Y2 and cut X1-j with X2-j at
        // one table angle.
        BadCase{
            "segments_overlap",
            "[part]\nsegment_centre_deg = [60.0, 60.0, 240.0, 300.0]\n",
            "part.segment_centre_deg[1]: segment Y1 must lie in quadrant 2"},
        BadCase{"segments_not_opposite",
                "[part]\nfacets_per_segment = 7\nreference_index = 4\n"
                "segment_span_deg = 42.0\n"
                "segment_centre_deg = [60.0, 120.0, 246.0, 300.0]\n",
                "part.segment_centre_deg[2]: must be segment_centre_deg[0] + "
                "180 (X2 opposite X1)"},
        BadCase{"mark_off_segment", "[part]\nmark_phi_deg = 0.0\n",
                "part.mark_phi_deg"},
        BadCase{"facet_above_floor", "[part]\nfacet_bottom_z_mm = -11.0\n",
                "part.facet_bottom_z_mm"},
        BadCase{"mark_in_big_notch", "[part]\nmark_phi_deg = 48.0\n",
                "part.mark_phi_deg: the mark reaches into a notch"},
        BadCase{"mark_start_in_big_notch", "[part]\nmark_r_start_mm = 56.0\n",
                "part.mark_phi_deg: the mark reaches into a notch"},
        BadCase{"reference_off_centre", "[part]\nreference_index = 4\n",
                "part.reference_index: outer strips reach into the big-notch"},
        BadCase{"reference_off_centre_facets",
                "[part]\nreference_index = 4\nstrip_pitch_mm = 7.0\n",
                "part.reference_index: facets reach 33.000 deg"},
        BadCase{"small_notch_shallow",
                "[part]\nsmall_notch_floor_z_mm = -11.2\n",
                "part.small_notch_floor_z_mm"},
        BadCase{"cylinder_above_notch_floor",
                "[[part.ref_cylinders]]\ndiameter_mm = 199.0\n"
                "z_bottom_mm = -16.0\nz_top_mm = -9.6\n"
                "[[part.ref_cylinders]]\ndiameter_mm = 200.0\n"
                "z_bottom_mm = -24.0\nz_top_mm = -16.0\n",
                "part.ref_cylinders[0].z_top_mm: above the big-notch floor"},
        BadCase{"cylinders_overlap",
                "[[part.ref_cylinders]]\ndiameter_mm = 199.0\n"
                "z_bottom_mm = -16.0\nz_top_mm = -12.0\n"
                "[[part.ref_cylinders]]\ndiameter_mm = 200.0\n"
                "z_bottom_mm = -20.0\nz_top_mm = -12.8\n",
                "part.ref_cylinders[1]: z [-20, -12.8] overlaps "
                "part.ref_cylinders[0]"},
        BadCase{"cylinder_inside_facets",
                "[[part.ref_cylinders]]\ndiameter_mm = 189.0\n"
                "z_bottom_mm = -24.0\nz_top_mm = -12.0\n",
                "part.ref_cylinders[0].diameter_mm: inside the pre-cut "
                "facets' corners (radius 97.534 mm)"},
        BadCase{"strips_overlap_entirely", "[part]\nstrip_pitch_mm = 5.875\n",
                "part.strip_pitch_mm: below half the strip width (6 mm)"},
        BadCase{"finishing_pointed",
                "[process.finishing]\ntip_angle_deg = 2.5\n",
                "process.finishing.tip_angle_deg: must be 0"},
        BadCase{"tool_numbers_shared", "[process.finishing]\nnumber = 3\n",
                "process.finishing.number: T3 is also process.notch.number"},
        BadCase{"probe_number_shared", "[process.probe]\nnumber = 1\n",
                "process.probe.number: T1 is also process.roughing.number"},
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
        // M-codes: two functions on one code, or a function on a code
        // the programs use with its standard meaning (M8 coolant on).
        BadCase{"m_code_shared", "[machine]\nm_b_unclamp = 10\n",
                "machine.m_b_unclamp: M10 is also machine.m_table_clamp"},
        BadCase{"m_code_probe_on_c", "[machine]\nm_probe_on = 601\n",
                "machine.m_probe_on: M601 is also machine.m_c_turning_off"},
        BadCase{"m_code_coolant", "[machine]\nm_table_clamp = 8\n",
                "machine.m_table_clamp: M8 is coolant on"},
        BadCase{"m_code_sync", "[machine]\nfanuc_sync_block = \"M12\"\n",
                "machine.fanuc_sync_block: M12 is also machine.m_b_clamp"},
        BadCase{"m_code_negative", "[machine]\nm_c_turning_on = -1\n",
                "machine.m_c_turning_on"},
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
