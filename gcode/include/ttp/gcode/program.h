// Program IR: what CAM means to send to the machine, independent of the
// controller's dialect. The writer turns it into FANUC or LinuxCNC text; the
// reader turns any text back into canonical statements (canon.h).
//
// CONTRACT between cam (producer) and gcode (writer): extend, do not rename.
// Coordinates are program coordinates (G54: W's origin at C = 0), mm; table
// angle C in degrees as commanded.
#pragma once

#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "ttp/geometry/config.h"

namespace ttp::gcode {

enum class Dialect { kFanuc, kLinuxCnc };
// "fanuc" | "linuxcnc"; throws InputError(source, 0, "dialect", ...).
Dialect ParseDialect(const std::string& name, const std::string& source);
const char* DialectName(Dialect d);

struct Axes {
  std::optional<double> x_mm, y_mm, z_mm, c_deg;
  std::optional<double> b_deg;
};

struct Comment {
  std::string text;
};
// incremental: the given axes move by their values (G91 for this block,
// G90 after it); C is indexed this way so that a table with roll-over
// turns as meant.
struct Rapid {
  Axes to;
  bool incremental = false;
};
// Linear feed move. feed is mm/min, or deg/min for a pure C move.
struct Feed {
  Axes to;
  double feed_per_min;
  bool incremental = false;
};
// Rapid in machine coordinates of the gauge line (G49 G53 G0): tool-length
// compensation is cancelled in the same block. Used for the tool-change
// position.
struct MachineRapid {
  Axes to;
};
// G43 H<tool> with a Z word: compensation on while moving (rapid) to z_mm.
struct LengthOffset {
  int tool;
  double z_mm;
};
// B axis to 0 and clamped (the spindle axis stays vertical).
struct BZeroClamp {};
struct Dwell {
  double seconds;
};
struct SpindleOn {
  double rpm;
  bool clockwise = true;
};                     // M3/M4
struct SpindleOff {};  // M5
struct Coolant {
  bool on;
};  // M8/M9
// M6 T with tool-length compensation (G43 H) switched on afterwards.
struct ToolChange {
  int tool;
  std::string description;
};
// C axis in turning (spindle) mode at rpm; rpm 0 stops it and returns C to
// positioning mode. FANUC: builder M-codes from the machine profile;
// LinuxCNC: spindle 1.
struct CSpin {
  double rpm;
};
struct TableClamp {
  bool clamp;
};
// Report to the compensation PC: becomes a `cut` row (feature name of
// talc-log.md section 5) with the table angle, sent when the motion before
// it has ended. FANUC: the profile's non-buffered block (G53 or an M-code)
// then DPRNT with the control's clock (#3012, hhmmss); LinuxCNC
// (debug,...), queued with the motion.
struct Report {
  std::string event;
  std::string feature;
  double c_deg;
};
// Probing move (FANUC G31 skip, LinuxCNC G38.2) towards `to`, stopping at
// the touch; then the skip position is reported for planned point
// `point_id`: FANUC `DPRNT[PROBE*<id>*X#5061[44]*Y#5062[44]*Z#5063[44]*
// C#5065[33]]`, LinuxCNC `(print,probe,<id>,#5061,#5062,#5063,#5066)` (the
// variables of the machine profile: fanuc_skip_variables,
// linuxcnc_probe_variables).
struct Probe {
  Axes to;
  double feed_per_min;
  int point_id;
};
struct ProgramEnd {};  // M30

using Statement =
    std::variant<Comment, Rapid, Feed, Dwell, SpindleOn, SpindleOff, Coolant,
                 ToolChange, CSpin, TableClamp, Report, Probe, ProgramEnd,
                 MachineRapid, LengthOffset, BZeroClamp>;

struct Program {
  std::string name;   // "pre" or "cycle"
  int number = 1000;  // FANUC O-number
  std::string title;  // first comment
  std::vector<Statement> statements;
};

}  // namespace ttp::gcode
