#include "ttp/models/time_series.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>
#include <regex>
#include <set>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/limits.h"

namespace ttp::models {
namespace {

enum class ColumnKind { kTime, kInput, kOutput, kIgnored };

ColumnKind KindOf(const std::string& name) {
  if (name == "t_s") return ColumnKind::kTime;
  if (name.rfind("n_", 0) == 0 || name.rfind("T_", 0) == 0)
    return ColumnKind::kInput;
  if (name.rfind("d_", 0) == 0) return ColumnKind::kOutput;
  return ColumnKind::kIgnored;
}

std::vector<std::string> SplitLine(std::string_view line) {
  std::vector<std::string> cells;
  size_t begin = 0;
  while (true) {
    const size_t comma = line.find(',', begin);
    const std::string_view cell = line.substr(
        begin, comma == std::string_view::npos ? std::string_view::npos
                                               : comma - begin);
    cells.push_back(Trim(std::string(cell)));
    if (comma == std::string_view::npos) break;
    begin = comma + 1;
  }
  return cells;
}

struct Column {
  int position = 0;
  ColumnKind kind = ColumnKind::kIgnored;
  int slot = -1;  // index among inputs or outputs
};

// Marks steps longer than kGapPeriods median steps; `lines` are the file
// lines of the rows (empty: name the row's t_s instead).
void FindGaps(TimeSeries& ts, const std::vector<int>& lines) {
  if (ts.rows() < 3) return;
  const double median = MedianStepS(ts);
  for (size_t i = 1; i < ts.rows(); ++i) {
    const double step = ts.t_s[i] - ts.t_s[i - 1];
    if (step > kGapPeriods * median) {
      ts.gap_rows.push_back(i);
      ts.warnings.push_back(fmt::format(
          "{}:{}: t_s: gap of {:g} s from t_s = {:g} to {:g} ({:.0f} sampling "
          "periods of {:g} s); models restart after it",
          ts.source, lines.empty() ? 0 : lines[i], step, ts.t_s[i - 1],
          ts.t_s[i], step / median, median));
    }
  }
}

}  // namespace

double MedianStepS(const TimeSeries& ts) {
  if (ts.rows() < 2) return 0;
  std::vector<double> steps(ts.rows() - 1);
  for (size_t i = 1; i < ts.rows(); ++i)
    steps[i - 1] = ts.t_s[i] - ts.t_s[i - 1];
  const auto mid =
      steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), mid, steps.end());
  return *mid;
}

int TimeSeries::InputIndex(std::string_view name) const {
  for (size_t i = 0; i < input_names.size(); ++i)
    if (input_names[i] == name) return static_cast<int>(i);
  return -1;
}

int TimeSeries::OutputIndex(std::string_view name) const {
  for (size_t i = 0; i < output_names.size(); ++i)
    if (output_names[i] == name) return static_cast<int>(i);
  return -1;
}

