// The executor's machine state along canonical statements: what the
// program has set up before each statement (tool, spindle, C turning, C
// clamp, axis position). Consumers that judge statements (the cut
// simulation, the collision model) read it instead of keeping their own
// copy of the state machine.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "ttp/gcode/canon.h"

namespace ttp::gcode {

struct ExecutionState {
  int tool = -1;  // tool in the spindle, -1 before the first M6
  // False from the start and after a tool change until the first move:
  // the tool's position along Z is not known (G43 brings it down from the
  // top of the travel).
  bool tool_position_known = false;
  double spindle_rpm = 0;    // main spindle, 0 = stopped
  double c_turning_rpm = 0;  // C in turning mode, 0 = positioning
  bool c_clamped = false;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // program coords
  double c_rad = 0;
};

// The state after `statement` given the state before it. A tool change
// stops the main spindle and C turning (as the readers and LinuxCNC do).
ExecutionState Step(const ExecutionState& before,
                    const CanonStatement& statement);

// states[i] = the state before statements[i]; states.back() = after the
// last (size statements.size() + 1).
std::vector<ExecutionState> ExecutionStates(
    const std::vector<CanonStatement>& statements);

}  // namespace ttp::gcode
