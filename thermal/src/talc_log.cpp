#include "ttp/thermal/talc_log.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <unordered_set>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/limits.h"
#include "ttp/models/time_series.h"

namespace ttp::thermal {

const char* const kNumericColumnNames[kNumericColumnCount] = {
    "T_env",       "T_ws",      "T_mwf",     "dT_cool",   "c_rpm",
    "spindle_rpm", "mwf",       "EX0C",      "EY0C",      "EZ0T",
    "ER0T",        "EA0C",      "EB0C",      "EC0C",      "pred_EX0C",
    "pred_EY0C",   "pred_EZ0T", "pred_ER0T", "pred_EA0C", "pred_EB0C",
    "pred_EC0C",   "c_deg",     "dur_s"};

namespace {

const std::pair<const char*, LogEvent> kEvents[] = {
    {"sample", LogEvent::kSample}, {"rtest", LogEvent::kRTest},
    {"cut", LogEvent::kCut},       {"phase", LogEvent::kPhase},
    {"update", LogEvent::kUpdate}, {"note", LogEvent::kNote}};

// Splits a CSV line; double quotes allow commas inside `text`.
std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char ch = line[i];
    if (quoted) {
      if (ch == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        cell += '"';
        ++i;
      } else if (ch == '"') {
        quoted = false;
      } else {
        cell += ch;
      }
    } else if (ch == '"') {
      quoted = true;
    } else if (ch == ',') {
      cells.push_back(Trim(cell));
      cell.clear();
    } else {
      cell += ch;
    }
  }
  cells.push_back(Trim(cell));
  return cells;
}

CAxisErrors ErrorsFrom(const LogRow& row, int first_column) {
  std::array<double, 7> micro;
  for (int i = 0; i < 7; ++i) micro[i] = row.values[first_column + i];
  return CAxisErrors::FromMicro(micro);
}

bool HasAll(const LogRow& row, int first_column) {
  for (int i = 0; i < 7; ++i) {
    if (std::isnan(row.values[first_column + i])) return false;
  }
  return true;
}

// Values far beyond any machine's: refused with the limit named (1e300
// would pass as finite and overflow every figure computed from it).
void CheckMagnitude(int column, double v, const std::string& source, int line) {
  double limit = 0;
  const char* unit = "";
  if (column >= kEX0C && column < kPredEX0C + 7) {
    limit = limits::kMaxRTestValueMicro;
    unit = "um or um/m";
  } else if (column == kTEnv || column == kTWs || column == kTMwf ||
             column == kDTCool) {
    limit = limits::kMaxTemperatureC;
    unit = "degC or K";
  } else if (column == kDurS) {
    limit = limits::kMaxLogSpanS;
    unit = "s";
  } else if (column == kCDeg) {
    limit = 1e6;
    unit = "deg";
  } else {
    limit = 1e9;  // speeds and flows
  }
  if (std::abs(v) > limit) {
    throw InputError(
        source, line, kNumericColumnNames[column],
        fmt::format("{:g} is beyond the limit of {:g} {}", v, limit, unit));
  }
  // A temperature (not dT_cool, a difference) below absolute zero.
  if ((column == kTEnv || column == kTWs || column == kTMwf) &&
      v < limits::kAbsoluteZeroC) {
    throw InputError(source, line, kNumericColumnNames[column],
                     fmt::format("{:g} degC is below absolute zero", v));
  }
}

}  // namespace

int TalcLog::CountEvent(LogEvent e) const {
  int n = 0;
  for (const auto& r : rows) n += r.event == e;
  return n;
}

