#include "ttp/verify/programs.h"

#include <algorithm>
#include <cmath>

#include "ttp/cam/programs.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"

namespace ttp::verify {

double ProgramsVerification::MaxSurfaceDeviationUm() const {
  double worst = 0;
  for (const VerifyReport* r : {&pre, &cycle})
    for (const Finding& f : r->findings)
      if (f.check.rfind("surface ", 0) == 0 && std::isfinite(f.measured))
        worst = std::max(worst, f.measured);
  return worst;
}

ProgramsVerification VerifyProgramTexts(const std::string& pre_text,
                                        const std::string& cycle_text,
                                        gcode::Dialect dialect,
                                        const Config& config,
                                        const VerifyOptions& options) {
  const std::string ext = dialect == gcode::Dialect::kFanuc ? "nc" : "ngc";
  const std::string pre_name = "pre." + ext, cycle_name = "cycle." + ext;
  const auto pre = gcode::ReadProgram(pre_text, dialect, config, pre_name);
  const auto cycle =
      gcode::ReadProgram(cycle_text, dialect, config, cycle_name);
  ProgramsVerification v;
  v.dialect = dialect;
  VerifyOptions o = options;
  o.stage = VerifyStage::kPre;
  o.after = nullptr;
  v.pre = VerifyStatements(pre, config, o, pre_name);
  o.stage = VerifyStage::kCycle;
  o.after = &pre;
  v.cycle = VerifyStatements(cycle, config, o, cycle_name);
  return v;
}

ProgramsVerification VerifyPrograms(const Config& config,
                                    gcode::Dialect dialect,
                                    const VerifyOptions& options) {
  return VerifyProgramTexts(
      gcode::WriteProgram(cam::BuildPreMachiningProgram(config), dialect,
                          config),
      gcode::WriteProgram(cam::BuildTestCycleProgram(config), dialect, config),
      dialect, config, options);
}

nlohmann::json ProgramsVerificationToJson(const ProgramsVerification& v) {
  nlohmann::json doc;
  doc["passed"] = v.Passed();
  doc["dialect"] = gcode::DialectName(v.dialect);
  doc["max_surface_deviation_um"] = v.MaxSurfaceDeviationUm();
  nlohmann::json failed = nlohmann::json::array();
  for (const VerifyReport* r : {&v.pre, &v.cycle})
    for (const Finding* f : r->Failed())
      failed.push_back(std::string(StageName(r->stage)) + ": " + f->check);
  doc["failed"] = failed;
  doc["pre"] = ReportToJson(v.pre);
  doc["cycle"] = ReportToJson(v.cycle);
  return doc;
}

}  // namespace ttp::verify
