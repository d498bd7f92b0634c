#include "command.h"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <set>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"

namespace ttp::app {
namespace {
std::multimap<int, Registrar>& Registry() {
  static std::multimap<int, Registrar> registry;
  return registry;
}
}  // namespace

Config GlobalOptions::LoadConfig() const {
  if (config_path.empty()) return Config{};
  return ::ttp::LoadConfig(config_path);
}

int AddRegistrar(int order, Registrar registrar) {
  Registry().emplace(order, std::move(registrar));
  return 0;
}

void RegisterAll(CLI::App& root, GlobalOptions& global) {
  for (auto& [order, registrar] : Registry()) registrar(root, global);
}

void WriteText(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::cout << text;
    return;
  }
  WriteFileAtomic(path, text);
}

void WriteJson(const std::string& path, const nlohmann::json& doc) {
  WriteText(path, JsonText(doc, 2) + "\n");
}

void AddMeasurementOptions(CLI::App* cmd, MeasurementArgs* a) {
  cmd->add_option("--units", a->units,
                  "units of a point cloud: mm (default), m, in");
  cmd->add_option("--instrument", a->instrument,
                  "cloud uncertainty model: cmm (the CMM's MPE, default) or "
                  "none");
  cmd->add_option("--cmm-mpe-um", a->cmm_mpe_um,
                  "clouds and DMIS: the CMM's MPE a + L/b per touch, a in um "
                  "(default 1.2)")
      ->check(FiniteRange(1e-3, 1000.0));
  cmd->add_option("--cmm-mpe-l-mm", a->cmm_mpe_l_mm,
                  "clouds and DMIS: b of the MPE a + L/b, in mm (default 400)")
      ->check(FiniteRange(1e-3, 1e9));
  auto* points =
      cmd->add_option("--cmm-points", a->cmm_points,
                      "DMIS results: the point list of the CMM program that "
                      "measured them (cmm_points.csv of ttp plan cmm); "
                      "default: the default plan");
  cmd->add_option("--cmm-touches", a->cmm_touches,
                  "DMIS results of a program of one's own: touches per plane, "
                  "in the pattern of ttp plan cmm (instead of --cmm-points)")
      ->excludes(points);
  cmd->add_option("--probe-repeatability-um", a->probe_repeatability_um,
                  "probe results: standard uncertainty of one touch (um)")
      ->check(FiniteRange(0.0, 1000.0));
  cmd->add_option("--probe-points", a->probe_points,
                  "probe results: the point list of the program (ttp plan "
                  "probe); default: the default plan");
  cmd->add_option("--probe-frame", a->probe_frame,
                  "probe results: x, y, z in the machine frame (machine), the "
                  "work offset G54 as the program prints them (program), or "
                  "auto (default)");
  cmd->add_option("--dial-resolution-um", a->dial_resolution_um,
                  "dial readings: gauge resolution (um)")
      ->check(FiniteRange(0.0, 1000.0));
  cmd->add_option("--dial-repeatability-um", a->dial_repeatability_um,
                  "dial readings: standard uncertainty of one reading (um)")
      ->check(FiniteRange(0.0, 1000.0));
}

inspect::MeasurementOptions ToMeasurementOptions(const MeasurementArgs& a,
                                                 const CLI::App& cmd) {
  inspect::MeasurementOptions mo;
  mo.read.units = inspect::ParseLengthUnit(a.units);
  mo.read.units_given = cmd.get_option("--units")->count() > 0;
  if (a.instrument == "none")
    mo.inspect.instrument = inspect::Instrument::kNone;
  else if (a.instrument != "cmm")
    throw InputError("--instrument", 0, "instrument",
                     "'" + a.instrument + "' is not cmm or none");
  mo.inspect.check_units = !mo.read.units_given;
  // One CMM: the same MPE for its scanned clouds and its DMIS planes.
  mo.dmis.cmm_mpe_um = a.cmm_mpe_um;
  mo.dmis.cmm_mpe_l_mm = a.cmm_mpe_l_mm;
  mo.dmis.points_csv_path = a.cmm_points;
  mo.dmis.touches_per_plane = a.cmm_touches;
  mo.dmis.Validate();
  mo.inspect.cmm_mpe_um = a.cmm_mpe_um;
  mo.inspect.cmm_mpe_l_mm = a.cmm_mpe_l_mm;
  mo.probe.repeatability_um = a.probe_repeatability_um;
  mo.probe.points_csv_path = a.probe_points;
  if (a.probe_frame == "machine")
    mo.probe.frame = inspect::ProbeFrame::kMachine;
  else if (a.probe_frame == "program")
    mo.probe.frame = inspect::ProbeFrame::kProgram;
  else if (a.probe_frame != "auto")
    throw InputError("--probe-frame", 0, "probe_frame",
                     "'" + a.probe_frame + "' is not auto, machine or program");
  mo.probe.Validate();
  mo.dial.resolution_um = a.dial_resolution_um;
  mo.dial.repeatability_um = a.dial_repeatability_um;
  mo.dial.Validate();
  return mo;
}