TalcLog ParseTalcLog(const std::string& text, const std::string& source) {
  TalcLog log;
  log.source = source;
  std::istringstream in(text);
  std::string raw;
  int line_no = 0;
  bool header_seen = false;
  int header_line = 0;
  // Column index of every known field, -1 if absent.
  std::array<int, kNumericColumnCount> numeric_index;
  numeric_index.fill(-1);
  int t_index = -1, event_index = -1, phase_index = -1, feature_index = -1,
      text_index = -1;
  double last_t = -std::numeric_limits<double>::infinity();
  int last_line = 0;
  std::unordered_set<std::string> lines_at_last_t;  // exact-duplicate check
  std::map<std::string, int> header_lines;  // key -> line of `# key: value`
  static const std::regex key_value(R"(^#\s*([A-Za-z0-9_.-]+)\s*:\s*(.*)$)");

  while (std::getline(in, raw)) {
    ++line_no;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();
    if (line_no == 1 && raw.rfind("\xEF\xBB\xBF", 0) == 0) raw.erase(0, 3);
    if (Trim(raw).empty()) continue;  // blank lines carry nothing
    if (raw[0] == '#') {
      if (header_seen) {
        throw InputError(source, line_no, "#",
                         "comment line after the header row (comments are "
                         "allowed only before it)");
      }
      std::smatch m;
      if (std::regex_match(raw, m, key_value)) {
        const std::string key = m[1];
        if (auto [it, fresh] = header_lines.emplace(key, line_no); !fresh) {
          throw InputError(source, line_no, key,
                           fmt::format("header key given twice (first on "
                                       "line {})",
                                       it->second));
        }
        log.header[key] = Trim(m[2]);
      }
      continue;
    }
    if (!header_seen) {
      header_seen = true;
      header_line = line_no;
      log.columns = SplitCsv(raw);
      std::set<std::string> seen;
      for (int i = 0; i < static_cast<int>(log.columns.size()); ++i) {
        const std::string& name = log.columns[i];
        if (!seen.insert(name).second) {
          throw InputError(source, line_no, name, "column named twice");
        }
        bool known = true;
        if (name == "t_s") {
          t_index = i;
        } else if (name == "event") {
          event_index = i;
        } else if (name == "phase") {
          phase_index = i;
        } else if (name == "feature") {
          feature_index = i;
        } else if (name == "text") {
          text_index = i;
        } else {
          known = false;
          for (int c = 0; c < kNumericColumnCount; ++c) {
            if (name == kNumericColumnNames[c]) {
              numeric_index[c] = i;
              known = true;
              if (c >= kPredEX0C && c < kPredEX0C + 7) {
                log.has_pred_columns = true;
              }
            }
          }
        }
        if (!known) log.unknown_columns.push_back(name);
      }
      if (t_index < 0) {
        throw InputError(
            source, line_no, "t_s",
            "missing required column 't_s'" + SeparatorHint(log.columns) +
                (header_lines.count("talc-log")
                     ? ""
                     : " (and no `# talc-log: 1` line before the header row: "
                       "not a TALC log, talc-log.md)"));
      }
      if (event_index < 0) {
        throw InputError(source, line_no, "event",
                         "missing required column 'event'");
      }
      continue;
    }

    const std::vector<std::string> cells = SplitCsv(raw);
    if (cells.size() != log.columns.size()) {
      throw InputError(source, line_no, "row",
                       fmt::format("{} cells, the header has {} columns",
                                   cells.size(), log.columns.size()));
    }
    LogRow row;
    row.line = line_no;
    row.values.fill(kNaN);
    if (cells[t_index].empty()) {
      throw InputError(source, line_no, "t_s", "t_s is required in every row");
    }
    row.t_s = ParseFiniteNumber(cells[t_index], source, line_no, "t_s");
    if (std::abs(row.t_s) > limits::kMaxLogTimeS) {
      throw InputError(source, line_no, "t_s",
                       fmt::format("{} s is beyond the limit of {:g} s",
                                   cells[t_index], limits::kMaxLogTimeS));
    }
    if (!log.rows.empty() &&
        row.t_s - log.rows.front().t_s > limits::kMaxLogSpanS) {
      throw InputError(
          source, line_no, "t_s",
          fmt::format("the log would span {:g} s from its first row (line "
                      "{}), beyond the limit of {:g} s ({:g} days)",
                      row.t_s - log.rows.front().t_s, log.rows.front().line,
                      limits::kMaxLogSpanS, limits::kMaxLogSpanS / 86400));
    }
    if (static_cast<std::int64_t>(log.rows.size()) >= limits::kMaxLogRows) {
      throw InputError(source, line_no, "row",
                       fmt::format("more than {} rows is beyond the limit",
                                   limits::kMaxLogRows));
    }
    for (int c = 0; c < kNumericColumnCount; ++c) {
      const int i = numeric_index[c];
      if (i >= 0 && !cells[i].empty()) {
        row.values[c] = ParseFiniteNumber(cells[i], source, line_no,
                                          kNumericColumnNames[c]);
        CheckMagnitude(c, row.values[c], source, line_no);
      }
    }
    if (phase_index >= 0) row.phase = cells[phase_index];
    if (feature_index >= 0) row.feature = cells[feature_index];
    if (text_index >= 0) row.text = cells[text_index];

    // Order and duplicates come before the row's meaning.
    if (row.t_s < last_t) {
      throw InputError(
          source, line_no, "t_s",
          fmt::format("rows out of order in time: t_s {} after {} (line {})",
                      cells[t_index], last_t, last_line));
    }
    if (row.t_s == last_t) {
      if (!lines_at_last_t.insert(raw).second) {
        log.warnings.push_back(
            {line_no, "duplicate", "exact duplicate row dropped"});
        continue;
      }
    } else {
      lines_at_last_t.clear();
      lines_at_last_t.insert(raw);
    }
    if (!log.rows.empty() && row.t_s - last_t > kMaxGapS) {
      log.gaps.push_back({line_no, last_t, row.t_s});
      log.warnings.push_back(
          {line_no, "gap",
           fmt::format("gap of {:.0f} s between rows (t_s {} to {}), more "
                       "than {:.0f} s",
                       row.t_s - last_t, last_t, row.t_s, kMaxGapS)});
    }
    last_t = row.t_s;
    last_line = line_no;

    const std::string event = cells[event_index];
    if (event.empty()) {
      throw InputError(source, line_no, "event",
                       "event is required in every row");
    }
    bool known_event = false;
    for (const auto& [name, ev] : kEvents) {
      if (event == name) {
        row.event = ev;
        known_event = true;
      }
    }
    if (!known_event) {
      row.event = LogEvent::kNote;
      if (!row.text.empty()) row.text += " ";
      row.text += fmt::format("[unknown event '{}']", event);
      log.warnings.push_back(
          {line_no, "unknown event",
           fmt::format("unknown event '{}' kept as a note", event)});
    }

    switch (row.event) {
      case LogEvent::kRTest: {
        for (int i = 0; i < 7; ++i) {
          if (!row.Has(static_cast<NumericColumn>(kEX0C + i))) {
            throw InputError(source, line_no, kNumericColumnNames[kEX0C + i],
                             "rtest row without its R-test value");
          }
        }
        RTestRecord r;
        r.line = line_no;
        r.t_end_s = row.t_s;
        double dur = row.Has(kDurS) ? row.values[kDurS] : 0.0;
        if (dur < 0) {
          throw InputError(source, line_no, "dur_s", "negative duration");
        }
        if (!row.Has(kDurS)) {
          log.warnings.push_back(
              {line_no, "rtest duration",
               "rtest row without dur_s: values taken at the row's t_s"});
        }
        r.t_ref_s = row.t_s - dur / 2;
        // One measuring cycle at a time: an R-test that does not describe
        // the machine after the previous one contradicts it (exact
        // duplicate rows were dropped above).
        if (!log.rtests.empty() && r.t_ref_s <= log.rtests.back().t_ref_s) {
          throw InputError(
              source, line_no, "t_s",
              fmt::format("R-test describing the machine at {:g} s (t_s - "
                          "dur_s/2), not after the previous one of line {} "
                          "({:g} s): two measuring cycles overlap",
                          r.t_ref_s, log.rtests.back().line,
                          log.rtests.back().t_ref_s));
        }
        r.measured = ErrorsFrom(row, kEX0C);
        if (HasAll(row, kPredEX0C)) r.pred = ErrorsFrom(row, kPredEX0C);
        log.rtests.push_back(r);
        break;
      }
      case LogEvent::kCut: {
        if (row.feature.empty()) {
          throw InputError(source, line_no, "feature",
                           "cut row without a feature name");
        }
        const std::optional<FeatureId> feature = FeatureId::Parse(row.feature);
        if (!feature || !feature->IsTestFeature()) {
          throw InputError(
              source, line_no, "feature",
              fmt::format("'{}' is not a feature name (Z1..Z9, X1-1..Y2-9)",
                          row.feature));
        }
        if (!row.Has(kCDeg)) {
          throw InputError(source, line_no, "c_deg",
                           "cut row without its table angle c_deg");
        }
        for (const auto& c : log.cuts) {
          if (c.feature == *feature) {
            throw InputError(source, line_no, "feature",
                             fmt::format("feature {} cut twice (first on "
                                         "line {})",
                                         row.feature, c.line));
          }
        }
        log.cuts.push_back(
            {line_no, row.t_s, *feature, row.values[kCDeg] * kDeg});
        break;
      }
      case LogEvent::kPhase: {
        if (row.phase != "CP" && row.phase != "POST" && row.phase != "NG") {
          throw InputError(
              source, line_no, "phase",
              fmt::format("phase '{}' is not CP, POST or NG", row.phase));
        }
        log.phases.push_back({line_no, row.t_s, row.phase});
        break;
      }
      default:
        break;
    }
    log.rows.push_back(std::move(row));
  }

  // Header keys (checked after reading so a missing key names the header).
  const int key_line = header_seen ? header_line : std::max(line_no, 1);
  for (const char* key : {"talc-log", "start", "compensation"}) {
    if (!log.header.count(key)) {
      throw InputError(source, key_line, key,
                       fmt::format("missing required header key '# {}:'", key));
    }
  }
  if (!header_seen) {
    throw InputError(source, key_line, "header", "no header row");
  }
  const auto key_line_of = [&](const char* key) {
    auto it = header_lines.find(key);
    return it == header_lines.end() ? 1 : it->second;
  };
  if (log.header["talc-log"] != "1") {
    throw InputError(
        source, key_line_of("talc-log"), "talc-log",
        fmt::format("format version '{}' is not 1", log.header["talc-log"]));
  }
  log.start = log.header["start"];
  if (const std::string why = models::Iso8601Problem(log.start); !why.empty()) {
    throw InputError(source, key_line_of("start"), "start",
                     fmt::format("'{}': {}", log.start, why));
  }
  const std::string comp = log.header["compensation"];
  if (comp != "on" && comp != "off") {
    throw InputError(source, key_line_of("compensation"), "compensation",
                     fmt::format("'{}' is not on or off", comp));
  }
  log.compensation = comp == "on";
  if (log.header.count("machine")) log.machine = log.header["machine"];
  if (log.header.count("sphere_distance_mm")) {
    const int line = key_line_of("sphere_distance_mm");
    log.sphere_distance_mm = ParseFiniteNumber(
        log.header["sphere_distance_mm"], source, line, "sphere_distance_mm");
    if (!(log.sphere_distance_mm >= limits::kMinSphereDistanceMm &&
          log.sphere_distance_mm <= limits::kMaxSphereDistanceMm)) {
      throw InputError(
          source, line, "sphere_distance_mm",
          fmt::format("{:g} mm is outside {:g}..{:g} mm (the R-test spheres' "
                      "distance)",
                      log.sphere_distance_mm, limits::kMinSphereDistanceMm,
                      limits::kMaxSphereDistanceMm));
    }
  }
  if (log.header.count("sphere_height_mm")) {
    const int line = key_line_of("sphere_height_mm");
    log.sphere_height_mm = ParseFiniteNumber(log.header["sphere_height_mm"],
                                             source, line, "sphere_height_mm");
    if (std::abs(*log.sphere_height_mm) > limits::kMaxSphereDistanceMm) {
      throw InputError(
          source, line, "sphere_height_mm",
          fmt::format("{:g} mm is beyond the limit of {:g} mm",
                      *log.sphere_height_mm, limits::kMaxSphereDistanceMm));
    }
  }
  return log;
}

