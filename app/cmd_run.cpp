// `ttp run -o DIR`: the main job on the defaults (or --config). A list of
// stages, each writing its outputs into DIR; a progress line per stage on a
// terminal (nothing when stdout is not one), then what was written where.
//
// Stages: the NC programs and schedule; LinuxCNC's rs274 on the LinuxCNC
// programs, compared with the project's own reader; the cut simulation of
// both programs; the part meshes; a twin run of the 8-hour cycle with an
// effect hidden in it (drawn from --seed unless --effect names one); the
// inspection of its CMM cloud; the check against its TALC log; the
// diagnosis; the HTML report.
#include <fmt/format.h>

#include <chrono>
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>
#include <random>

#include "command.h"
#include "planned_cuts.h"
#include "ttp/cam/programs.h"
#include "ttp/cam/schedule.h"
#include "ttp/diagnosis/diagnose.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/inspect/grade.h"
#include "ttp/inspect/measurement.h"
#include "ttp/report/assemble.h"
#include "ttp/sim/twin.h"
#include "ttp/thermal/check.h"
#include "ttp/thermal/talc_log.h"
#include "ttp/verify/programs.h"
#include "ttp/verify/verify.h"

namespace ttp::app {
namespace {

namespace fs = std::filesystem;

struct RunArgs {
  std::string out_dir;
  std::string effect = "random";
  double size = 0;  // 0 = a clear size for the effect
  std::uint64_t seed = 1;
  // --effect parsed (empty: drawn from the seed).
  std::optional<diagnosis::Cause> cause;
};

// The effect hidden in the twin run: the one asked for, or one drawn from
// the seed (possibly none).
diagnosis::Cause HiddenCause(const RunArgs& args) {
  if (args.cause) return *args.cause;
  std::mt19937_64 rng(args.seed);
  return diagnosis::kAllCauses[rng() % 5];
}

// Sizes well inside the range the battery shows is diagnosable, in each
// cause's own unit (sim/twin.h).
double ClearSize(diagnosis::Cause cause) {
  switch (cause) {
    case diagnosis::Cause::kNone:
      return 0;
    case diagnosis::Cause::kWorkpieceExpansion:
      return 0.8;  // gain
    case diagnosis::Cause::kToolWear:
      return 3.0;  // um/m
    case diagnosis::Cause::kClampingDistortion:
      return 3.0;  // um
    case diagnosis::Cause::kCAxisIndexing:
      return 200.0;  // urad
  }
  return 0;
}

// The hidden effect at its size (given, or the clear one); a size beyond
// the effect's range is bad input naming --size.
void SetHiddenEffect(const RunArgs& args, diagnosis::Cause cause,
                     sim::TwinOptions* options) {
  try {
    sim::SetEffect(options, diagnosis::CauseName(cause),
                   args.size > 0 ? args.size : ClearSize(cause));
  } catch (const std::invalid_argument& e) {
    throw InputError("--size", 0, "size", e.what());
  }
}

struct RunContext {
  Config config;
  RunArgs args;
  fs::path out_dir;    // where the stages write (a staging folder)
  fs::path shown_dir;  // the output folder, as files are named in outputs
  // Outputs in the order written: path and what it holds.
  std::vector<std::pair<fs::path, std::string>> written;
  // Lines for the closing summary.
  std::vector<std::string> summary;
  bool judged_failure = false;

  // Kept between stages.
  std::string program_text[2][2];  // [pre, cycle][fanuc, linuxcnc]
  sim::TwinRun twin;
  diagnosis::Cause hidden = diagnosis::Cause::kNone;
  inspect::Measurement measurement;
  inspect::GradeResult grade;  // of the measurement, as `ttp grade`
  thermal::TalcLog log;
  // The log's estimator and simulation: fitted once, shared by the check,
  // the diagnosis and the report.
  std::optional<thermal::MachineErrorEstimator> estimator;
  thermal::Simulation simulation;
  diagnosis::PreparedDiagnosis diagnosis;

