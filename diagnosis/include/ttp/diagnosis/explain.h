// What a reader of a diagnosis needs beside the numbers: a summary sentence
// (the cause and its evidence against the other candidates) and the
// residuals of the figures per cycle before and after the chosen effect.
// Computed here, from the diagnosis' own results, so that the report only
// renders them.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "ttp/diagnosis/diagnose.h"

namespace ttp::diagnosis {

// Residuals measured - simulated of E_X, E_Y, E_Z, E_TTP (um) per cycle
// 1..cycles (NaN where there is none), before and after the chosen effect,
// with their standard uncertainty.
struct ResidualTable {
  static constexpr std::array<const char*, 4> kFigures = {"E_X", "E_Y", "E_Z",
                                                          "E_TTP"};
  std::vector<int> cycles;
  // [figure][cycle index], um.
  std::array<std::vector<double>, 4> before_um, after_um, sigma_um;
};

struct DiagnosisExplanation {
  std::string summary;
  ResidualTable residuals;
};

// `run` and `report` as DiagnosePrepared made them; `evidence_threshold` the
// one it used.
DiagnosisExplanation ExplainDiagnosis(const PreparedRun& run,
                                      const DiagnosisReport& report,
                                      const PartSpec& part,
                                      double evidence_threshold);

}  // namespace ttp::diagnosis
