// `ttp plan probe|cmm|dial`: where and how to measure the finished piece.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "command.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/frames.h"
#include "ttp/plan/plan.h"
#include "ttp/plan/probe_program.h"

namespace ttp::app {
namespace {

namespace fs = std::filesystem;

struct PlanCliOptions {
  std::string output = "-";
  std::string points_csv;
  std::string dialect = "fanuc";
  std::string dir = "plan";
  plan::PlanOptions plan;
  plan::ProbeOptions probe;
};

void AddPlanOptions(CLI::App* cmd, PlanCliOptions& o) {
  cmd->add_option("--facet-columns", o.plan.facet_columns,
                  "points across each facet");
  cmd->add_option("--facet-rows", o.plan.facet_rows, "points up each facet");
  cmd->add_option("--strip-points", o.plan.strip_points_per_side,
                  "points on each strip, per side of the small notch");
  cmd->add_option("--edge-margin-mm", o.plan.edge_margin_mm,
                  "distance of the points from the features' edges");
}

void Say(const GlobalOptions& global, const std::string& text) {
  if (!global.quiet) std::cerr << text << "\n";
}

void Register(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "plan", "plan the measurement of the finished piece (probe, CMM, dial)");
  cmd->require_subcommand(1);
  auto o = std::make_shared<PlanCliOptions>();

  auto* probe = cmd->add_subcommand(
      "probe", "on-machine probing program + the point list it expects back");
  probe->add_option("--dialect", o->dialect, "fanuc (G31) or linuxcnc (G38.2)");
  probe->add_option("-o,--output", o->output, "program file (default stdout)");
  probe->add_option("--points-csv", o->points_csv,
                    "write the planned points (id, feature, point, approach)");
  probe->add_option("--clearance-mm", o->probe.clearance_mm,
                    "start of each probing move off the surface");
  probe->add_option("--overtravel-mm", o->probe.overtravel_mm,
                    "probing move length beyond the surface");
  probe->add_option("--touch-window-mm", o->probe.touch_window_mm,
                    "FANUC: alarm when a touch is further than this from its "
                    "nominal (or missing)");
  probe->add_option("--log-file", o->probe.log_file,
                    "LinuxCNC: the file (LOGOPEN) the program writes its "
                    "results to");
  probe->add_flag("!--no-qualify", o->probe.qualify,
                  "skip the stylus qualification on the R-test sphere");
  probe->add_flag("!--no-drift", o->probe.drift,
                  "skip re-probing the reference facets at the end");
  AddPlanOptions(probe, *o);
  probe->callback([&global, o] {
    const Config config = global.LoadConfig();
    const auto dialect = gcode::ParseDialect(o->dialect, "--dialect");
    const auto points = plan::PlanProbePoints(config, o->plan, o->probe);
    const std::string text =
        plan::WriteProbeProgram(config, points, dialect, o->probe);
    OutputBatch outputs;  // the program and its point list, or neither
    outputs.Add(o->output, text);
    if (!o->points_csv.empty())
      outputs.Add(o->points_csv, plan::PointsToCsv(points));
    outputs.Commit();
    Say(global,
        fmt::format(
            "{} points; the program qualifies the stylus on the R-test "
            "sphere, checks every touch and writes one row per touch {}: "
            "run `ttp inspect` on that file{}",
            points.size(),
            dialect == gcode::Dialect::kFanuc
                ? "to the DPRNT port (FANUC)"
                : "to " + o->probe.log_file + " (LinuxCNC LOG)",
            o->points_csv.empty() ? ""
                                  : " with --probe-points " + o->points_csv));
  });

  auto* cmm = cmd->add_subcommand(
      "cmm", "CMM point list (CSV) and DMIS program for the same points");
  cmm->add_option("-o,--output", o->dir, "folder to write into")
      ->default_val("plan");
  AddPlanOptions(cmm, *o);
  cmm->callback([&global, o] {
    const Config config = global.LoadConfig();
    const auto points = plan::PlanPoints(config.part, o->plan);
    fs::create_directories(o->dir);
    const fs::path csv = fs::path(o->dir) / "cmm_points.csv";
    const fs::path dmis = fs::path(o->dir) / "cmm_program.dmi";
    OutputBatch outputs;
    outputs.Add(csv, plan::PointsToCsv(points));
    outputs.Add(dmis, plan::PointsToDmis(points, config.part));
    outputs.Commit();
    std::cout << fmt::format("{} points\n{}\n{}\n", points.size(), csv.string(),
                             dmis.string());
  });

  auto* dial = cmd->add_subcommand(
      "dial", "printable dial-gauge sheet (HTML) and the CSV template");
  dial->add_option("-o,--output", o->dir, "folder to write into")
      ->default_val("plan");
  dial->callback([&global, o] {
    const Config config = global.LoadConfig();
    fs::create_directories(o->dir);
    const fs::path html = fs::path(o->dir) / "dial_sheet.html";
    const fs::path csv = fs::path(o->dir) / "dial_readings.csv";
    OutputBatch outputs;
    outputs.Add(html, plan::DialSheetHtml(config.part));
    outputs.Add(csv, plan::DialTemplateCsv(config.part));
    outputs.Commit();
    std::cout << html.string() << "\n" << csv.string() << "\n";
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(40, Register);
}  // namespace ttp::app
