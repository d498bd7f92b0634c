// The two programs of the piece verified in one call: the pre-machining
// program cut from the blank, then the test-cycle program cut from what the
// pre-machining left (not from the drawing's ideal piece), each read back
// from its program text first so the text is what is checked.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "ttp/gcode/program.h"
#include "ttp/geometry/config.h"
#include "ttp/verify/verify.h"

namespace ttp::verify {

struct ProgramsVerification {
  gcode::Dialect dialect = gcode::Dialect::kFanuc;
  VerifyReport pre;    // blank -> pre-machined piece (drawing + allowance)
  VerifyReport cycle;  // simulated pre-machined piece -> finished piece

  bool Passed() const { return pre.AllPassed() && cycle.AllPassed(); }
  // Largest |deviation| of a feature surface from nominal over both
  // programs, um.
  double MaxSurfaceDeviationUm() const;
};

// Verifies the given program texts (pre-machining, test cycle) of one
// dialect. `options.stage` and `options.after` are set here; the pitches
// and tolerances are taken from `options`. Throws InputError when a text
// cannot be read.
ProgramsVerification VerifyProgramTexts(const std::string& pre_text,
                                        const std::string& cycle_text,
                                        gcode::Dialect dialect,
                                        const Config& config,
                                        const VerifyOptions& options = {});

// Builds both programs for `config` (cam), writes them in `dialect` and
// verifies them as above.
ProgramsVerification VerifyPrograms(
    const Config& config, gcode::Dialect dialect = gcode::Dialect::kFanuc,
    const VerifyOptions& options = {});

// {"passed", "dialect", "max_surface_deviation_um", "failed": [check...],
//  "pre": ReportToJson(pre), "cycle": ReportToJson(cycle)}
nlohmann::json ProgramsVerificationToJson(const ProgramsVerification& v);

}  // namespace ttp::verify