TimeSeries ParseThermalLog(std::string_view text, const std::string& source) {
  TimeSeries ts;
  ts.source = source;
  static const std::regex key_value(R"(^#\s*([A-Za-z0-9_.-]+)\s*:\s*(.*)$)");

  std::vector<Column> columns;
  std::vector<std::string> names;
  int header_line = 0;
  int time_position = -1;
  std::vector<std::vector<double>> in_rows, out_rows;
  std::vector<int> lines;
  double last_t = -std::numeric_limits<double>::infinity();

  int line_no = 0;
  size_t pos = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") pos = 3;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string line(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (Trim(line).empty()) {
      if (nl == text.size()) break;
      continue;
    }
    if (line[0] == '#') {
      if (header_line != 0) {
        throw InputError(source, line_no, "#",
                         "comment line after the header row (comments are "
                         "allowed only before it)");
      }
      std::smatch m;
      if (std::regex_match(line, m, key_value)) ts.header[m[1]] = Trim(m[2]);
      continue;
    }
    if (header_line == 0) {
      header_line = line_no;
      // Required header keys, checked once the header block is complete.
      auto version = ts.header.find("thermal-log");
      if (version == ts.header.end()) {
        throw InputError(source, line_no, "# thermal-log",
                         "required header key is missing (a thermal log "
                         "starts with `# thermal-log: 1`)");
      }
      if (version->second != "1") {
        throw InputError(source, line_no, "# thermal-log",
                         fmt::format("version '{}' is not supported (only 1)",
                                     version->second));
      }
      auto start = ts.header.find("start");
      if (start == ts.header.end()) {
        throw InputError(source, line_no, "# start",
                         "required header key is missing (ISO 8601 date-time "
                         "with offset of t_s = 0)");
      }
      if (const std::string why = Iso8601Problem(start->second); !why.empty()) {
        throw InputError(source, line_no, "# start",
                         fmt::format("'{}': {}", start->second, why));
      }
      names = SplitLine(line);
      std::set<std::string> seen;
      for (int i = 0; i < static_cast<int>(names.size()); ++i) {
        const std::string& name = names[i];
        if (name.empty())
          throw InputError(source, line_no, fmt::format("column {}", i + 1),
                           "empty column name");
        if (!seen.insert(name).second)
          throw InputError(source, line_no, name, "column named twice");
        Column c;
        c.position = i;
        c.kind = KindOf(name);
        if (c.kind == ColumnKind::kTime) time_position = i;
        if (c.kind == ColumnKind::kInput) {
          c.slot = static_cast<int>(ts.input_names.size());
          ts.input_names.push_back(name);
        } else if (c.kind == ColumnKind::kOutput) {
          c.slot = static_cast<int>(ts.output_names.size());
          ts.output_names.push_back(name);
        }
        columns.push_back(c);
      }
      if (time_position < 0)
        throw InputError(source, line_no, "t_s",
                         "required column is missing from the header" +
                             SeparatorHint(names));
      if (ts.input_names.empty())
        throw InputError(source, line_no, "n_* / T_*",
                         "no input column (a speed n_<name> or a temperature "
                         "T_<name>)");
      continue;
    }
    const std::vector<std::string> cells = SplitLine(line);
    if (cells.size() != names.size()) {
      throw InputError(source, line_no, "",
                       fmt::format("{} cells where the header has {} columns",
                                   cells.size(), names.size()));
    }
    std::vector<double> in(ts.input_names.size()), out(ts.output_names.size());
    double t = 0;
    // Values far beyond any machine's are refused with the limit named
    // (1e300 is finite, and a fit on it gives a model of 1e301 um that
    // reports zero error).
    auto bounded = [&](double v, double limit, const char* unit,
                       const std::string& name) {
      if (std::abs(v) > limit)
        throw InputError(
            source, line_no, name,
            fmt::format("{:g} is beyond the limit of {:g} {}", v, limit, unit));
      return v;
    };
    for (const Column& c : columns) {
      const std::string& cell = cells[c.position];
      const std::string& name = names[c.position];
      switch (c.kind) {
        case ColumnKind::kTime:
          if (cell.empty())
            throw InputError(source, line_no, name, "empty time cell");
          t = bounded(ParseFiniteNumber(cell, source, line_no, name),
                      limits::kMaxLogTimeS, "s", name);
          break;
        case ColumnKind::kInput:
          if (cell.empty())
            throw InputError(source, line_no, name,
                             "empty input cell (speeds and temperatures are "
                             "required in every row)");
          {
            const bool temperature = name.rfind("T_", 0) == 0;
            in[c.slot] = bounded(ParseFiniteNumber(cell, source, line_no, name),
                                 temperature ? limits::kMaxTemperatureC
                                             : limits::kMaxSpeedPerMin,
                                 temperature ? "degC" : "1/min", name);
            if (temperature && in[c.slot] < limits::kAbsoluteZeroC)
              throw InputError(
                  source, line_no, name,
                  fmt::format("{:g} degC is below absolute zero", in[c.slot]));
            break;
          }
        case ColumnKind::kOutput:
          out[c.slot] =
              cell.empty()
                  ? kNaN
                  : bounded(ParseFiniteNumber(cell, source, line_no, name),
                            limits::kMaxDisplacementUm, "um", name);
          break;
        case ColumnKind::kIgnored:
          break;
      }
    }
    if (!(t > last_t)) {
      throw InputError(
          source, line_no, "t_s",
          fmt::format("time {:g} s does not increase (previous row: {:g} s)", t,
                      last_t));
    }
    last_t = t;
    ts.t_s.push_back(t);
    in_rows.push_back(std::move(in));
    out_rows.push_back(std::move(out));
    lines.push_back(line_no);
  }
  if (header_line == 0)
    throw InputError(source, line_no, "t_s",
                     "no header row (required column t_s is missing)");
  if (ts.t_s.empty())
    throw InputError(source, header_line, "", "no data rows after the header");

  const Eigen::Index n = static_cast<Eigen::Index>(ts.rows());
  ts.inputs.resize(n, static_cast<Eigen::Index>(ts.input_names.size()));
  ts.outputs_um.resize(n, static_cast<Eigen::Index>(ts.output_names.size()));
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < ts.inputs.cols(); ++j)
      ts.inputs(i, j) = in_rows[i][j];
    for (Eigen::Index j = 0; j < ts.outputs_um.cols(); ++j)
      ts.outputs_um(i, j) = out_rows[i][j];
  }
  FindGaps(ts, lines);
  return ts;
}

