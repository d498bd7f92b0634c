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
// Tool-length compensation alone in its block: G43 H<tool> (tool >= 0) or
// G49 (tool < 0). The programmed position of the unmoved tool changes by
// the offset (as the readers and rs274 take it); the next move goes to
// its target with the new offset.
struct LengthCompensation {
  int tool = -1;
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
// Probing move (FANUC G31 skip, LinuxCNC G38.2) along one linear axis
// towards `to`, stopping at the touch; then one row of the probing log
// (ProbeLog) for planned point `point_id`. FANUC: the check of the skip
// position against nominal_mm, `IF [ABS[#<var>-<nominal>] GT <window>]
// THEN #3000=<alarm> (NO TOUCH <PASS> <id>)`, and
// `DPRNT[<PASS>*<id>*<feature>*X#5061[44]*Y#5062[44]*Z#5063[44]*C#5065[33]*
// T#3012[60]]`; LinuxCNC `(LOG,<id>,#5061,#5062,#5063,#5066,<feature>,
// <pass>)` (G38.2 itself stops the program without a touch). The
// variables are the machine profile's (fanuc_skip_variables,
// linuxcnc_probe_variables).
struct Probe {
  Axes to;
  double feed_per_min;
  int point_id;
  std::string feature;           // "X1-5", "SPHERE"
  std::string pass = "measure";  // qualify | measure | drift
  double nominal_mm = 0;         // the nominal contact on the moving axis
  double touch_window_mm = 1.0;  // FANUC: farther from nominal_mm is an alarm
  int alarm = 1;                 // FANUC: #3000 = alarm
};
// Spindle oriented (M19; LinuxCNC M19 R0): a touch probe must not turn.
struct SpindleOrient {};
// The touch probe's signal on or off: FANUC machine.m_probe_on /
// m_probe_off, LinuxCNC M64 / M65 P machine.linuxcnc_probe_output.
struct ProbeSignal {
  bool on;
};
// The probing log: FANUC POPEN and the header
// DPRNT[TTP*PROBE*LOG*O<number>*D#3011[80]*T#3012[60]] / PCLOS; LinuxCNC
// (LOGOPEN,<file>) and the CSV header row
// (LOG,point_id,x,y,z,c_deg,feature,pass) / (LOGCLOSE).
struct ProbeLog {
  bool open;
  std::string file;  // LinuxCNC: the log file
};
struct ProgramEnd {};  // M30

using Statement =
    std::variant<Comment, Rapid, Feed, Dwell, SpindleOn, SpindleOff, Coolant,
                 ToolChange, CSpin, TableClamp, Report, Probe, ProgramEnd,
                 MachineRapid, LengthOffset, BZeroClamp, SpindleOrient,
                 ProbeSignal, ProbeLog, LengthCompensation>;

struct Program {
  std::string name;   // "pre" or "cycle"
  int number = 1000;  // FANUC O-number
  std::string title;  // first comment
  // LinuxCNC: exact stop (G61: every move ends where it is programmed, as
  // probing needs) instead of path blending within a tolerance.
  bool exact_stop = false;
  std::vector<Statement> statements;
};

}  // namespace ttp::gcode