void AddLimitOptions(CLI::App* cmd, inspect::GradeLimits* limits,
                     std::string* figures) {
  cmd->add_option("--limit-linear-um", limits->linear_um,
                  "limit of E_X, E_Y, E_Z, E_TTP in um (thesis action limit)")
      ->capture_default_str();
  cmd->add_option("--limit-angular-um-per-m", limits->angular_um_per_m,
                  "limit of E_B (and E_C) in um/m (thesis action limit)")
      ->capture_default_str();
  cmd->add_option("--limits-basis", limits->basis,
                  "where the limits come from, shown with the verdict (e.g. "
                  "\"customer agreement 2026-04\")");
  cmd->add_option("--figures", *figures,
                  "figures graded: thesis (E_X,E_Y,E_Z,E_B,E_TTP), all (adds "
                  "E_C) or a comma-separated list")
      ->capture_default_str();
}

CLI::Option* AddOutputOption(CLI::App* cmd, std::string* path,
                             const std::string& what, bool required) {
  CLI::Option* o = cmd->add_option("-o,--output", *path, what);
  if (required) o->required();
  return o;
}

CLI::Option* AddJsonOption(CLI::App* cmd, std::string* path,
                           const std::string& what) {
  return cmd->add_option("--json", *path, what + " ('-': pure JSON on stdout)");
}

std::ostream& TextOut(const std::string& json_path) {
  return JsonToStdout(json_path) ? std::cerr : std::cout;
}

CLI::Option* AddVerboseFlag(CLI::App* cmd, bool* verbose) {
  return cmd->add_flag("-v,--verbose", *verbose, "details after the summary");
}

namespace {

// Options whose values are names (enums): compared case-insensitively.
const std::set<std::string>& EnumOptions() {
  static const std::set<std::string> names = {
      "--dialect",    "--effect",      "--compensation", "--robust", "--units",
      "--instrument", "--probe-frame", "--measurement",  "--cause"};
  return names;
}

// Options that hold counts or seeds: a negative value is an error, not a
// wrap-around to 2^64 - 1.
const std::set<std::string>& NonNegativeOptions() {
  static const std::set<std::string> names = {"--seed", "--points", "--cycles",
                                              "--runs", "--threads"};
  return names;
}

void ApplyTo(CLI::App* app) {
  for (CLI::Option* o : app->get_options()) {
    std::string long_name;
    for (const std::string& n : o->get_lnames()) long_name = "--" + n;
    if (EnumOptions().count(long_name)) {
      o->transform(
          [](std::string v) {
            std::transform(v.begin(), v.end(), v.begin(), [](unsigned char c) {
              return static_cast<char>(std::tolower(c));
            });
            return v;
          },
          "", "case-insensitive");
    }
    // An output given as an empty word (`--json ""`, a shell variable
    // left unset) would be skipped without a word: refused instead.
    if (long_name == "--json" || long_name == "--output" ||
        long_name == "--csv" || long_name == "--points-csv") {
      o->check(CLI::Validator(
          [](std::string& v) {
            return v.empty() ? std::string(
                                   "needs a file name (- for "
                                   "standard output)")
                             : std::string();
          },
          "", "output path"));
    }
    if (NonNegativeOptions().count(long_name)) {
      o->check(CLI::Validator(
          [](std::string& v) {
            return !v.empty() && v[0] == '-'
                       ? std::string("must be 0 or more, not ") + v
                       : std::string();
          },
          "", "non-negative"));
    }
  }
  for (CLI::App* sub : app->get_subcommands({})) ApplyTo(sub);
}

std::vector<std::string> OptionNames(const CLI::App& app) {
  std::vector<std::string> out;
  for (const CLI::Option* o : app.get_options()) {
    for (const std::string& n : o->get_lnames()) out.push_back("--" + n);
    for (const std::string& n : o->get_snames()) out.push_back("-" + n);
  }
  return out;
}

}  // namespace

