#include "ttp/gcode/execution.h"

namespace ttp::gcode {

ExecutionState Step(const ExecutionState& before,
                    const CanonStatement& statement) {
  ExecutionState s = before;
  switch (statement.kind) {
    case CanonKind::kToolChange:
      s.tool = static_cast<int>(statement.value);
      s.tool_position_known = false;
      s.spindle_rpm = 0;
      s.c_turning_rpm = 0;
      break;
    case CanonKind::kSpindle:
      s.spindle_rpm = statement.value;
      break;
    case CanonKind::kCSpin:
      s.c_turning_rpm = statement.value;
      break;
    case CanonKind::kClamp:
      s.c_clamped = statement.value > 0;
      break;
    case CanonKind::kTraverse:
    case CanonKind::kFeed:
    case CanonKind::kProbe:
      s.tool_position_known = true;
      break;
    default:
      break;
  }
  s.position_mm = statement.end_mm;
  s.c_rad = statement.end_c_rad;
  return s;
}

std::vector<ExecutionState> ExecutionStates(
    const std::vector<CanonStatement>& statements) {
  std::vector<ExecutionState> states;
  states.reserve(statements.size() + 1);
  states.emplace_back();
  for (const CanonStatement& s : statements)
    states.push_back(Step(states.back(), s));
  return states;
}

}  // namespace ttp::gcode
