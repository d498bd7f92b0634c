// Program IR -> controller text (FANUC 30i or LinuxCNC), deterministic.
//
// Number formats: mm 4 decimals, degrees 3 decimals, feeds 1 decimal,
// seconds 3 decimals, rpm rounded to whole 1/min. Every move line carries its
// motion G-code; F is written when it changes.
//
// FANUC: `%`, `O<n> (<title>)`, safety block `G17 G21 G40 G49 G69 G80 G90
// G94`, G54, `T<n> M6`, `G0 G43 H<n> Z<z>`, tool change position
// `G49 G53 G0 ...`, B `M<unclamp> G0 B0 M<clamp>`, incremental C
// `G91 G0 C<d>` + `G90`,
// M3/M4 S, M5, M8/M9, `G04 X<s>`, C turning `M<m_c_turning_on> S<rpm>` (S on
// that block is the C speed, not the main spindle's) and `M<m_c_turning_off>`,
// table clamp `M<m_table_clamp>` / `M<m_table_unclamp>`, reports
// the profile's non-buffered block (`G53`) then
// `DPRNT[CUT*<feature>*C<deg>*T#3012[60]]` between POPEN (before the first
// report) and PCLOS (before M30), M30, `%`.
//
// LinuxCNC: safety block with `G64 P<tol>` instead of G69, `G4 P<s>`, C
// turning as spindle 1 (`M3 $1 S<rpm>` / `M5 $1`), clamps as the profile's
// digital outputs (`M64 P<n>` clamp, `M65 P<n>` unclamp), reports
// `(debug,cut,<feature>,<deg>)` (queued with the motion).
#pragma once

#include <string>

#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"

namespace ttp::gcode {

// LinuxCNC path blending tolerance (G64 P), mm.
constexpr double kLinuxCncBlendToleranceMm = 0.005;

// Throws InputError(program.name, 0, "statement <i>", ...) on a statement
// that cannot be written (negative rpm or feed, non-finite numbers...).
std::string WriteProgram(const Program& program, Dialect dialect,
                         const Config& config);

}  // namespace ttp::gcode
