#include "ttp/thermal/time_series.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/series.h"

namespace ttp::thermal {
namespace {

struct InputColumn {
  NumericColumn column;
  const char* name;
};
constexpr InputColumn kLoggedInputs[] = {
    {kTEnv, "T_env"},           {kTWs, "T_ws"},
    {kTMwf, "T_mwf"},           {kDTCool, "T_dT_cool"},
    {kSpindleRpm, "n_spindle"}, {kCRpm, "n_c"}};

const char* const kOutputNames[7] = {
    "d_EX0C", "d_EY0C", "d_EZ0T", "d_ER0T", "d_EA0C_r", "d_EB0C_r", "d_EC0C_r"};

}  // namespace

models::TimeSeries ReadThermalOrTalcLog(const std::string& path) {
  const std::string text = ReadTextFile(path);
  const size_t start = text.rfind("\xEF\xBB\xBF", 0) == 0 ? 3 : 0;
  std::istringstream in(text.substr(start));
  std::string line;
  while (std::getline(in, line) && !line.empty() && line[0] == '#') {
    const size_t key = line.find_first_not_of("# \t");
    if (key != std::string::npos && line.compare(key, 9, "talc-log:") == 0)
      return TalcLogToTimeSeries(ParseTalcLog(text, path));
  }
  return models::ParseThermalLog(text, path);
}

models::TimeSeries TalcLogToTimeSeries(const TalcLog& log) {
  models::TimeSeries ts;
  ts.source = log.source;
  ts.header = log.header;
  ts.header["converted-from"] = "TALC log (talc-log.md)";
  const double radius_um = log.sphere_distance_mm * 1000.0;
  ts.header["angles-as-um-at-radius-mm"] =
      fmt::format("{:g}", log.sphere_distance_mm);

  // Inputs the log fills at least once.
  std::vector<InputColumn> used;
  for (const auto& c : kLoggedInputs) {
    if (std::any_of(log.rows.begin(), log.rows.end(),
                    [&](const LogRow& r) { return r.Has(c.column); }))
      used.push_back(c);
  }
  for (const auto& c : used) ts.input_names.push_back(c.name);
  for (const char* name : kOutputNames) ts.output_names.push_back(name);

  // Row times: every sample row and every R-test reference time.
  struct Row {
    double t;
    int source_row;  // index into log.rows for inputs, -1 for an R-test
    int rtest = -1;
  };
  std::vector<Row> rows;
  for (size_t i = 0; i < log.rows.size(); ++i)
    if (log.rows[i].event == LogEvent::kSample)
      rows.push_back({log.rows[i].t_s, static_cast<int>(i), -1});
  for (size_t k = 0; k < log.rtests.size(); ++k)
    rows.push_back({log.rtests[k].t_ref_s, -1, static_cast<int>(k)});
  std::stable_sort(rows.begin(), rows.end(),
                   [](const Row& a, const Row& b) { return a.t < b.t; });

  // Held input values: start from the first logged value of each column.
  std::vector<double> held(used.size(), kNaN);
  for (size_t c = 0; c < used.size(); ++c)
    for (const auto& r : log.rows)
      if (r.Has(used[c].column)) {
        held[c] = r.values[used[c].column];
        break;
      }
  // The machine's own error at an R-test: as logged with compensation
  // off; with it on, the R-test sees the residual, and the machine's error
  // is the residual plus the prediction in force (talc-log.md section 2,
  // thesis 6.4.2), linear between the rows that give all seven pred_
  // values, as the estimator takes it.
  std::vector<double> pred_t;
  std::vector<CAxisErrors> pred;
  if (log.compensation) {
    for (const auto& row : log.rows) {
      bool all = true;
      for (int i = 0; i < 7; ++i) all &= row.Has(NumericColumn(kPredEX0C + i));
      if (!all || (!pred_t.empty() && row.t_s == pred_t.back())) continue;
      std::array<double, 7> micro;
      for (int i = 0; i < 7; ++i) micro[i] = row.values[kPredEX0C + i];
      pred_t.push_back(row.t_s);
      pred.push_back(CAxisErrors::FromMicro(micro));
    }
    if (pred_t.empty() && !log.rtests.empty())
      throw InputError(log.source, 0, "pred_EX0C",
                       "compensation on but no row gives the pred_ values: "
                       "the machine's own error cannot be recovered from "
                       "the R-tests");
  }
  auto machine_error = [&](const RTestRecord& r) {
    return log.compensation ? r.measured + Interpolate(pred_t, pred, r.t_ref_s)
                            : r.measured;
  };
  std::array<double, 7> first_rtest;
  first_rtest.fill(kNaN);
  if (!log.rtests.empty()) {
    const auto v = machine_error(log.rtests.front()).AsVector();
    for (int e = 0; e < 7; ++e) first_rtest[e] = v(e);
  }

  std::vector<std::vector<double>> in_rows, out_rows;
  size_t next_log_row = 0;
  for (const Row& r : rows) {
    // Every log row up to this time updates the held inputs (causal).
    while (next_log_row < log.rows.size() &&
           log.rows[next_log_row].t_s <= r.t) {
      const LogRow& lr = log.rows[next_log_row];
      for (size_t c = 0; c < used.size(); ++c)
        if (lr.Has(used[c].column)) held[c] = lr.values[used[c].column];
      ++next_log_row;
    }
    std::vector<double> out(7, kNaN);
    if (r.rtest >= 0) {
      const auto v = machine_error(log.rtests[r.rtest]).AsVector();  // mm, rad
      for (int e = 0; e < 7; ++e) {
        const double rel = v(e) - first_rtest[e];
        out[e] = e < 4 ? rel * 1000.0 : rel * radius_um;
      }
    }
    if (!ts.t_s.empty() && r.t <= ts.t_s.back()) {
      // Same time as the previous row: merge the R-test into it.
      for (int e = 0; e < 7; ++e)
        if (std::isfinite(out[e])) out_rows.back()[e] = out[e];
      continue;
    }
    ts.t_s.push_back(r.t);
    in_rows.push_back(held);
    out_rows.push_back(out);
  }
  const Eigen::Index n = static_cast<Eigen::Index>(ts.t_s.size());
  ts.inputs.resize(n, static_cast<Eigen::Index>(used.size()));
  ts.outputs_um.resize(n, 7);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index c = 0; c < ts.inputs.cols(); ++c)
      ts.inputs(i, c) = in_rows[i][c];
    for (Eigen::Index e = 0; e < 7; ++e) ts.outputs_um(i, e) = out_rows[i][e];
  }
  models::FindGapRows(ts);
  for (const auto& w : log.warnings)
    ts.warnings.push_back(
        fmt::format("{}:{}: {}: {}", log.source, w.line, w.rule, w.message));
  return ts;
}

}  // namespace ttp::thermal
