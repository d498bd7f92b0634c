// Cut simulation of an NC program and the program checks: the tool is
// swept through the stock (blank for the pre-machining, the ideal
// pre-machined piece for the test cycle) along the canonical statements, in
// the workpiece frame W, on a multi-dexel model (dexel.h): feature probes
// (rays along the normals of every nominal feature, exact) and a coarse
// Z-dexel grid over the whole piece (rapids, collisions).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/gcode/canon.h"
#include "ttp/geometry/config.h"

namespace ttp::verify {

enum class VerifyStage { kPre, kCycle };
const char* StageName(VerifyStage stage);
// "pre" | "cycle"; throws InputError(source, 0, "stage", ...).
VerifyStage ParseStage(const std::string& name, const std::string& source);
// Cycle when the program reports cuts to the compensation PC, else pre.
VerifyStage DetectStage(const std::vector<gcode::CanonStatement>& statements);

struct Finding {
  std::string check;  // "rapid cuts no material", "surface X1-5", ...
  bool pass = true;
  double measured = 0;  // in unit
  double limit = 0;     // in unit; pass when measured <= limit
  std::string unit;     // "mm" or "um"
  int statement = -1;   // index into the canonical statements, -1 = none
  int source_line = 0;  // line in the program text, 0 = none
  std::string detail;
};

struct VerifyOptions {
  VerifyStage stage = VerifyStage::kPre;
  double probe_pitch_mm = 1.0;   // spacing of the feature probe rays
  double coarse_pitch_mm = 1.0;  // spacing of the Z-dexel grid
  double surface_tolerance_mm = 0.005;
  double axis_tolerance_mm = 0.001;  // "only C changes", "Z fixed"
  // Test cycle only: the pre-machining program's statements, cut from the
  // blank first (the cycle then starts from the simulated pre-machined
  // piece instead of the drawing's ideal one). Not owned; may be null.
  const std::vector<gcode::CanonStatement>* after = nullptr;
};

struct VerifyReport {
  VerifyStage stage = VerifyStage::kPre;
  std::string source;
  int statements = 0;
  int rays = 0;
  int probe_rays = 0;
  std::vector<Finding> findings;

  bool AllPassed() const;
  const Finding* Find(const std::string& check) const;
  std::vector<const Finding*> Failed() const;
};

// Simulates the statements (program coordinates as the reader gives them)
// and judges them. Throws nothing for a bad program: problems are findings.
VerifyReport VerifyStatements(
    const std::vector<gcode::CanonStatement>& statements, const Config& config,
    const VerifyOptions& options, const std::string& source);

nlohmann::json ReportToJson(const VerifyReport& report);
// Plain text: a summary first (what was checked, how many checks passed,
// the failures with their lines); with `verbose` then every check with its
// numbers, failures first.
std::string FormatReportTable(const VerifyReport& report, bool verbose = false);

}  // namespace ttp::verify