TalcLog ReadTalcLog(const std::string& path) {
  return ParseTalcLog(ReadTextFile(path), path);  // InputError names the path
}

nlohmann::json LogSummaryJson(const TalcLog& log) {
  nlohmann::json j;
  j["source"] = log.source;
  j["start"] = log.start;
  j["machine"] = log.machine;
  j["compensation"] = log.compensation ? "on" : "off";
  j["has_predictions"] = log.has_pred_columns;
  j["span_s"] = {log.FirstTimeS(), log.LastTimeS()};
  j["rows"] = log.rows.size();
  j["samples"] = log.CountEvent(LogEvent::kSample);
  j["rtests"] = log.rtests.size();
  if (log.rtests.size() >= 2) {
    j["rtest_mean_interval_s"] =
        (log.rtests.back().t_ref_s - log.rtests.front().t_ref_s) /
        (log.rtests.size() - 1);
  }
  j["cuts"] = log.cuts.size();
  nlohmann::json cuts = nlohmann::json::array();
  for (const auto& c : log.cuts) {
    cuts.push_back({{"feature", c.feature.ToString()},
                    {"t_s", c.t_s},
                    {"c_deg", c.c_rad / kDeg}});
  }
  j["cut_list"] = cuts;
  nlohmann::json phases = nlohmann::json::array();
  for (const auto& p : log.phases) {
    phases.push_back({{"phase", p.phase}, {"t_s", p.t_s}});
  }
  j["phases"] = phases;
  nlohmann::json gaps = nlohmann::json::array();
  for (const auto& g : log.gaps) {
    gaps.push_back({{"line", g.line}, {"from_s", g.from_s}, {"to_s", g.to_s}});
  }
  j["gaps"] = gaps;
  nlohmann::json warnings = nlohmann::json::array();
  for (const auto& w : log.warnings) {
    warnings.push_back(
        {{"line", w.line}, {"rule", w.rule}, {"message", w.message}});
  }
  j["warnings"] = warnings;
  j["unknown_columns"] = log.unknown_columns;
  return j;
}

