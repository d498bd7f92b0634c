// `ttp diagnose --log LOG MEASUREMENT`: what the simulation gets wrong
// (diagnosis.md); one status (named, none, unexplained: exit 0; refused:
// exit 1; unreadable input: exit 2). `ttp twin`: a synthetic run with
// hidden effects (sim/).
#include <filesystem>

#include "command.h"
#include "planned_cuts.h"
#include "ttp/diagnosis/diagnose.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/inspect/measurement.h"
#include "ttp/sim/twin.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::app {
namespace {

void RegisterDiagnosis(CLI::App& root, GlobalOptions& global) {
  {
    auto* cmd = root.add_subcommand(
        "diagnose",
        "compare a measured piece with its simulation from the TALC log and "
        "name what the simulation gets wrong");
    auto log_path = std::make_shared<std::string>();
    auto measurement = std::make_shared<std::string>();
    auto json_out = std::make_shared<std::string>();
    auto threshold = std::make_shared<double>(
        diagnosis::DiagnosisOptions{}.evidence_threshold);
    cmd->add_option("--log", *log_path, "TALC log (CSV)")->required();
    cmd->add_option(
           "measurement", *measurement,
           "measured piece: the JSON of `ttp inspect --json` (or per-feature "
           "results, or figures and facet angles as in a truth.json), or any "
           "measurement `ttp inspect` reads (a point cloud PLY/PCD/XYZ, "
           "dial CSV, DMIS, probe CSV), which is inspected first")
        ->required();
    cmd->add_option("--json", *json_out, "also write the diagnosis as JSON");
    auto how = std::make_shared<MeasurementArgs>();
    AddMeasurementOptions(cmd, how.get());
    cmd->add_option("--evidence", *threshold,
                    "BIC margin over the nominal model needed to name a "
                    "cause (default: the calibrated threshold, "
                    "docs/DIAGNOSIS.md)")
        ->check(FiniteRange(0.0, 1e6));
    auto no_schedule = std::make_shared<bool>(false);
    cmd->add_flag("--no-schedule-check", *no_schedule,
                  "do not check the log's cuts against the program's "
                  "schedule (for a log of another program)");
    cmd->callback([&global, cmd, log_path, measurement, json_out, threshold,
                   no_schedule, how] {
      const thermal::TalcLog log = ReadTalcLogWarning(*log_path, global);
      const Config config = global.LoadConfig();
      diagnosis::DiagnosisOptions options;
      options.evidence_threshold = *threshold;
      std::string invalid;
      if (!options.IsValid(&invalid))
        throw CLI::ValidationError("--evidence", invalid);
      const inspect::Measurement loaded = inspect::LoadMeasurement(
          config, *measurement, ToMeasurementOptions(*how, *cmd));
      PrintMeasurementWarnings(*measurement, loaded.result.warnings, global);
      const diagnosis::MeasuredPiece measured =
          diagnosis::MeasuredPieceFromInspection(config.part, loaded.result);
      // A log that does not match the program's schedule (or does not
      // cover its cuts) cannot belong to the measured piece: refused.
      diagnosis::DiagnosisReport report;
      std::string refusal = *no_schedule ? "" : ScheduleRefusal(log, config);
      if (refusal.empty()) {
        try {
          report = diagnosis::DiagnoseRun(log, config, measured, options);
        } catch (const InputError& e) {
          if (!RefusesTheDiagnosis(e)) throw;
          refusal = e.what();
        }
      }
      if (!refusal.empty()) {
        report = {};
        report.status = diagnosis::DiagnosisStatus::kRefused;
        report.reason = refusal;
      }
      if (!global.quiet || json_out->empty())
        TextOut(*json_out) << diagnosis::DiagnosisText(report);
      if (!json_out->empty()) {
        nlohmann::json j = diagnosis::DiagnosisToJson(report);
        j["measurement_warnings"] = loaded.result.warnings;
        WriteJson(*json_out, j);
      }
      if (report.status == diagnosis::DiagnosisStatus::kRefused)
        global.exit_code = kExitJudgedFailure;
    });
  }
  {
    auto* cmd = root.add_subcommand(
        "twin",
        "synthetic run: TALC log, measured piece and truth, with a hidden "
        "effect");
    auto effect = std::make_shared<std::string>("none");
    auto options = std::make_shared<sim::TwinOptions>();
    auto size = std::make_shared<double>(0.0);
    auto compensation = std::make_shared<std::string>("off");
    auto out_dir = std::make_shared<std::string>();
    cmd->add_option("--effect", *effect,
                    "none, workpiece_expansion, tool_wear, "
                    "clamping_distortion or c_axis_indexing");
    cmd->add_option("--size", *size,
                    "effect size: workpiece_expansion gain, tool_wear um/m, "
                    "clamping_distortion um, c_axis_indexing urad")
        ->check(FiniteRange(0.0, 1e4));
    cmd->add_option("--seed", options->seed, "random seed (default 1)");
    cmd->add_option("--step-um", options->step_um,
                    "an effect outside the catalogue: every facet shifted "
                    "by this much from a cycle on (--step-from-cycle)")
        ->check(FiniteRange(-1e3, 1e3));
    cmd->add_option("--step-from-cycle", options->step_from_cycle,
                    "first cycle of the step (default: drawn, 3..7)")
        ->check(CLI::Range(0, 8));
    cmd->add_option("--two-lobe-um", options->two_lobe_amplitude_um,
                    "an effect outside the catalogue: a two-lobe radial "
                    "distortion of this amplitude")
        ->check(FiniteRange(0.0, 1e3));
    cmd->add_option("--compensation", *compensation,
                    "on (the controller compensates with an imperfect model; "
                    "pred_* columns in the log) or off (default)")
        ->check(CLI::IsMember({"on", "off"}));
    cmd->add_option("--rtest-interval-s", options->rtest_interval_s,
                    "time between R-tests (default 300)")
        ->check(FiniteRange(150.0, 7200.0));
    cmd->add_option("--point-noise-um", options->point_noise_um,
                    "CMM noise per point (default 0.4)")
        ->check(FiniteRange(0.0, 1000.0));
    cmd->add_option("--points", options->cloud_points,
                    "points in the measured cloud (default 20000)")
        ->check(CLI::Range(1000, 10'000'000));
    auto measurement = std::make_shared<std::string>("cloud");
    cmd->add_option(
           "--measurement", *measurement,
           "how the measured piece is written: cloud (= ply: a CMM cloud of "
           "the cut piece in a random pose, binary PLY with double "
           "coordinates, piece.ply; default), xyz (the same cloud as text, "
           "piece.xyz) or json (per-feature results in the `ttp inspect "
           "--json` format, measured.json)")
        ->check(CLI::IsMember({"cloud", "ply", "xyz", "json"}));
    cmd->add_option("--stray-fraction", options->stray_fraction,
                    "stray points per cloud point (default 0.002)")
        ->check(FiniteRange(0.0, 0.49));
    cmd->add_option("-o,--output", *out_dir,
                    "output directory: talc.csv (the TALC log), the measured "
                    "piece and truth.json (the hidden effect and its "
                    "parameters, the true figures)")
        ->required();
    cmd->callback(
        [&global, effect, options, size, compensation, out_dir, measurement] {
          sim::TwinOptions o = *options;
          o.compensation = *compensation == "on";
          if (*effect != "none" && sim::FindEffect(*effect) == nullptr)
            throw CLI::ValidationError("--effect",
                                       "unknown effect '" + *effect + "'");
          if (*effect != "none" && !(*size > 0))
            throw CLI::ValidationError("--size", "must be > 0 with an effect");
          try {
            sim::SetEffect(&o, *effect, *size);
          } catch (const std::invalid_argument& e) {
            throw CLI::ValidationError("--size", e.what());  // name is known
          }
          std::string invalid;
          if (!o.IsValid(&invalid)) throw CLI::ValidationError("twin", invalid);
          const Config config = global.LoadConfig();
          const sim::TwinRun run = sim::RunTwin(config, o);
          // All three files or none (an existing run survives a failure).
          StagedFolder staged(*out_dir);
          const std::string written =
              (std::filesystem::path(*out_dir) /
               std::filesystem::path(
                   sim::WriteTwin(config, run, o, staged.path().string(),
                                  sim::TwinMeasurementFromName(*measurement)))
                   .filename())
                  .lexically_normal()
                  .string();
          staged.Commit();
          if (!global.quiet)
            WriteText("-", "wrote " +
                               (std::filesystem::path(*out_dir) / "talc.csv")
                                   .lexically_normal()
                                   .string() +
                               ", " + written + ", " +
                               (std::filesystem::path(*out_dir) / "truth.json")
                                   .lexically_normal()
                                   .string() +
                               " (cause " +
                               run.truth["cause"].get<std::string>() + ")\n");
        });
  }
}

}  // namespace
TTP_REGISTER_COMMANDS(45, RegisterDiagnosis);
}  // namespace ttp::app