void FindGapRows(TimeSeries& ts) {
  ts.gap_rows.clear();
  FindGaps(ts, {});
}

TimeSeries ReadThermalLog(const std::filesystem::path& path) {
  const std::string text = ReadTextFile(path);
  return ParseThermalLog(text, path.string());
}

namespace {

const std::regex& Iso8601Form() {
  static const std::regex form(
      R"(^(\d{4})-(\d{2})-(\d{2})T(\d{2}):(\d{2})(:(\d{2}(\.\d+)?))?)"
      R"((Z|([+-])(\d{2}):?(\d{2}))$)");
  return form;
}

bool IsLeapYear(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

// Matches `text` against the form into `m` and checks its fields: why it is
// no ISO 8601 date-time with offset naming a real moment, or "".
std::string MatchIso8601(const std::string& text, std::smatch& m) {
  if (!std::regex_match(text, m, Iso8601Form()))
    return "not an ISO 8601 date-time with offset";
  const int year = std::stoi(m[1]), month = std::stoi(m[2]),
            day = std::stoi(m[3]);
  static const int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  if (month < 1 || month > 12)
    return fmt::format("month {} does not exist", month);
  const int days = kDays[month - 1] + (month == 2 && IsLeapYear(year));
  if (day < 1 || day > days)
    return fmt::format("day {} does not exist in {:04d}-{:02d}", day, year,
                       month);
  if (std::stoi(m[4]) > 23 || std::stoi(m[5]) > 59 ||
      (m[7].matched && std::stod(m[7]) >= 61))
    return "not a time of day";
  if (m[10].matched) {
    const int oh = std::stoi(m[11]), om = std::stoi(m[12]);
    const bool minus = m[10] == "-";
    if (om > 59 || oh > 14 || (minus && oh > 12) || (oh == 14 && om > 0) ||
        (oh == 12 && minus && om > 0))
      return "UTC offset " + text.substr(static_cast<size_t>(m.position(9))) +
             " does not exist (-12:00..+14:00)";
  }
  return "";
}

}  // namespace

std::string Iso8601Problem(const std::string& text) {
  std::smatch m;
  return MatchIso8601(text, m);
}

std::optional<double> Iso8601EpochS(const std::string& text) {
  std::smatch m;
  if (!MatchIso8601(text, m).empty()) return std::nullopt;
  const int year = std::stoi(m[1]), month = std::stoi(m[2]),
            day = std::stoi(m[3]);
  // Days since 1970-01-01 of a proleptic Gregorian date (the civil-date
  // algorithm: years start in March so that the leap day comes last).
  const int y = year - (month <= 2);
  const int era = (y >= 0 ? y : y - 399) / 400;
  const int yoe = y - era * 400;
  const int doy = (153 * (month + (month > 2 ? -3 : 9)) + 2) / 5 + day - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  const double days = static_cast<double>(era) * 146097 + doe - 719468;
  double seconds = days * 86400 + std::stoi(m[4]) * 3600.0 +
                   std::stoi(m[5]) * 60.0 +
                   (m[7].matched ? std::stod(m[7]) : 0.0);
  if (m[10].matched) {
    const double offset = std::stoi(m[11]) * 3600.0 + std::stoi(m[12]) * 60.0;
    seconds += m[10] == "+" ? -offset : offset;
  }
  return seconds;
}

std::optional<double> StartEpochS(const TimeSeries& ts) {
  const auto it = ts.header.find("start");
  if (it == ts.header.end()) return std::nullopt;
  return Iso8601EpochS(it->second);
}

}  // namespace ttp::models
