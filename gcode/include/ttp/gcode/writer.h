// Program IR -> controller text (FANUC 30i or LinuxCNC), deterministic.
//
// Number formats: mm 4 decimals, degrees 3 decimals, feeds 1 decimal,
// seconds 3 decimals, rpm rounded to whole 1/min. Every move line carries its
// motion G-code; F is written when it changes.
//
// FANUC: `%`, `O<n> (<title>)`, safe block, G54, `T<n> M6` + `G43 H<n>`,
// M3/M4 S, M5, M8/M9, `G04 X<s>`, C turning `M<m_c_turning_on> S<rpm>` (S on
// that block is the C speed, not the main spindle's) and `M<m_c_turning_off>`,
// table clamp `M<m_table_clamp>` / `M<m_table_unclamp>`, reports
// `DPRNT[CUT*<feature>*C<deg>]` between POPEN (before the first report) and
// PCLOS (before M30), M30, `%`.
//
// LinuxCNC: same blocks with `G4 P<s>`, C turning as spindle 1
// (`M3 $1 S<rpm>` / `M5 $1`), clamp as digital output 0 (`M64 P0` clamp,
// `M65 P0` unclamp), reports `(print,cut,<feature>,<deg>)`.
#pragma once

#include <string>

#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"

namespace ttp::gcode {

// LinuxCNC digital output that drives the table clamp.
constexpr int kLinuxCncClampOutput = 0;

// Throws InputError(program.name, 0, "statement <i>", ...) on a statement
// that cannot be written (negative rpm or feed, non-finite numbers...).
std::string WriteProgram(const Program& program, Dialect dialect,
                         const Config& config);

}  // namespace ttp::gcode
