#include "ttp/cam/schedule.h"

#include <fmt/format.h>

#include <cmath>

#include "ttp/cam/programs.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"

namespace ttp::cam {
namespace {

std::string ToolName(const Config& c, int number) {
  const ToolSpec* t = c.process.CuttingToolByNumber(number);
  return t ? t->name : "";
}

// "cut,<feature>,<deg>" -> the test feature and the angle.
bool SplitReport(const std::string& text, FeatureId* feature, double* c_deg) {
  gcode::ReportText r;
  if (!gcode::ParseReportText(text, &r) || r.event != "cut") return false;
  const std::optional<FeatureId> f = FeatureId::Parse(r.feature);
  if (!f || !f->IsTestFeature()) return false;
  *feature = *f;
  *c_deg = r.c_deg;
  return true;
}

}  // namespace

Schedule ScheduleFromCanon(const std::vector<gcode::CanonStatement>& canon,
                           const Config& config, const std::string& source) {
  Schedule schedule;
  schedule.cycle_period_s = config.process.cycle_period_s;
  schedule.total_s = gcode::TotalDuration(canon);
  const int cycles = config.part.cycles();
  schedule.cycle_start_s.assign(cycles + 1, -1.0);
  int tool = 0;
  int cycle = 0;
  const gcode::CanonStatement* last_feed = nullptr;
  const gcode::CanonStatement* last_dwell = nullptr;
  ScheduledRTest* rtest = nullptr;  // open R-test
  for (const gcode::CanonStatement& s : canon) {
    switch (s.kind) {
      case gcode::CanonKind::kToolChange:
        tool = static_cast<int>(s.value);
        break;
      case gcode::CanonKind::kFeed:
        last_feed = &s;
        break;
      case gcode::CanonKind::kDwell:
        last_dwell = &s;
        break;
      case gcode::CanonKind::kComment:
        for (int k = 0; k <= cycles; ++k)
          if (s.text == CycleCommentText(k)) {
            schedule.cycle_start_s[k] = s.start_s;
            cycle = k;
          }
        if (s.text ==
            RTestCommentText(static_cast<int>(schedule.rtests.size()))) {
          schedule.rtests.emplace_back();
          rtest = &schedule.rtests.back();
          rtest->number = static_cast<int>(schedule.rtests.size()) - 1;
          rtest->after_cycle = cycle;
          rtest->start_s = s.start_s;
        } else if (rtest && s.text == RTestDoneCommentText(rtest->number)) {
          rtest->end_s = s.start_s;
          if (rtest->positions.size() != kRTestPositions)
            throw InputError(
                source, s.source_line, "report",
                fmt::format("R-test {} reports {} positions, not {}",
                            rtest->number, rtest->positions.size(),
                            kRTestPositions));
          rtest->log_t_s = rtest->positions.back().report_s;
          rtest->dur_s = rtest->log_t_s - rtest->positions.front().measure_s;
          rtest = nullptr;
        }
        break;
      case gcode::CanonKind::kReport: {
        gcode::ReportText r;
        if (gcode::ParseReportText(s.text, &r) && r.event == "rtest") {
          int n = 0, k = 0;
          if (!rtest || !ParseRTestPositionFeature(r.feature, &n, &k) ||
              n != rtest->number ||
              k != static_cast<int>(rtest->positions.size()) + 1 || !last_dwell)
            throw InputError(
                source, s.source_line, "report",
                "R-test report out of its R-test's order: " + s.text);
          ScheduledRTestPosition p;
          p.position = k;
          p.c_deg = r.c_deg;
          p.measure_s = last_dwell->start_s;
          p.report_s = s.start_s;
          p.source_line = s.source_line;
          rtest->positions.push_back(p);
          schedule.table_angles_deg.push_back(r.c_deg);
          break;
        }
        ScheduledCut cut;
        if (!SplitReport(s.text, &cut.feature, &cut.c_deg))
          throw InputError(source, s.source_line, "report",
                           "not a cut of a test feature: " + s.text);
        if (!last_feed)
          throw InputError(source, s.source_line, "report",
                           "report of a cut without a feed move before it");
        cut.index = cut.feature.index;
        cut.cycle = CycleForIndex(config.part, cut.index);
        cut.start_s = last_feed->start_s;
        cut.end_s = last_feed->start_s + last_feed->duration_s;
        cut.tool = tool;
        cut.tool_name = ToolName(config, tool);
        cut.source_line = s.source_line;
        schedule.cuts.push_back(cut);
        schedule.table_angles_deg.push_back(cut.c_deg);
        last_feed = nullptr;  // one feed pass per reported cut
        break;
      }
      default:
        break;
    }
  }
  if (rtest)
    throw InputError(
        source, 0, "report",
        fmt::format("R-test {} is not closed by its '{}' comment",
                    rtest->number, RTestDoneCommentText(rtest->number)));
  return schedule;
}

Schedule BuildSchedule(const Config& config, double dry_run_s) {
  gcode::Program program = BuildTestCycleProgram(config);
  if (dry_run_s >= 0) ShortenDwells(program, dry_run_s);
  const std::string text =
      gcode::WriteProgram(program, gcode::Dialect::kLinuxCnc, config);
  const auto canon =
      gcode::ReadProgram(text, gcode::Dialect::kLinuxCnc, config, "cycle");
  return ScheduleFromCanon(canon, config, "cycle");
}

std::string ScheduleToCsv(const Schedule& schedule) {
  std::string out =
      "feature,cycle,index,start_s,end_s,c_deg,tool,tool_name,line\n";
  for (const ScheduledCut& c : schedule.cuts) {
    out += fmt::format("{},{},{},{:.3f},{:.3f},{:.3f},{},\"{}\",{}\n",
                       c.feature.ToString(), c.cycle, c.index, c.start_s,
                       c.end_s, c.c_deg, c.tool, c.tool_name, c.source_line);
  }
  return out;
}

std::string RTestsToCsv(const Schedule& schedule) {
  std::string out =
      "rtest,position,after_cycle,measure_s,report_s,c_deg,log_t_s,dur_s,"
      "line\n";
  for (const ScheduledRTest& r : schedule.rtests)
    for (const ScheduledRTestPosition& p : r.positions)
      out +=
          fmt::format("{},{},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{}\n",
                      r.number, p.position, r.after_cycle, p.measure_s,
                      p.report_s, p.c_deg, r.log_t_s, r.dur_s, p.source_line);
  return out;
}

nlohmann::json ScheduleToJson(const Schedule& schedule) {
  nlohmann::json doc;
  doc["cycle_period_s"] = schedule.cycle_period_s;
  doc["cycle_start_s"] = schedule.cycle_start_s;
  doc["total_s"] = schedule.total_s;
  nlohmann::json cuts = nlohmann::json::array();
  for (const ScheduledCut& c : schedule.cuts) {
    nlohmann::json j;
    j["feature"] = c.feature.ToString();
    j["cycle"] = c.cycle;
    j["index"] = c.index;
    j["start_s"] = c.start_s;
    j["end_s"] = c.end_s;
    j["c_deg"] = c.c_deg;
    j["tool"] = c.tool;
    j["tool_name"] = c.tool_name;
    j["line"] = c.source_line;
    cuts.push_back(j);
  }
  doc["cuts"] = cuts;
  nlohmann::json rtests = nlohmann::json::array();
  for (const ScheduledRTest& r : schedule.rtests) {
    nlohmann::json j;
    j["rtest"] = r.number;
    j["after_cycle"] = r.after_cycle;
    j["start_s"] = r.start_s;
    j["end_s"] = r.end_s;
    j["log_t_s"] = r.log_t_s;
    j["dur_s"] = r.dur_s;
    nlohmann::json positions = nlohmann::json::array();
    for (const ScheduledRTestPosition& p : r.positions)
      positions.push_back({{"position", p.position},
                           {"c_deg", p.c_deg},
                           {"measure_s", p.measure_s},
                           {"report_s", p.report_s},
                           {"line", p.source_line}});
    j["positions"] = positions;
    rtests.push_back(j);
  }
  doc["rtests"] = rtests;
  return doc;
}

std::string FormatScheduleTable(const Schedule& schedule) {
  std::string out =
      fmt::format("{:<8} {:>5} {:>12} {:>12} {:>9} {:>4}  {}\n", "feature",
                  "cycle", "start_s", "end_s", "c_deg", "tool", "tool name");
  for (const ScheduledCut& c : schedule.cuts) {
    out += fmt::format("{:<8} {:>5} {:>12.3f} {:>12.3f} {:>9.3f} {:>4}  {}\n",
                       c.feature.ToString(), c.cycle, c.start_s, c.end_s,
                       c.c_deg, c.tool, c.tool_name);
  }
  if (!schedule.rtests.empty()) {
    out +=
        fmt::format("{:<8} {:>5} {:>12} {:>12} {:>9}  {}\n", "R-test", "after",
                    "start_s", "log_t_s", "dur_s", "table angles (deg)");
    for (const ScheduledRTest& r : schedule.rtests) {
      std::string angles;
      for (const ScheduledRTestPosition& p : r.positions)
        angles += fmt::format("{}{:.3f}", angles.empty() ? "" : " ", p.c_deg);
      out += fmt::format("{:<8} {:>5} {:>12.3f} {:>12.3f} {:>9.3f}  {}\n",
                         fmt::format("R{}", r.number), r.after_cycle, r.start_s,
                         r.log_t_s, r.dur_s, angles);
    }
  }
  out += fmt::format(
      "{} cuts; {} R-tests; cycle period {:.0f} s; program "
      "{:.3f} s\n",
      schedule.cuts.size(), schedule.rtests.size(), schedule.cycle_period_s,
      schedule.total_s);
  return out;
}

void WriteScheduleCsv(const std::filesystem::path& path,
                      const Schedule& schedule) {
  WriteFileAtomic(path, ScheduleToCsv(schedule));
}

void WriteScheduleJson(const std::filesystem::path& path,
                       const Schedule& schedule) {
  WriteFileAtomic(path, JsonText(ScheduleToJson(schedule), 2) + "\n");
}

}  // namespace ttp::cam