std::string LogSummaryText(const TalcLog& log) {
  std::string s;
  s += fmt::format("log           {}\n", log.source);
  s += fmt::format("start         {}\n", log.start);
  if (!log.machine.empty()) s += fmt::format("machine       {}\n", log.machine);
  s += fmt::format("span          {:.0f} .. {:.0f} s ({:.2f} h)\n",
                   log.FirstTimeS(), log.LastTimeS(),
                   (log.LastTimeS() - log.FirstTimeS()) / 3600);
  s += fmt::format("rows          {} ({} samples)\n", log.rows.size(),
                   log.CountEvent(LogEvent::kSample));
  s += fmt::format("compensation  {}{}\n", log.compensation ? "on" : "off",
                   log.has_pred_columns ? " (pred_ columns present)" : "");
  s += fmt::format("R-tests       {}", log.rtests.size());
  if (log.rtests.size() >= 2) {
    s += fmt::format(", every {:.0f} s on average",
                     (log.rtests.back().t_ref_s - log.rtests.front().t_ref_s) /
                         (log.rtests.size() - 1));
  }
  s += "\n";
  s += fmt::format("cuts          {}\n", log.cuts.size());
  for (const auto& c : log.cuts) {
    s += fmt::format("  {:>6}  t = {:7.0f} s  C = {:7.2f} deg\n",
                     c.feature.ToString(), c.t_s, c.c_rad / kDeg);
  }
  s += fmt::format("phases        {}\n", log.phases.size());
  s += fmt::format("gaps > {:.0f} s  {}\n", kMaxGapS, log.gaps.size());
  if (!log.unknown_columns.empty()) {
    s += "unknown columns (ignored):";
    for (const auto& c : log.unknown_columns) s += " " + c;
    s += "\n";
  }
  s += fmt::format("warnings      {}\n", log.warnings.size());
  for (const auto& w : log.warnings) {
    s += fmt::format("  line {}: {}: {}\n", w.line, w.rule, w.message);
  }
  return s;
}

}  // namespace ttp::thermal
