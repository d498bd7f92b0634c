// Grading of the thermal figures against limits with the ISO 14253-1
// decision rule: a value conforms when |value| <= limit - U, does not
// conform when |value| > limit + U; in between the case is undecidable.
//
// One decision for every command (`ttp grade`, `ttp report`, `ttp run`, their
// JSON): by default the figures the thesis evaluates (7.2.1: E_X, E_Y, E_Z,
// E_B, E_TTP), E_C only on request. A figure is not decidable, and left out
// of the overall verdict with the reason, when the instrument cannot measure
// it (a dial gauge measures no angle: no E_B, no E_C) or when its U reaches
// its limit in some cycle (the measurement cannot prove conformance).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/figures.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/measurement.h"

namespace ttp::inspect {

enum class Figure { kEX, kEY, kEZ, kEB, kETTP, kEC };
constexpr Figure kAllFigures[] = {Figure::kEX, Figure::kEY,   Figure::kEZ,
                                  Figure::kEB, Figure::kETTP, Figure::kEC};
const char* FigureName(Figure f);  // "E_X", ...
bool IsAngular(Figure f);          // E_B, E_C: um/m
const char* FigureUnit(Figure f);  // "um" or "um/m"
// "E_X" .. "E_C", case-insensitive ("e_ttp"); false when unknown.
bool ParseFigure(const std::string& name, Figure* f);

// What is graded and against which limits (per customer agreement; the
// defaults are the thesis' action limits, 7.2.1).
struct GradeLimits {
  double linear_um = 5.0;          // E_X, E_Y, E_Z, E_TTP
  double angular_um_per_m = 15.0;  // E_B, E_C
  // The figures graded; the thesis evaluates E_X..E_TTP, not E_C.
  std::vector<Figure> figures = {Figure::kEX, Figure::kEY, Figure::kEZ,
                                 Figure::kEB, Figure::kETTP};
  // Where the limits come from, shown with every verdict; empty = the
  // thesis' action limits when the numbers are the defaults, else
  // "given limits".
  std::string basis;

  bool IsValid(std::string* error) const;  // names the field
  void Validate() const;  // throws InputError naming the option
  double For(Figure f) const {
    return IsAngular(f) ? angular_um_per_m : linear_um;
  }
  bool Grades(Figure f) const;
  // "5 um linear, 15 um/m angular (the thesis' action limits, 7.2.1)".
  std::string Describe() const;
};

// Parses "E_X,E_Y,..." (case-insensitive), "thesis" (the default set) or
// "all" (with E_C). Throws InputError("--figures", ...) when unknown.
std::vector<Figure> ParseFigureList(const std::string& text);

// Per value: pass / fail / undecidable by the rule; missing = the feature
// was not measured; not_decidable = the figure is left out of the verdict
// (see FigureGrade::reason).
enum class Verdict { kPass, kFail, kUndecidable, kMissing, kNotDecidable };
constexpr int kVerdictCount = 5;
// "pass", "fail", "undecidable", "missing", "not_decidable"
const char* VerdictName(Verdict v);

struct GradedValue {
  int cycle = 0;
  Figure figure = Figure::kEX;
  double value = 0, u = 0,
         limit = 0;  // um or um/m; U expanded (k = 2); NaN = none
  Verdict verdict = Verdict::kMissing;
};

// The figure over all cycles.
struct FigureGrade {
  Figure figure = Figure::kEX;
  double limit = 0;
  bool decided = false;  // counted in the overall verdict
  std::string reason;    // why not decided (empty when decided)
  Verdict verdict = Verdict::kNotDecidable;  // fail / pass / undecidable
  double max_u = 0;  // largest U over the cycles (NaN = none)
};

// What the instrument behind the figures can measure.
struct Capability {
  bool angles = true;      // facet angles (E_B, E_C)
  std::string instrument;  // "dial gauge", ... for the reason text
};
Capability CapabilityOf(MeasurementKind kind);

struct GradeResult {
  std::vector<GradedValue> values;   // graded figures, cycle by cycle
  std::vector<FigureGrade> figures;  // one per figure of kAllFigures
  // fail if any value of a decided figure fails; pass if every value of the
  // decided figures passes (and at least one figure is decided); else
  // undecidable (a value within U of its limit, or missing).
  Verdict overall = Verdict::kUndecidable;
  int counts[kVerdictCount] = {0, 0, 0, 0, 0};  // by Verdict, over values
  GradeLimits limits;
  std::vector<Figure> DecidedOn() const;
  // "FAIL on E_X, E_Y, E_Z, E_TTP: 3 of 40 values fail; not decided: E_B
  // (U up to 16.3 um/m at or above the limit 15 um/m), E_C (not requested)".
  std::string Summary() const;
};

Verdict Decide(double value, double u, double limit);

// Grades figures (and E_C from extras, when requested) measured by an
// instrument with `capability`.
GradeResult GradeFigures(const std::vector<CycleFigures>& figures,
                         const std::vector<CycleExtras>& extras,
                         const Capability& capability,
                         const GradeLimits& limits);
// The measurement's figures with the capability of its kind.
GradeResult GradeMeasurement(const Measurement& m, const GradeLimits& limits);

// The same on an inspection JSON document (`ttp inspect --json`: its
// "figures" with U, and "kind" for the capability). Throws
// InputError(source, 0, field, problem) on a malformed document.
GradeResult GradeFigures(const nlohmann::json& inspection,
                         const GradeLimits& limits, const std::string& source);

// schemas/grade.schema.json
nlohmann::json GradeToJson(const GradeResult& result);
// Same; `limits` must be the result's own (kept for callers that pass it).
nlohmann::json GradeToJson(const GradeResult& result,
                           const GradeLimits& limits);
// Summary first; the per-value table with verbose.
std::string GradeTable(const GradeResult& result, bool verbose = true);

}  // namespace ttp::inspect
