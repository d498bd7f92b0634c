// Program text (FANUC or LinuxCNC dialect) -> canonical statements, in the
// rs274ngc style: read (lex blocks into words and comments with line
// numbers), check (unknown/unsupported words, conflicting modal words,
// missing feed, bad numbers), convert (modal state -> canonical statements)
// and execute (time model, see ApplyTimeModel).
//
// Semantics the readers share (so both dialects and rs274 agree):
// - kSpindle / kCSpin / kCoolant / kClamp are emitted only when the state
//   changes (M5 on a stopped spindle emits nothing); S alone while a spindle
//   turns changes its speed.
// - M6 stops the main spindle and C turning (as LinuxCNC does), then emits
//   kToolChange; G43 H is accepted and has no canonical effect.
// - M30 (or M2) emits kEnd only; the rest of the text is not read.
// - The machine starts at program (0, 0, 0), C = 0.
// - FANUC: an axis or dwell value without a decimal point is in least input
//   increments (X10 = 0.010 mm, G04 X1000 = 1 s), as on the control.
// - FANUC DPRNT[CUT*<feature>*C<deg>] and LinuxCNC (print,cut,<feature>,<deg>)
//   give kReport with text "cut,<feature>,<deg>" (deg as written).
// - Probe moves: FANUC G31, LinuxCNC G38.2 -> kProbe. M19 (spindle
//   orientation, LinuxCNC M19 R<deg>) and the probing program's FANUC touch
//   check `IF [ABS[#50xx-<nominal>] GT <window>] THEN #3000=<n> (...)` have
//   no canonical effect; LinuxCNC M64/M65 P of the profile's probe output
//   neither.
// Not supported (InputError): other macros/#variables, WHILE, subprograms,
// O-word control in LinuxCNC, arcs, canned cycles, G55-G59, inverse-time feed.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"

namespace ttp::gcode {

// FANUC if the text has an O-number line, DPRNT/POPEN or `G04 X`; LinuxCNC if
// it has `$<n>`, `(print,`/`(debug,`, `G64 P`, `G4 P` or M64/M65 (the first
// such line decides); nullopt when nothing decides.
std::optional<Dialect> DecideDialect(const std::string& text);

// DecideDialect, LinuxCNC when nothing decides (every FANUC program of ours
// has its O-number line).
Dialect DetectDialect(const std::string& text);

// The dialect for `--dialect auto`: DecideDialect's; when nothing decides,
// LinuxCNC if `source` ends in .ngc (LinuxCNC's extension) or the program
// reads the same in both, else InputError(source,
// line, word) naming the first word whose value the two controls read
// differently (a nonzero X/Y/Z/C without a decimal point: least input
// increments on FANUC; P of a dwell: ms on FANUC, s in LinuxCNC).
Dialect ResolveDialect(const std::string& text, const std::string& source);

// Throws InputError(source, line, word, problem) on bad input.
std::vector<CanonStatement> ReadProgram(const std::string& text,
                                        Dialect dialect, const Config& config,
                                        const std::string& source);

// Time model of the machine profile; fills start_s and duration_s in order.
// Rapids: max(XYZ length / rapid_mm_min, |dC| / c_index_deg_s). Feeds and
// probes: XYZ length / feed, or |dC| (deg) / feed for a pure C move. Dwells:
// their seconds. C turning: c_spinup_s * |rpm change| / c_max_rpm. Every
// other statement takes no time. Positions start at start_mm (program
// coordinates; ReadProgram and RunRs274 give machine zero), C = 0.
void ApplyTimeModel(std::vector<CanonStatement>& statements,
                    const MachineProfile& machine,
                    const Eigen::Vector3d& start_mm = Eigen::Vector3d::Zero());

// End time of the last statement (0 when empty).
double TotalDuration(const std::vector<CanonStatement>& statements);

}  // namespace ttp::gcode
