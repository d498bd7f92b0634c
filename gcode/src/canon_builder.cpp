#include "canon_builder.h"

#include <cmath>

#include "ttp/geometry/constants.h"

namespace ttp::gcode {

CanonStatement& CanonBuilder::Push(CanonKind kind) {
  Flush();
  return PushRaw(kind);
}

void CanonBuilder::Flush() {
  EmitSpindleIfChanged(0);
  EmitSpindleIfChanged(1);
}

CanonStatement& CanonBuilder::PushRaw(CanonKind kind) {
  CanonStatement s;
  s.kind = kind;
  s.end_mm = position_mm_;
  s.end_c_rad = c_deg_ * kDeg;
  s.length_offset_mm = tool_length_offset_mm_;
  s.length_offset_tool = tool_length_offset_tool_;
  s.source_line = line_;
  out_.push_back(s);
  return out_.back();
}

void CanonBuilder::Traverse(const Eigen::Vector3d& to_mm, double c_deg) {
  position_mm_ = to_mm;
  c_deg_ = c_deg;
  Push(CanonKind::kTraverse);
}

void CanonBuilder::Feed(const Eigen::Vector3d& to_mm, double c_deg,
                        double feed_per_min) {
  position_mm_ = to_mm;
  c_deg_ = c_deg;
  Push(CanonKind::kFeed).feed_per_min = feed_per_min;
}

void CanonBuilder::Probe(const Eigen::Vector3d& to_mm, double c_deg,
                         double feed_per_min) {
  position_mm_ = to_mm;
  c_deg_ = c_deg;
  Push(CanonKind::kProbe).feed_per_min = feed_per_min;
}

void CanonBuilder::Dwell(double seconds) {
  Push(CanonKind::kDwell).value = seconds;
}

void CanonBuilder::EmitSpindleIfChanged(int spindle) {
  Spindle& s = spindles_[spindle];
  const double rpm = s.on ? s.rpm : 0.0;
  const bool changed =
      rpm != s.emitted_rpm || (rpm > 0 && s.clockwise != s.emitted_clockwise);
  if (!changed) return;
  CanonStatement& st =
      PushRaw(spindle == 0 ? CanonKind::kSpindle : CanonKind::kCSpin);
  st.value = rpm;
  st.clockwise = s.clockwise;
  s.emitted_rpm = rpm;
  s.emitted_clockwise = s.clockwise;
}

void CanonBuilder::SetSpindleSpeed(int spindle, double rpm) {
  spindles_[spindle].rpm = rpm;
}

void CanonBuilder::StartSpindle(int spindle, bool clockwise) {
  spindles_[spindle].on = true;
  spindles_[spindle].clockwise = clockwise;
}

void CanonBuilder::StopSpindle(int spindle) { spindles_[spindle].on = false; }

void CanonBuilder::SetCoolant(bool on) {
  if (on == coolant_) return;
  coolant_ = on;
  Push(CanonKind::kCoolant).value = on ? 1 : 0;
}

void CanonBuilder::SetClamp(bool clamp) {
  if (clamp_ && *clamp_ == clamp) return;
  clamp_ = clamp;
  Push(CanonKind::kClamp).value = clamp ? 1 : 0;
}

void CanonBuilder::ChangeTool(int tool) {
  Push(CanonKind::kToolChange).value = tool;
}

void CanonBuilder::Report(const std::string& text) {
  Push(CanonKind::kReport).text = text;
}

void CanonBuilder::Comment(const std::string& text) {
  Push(CanonKind::kComment).text = text;
}

void CanonBuilder::End() { Push(CanonKind::kEnd); }

}  // namespace ttp::gcode
