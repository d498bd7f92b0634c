// `ttp plan probe|cmm|dmis-check|dial|setup`: where and how to measure the
// finished piece, and the machine setup sheet.
#include <fmt/format.h>

#include <filesystem>
#include <iostream>

#include "command.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/json_text.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/inspect/dmis.h"
#include "ttp/plan/dmis_writer.h"
#include "ttp/plan/plan.h"
#include "ttp/plan/probe_program.h"
#include "ttp/plan/setup_sheet.h"

namespace ttp::app {
namespace {

// `-o` names a folder: one that exists, or a path where one can be made (the
// output batch makes it); a file there is the user's mistake, not ours.
void RequireFolderOrNothing(const std::string& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) &&
      !std::filesystem::is_directory(dir, ec))
    throw InputError("-o", 0, "output", dir + " is a file, not a folder");
}

namespace fs = std::filesystem;

struct PlanCliOptions {
  std::string output = "-";
  std::string points_csv;
  std::string dialect = "fanuc";
  std::string dir = "plan";
  plan::PlanOptions plan;
  plan::ProbeOptions probe;
  plan::DmisOptions dmis;
  std::string json;
  std::string check_file;
  bool statements_only = false;
};

void PrintProgramCheck(std::ostream& os, const inspect::DmisProgramCheck& c) {
  for (const inspect::DmisRunCheck& k : c.checks) {
    os << (k.passed ? "  ok    " : "  FAIL  ") << k.name << "\n";
    for (size_t i = 0; i < k.findings.size() && i < 10; ++i)
      os << "        line " << k.findings[i].line << ": "
         << k.findings[i].problem << "\n";
    if (k.findings.size() > 10)
      os << "        ... " << k.findings.size() - 10 << " more\n";
  }
  os << fmt::format(
      "{} automatic points, {} straight moves, path {:.0f} mm, smallest "
      "clearance of the stylus ball {:.3f} mm ({})\n",
      c.probe_points, c.moves, c.path_length_mm, c.min_clearance_mm,
      c.min_clearance_where);
}

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

