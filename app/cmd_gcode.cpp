// `ttp gcode pre|cycle|read|translate|check`: the two NC programs of the
// piece, the program reader, the dialect translation and the independent
// check with LinuxCNC's rs274.
#include <fmt/format.h>

#include <cmath>
#include <iostream>

#include "command.h"
#include "dialect_option.h"
#include "ttp/cam/programs.h"
#include "ttp/gcode/canon_to_program.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"

namespace ttp::app {
namespace {

using namespace ttp::gcode;

struct GcodeOptions {
  std::string program_path;
  std::string dialect = "auto";
  std::string output = "-";
  std::string to;
};

nlohmann::json StatementToJson(const CanonStatement& s) {
  nlohmann::json j;
  j["kind"] = CanonKindName(s.kind);
  j["line"] = s.source_line;
  j["end_mm"] = {s.end_mm.x(), s.end_mm.y(), s.end_mm.z()};
  j["end_c_deg"] = s.end_c_rad * 180.0 / M_PI;
  // The controlled point is the tip only with the spindle tool's offset.
  j["length_offset_mm"] = s.length_offset_mm;
  if (s.length_offset_tool >= 0) j["length_offset_tool"] = s.length_offset_tool;
  if (s.kind == CanonKind::kFeed || s.kind == CanonKind::kProbe)
    j["feed_per_min"] = s.feed_per_min;
  j["value"] = s.value;
  if (s.kind == CanonKind::kSpindle || s.kind == CanonKind::kCSpin)
    j["clockwise"] = s.clockwise;
  if (!s.text.empty()) j["text"] = s.text;
  j["start_s"] = s.start_s;
  j["duration_s"] = s.duration_s;
  return j;
}

// The program's statements as JSON text, one statement per line: written
// statement by statement, because a document tree of a long program (a
// million lines of CAM output) takes ten times the memory of the text.
std::string ReadResultJson(const std::string& program, Dialect dialect,
                           const std::vector<CanonStatement>& statements) {
  std::string out = "{\n  \"dialect\": " + JsonText(DialectName(dialect)) +
                    ",\n  \"program\": " + JsonText(program) +
                    ",\n  \"statements\": [";
  for (size_t i = 0; i < statements.size(); ++i) {
    out += i == 0 ? "\n    " : ",\n    ";
    out += JsonText(StatementToJson(statements[i]));
  }
  out += statements.empty() ? "]" : "\n  ]";
  out += ",\n  \"total_s\": " + JsonText(TotalDuration(statements)) + "\n}\n";
  return out;
}

void RegisterGcode(CLI::App& root, GlobalOptions& global) {
  auto* gcode = root.add_subcommand(
      "gcode",
      "write the piece's programs; read, translate and check FANUC / "
      "LinuxCNC programs");
  gcode->require_subcommand(1);
  auto opts = std::make_shared<GcodeOptions>();
  const auto add_common = [&](CLI::App* cmd) {
    cmd->add_option("program", opts->program_path, "program text")
        ->required()
        ->check(CLI::ExistingFile);
    cmd->add_option("--dialect", opts->dialect,
                    "auto (default), fanuc or linuxcnc");
  };

  // The two programs of the piece.
  const auto add_program = [&](const char* name, const char* help,
                               gcode::Program (*build)(const Config&)) {
    auto* cmd = gcode->add_subcommand(name, help);
    auto dialect = std::make_shared<std::string>("fanuc");
    auto output = std::make_shared<std::string>("-");
    cmd->add_option("--dialect", *dialect, "fanuc (default) or linuxcnc");
    cmd->add_option("-o,--output", *output, "text here (default stdout)");
    auto dry_run = std::make_shared<double>(-1.0);
    cmd->add_option("--dry-run", *dry_run,
                    "shorten every dwell to at most this many seconds (a "
                    "trial run on a controller; nothing else changes)")
        ->check(FiniteRange(0.0, 86400.0));
    auto rtest_interval = std::make_shared<double>(-1.0);
    if (std::string(name) == "cycle")
      cmd->add_option("--rtest-interval", *rtest_interval,
                      "R-test every this many seconds (0 = none; default: "
                      "process.rtest_interval_s of the config)")
          ->check(FiniteRange(0.0, 86400.0));
    cmd->callback([&global, dialect, output, build, dry_run, rtest_interval] {
      const Dialect d = ParseDialect(*dialect, "--dialect");
      Config config = global.LoadConfig();
      if (*rtest_interval >= 0)
        config.process.rtest_interval_s = *rtest_interval;
      gcode::Program program = build(config);
      if (*dry_run >= 0) cam::ShortenDwells(program, *dry_run);
      WriteText(*output, WriteProgram(program, d, config));
    });
  };
  add_program("pre", "write the pre-machining program (steps 1-5, NC hold)",
              &cam::BuildPreMachiningProgram);
  add_program("cycle", "write the 8-hour test-cycle program",
              &cam::BuildTestCycleProgram);

  auto* read = gcode->add_subcommand(
      "read", "canonical statements and times of a program (JSON)");
  add_common(read);
  read->add_option("-o,--output", opts->output, "JSON here (default stdout)");
  read->callback([&global, opts] {
    const Config config = global.LoadConfig();
    const std::string text = ReadTextFile(opts->program_path);
    const Dialect dialect =
        ChooseDialect(opts->dialect, text, opts->program_path);
    const auto statements =
        ReadProgram(text, dialect, config, opts->program_path);
    WriteText(opts->output,
              ReadResultJson(opts->program_path, dialect, statements));
  });

  auto* translate = gcode->add_subcommand(
      "translate", "write a program in the other dialect");
  add_common(translate);
  translate->add_option("--to", opts->to, "fanuc or linuxcnc")->required();
  translate->add_option("-o,--output", opts->output,
                        "text here (default stdout)");
  translate->callback([&global, opts] {
    const Config config = global.LoadConfig();
    const std::string text = ReadTextFile(opts->program_path);
    const Dialect from = ChooseDialect(opts->dialect, text, opts->program_path);
    const Dialect to = ParseDialect(opts->to, "--to");
    const auto statements = ReadProgram(text, from, config, opts->program_path);
    const Program program = ProgramFromCanon(
        statements, "translated", config.machine.program_number,
        "translated from " + opts->program_path, opts->program_path);
    WriteText(opts->output, WriteProgram(program, to, config));
  });

  auto* check = gcode->add_subcommand(
      "check",
      "run LinuxCNC's rs274 on the program (FANUC: on its translation) and "
      "compare with our reader; exit 1 when they differ");
  add_common(check);
  check->callback([&global, opts] {
    const Config config = global.LoadConfig();
    const std::string text = ReadTextFile(opts->program_path);
    const Dialect dialect =
        ChooseDialect(opts->dialect, text, opts->program_path);
    auto ours = ReadProgram(text, dialect, config, opts->program_path);
    std::string ngc = text;
    if (dialect == Dialect::kFanuc) {
      ngc = WriteProgram(ProgramFromCanon(ours, "translated", 1, "translated",
                                          opts->program_path),
                         Dialect::kLinuxCnc, config);
      // The probing log's rows become LinuxCNC LOG lines, which rs274 does
      // not report: they are not part of the compared toolpath.
      for (CanonStatement& s : ours)
        if (s.kind == CanonKind::kReport && IsProbeLogReport(s.text))
          s.kind = CanonKind::kComment;
    }
    Rs274Result rs;
    try {
      rs = RunRs274(ngc, config);
    } catch (const InputError& e) {
      if (e.source() != "rs274") throw;
      // rs274 numbers the blocks by the program's own lines; a FANUC
      // program is checked through its translation, whose lines differ.
      const bool own_lines = dialect == Dialect::kLinuxCnc;
      throw InputError(opts->program_path, own_lines ? e.line() : 0, "rs274",
                       std::string("LinuxCNC's interpreter refuses the "
                                   "program") +
                           (own_lines ? "" : " (its LinuxCNC translation)") +
                           ": " + e.problem());
    }
    const ToolpathDifference d =
        CompareToolpaths(ours, rs.statements, rs.ResolutionMm());
    if (d.same) {
      if (!global.quiet)
        std::cout << fmt::format(
            "same toolpath: {} statements, ours {:.3f} s, rs274 {:.3f} s\n",
            ours.size(), TotalDuration(ours), TotalDuration(rs.statements));
    } else {
      std::cout << fmt::format("differ: {} (program line {}, rs274 line {})\n",
                               d.what, d.line_a, d.line_b);
      global.exit_code = kExitJudgedFailure;
    }
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(20, RegisterGcode);
}  // namespace ttp::app
