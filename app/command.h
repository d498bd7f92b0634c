// Subcommand registry of the `ttp` program. Each cmd_<area>.cpp registers
// its subcommands with a static TTP_REGISTER_COMMANDS(fn); main() builds the
// CLI from the registry, runs the chosen callback and maps errors to exit
// codes: 0 ok, 1 a judged failure, 2 bad input or usage, 3 a bug in ttp.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/inspect/grade.h"
#include "ttp/inspect/measurement.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::app {

constexpr int kExitOk = 0;
constexpr int kExitJudgedFailure = 1;
constexpr int kExitBadInput = 2;
constexpr int kExitInternalError = 3;  // a bug in ttp, never the input's fault

struct GlobalOptions {
  std::string config_path;  // --config FILE (TOML/JSON), empty = defaults
  bool quiet = false;       // --quiet: no progress, no info messages
  int exit_code = kExitOk;  // set by a command to report a judged failure

  // The config from --config, or the embedded defaults.
  Config LoadConfig() const;
};

using Registrar = std::function<void(CLI::App& root, GlobalOptions& global)>;

// Called from static initialisers; returns a dummy so it can run there.
int AddRegistrar(int order, Registrar registrar);
void RegisterAll(CLI::App& root, GlobalOptions& global);

// Writes JSON (pretty, stable key order) atomically; "-" = stdout.
void WriteJson(const std::string& path, const nlohmann::json& doc);
// Writes text atomically; "-" = stdout.
void WriteText(const std::string& path, const std::string& text);

// The grading options shared by `grade`, `report` and `run`:
// --limit-linear-um, --limit-angular-um-per-m, --limits-basis and
// --figures (a list such as "E_X,E_B", "thesis" or "all"; parse it with
// inspect::ParseFigureList into limits->figures).
void AddLimitOptions(CLI::App* cmd, inspect::GradeLimits* limits,
                     std::string* figures);

// How a measurement was taken, for every command that reads one (inspect,
// grade, check, diagnose, report): cloud units and uncertainty model, the
// CMM's MPE and the touches behind DMIS planes, the probe's point list and
// repeatability, the dial gauge.
struct MeasurementArgs {
  std::string units = "mm";
  std::string instrument = "cmm";
  double cmm_mpe_um = 1.2;
  double cmm_mpe_l_mm = 400.0;
  std::string cmm_points;
  int cmm_touches = 0;
  double probe_repeatability_um = 0.5;
  std::string probe_points;
  std::string probe_frame = "auto";
  double dial_resolution_um = 1.0;
  double dial_repeatability_um = 0.5;
};
void AddMeasurementOptions(CLI::App* cmd, MeasurementArgs* args);
// InputError naming the option for a bad value. `cmd` is the command the
// options were added to (whether --units was given).
inspect::MeasurementOptions ToMeasurementOptions(const MeasurementArgs& args,
                                                 const CLI::App& cmd);

// ---- Shared conventions of every subcommand (one option vocabulary) ----
// -o/--output: the command's main output (a file or a folder).
CLI::Option* AddOutputOption(CLI::App* cmd, std::string* path,
                             const std::string& what, bool required = false);
// --json FILE: the command's result as JSON; "-" writes pure JSON to stdout
// (the command then sends its table to stderr or leaves it out: see
// JsonToStdout).
CLI::Option* AddJsonOption(CLI::App* cmd, std::string* path,
                           const std::string& what = "the result as JSON");
inline bool JsonToStdout(const std::string& json_path) {
  return json_path == "-";
}
// Where a command prints its readable result: stdout, or stderr when
// `--json -` takes stdout.
std::ostream& TextOut(const std::string& json_path);
// -v/--verbose: details after the summary.
CLI::Option* AddVerboseFlag(CLI::App* cmd, bool* verbose);

// Applied by main() to the whole command tree after registration: values of
// enum-like options are case-insensitive (--dialect FANUC), counts and
// seeds must be non-negative (no wrap-around of -1), defaults are shown in
// the help.
void ApplyConventions(CLI::App& root);

// Edit distance: insert, delete, substitute, swap two neighbours (1 each).
int EditDistance(const std::string& a, const std::string& b);
// The closest of `candidates` to `word` within a distance that still reads
// as a typo (about a third of the word); empty when none is.
std::string ClosestMatch(const std::string& word,
                         const std::vector<std::string>& candidates);
// "did you mean" for a command line CLI11 refused: an unknown subcommand
// or option of the chosen subcommand. Empty when it has no suggestion.
std::string DidYouMean(const CLI::App& root, int argc, const char* const* argv);

// A CLI11 check: a finite number in [min, max] (CLI::Range lets NaN pass).
inline CLI::Validator FiniteRange(double min, double max) {
  return CLI::Validator(
      [min, max](std::string& text) -> std::string {
        char* end = nullptr;
        const double v = std::strtod(text.c_str(), &end);
        if (text.empty() || *end != '\0' || !(v >= min && v <= max))
          return "'" + text + "' is not a number in [" +
                 CLI::detail::to_string(min) + ", " +
                 CLI::detail::to_string(max) + "]";
        return std::string();
      },
      "NUMBER in [" + CLI::detail::to_string(min) + ", " +
          CLI::detail::to_string(max) + "]");
}

// True when stdout is a terminal (progress displays only then).
bool StdoutIsTerminal();

// Reads a TALC log and prints its lenient problems (gaps, dropped
// duplicates, unknown events: talc-log.md section 4) as warnings on
// stderr, naming file and line, unless --quiet.
thermal::TalcLog ReadTalcLogWarning(const std::string& path,
                                    const GlobalOptions& global);

// Prints a measurement's own warnings (inspect::LoadMeasurement: figures
// without U, a feature missing, stale figures) on stderr, naming the file,
// unless --quiet; `check` and `diagnose` also write them to their JSON as
// "measurement_warnings".
void PrintMeasurementWarnings(const std::string& path,
                              const std::vector<std::string>& warnings,
                              const GlobalOptions& global);

}  // namespace ttp::app

#define TTP_CONCAT_INNER(a, b) a##b
#define TTP_CONCAT(a, b) TTP_CONCAT_INNER(a, b)
// order: position in `ttp --help` (lower first).
#define TTP_REGISTER_COMMANDS(order, fn)                     \
  static const int TTP_CONCAT(ttp_registrar_, __COUNTER__) = \
      ::ttp::app::AddRegistrar(order, fn)
