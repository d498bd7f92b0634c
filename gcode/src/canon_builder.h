// State machine shared by the program reader and the rs274 canon parser, so
// that both turn the same machine actions into the same canonical statements
// (state changes only, positions carried along).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ttp/gcode/canon.h"

namespace ttp::gcode {

class CanonBuilder {
 public:
  // Spindle changes of one line are merged (M4 S2000 on a turning spindle
  // is one change), so they are emitted when the line changes or another
  // statement comes.
  void SetLine(int line) {
    if (line != line_) Flush();
    line_ = line;
  }
  const Eigen::Vector3d& position_mm() const { return position_mm_; }
  // Where the machine stands before the first statement (program
  // coordinates).
  void SetStart(const Eigen::Vector3d& p_mm) { position_mm_ = p_mm; }
  double c_deg() const { return c_deg_; }

  void Traverse(const Eigen::Vector3d& to_mm, double c_deg);
  void Feed(const Eigen::Vector3d& to_mm, double c_deg, double feed_per_min);
  void Probe(const Eigen::Vector3d& to_mm, double c_deg, double feed_per_min);
  void Dwell(double seconds);
  // spindle 0 = main spindle (kSpindle), 1 = C turning (kCSpin).
  void SetSpindleSpeed(int spindle, double rpm);
  void StartSpindle(int spindle, bool clockwise);
  void StopSpindle(int spindle);
  void SetCoolant(bool on);
  void SetClamp(bool clamp);
  void ChangeTool(int tool);
  // G43/G49: the programmed position of the unchanged physical position moves
  // by the change of the length offset (as rs274 does). `tool`: the tool
  // whose length it is (-1: G49, or not known).
  void SetToolLengthOffset(double length_mm, int tool = -1) {
    position_mm_.z() -= length_mm - tool_length_offset_mm_;
    tool_length_offset_mm_ = length_mm;
    tool_length_offset_tool_ = tool;
  }
  void Report(const std::string& text);
  void Comment(const std::string& text);
  void End();

  std::vector<CanonStatement> Take() {
    Flush();
    return std::move(out_);
  }

 private:
  struct Spindle {
    bool on = false;
    bool clockwise = true;
    double rpm = 0;
    double emitted_rpm = 0;  // effective rpm last emitted (0 = stopped)
    bool emitted_clockwise = true;
  };
  CanonStatement& Push(CanonKind kind);  // flushes spindle changes first
  CanonStatement& PushRaw(CanonKind kind);
  void Flush();
  void EmitSpindleIfChanged(int spindle);

  int line_ = 0;
  Eigen::Vector3d position_mm_ = Eigen::Vector3d::Zero();
  double c_deg_ = 0;
  double tool_length_offset_mm_ = 0;
  int tool_length_offset_tool_ = -1;
  Spindle spindles_[2];
  bool coolant_ = false;
  std::optional<bool> clamp_;
  std::vector<CanonStatement> out_;
};

}  // namespace ttp::gcode
