// Reader of the controller's TALC log (talc-log.md, format v1). Strict rules
// throw ttp::InputError (file, line, column or rule); lenient ones become
// warnings in the result. Inside: seconds, mm and rad; the R-test and pred_
// values are converted from um and um/m on reading.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "ttp/geometry/features.h"
#include "ttp/geometry/rigid_table.h"

namespace ttp::thermal {

enum class LogEvent { kSample, kRTest, kCut, kPhase, kUpdate, kNote };

// Numeric columns the reader knows; a row stores NaN where a cell is empty.
enum NumericColumn : int {
  kTEnv = 0,
  kTWs,
  kTMwf,
  kDTCool,
  kCRpm,
  kSpindleRpm,
  kMwf,
  kEX0C,  // kEX0C + i: the seven R-test values in log order (um, um/m)
  kPredEX0C = kEX0C + 7,  // kPredEX0C + i: the seven pred_ values
  kCDeg = kPredEX0C + 7,
  kDurS,
  kNumericColumnCount
};
extern const char* const kNumericColumnNames[kNumericColumnCount];

struct LogRow {
  int line = 0;  // 1-based line in the file
  double t_s = 0;
  LogEvent event = LogEvent::kNote;
  std::array<double, kNumericColumnCount> values;  // NaN = not given
  std::string phase, feature, text;

  bool Has(NumericColumn c) const { return !std::isnan(values[c]); }
};

struct RTestRecord {
  int line = 0;
  double t_end_s = 0;    // the row's t_s: the measurement cycle ended here
  double t_ref_s = 0;    // t_s - dur_s/2: the time its values describe
  CAxisErrors measured;  // as logged (residual if comp. on)
  std::optional<CAxisErrors> pred;  // pred_ given in the same row
};

struct CutRecord {
  int line = 0;
  double t_s = 0;  // end of the cut
  FeatureId feature;  // a test feature (facet or strip); named in the log
  double c_rad = 0;  // commanded table angle during the cut
};

struct PhaseRecord {
  int line = 0;
  double t_s = 0;
  std::string phase;  // CP, POST or NG
};

struct LogWarning {
  int line = 0;
  std::string rule;  // "duplicate", "gap", "unknown event", ...
  std::string message;
};

struct LogGap {
  int line = 0;  // line of the row after the gap
  double from_s = 0, to_s = 0;
};

struct TalcLog {
  std::string source;
  std::map<std::string, std::string> header;  // every `# key: value`
  int version = 1;
  std::string start;  // ISO 8601 with offset
  std::string machine;
  double sphere_distance_mm = 160.0;
  std::optional<double> sphere_height_mm;
  bool compensation = false;
  std::vector<std::string> columns;          // header row as written
  std::vector<std::string> unknown_columns;  // kept names, values ignored
  bool has_pred_columns = false;
  std::vector<LogRow> rows;  // accepted rows, in file order
  std::vector<RTestRecord> rtests;
  std::vector<CutRecord> cuts;
  std::vector<PhaseRecord> phases;
  std::vector<LogGap> gaps;
  std::vector<LogWarning> warnings;

  int CountEvent(LogEvent e) const;
  double FirstTimeS() const { return rows.empty() ? 0 : rows.front().t_s; }
  double LastTimeS() const { return rows.empty() ? 0 : rows.back().t_s; }
};

constexpr double kMaxGapS = 600.0;  // talc-log.md section 4

// Parses log text; `source` names it in errors.
TalcLog ParseTalcLog(const std::string& text, const std::string& source);
TalcLog ReadTalcLog(const std::string& path);

// Summary (span, samples, R-tests, cuts, gaps, compensation, warnings).
nlohmann::json LogSummaryJson(const TalcLog& log);
std::string LogSummaryText(const TalcLog& log);

}  // namespace ttp::thermal