  void Write(const std::string& name, const std::string& text,
             const std::string& what) {
    const fs::path path = out_dir / name;
    WriteFileAtomic(path, text);
    written.emplace_back(path, what);
  }
  void WriteJsonFile(const std::string& name, const nlohmann::json& doc,
                     const std::string& what) {
    Write(name, JsonText(doc, 2) + "\n", what);
  }
};

struct Stage {
  const char* name;
  std::function<void(RunContext&)> run;
};

constexpr const char* kProgramNames[2] = {"pre", "cycle"};

void ProgramsStage(RunContext& ctx) {
  using gcode::Dialect;
  gcode::Program (*build[2])(const Config&) = {&cam::BuildPreMachiningProgram,
                                               &cam::BuildTestCycleProgram};
  const char* what[2] = {"pre-machining program", "test-cycle program"};
  for (int p = 0; p < 2; ++p) {
    const gcode::Program program = build[p](ctx.config);
    ctx.program_text[p][0] =
        gcode::WriteProgram(program, Dialect::kFanuc, ctx.config);
    ctx.program_text[p][1] =
        gcode::WriteProgram(program, Dialect::kLinuxCnc, ctx.config);
    ctx.Write(fmt::format("{}_fanuc.nc", kProgramNames[p]),
              ctx.program_text[p][0],
              fmt::format("{}, FANUC (O{})", what[p], program.number));
    ctx.Write(fmt::format("{}_linuxcnc.ngc", kProgramNames[p]),
              ctx.program_text[p][1], fmt::format("{}, LinuxCNC", what[p]));
  }
}

void ScheduleStage(RunContext& ctx) {
  const cam::Schedule schedule = cam::BuildSchedule(ctx.config);
  ctx.Write(
      "schedule.csv", cam::ScheduleToCsv(schedule),
      fmt::format("schedule of the {} test cuts (CSV)", schedule.cuts.size()));
  ctx.WriteJsonFile("schedule.json", cam::ScheduleToJson(schedule),
                    "schedule (JSON)");
}

// rs274 reads each LinuxCNC program; its canonical moves must equal the
// project's own reading of the FANUC and the LinuxCNC text.
void Rs274Stage(RunContext& ctx) {
  nlohmann::json doc = nlohmann::json::array();
  if (!gcode::Rs274Available()) {
    ctx.summary.push_back("rs274: not installed, programs not checked");
    doc.push_back({{"available", false}});
  } else {
    for (int p = 0; p < 2; ++p) {
      const std::string name = fmt::format("{}_linuxcnc.ngc", kProgramNames[p]);
      const gcode::Rs274Result rs =
          gcode::RunRs274(ctx.program_text[p][1], ctx.config);
      const auto own_linuxcnc = gcode::ReadProgram(
          ctx.program_text[p][1], gcode::Dialect::kLinuxCnc, ctx.config, name);
      const auto own_fanuc = gcode::ReadProgram(
          ctx.program_text[p][0], gcode::Dialect::kFanuc, ctx.config,
          fmt::format("{}_fanuc.nc", kProgramNames[p]));
      const auto d1 = gcode::CompareToolpaths(rs.statements, own_linuxcnc);
      const auto d2 = gcode::CompareToolpaths(own_linuxcnc, own_fanuc);
      const bool ok = d1.same && d2.same;
      ctx.judged_failure |= !ok;
      doc.push_back({{"program", name},
                     {"rs274_statements", rs.statements.size()},
                     {"rs274_equals_own_reader", d1.same},
                     {"fanuc_equals_linuxcnc", d2.same},
                     {"difference", d1.same ? d2.what : d1.what}});
      ctx.summary.push_back(fmt::format(
          "rs274 {}: {} canonical statements, {}", name, rs.statements.size(),
          ok ? "same toolpath as the project's reader and the FANUC twin"
             : "DIFFERS: " + (d1.same ? d2.what : d1.what)));
    }
  }
  ctx.WriteJsonFile("rs274_check.json", doc,
                    "rs274 check of the LinuxCNC programs");
}

// Both programs as the machine gets them (FANUC): the pre-machining cut
// from the blank, the test cycle from what the pre-machining left.
void VerifyStage(RunContext& ctx) {
  const verify::ProgramsVerification v =
      verify::VerifyProgramTexts(ctx.program_text[0][0], ctx.program_text[1][0],
                                 gcode::Dialect::kFanuc, ctx.config);
  ctx.WriteJsonFile("verify.json", verify::ProgramsVerificationToJson(v),
                    "cut simulation findings of both programs");
  for (const verify::VerifyReport* report : {&v.pre, &v.cycle}) {
    const auto failed = report->Failed();
    ctx.judged_failure |= !failed.empty();
    ctx.summary.push_back(fmt::format(
        "cut simulation {}: {} checks, {}", report->source,
        report->findings.size(),
        failed.empty() ? "all passed"
                       : fmt::format("{} FAILED (first: {})", failed.size(),
                                     failed.front()->check)));
  }
  ctx.summary.push_back(
      fmt::format("cut simulation: largest surface deviation from nominal "
                  "{:.4f} um",
                  v.MaxSurfaceDeviationUm()));
}

void MeshStage(RunContext& ctx) {
  for (const fs::path& path : WritePartMeshes(ctx.config, ctx.out_dir / "part"))
    ctx.written.emplace_back(
        path, path.extension() == ".csv" || path.extension() == ".json"
                  ? "nominal features"
                  : "part mesh, faces tagged with their feature");
}

void TwinStage(RunContext& ctx) {
  sim::TwinOptions options;
  options.seed = ctx.args.seed;
  const diagnosis::Cause cause = HiddenCause(ctx.args);
  SetHiddenEffect(ctx.args, cause, &options);
  ctx.hidden = cause;
  ctx.twin = sim::RunTwin(ctx.config, options);
  // As `ttp twin` writes it: the log, the truth (without the pose, which the
  // cloud's random pose replaces) and the finished piece measured on a CMM
  // (the twin's point count and probing noise, 0.2 % strays, any pose).
  const fs::path dir = ctx.out_dir / "twin";
  const fs::path cloud_path = sim::WriteTwin(
      ctx.config, ctx.twin, options, dir.string(), sim::TwinMeasurement::kPly);
  ctx.written.emplace_back(dir / "talc.csv",
                           "TALC log of the twin run (8-hour cycle)");
  ctx.written.emplace_back(dir / "truth.json",
                           "truth of the twin run (the hidden effect)");
  ctx.written.emplace_back(
      cloud_path,
      fmt::format("CMM cloud of the twin's piece ({} points plus strays)",
                  options.cloud_points));
}

void InspectStage(RunContext& ctx) {
  ctx.measurement =
      inspect::LoadMeasurement(ctx.config, ctx.out_dir / "twin/piece.ply");
  ctx.measurement.source = ctx.measurement.result.source =
      (ctx.shown_dir / "twin/piece.ply").string();
  ctx.WriteJsonFile(
      "inspection.json", inspect::MeasurementToJson(ctx.measurement),
      "inspection of the twin's cloud: E_X..E_TTP with U (k = 2)");
  const auto& r = ctx.measurement.result;
  ctx.grade = inspect::GradeMeasurement(ctx.measurement, {});
  ctx.WriteJsonFile("grade.json", inspect::GradeToJson(ctx.grade),
                    "verdict on the twin's piece (as ttp grade)");
  // The verdict is what a reader looks for first.
  ctx.summary.insert(
      ctx.summary.begin(),
      "verdict on the twin's piece (as ttp grade): " +
          ctx.grade.Summary().substr(0, ctx.grade.Summary().find('\n')));
  ctx.summary.push_back(
      fmt::format("inspection: {} points, {} on features, {} rejected as stray",
                  r.points_total, r.points_assigned, r.points_rejected));
}

void CheckStage(RunContext& ctx) {
  ctx.log = thermal::ParseTalcLog(ctx.twin.log_text,
                                  (ctx.shown_dir / "twin/talc.csv").string());
  const thermal::ScheduleCheck schedule =
      thermal::CheckLogAgainstSchedule(ctx.log, PlannedCuts(ctx.config));
  ctx.estimator = thermal::MachineErrorEstimator::Fit(
      ctx.log, thermal::EstimatorOptionsFor(ctx.config.machine));
  ctx.simulation =
      thermal::SimulatePiece(ctx.log, ctx.config, *ctx.estimator, {});
  const thermal::CheckResult check =
      thermal::CheckPiece(ctx.log, ctx.config, *ctx.estimator, ctx.simulation,
                          ctx.measurement.result.figures);
  nlohmann::json doc = thermal::CheckToJson(check);
  doc["schedule"] = {{"offset_s", schedule.offset_s},
                     {"max_deviation_s", schedule.max_deviation_s},
                     {"matched_cuts", schedule.matched}};
  ctx.WriteJsonFile("check.json", doc, "measured vs simulated (JSON)");
  ctx.Write("check.txt", thermal::CheckTable(check),
            "measured vs simulated (table)");
  ctx.summary.push_back(fmt::format(
      "check: {} cuts on the schedule; {} of {} figures agree with the "
      "simulation within U, {} beyond the run's limit: {}",
      schedule.matched, check.compared - check.disagreements, check.compared,
      check.beyond_run_limit, check.agree() ? "agree" : "DISAGREE"));
}

void ReportStage(RunContext& ctx) {
  report::ReportOptions options;
  options.title = "Thermal test piece report (twin run)";
  options.run_info["measurement"] = "twin/piece.ply (synthetic CMM cloud)";
  options.run_info["hidden_effect"] = diagnosis::CauseName(ctx.hidden);
  report::ReportInputs inputs;
  inputs.measurement = &ctx.measurement;
  inputs.grade = &ctx.grade;
  inputs.log = &ctx.log;
  inputs.diagnosis = &ctx.diagnosis;
  const diagnosis::DiagnosisExplanation explained = diagnosis::ExplainDiagnosis(
      ctx.diagnosis.run, ctx.diagnosis.report, ctx.config.part,
      options.diagnosis.evidence_threshold);
  inputs.explanation = &explained;
  report::WriteReport(ctx.config, inputs, ctx.out_dir / "report.html",
                      ctx.out_dir / "report.json", options);
  ctx.written.emplace_back(ctx.out_dir / "report.html",
                           "the report (open in a browser; works offline)");
  ctx.written.emplace_back(ctx.out_dir / "report.json",
                           "the data the report is made from");
  ctx.summary.push_back(
      "report: " + (ctx.shown_dir / "report.html").lexically_normal().string());
}

void DiagnoseStage(RunContext& ctx) {
  const diagnosis::MeasuredPiece measured =
      diagnosis::MeasuredPieceFromInspection(ctx.config.part,
                                             ctx.measurement.result);
  ctx.diagnosis.run = diagnosis::PrepareRun(ctx.log, ctx.config, *ctx.estimator,
                                            ctx.simulation, measured);
  ctx.diagnosis.report = diagnosis::DiagnosePrepared(ctx.diagnosis.run, ctx.log,
                                                     ctx.config.part, measured);
  const diagnosis::DiagnosisReport& report = ctx.diagnosis.report;
  ctx.WriteJsonFile("diagnosis.json", diagnosis::DiagnosisToJson(report),
                    "diagnosis of the twin run");
  ctx.Write("diagnosis.txt", diagnosis::DiagnosisText(report),
            "diagnosis (text)");
  const std::string hidden = diagnosis::CauseName(ctx.hidden);
  const std::string outcome =
      report.status == diagnosis::DiagnosisStatus::kNamed
          ? report.cause
          : diagnosis::StatusName(report.status);
  ctx.summary.push_back(fmt::format(
      "diagnosis: {} ({}; the twin hid {}: {}); residual RMS {:.3f} -> {:.3f} "
      "um",
      diagnosis::StatusName(report.status), outcome, hidden,
      outcome == hidden ? "right" : "NOT the hidden cause",
      report.baseline_rms_um, report.extended_rms_um));
  if (report.status == diagnosis::DiagnosisStatus::kRefused)
    ctx.judged_failure = true;
}

// The main job, in order.
const std::vector<Stage>& Stages() {
  static const std::vector<Stage> stages = {
      {"NC programs (pre, cycle; FANUC and LinuxCNC)", ProgramsStage},
      {"schedule", ScheduleStage},
      {"rs274 check of the LinuxCNC programs", Rs274Stage},
      {"cut simulation of both programs", VerifyStage},
      {"part meshes and nominal features", MeshStage},
      {"twin run of the 8-hour cycle with a hidden effect", TwinStage},
      {"inspection of the twin's CMM cloud", InspectStage},
      {"check against the TALC log", CheckStage},
      {"diagnosis", DiagnoseStage},
      {"report", ReportStage},
  };
  return stages;
}

void RegisterRun(CLI::App& root, GlobalOptions& global) {
  auto args = std::make_shared<RunArgs>();
  auto* cmd = root.add_subcommand(
      "run",
      "the main job: programs, rs274 check, cut simulation, a twin run with a "
      "hidden effect, its inspection, check, diagnosis and report");
  cmd->add_option("-o,--output", args->out_dir, "output folder (created)")
      ->required();
  cmd->add_option("--effect", args->effect,
                  "effect hidden in the twin run: random (default, drawn "
                  "from --seed), none, workpiece_expansion, tool_wear, "
                  "clamping_distortion, c_axis_indexing");
  cmd->add_option("--size", args->size,
                  "size of the hidden effect in its unit (default: a clear "
                  "one)");
  cmd->add_option("--seed", args->seed, "seed of the twin run (default 1)");
  cmd->callback([&global, args, cmd] {
    RunContext ctx;
    ctx.config = global.LoadConfig();
    ctx.args = *args;
    if (args->effect != "random") {
      try {
        ctx.args.cause = diagnosis::CauseFromName(args->effect);
      } catch (const std::invalid_argument& e) {
        throw InputError("--effect", 0, "effect", e.what());
      }
    }
    // 0 is not "a clear size": leave --size out for that.
    if (cmd->get_option("--size")->count() > 0 && !(args->size > 0))
      throw InputError("--size", 0, "size",
                       "must be > 0 (leave --size out for a clear size)");
    {  // a size beyond the effect's range is refused before any stage
      sim::TwinOptions checked;
      SetHiddenEffect(ctx.args, HiddenCause(ctx.args), &checked);
    }
    // Every stage writes into a staging folder; its files move into the
    // output folder only when all stages are done (all or none).
    StagedFolder staged(args->out_dir);
    ctx.out_dir = staged.path();
    ctx.shown_dir = args->out_dir;
    const bool progress = !global.quiet && StdoutIsTerminal();
    const auto& stages = Stages();
    for (size_t i = 0; i < stages.size(); ++i) {
      const auto t0 = std::chrono::steady_clock::now();
      if (progress)
        std::cout << fmt::format("[{}/{}] {} ...", i + 1, stages.size(),
                                 stages[i].name)
                  << std::flush;
      try {
        stages[i].run(ctx);
      } catch (const InputError& e) {
        // A file the job made itself (the twin's log or cloud) that it
        // cannot read back: the configuration passed every check, so this
        // is ttp's fault, not the user's input (exit 3).
        // Stages name the job's files by the staging folder or by the
        // output folder they will be shown in.
        const std::string staging = staged.path().string() + "/";
        const std::string output =
            (fs::path(args->out_dir) / "").lexically_normal().string();
        fs::path shown;
        if (e.source().rfind(staging, 0) == 0)
          shown = fs::path(args->out_dir) /
                  fs::path(e.source()).lexically_relative(staged.path());
        else if (fs::path(e.source())
                     .lexically_normal()
                     .string()
                     .rfind(output, 0) == 0)
          shown = e.source();
        else
          throw;
        throw std::runtime_error(fmt::format(
            "stage '{}' refused the job's own {}: {} (please report it "
            "with the configuration; nothing was written)",
            stages[i].name, shown.string(),
            FormatInputError("", e.line(), e.field(), e.problem())));
      }
      if (progress) {
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0)
                .count();
        std::cout << fmt::format(" done ({:.2f} s)\n", s);
      }
    }
    staged.Commit();
    ctx.out_dir = args->out_dir;
    for (auto& [path, what] : ctx.written)
      path = ctx.out_dir / path.lexically_relative(staged.path());
    if (ctx.judged_failure) global.exit_code = kExitJudgedFailure;
    if (global.quiet) return;
    // What was decided first (the verdict leads), then where it is.
    for (const auto& line : ctx.summary) std::cout << line << "\n";
    std::cout << fmt::format(
        "wrote {} files into {}:\n", ctx.written.size(),
        fs::absolute(ctx.out_dir).lexically_normal().string());
    for (const auto& [path, what] : ctx.written)
      std::cout << fmt::format("  {:<40} {}\n", path.string(), what);
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(5, RegisterRun);
}  // namespace ttp::app
