// Canonical statements -> program IR, so that a program read in one dialect
// can be written in the other (e.g. a FANUC program checked by rs274 through
// its LinuxCNC translation).
#pragma once

#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/gcode/program.h"

namespace ttp::gcode {

// Motions become moves with all four axes given. A probe move becomes a
// Probe along its one moving axis, with the point, feature and pass of the
// log row printed after it (FANUC DPRNT "PASS*ID*FEATURE*X#...") and no
// nominal contact (so it cannot be written for FANUC, whose touch check
// needs one); the probing log's header row (ttp's "TTP*PROBE*LOG*...")
// opens the log, closed at the end. Other reports need the text
// "<event>,<feature>,<c_deg>". InputError(source, line, ...) otherwise.
Program ProgramFromCanon(const std::vector<CanonStatement>& statements,
                         const std::string& name, int number,
                         const std::string& title, const std::string& source);

// True for a report that ProgramFromCanon writes as the probing log (its
// header row, a row after a probe move): the other dialect's program writes
// it as a log line, not as a report.
bool IsProbeLogReport(const std::string& text);

}  // namespace ttp::gcode
