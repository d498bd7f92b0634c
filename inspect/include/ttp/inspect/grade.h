// Grading of the thermal figures against limits with the ISO 14253-1
// decision rule: a value conforms when |value| <= limit - U, does not
// conform when |value| > limit + U; in between the case is undecidable.
// Limits apply per figure and over all cycles.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace ttp::inspect {

struct GradeLimits {
  double linear_um = 5.0;          // E_X, E_Y, E_Z, E_TTP
  double angular_um_per_m = 15.0;  // E_B (and E_C when present)
  void Validate() const;           // throws InputError naming the option
};

enum class Verdict { kPass, kFail, kUndecidable, kMissing };
const char* VerdictName(Verdict v);  // "pass", "fail", "undecidable", "missing"

struct GradedValue {
  int cycle = 0;
  std::string figure;                  // "E_X", ...
  double value = 0, u = 0, limit = 0;  // um or um/m; U expanded (k = 2)
  Verdict verdict = Verdict::kMissing;
};

struct GradeResult {
  std::vector<GradedValue> values;
  // fail if any value fails; pass if every value passes; else undecidable
  // (including missing figures: conformance is not shown).
  Verdict overall = Verdict::kUndecidable;
  int counts[4] = {0, 0, 0, 0};  // by Verdict
};

Verdict Decide(double value, double u, double limit);

// Grades the "figures" array of an inspection JSON (ttp inspect --json).
// Throws InputError(source, 0, field, problem) on a malformed document.
GradeResult GradeFigures(const nlohmann::json& inspection,
                         const GradeLimits& limits, const std::string& source);

nlohmann::json GradeToJson(const GradeResult& result,
                           const GradeLimits& limits);
std::string GradeTable(const GradeResult& result, const GradeLimits& limits);

}  // namespace ttp::inspect
