// A thermal test log as a time series: inputs (speeds, temperatures) at every
// sample, outputs (displacements at the tool) where they were measured.
// ../shared/spec/thermal-log.md is the file format; TALC logs are converted
// into the same model (thermal::TalcLogToTimeSeries).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace ttp::models {

// thermal-log.md section 2: a step longer than this many sampling periods
// (the median step) is a gap.
inline constexpr double kGapPeriods = 10.0;

struct TimeSeries {
  std::string source;                         // file name, for messages
  std::map<std::string, std::string> header;  // `# key: value` lines
  std::vector<double> t_s;                    // strictly increasing
  std::vector<std::string> input_names;   // n_* and T_* columns, in file order
  Eigen::MatrixXd inputs;                 // rows: samples; cols: input_names
  std::vector<std::string> output_names;  // d_* columns, in file order
  Eigen::MatrixXd outputs_um;             // NaN where not measured
  // Rows i with t_s[i] - t_s[i-1] larger than kGapPeriods sampling periods
  // (the median step): a model restarts there instead of bridging the gap.
  std::vector<std::size_t> gap_rows;
  std::vector<std::string> warnings;

  std::size_t rows() const { return t_s.size(); }
  int InputIndex(std::string_view name) const;   // -1 when absent
  int OutputIndex(std::string_view name) const;  // -1 when absent
};

// Reads a thermal-log.md file; bad input throws ttp::InputError naming file,
// line and column.
TimeSeries ReadThermalLog(const std::filesystem::path& path);
TimeSeries ParseThermalLog(std::string_view text, const std::string& source);

// Why `text` is not an ISO 8601 date-time with offset as thermal-log.md
// and talc-log.md require it (YYYY-MM-DDTHH:MM[:SS[.s]] and Z or +-HH[:]MM:
// a real calendar day, a time of day, a UTC offset within -12:00..+14:00);
// empty when it is one.
std::string Iso8601Problem(const std::string& text);

// The log's `start` header (thermal-log.md: ISO 8601 date-time with offset
// of t_s = 0) as seconds since 1970-01-01T00:00:00Z; nullopt when the
// header is absent or not such a date-time (Iso8601Problem). Two logs of one
// test continue each other in this time, whatever their t_s.
std::optional<double> StartEpochS(const TimeSeries& ts);
std::optional<double> Iso8601EpochS(const std::string& text);

// The sampling period: the upper median of the steps between rows (of two
// middle values, the larger); 0 for fewer than two rows.
double MedianStepS(const TimeSeries& ts);

// Recomputes gap_rows (and adds a warning per gap) from t_s by the rule
// above; for series built by other readers.
void FindGapRows(TimeSeries& ts);

}  // namespace ttp::models
