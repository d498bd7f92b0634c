// Independent check with LinuxCNC's stand-alone interpreter /usr/bin/rs274,
// and comparison of two canonical sequences.
#pragma once

#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/geometry/config.h"

namespace ttp::gcode {

struct Rs274Result {
  std::vector<CanonStatement> statements;  // parsed, time model applied
  std::string canon_text;                  // rs274's canon file
  std::string stderr_text;                 // rs274's diagnostics
  bool inches = false;  // the program switched to inches (G20) somewhere
  // How far rs274's positions may be from the exact ones: its canon text
  // prints 4 decimals in the program's units, a position and the work
  // offset it is printed against each rounded (0.2 um in mm, 2.54 um in
  // inches). The tolerance a comparison with our reading takes.
  double ResolutionMm() const {
    return inches ? 2 * 0.5e-4 * 25.4 + 1e-6 : 1.5e-4;
  }
};

// True when /usr/bin/rs274 exists and is executable.
bool Rs274Available();

// Runs rs274 on LinuxCNC text in a temporary folder with a generated INI
// (metric, XYZC, SPINDLES=2) and tool table (inches, from the config's
// tools). The harness numbers every block N<line> so that canon lines carry
// the source line, and turns `(print,` into `(debug,ttp-report:` so that
// reports appear in order in the canon file. Throws InputError("rs274",
// line, "", message) when rs274 rejects the program; std::runtime_error when
// rs274 cannot be run.
Rs274Result RunRs274(const std::string& ngc_text, const Config& config);

// Parses rs274's canon output (mm, degrees) into canonical statements with
// the reader's semantics (state changes only, M30 resets dropped, interpreter
// comments dropped). source names the text in errors.
// c_clamp_output: the digital output (M64/M65 P) of the C clamp; start_mm:
// where the machine stands before the first call (program coordinates).
std::vector<CanonStatement> ParseRs274Canon(
    const std::string& canon_text, const std::string& source,
    int c_clamp_output = 0,
    const Eigen::Vector3d& start_mm = Eigen::Vector3d::Zero());

struct ToolpathDifference {
  bool same = true;
  // Index in each sequence of the first differing statement (among the
  // compared ones; comments are skipped); size() when one sequence ended.
  size_t index_a = 0, index_b = 0;
  int line_a = 0, line_b = 0;  // source lines, 0 if none
  std::string what;            // human-readable reason
};

// Compares motions (kind, end position and tool-length offset within
// tolerance_mm, C within tolerance_rad, feed), dwells, spindle and C turning
// (rpm, direction), coolant, clamp, tool changes, reports (text) and the end,
// in order. Comments are ignored; times are not compared.
ToolpathDifference CompareToolpaths(const std::vector<CanonStatement>& a,
                                    const std::vector<CanonStatement>& b,
                                    double tolerance_mm = 1e-6,
                                    double tolerance_rad = 1e-9);

}  // namespace ttp::gcode
