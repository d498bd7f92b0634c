// `ttp verify [PROGRAM] [--after PRE]`: cut simulation of a program and the
// program checks (surfaces at their nominal place, no rapid in material,
// travel, adapter, only C between cycles). Exit 0 all good, 1 a check failed,
// 2 bad input.
#include <fmt/format.h>

#include <iostream>

#include "command.h"
#include "dialect_option.h"
#include "ttp/gcode/execution.h"
#include "ttp/gcode/reader.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/verify/programs.h"
#include "ttp/verify/verify.h"

namespace ttp::app {
namespace {

struct VerifyCliOptions {
  std::string program_path;
  std::string dialect = "auto";
  std::string stage = "auto";
  std::string json_path;
  std::string after_path;
  double pitch_mm = 1.0;
  bool verbose = false;
  double rtest_interval_s = -1.0;  // < 0: the config's
};

void RegisterVerify(CLI::App& root, GlobalOptions& global) {
  auto opts = std::make_shared<VerifyCliOptions>();
  auto* cmd = root.add_subcommand(
      "verify",
      "simulate the cut of a program and check it (exit 1 when a check "
      "fails)");
  cmd->add_option("program", opts->program_path,
                  "program text (FANUC or LinuxCNC); without one, the "
                  "project's own two programs for the config are generated "
                  "and verified (pre-machining, then the test cycle on what "
                  "it left)");
  cmd->add_option("--dialect", opts->dialect,
                  "auto (default), fanuc or linuxcnc");
  cmd->add_option("--stage", opts->stage,
                  "pre (blank -> pre-machined), cycle (pre-machined -> "
                  "finished) or auto (default: cycle if it reports cuts)");
  cmd->add_option("--json", opts->json_path, "write the findings as JSON");
  cmd->add_option("--after", opts->after_path,
                  "test cycle: cut this pre-machining program from the blank "
                  "first (default: start from the drawing's ideal "
                  "pre-machined piece)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--pitch", opts->pitch_mm,
                  "spacing of the probe rays and the Z-dexel grid, mm "
                  "(default 1; surfaces are exact whatever the spacing)");
  cmd->add_flag("-v,--verbose", opts->verbose,
                "every check with its numbers, not only the summary");
  cmd->add_option("--rtest-interval", opts->rtest_interval_s,
                  "without a program: the test cycle with an R-test every "
                  "this many seconds (0 = none; default: the config's)")
      ->check(FiniteRange(0.0, 86400.0));
  cmd->callback([&global, opts] {
    Config config = global.LoadConfig();
    if (opts->rtest_interval_s >= 0) {
      if (!opts->program_path.empty())
        throw InputError("verify", 0, "--rtest-interval",
                         "only without a program (a given program is "
                         "verified as written)");
      config.process.rtest_interval_s = opts->rtest_interval_s;
    }
    if (!(opts->pitch_mm > 0.05 && opts->pitch_mm <= 10))
      throw InputError("--pitch", 0, "pitch", "must be in (0.05, 10] mm");
    if (opts->program_path.empty()) {
      if (!opts->after_path.empty() || opts->stage != "auto")
        throw InputError("verify", 0, "program",
                         "--after and --stage need a program");
      verify::VerifyOptions options;
      options.probe_pitch_mm = opts->pitch_mm;
      options.coarse_pitch_mm = opts->pitch_mm;
      const verify::ProgramsVerification v = verify::VerifyPrograms(
          config,
          opts->dialect == "auto"
              ? gcode::Dialect::kFanuc
              : gcode::ParseDialect(opts->dialect, "--dialect"),
          options);
      if (!opts->json_path.empty())
        WriteJson(opts->json_path, verify::ProgramsVerificationToJson(v));
      if (opts->json_path != "-") {
        std::cout << verify::FormatReportTable(v.pre, opts->verbose) << "\n"
                  << verify::FormatReportTable(v.cycle, opts->verbose)
                  << fmt::format(
                         "\nboth programs: {}; largest surface deviation "
                         "{:.4f} um\n",
                         v.Passed() ? "passed" : "FAILED",
                         v.MaxSurfaceDeviationUm());
      }
      if (!v.Passed()) global.exit_code = kExitJudgedFailure;
      return;
    }
    const std::string text = ReadTextFile(opts->program_path);
    const gcode::Dialect dialect =
        ChooseDialect(opts->dialect, text, opts->program_path);
    const auto statements =
        gcode::ReadProgram(text, dialect, config, opts->program_path);
    // The probing program (`ttp plan probe`) touches the finished piece
    // with the probe: verify simulates cutting programs and would take
    // every touch for a cut. Say what checks it instead.
    {
      const auto states = gcode::ExecutionStates(statements);
      for (size_t i = 0; i < statements.size(); ++i)
        if (statements[i].kind == gcode::CanonKind::kProbe &&
            states[i].tool == config.process.probe.number)
          throw InputError(
              opts->program_path, statements[i].source_line, "program",
              fmt::format(
                  "a probing program (a probe move with the probe, T{}): "
                  "ttp verify simulates the cutting programs (pre-machining "
                  "and test cycle). A probing program written by ttp plan "
                  "probe had its touches checked against the piece when it "
                  "was written; ttp gcode check compares it with LinuxCNC's "
                  "rs274",
                  config.process.probe.number));
    }
    verify::VerifyOptions options;
    options.stage = opts->stage == "auto"
                        ? verify::DetectStage(statements)
                        : verify::ParseStage(opts->stage, "--stage");
    options.probe_pitch_mm = opts->pitch_mm;
    options.coarse_pitch_mm = opts->pitch_mm;
    std::vector<gcode::CanonStatement> before;
    if (!opts->after_path.empty()) {
      if (options.stage != verify::VerifyStage::kCycle)
        throw InputError("--after", 0, "after",
                         "only a test-cycle program is verified after a "
                         "pre-machining program");
      const std::string pre_text = ReadTextFile(opts->after_path);
      before = gcode::ReadProgram(
          pre_text, ChooseDialect(opts->dialect, pre_text, opts->after_path),
          config, opts->after_path);
      options.after = &before;
    }
    const verify::VerifyReport report = verify::VerifyStatements(
        statements, config, options, opts->program_path);
    if (!opts->json_path.empty())
      WriteJson(opts->json_path, verify::ReportToJson(report));
    if (opts->json_path != "-")
      std::cout << verify::FormatReportTable(report, opts->verbose);
    if (!report.AllPassed()) global.exit_code = kExitJudgedFailure;
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(35, RegisterVerify);
}  // namespace ttp::app