void ApplyConventions(CLI::App& root) { ApplyTo(&root); }

int EditDistance(const std::string& a, const std::string& b) {
  // Optimal string alignment: Levenshtein plus the swap of two neighbours,
  // the commonest typo ("grdae").
  const size_t n = a.size(), m = b.size();
  std::vector<std::vector<int>> d(n + 1, std::vector<int>(m + 1));
  for (size_t i = 0; i <= n; ++i) d[i][0] = static_cast<int>(i);
  for (size_t j = 0; j <= m; ++j) d[0][j] = static_cast<int>(j);
  for (size_t i = 1; i <= n; ++i) {
    for (size_t j = 1; j <= m; ++j) {
      const int cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] =
          std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

std::string ClosestMatch(const std::string& word,
                         const std::vector<std::string>& candidates) {
  std::string best;
  int best_d = std::max(1, static_cast<int>(word.size()) / 3) + 1;
  for (const std::string& c : candidates) {
    const int d = EditDistance(word, c);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  return best;
}

std::string DidYouMean(const CLI::App& root, int argc,
                       const char* const* argv) {
  // The subcommand chain named on the command line, then the first word
  // that is neither a known subcommand nor a known option.
  const CLI::App* app = &root;
  std::vector<std::string> known = OptionNames(root);
  for (int i = 1; i < argc; ++i) {
    std::string word = argv[i];
    if (word == "--") break;
    const std::string name = word.substr(0, word.find('='));
    char* end = nullptr;
    std::strtod(word.c_str(), &end);
    const bool number = !word.empty() && end != nullptr && *end == '\0';
    if (name.rfind("-", 0) == 0 && !number) {
      std::vector<std::string> here = OptionNames(*app);
      here.insert(here.end(), known.begin(), known.end());
      if (std::find(here.begin(), here.end(), name) != here.end()) continue;
      const std::string match = ClosestMatch(name, here);
      if (!match.empty())
        return "unknown option '" + name + "'; did you mean '" + match + "'?";
      continue;
    }
    std::vector<std::string> subs;
    const CLI::App* next = nullptr;
    for (const CLI::App* sub : app->get_subcommands({})) {
      subs.push_back(sub->get_name());
      if (sub->get_name() == word) next = sub;
    }
    if (next != nullptr) {
      known = OptionNames(*app);
      app = next;
      continue;
    }
    // A positional argument of the current command, or a misspelt
    // subcommand when the command has subcommands and takes none.
    if (!subs.empty() && app->get_require_subcommand_min() > 0) {
      const std::string match = ClosestMatch(word, subs);
      if (!match.empty())
        return "unknown command '" + word + "'; did you mean '" + match + "'?";
    }
  }
  return "";
}

bool StdoutIsTerminal() { return ::isatty(STDOUT_FILENO) != 0; }

thermal::TalcLog ReadTalcLogWarning(const std::string& path,
                                    const GlobalOptions& global) {
  thermal::TalcLog log = thermal::ReadTalcLog(path);
  if (!global.quiet)
    for (const thermal::LogWarning& w : log.warnings)
      std::fprintf(stderr, "warning: %s:%d: %s\n", path.c_str(), w.line,
                   w.message.c_str());
  return log;
}

void PrintMeasurementWarnings(const std::string& path,
                              const std::vector<std::string>& warnings,
                              const GlobalOptions& global) {
  if (global.quiet) return;
  for (const std::string& w : warnings)
    std::fprintf(stderr, "warning: %s: %s\n", path.c_str(), w.c_str());
}

}  // namespace ttp::app