void RegisterPlan(CLI::App& root, GlobalOptions& global) {
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
      "cmm",
      "CMM point list (CSV) and DMIS program for the same points, checked "
      "before it is written");
  cmm->add_option("-o,--output", o->dir, "folder to write into")
      ->default_val("plan");
  cmm->add_option("--stylus-diameter-mm", o->dmis.stylus_diameter_mm,
                  "CMM stylus ball diameter");
  cmm->add_option("--stylus-length-mm", o->dmis.stylus_length_mm,
                  "CMM stylus length (probe head to ball centre)");
  cmm->add_option("--approach-mm", o->dmis.approach_mm,
                  "SNSET/APPRCH and RETRCT distance");
  cmm->add_option("--clearance-height-mm", o->dmis.clearance_height_mm,
                  "ball centre height above the top face between features");
  cmm->add_option("--json", o->json, "the program check as JSON");
  AddPlanOptions(cmm, *o);
  cmm->callback([&global, o] {
    const Config config = global.LoadConfig();
    o->dmis.retract_mm = o->dmis.approach_mm;
    const auto points = plan::CmmPoints(config.part, o->plan, o->dmis);
    const std::string program =
        plan::WriteDmisProgram(config.part, points, o->dmis);
    // The program is checked as a CMM would run it before it is written:
    // a failure here is a bug of the writer, never the user's input.
    const PartMesh mesh = BuildPartMesh(config.part, Stage::kFinished);
    inspect::DmisPathOptions path;
    const inspect::DmisProgramCheck check = inspect::CheckDmisProgram(
        inspect::ParseDmisProgram(program, "cmm_program.dmi"), config.part,
        mesh, path);
    if (!check.Passed()) {
      PrintProgramCheck(std::cerr, check);
      throw std::logic_error("the written DMIS program fails its own check");
    }
    RequireFolderOrNothing(o->dir);  // the batch creates it
    const fs::path csv = fs::path(o->dir) / "cmm_points.csv";
    const fs::path dmis = fs::path(o->dir) / "cmm_program.dmi";
    OutputBatch outputs;
    outputs.Add(csv, plan::PointsToCsv(points));
    outputs.Add(dmis, program);
    outputs.Commit();
    if (!o->json.empty())
      WriteJson(o->json, inspect::DmisProgramCheckToJson(check));
    std::cout << fmt::format("{} points\n{}\n{}\n", points.size(), csv.string(),
                             dmis.string());
    if (!global.quiet) PrintProgramCheck(std::cerr, check);
  });

  auto* check = cmd->add_subcommand(
      "dmis-check",
      "check a DMIS program: DMIS 5 statements and labels; for a program of "
      "this piece also sensor, feeds, alignment, point patterns and the "
      "stylus path against the piece");
  check->add_option("program", o->check_file, "DMIS program (.dmi)")
      ->required();
  check->add_flag("--statements-only", o->statements_only,
                  "only the DMIS 5 statement and label checks (a program of "
                  "another part)");
  check->add_option("--json", o->json, "the findings as JSON");
  check->callback([&global, o] {
    const Config config = global.LoadConfig();
    const inspect::DmisProgram program =
        inspect::ParseDmisProgram(ReadTextFile(o->check_file), o->check_file);
    std::ostream& os = TextOut(o->json);
    nlohmann::json j;
    bool passed = true;
    if (o->statements_only) {
      const auto findings = inspect::CheckDmisStandard(program);
      passed = findings.empty();
      nlohmann::json f = nlohmann::json::array();
      for (const auto& x : findings) {
        os << fmt::format("  line {}: {}: {}\n", x.line, x.check, x.problem);
        f.push_back(
            {{"line", x.line}, {"check", x.check}, {"problem", x.problem}});
      }
      os << fmt::format("{} statements, {} findings\n",
                        program.statements.size(), findings.size());
      j = {{"passed", passed},
           {"statements", program.statements.size()},
           {"findings", f}};
    } else {
      const PartMesh mesh = BuildPartMesh(config.part, Stage::kFinished);
      const auto c = inspect::CheckDmisProgram(program, config.part, mesh);
      PrintProgramCheck(os, c);
      passed = c.Passed();
      j = inspect::DmisProgramCheckToJson(c);
    }
    if (!o->json.empty()) WriteJson(o->json, j);
    if (!passed) global.exit_code = kExitJudgedFailure;
  });

  auto* dial = cmd->add_subcommand(
      "dial", "printable dial-gauge sheet (HTML) and the CSV template");
  dial->add_option("-o,--output", o->dir, "folder to write into")
      ->default_val("plan");
  dial->callback([&global, o] {
    const Config config = global.LoadConfig();
    RequireFolderOrNothing(o->dir);  // the batch creates it
    const fs::path html = fs::path(o->dir) / "dial_sheet.html";
    const fs::path csv = fs::path(o->dir) / "dial_readings.csv";
    OutputBatch outputs;
    outputs.Add(html, plan::DialSheetHtml(config.part));
    outputs.Add(csv, plan::DialTemplateCsv(config.part));
    outputs.Commit();
    std::cout << html.string() << "\n" << csv.string() << "\n";
  });

  auto* setup = cmd->add_subcommand(
      "setup",
      "printable setup sheet (HTML): G54, tools with T/H, lengths and "
      "stick-out, adapter, clamps, R-test sphere, dial-gauge positions");
  setup->add_option("-o,--output", o->output, "HTML file (default stdout)");
  setup->add_option("--json", o->json, "the sheet's numbers as JSON");
  setup->callback([&global, o] {
    const Config config = global.LoadConfig();
    const plan::SetupSheet sheet = plan::BuildSetupSheet(config);
    OutputBatch outputs;
    outputs.Add(o->output, plan::SetupSheetHtml(sheet));
    if (!o->json.empty())
      outputs.Add(o->json, JsonText(plan::SetupSheetToJson(sheet), 2) + "\n");
    outputs.Commit();
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(40, RegisterPlan);
}  // namespace ttp::app
