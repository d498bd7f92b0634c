// Canonical statements -> program IR, so that a program read in one dialect
// can be written in the other (e.g. a FANUC program checked by rs274 through
// its LinuxCNC translation).
#pragma once

#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/gcode/program.h"

namespace ttp::gcode {

// Motions become moves with all four axes given. Probe moves have no IR
// statement yet: InputError(source, line, "probe", ...). Reports need the
// text "<event>,<feature>,<c_deg>".
Program ProgramFromCanon(const std::vector<CanonStatement>& statements,
                         const std::string& name, int number,
                         const std::string& title, const std::string& source);

}  // namespace ttp::gcode
