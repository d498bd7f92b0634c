#include <gtest/gtest.h>

#include "ttp/gcode/reader.h"

namespace ttp::gcode {
namespace {

// Durations worked out by hand from the default profile: rapid 30000 mm/min
// (500 mm/s), C indexing 360 deg/s, C spin-up 5 s to 1200 rpm.
TEST(TimeModelTest, DurationsFollowTheMachineProfile) {
  const char* text =
      "G0 X300 Y400 Z0\n"  // 500 mm at 500 mm/s: 1 s
      "G0 C720\n"          // 720 deg at 360 deg/s: 2 s
      "G0 X0 Y0 C90\n"     // 500 mm: 1 s; 630 deg: 1.75 s -> 1.75 s
      "G1 X30 F600\n"      // 30 mm at 10 mm/s: 3 s
      "G1 C180 F1800\n"    // pure C: 90 deg at 30 deg/s: 3 s
      "G4 P2.5\n"          // 2.5 s
      "M3 $1 S600\n"       // 0 -> 600 rpm: 2.5 s
      "M3 $1 S1200\n"      // 600 -> 1200 rpm: 2.5 s
      "M5 $1\n"            // 1200 -> 0: 5 s
      "M3 S1000\n";        // main spindle: no time in the model
  // The machine starts at machine zero: W's origin put there.
  Config config;
  config.machine.table_top_z_mm =
      -(config.part.adapter_height_mm + config.part.height_mm());
  const auto s = ReadProgram(text, Dialect::kLinuxCnc, config, "t.ngc");
  const std::vector<double> want = {1, 2, 1.75, 3, 3, 2.5, 2.5, 2.5, 5, 0};
  ASSERT_EQ(s.size(), want.size());
  double t = 0;
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_NEAR(s[i].duration_s, want[i], 1e-12) << i;
    EXPECT_NEAR(s[i].start_s, t, 1e-12) << i;
    t += want[i];
  }
  EXPECT_NEAR(TotalDuration(s), 23.25, 1e-12);
}

TEST(TimeModelTest, FasterMachineTakesLessTime) {
  Config fast;
  fast.machine.rapid_mm_min = 60000;
  fast.machine.c_index_deg_s = 720;
  const char* text = "G0 X300 Y400\nG0 C720\n";
  const double slow_s =
      TotalDuration(ReadProgram(text, Dialect::kLinuxCnc, Config{}, "t.ngc"));
  const double fast_s =
      TotalDuration(ReadProgram(text, Dialect::kLinuxCnc, fast, "t.ngc"));
  EXPECT_NEAR(slow_s, 3.0, 1e-12);
  EXPECT_NEAR(fast_s, 1.5, 1e-12);
}

TEST(TimeModelTest, EmptyProgramTakesNoTime) {
  std::vector<CanonStatement> none;
  ApplyTimeModel(none, MachineProfile{});
  EXPECT_EQ(TotalDuration(none), 0.0);
}

}  // namespace
}  // namespace ttp::gcode
