// The executor's state along a LinuxCNC text read by the project's reader:
// what each line of the text sets up (the oracle is the text itself).
#include "ttp/gcode/execution.h"

#include <gtest/gtest.h>

#include "ttp/gcode/reader.h"

namespace ttp::gcode {
namespace {

TEST(ExecutionTest, StateFollowsToolSpindleTurningClampAndPosition) {
  const std::string text =
      "G17 G21 G90 G94\n"
      "T4 M6\n"                  // 2
      "M3 S8000\n"               // 3
      "G0 G43 H4 Z50.0\n"        // 4
      "M64 P0\n"                 // 5
      "G1 X10.0 Y5.0 F600.0\n"   // 6
      "M65 P0\n"                 // 7
      "M3 $1 S1200\n"            // 8
      "G4 P1.0\n"                // 9
      "M5 $1\n"                  // 10
      "T20 M6\n"                 // 11
      "M30\n";
  const auto canon = ReadProgram(text, Dialect::kLinuxCnc, Config{}, "t");
  const auto states = ExecutionStates(canon);
  ASSERT_EQ(states.size(), canon.size() + 1);
  // The state before the first statement of a line.
  const auto before_line = [&](int line) {
    for (size_t i = 0; i < canon.size(); ++i)
      if (canon[i].source_line == line) return states[i];
    ADD_FAILURE() << "no statement on line " << line;
    return ExecutionState{};
  };
  EXPECT_EQ(states.front().tool, -1);
  EXPECT_FALSE(states.front().tool_position_known);
  const ExecutionState at4 = before_line(4);
  EXPECT_EQ(at4.tool, 4);
  EXPECT_DOUBLE_EQ(at4.spindle_rpm, 8000);
  EXPECT_FALSE(at4.tool_position_known);
  const ExecutionState at6 = before_line(6);
  EXPECT_TRUE(at6.tool_position_known);
  EXPECT_TRUE(at6.c_clamped);
  EXPECT_DOUBLE_EQ(at6.position_mm.z(), 50.0);
  const ExecutionState at9 = before_line(9);
  EXPECT_FALSE(at9.c_clamped);
  EXPECT_DOUBLE_EQ(at9.c_turning_rpm, 1200);
  EXPECT_DOUBLE_EQ(at9.position_mm.x(), 10.0);
  EXPECT_DOUBLE_EQ(at9.position_mm.y(), 5.0);
  // The second tool change: main spindle stopped, new tool, position
  // unknown until it moves.
  const ExecutionState& end = states.back();
  EXPECT_EQ(end.tool, 20);
  EXPECT_DOUBLE_EQ(end.spindle_rpm, 0);
  EXPECT_DOUBLE_EQ(end.c_turning_rpm, 0);
  EXPECT_FALSE(end.tool_position_known);
}

}  // namespace
}  // namespace ttp::gcode
