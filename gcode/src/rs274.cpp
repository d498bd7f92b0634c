#include "ttp/gcode/rs274.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <stdlib.h>
#include <sys/file.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "canon_builder.h"
#include "ttp/gcode/reader.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/frames.h"

namespace ttp::gcode {
namespace fs = std::filesystem;
namespace {

constexpr const char* kRs274Path = "/usr/bin/rs274";
constexpr const char* kReportPrefix = "ttp-report:";
constexpr double kMmPerInch = 25.4;

// Removes the temporary folder whatever happens.
struct TempDir {
  fs::path path;
  TempDir() {
    std::string templ =
        (fs::temp_directory_path() / "ttp-rs274-XXXXXX").string();
    if (!mkdtemp(templ.data()))
      throw std::runtime_error("cannot create a temporary folder for rs274");
    path = templ;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::string IniText() {
  return "[EMC]\nVERSION = 1.1\n"
         "[RS274NGC]\nPARAMETER_FILE = ttp.var\n"
         "[TRAJ]\nCOORDINATES = XYZBC\nLINEAR_UNITS = mm\n"
         "ANGULAR_UNITS = degree\nSPINDLES = 2\n"
         "[KINS]\nJOINTS = 5\nKINEMATICS = trivkins coordinates=XYZBC\n";
}

// G54 active with W's origin height as its Z offset, so that G53 (machine
// coordinates) means what it means on the machine. rs274 reads the
// parameter file in inches, as the tool table.
std::string VarFileText(const Config& config) {
  return fmt::format("5220\t1.000000\n5223\t{:.8f}\n",
                     WorkpieceOriginHeightMm(config) / kMmPerInch);
}

// rs274 reads the tool table in inches whatever the INI says.
std::string ToolTableText(const Config& config) {
  std::string out;
  std::set<int> written;
  for (const ToolSpec* t : config.process.Tools()) {
    if (!written.insert(t->number).second) continue;
    out += fmt::format("T{0} P{0} Z{1:.6f} D{2:.6f} ;{3}\n", t->number,
                       t->length_mm / kMmPerInch, t->diameter_mm / kMmPerInch,
                       t->name);
  }
  return out;
}

// Numbers every block with its line so that canon lines name it, and routes
// (print,...) to MESSAGE so that reports keep their place in the canon.
std::string PrepareProgram(const std::string& ngc_text) {
  std::stringstream in(ngc_text);
  std::string line, out;
  int number = 0;
  static const std::regex print_re(R"(\(\s*print\s*,)", std::regex::icase);
  // The program's own block number (after an optional block delete) gives
  // way to the line's: a block takes one N word.
  static const std::regex number_re(R"(^\s*(/?)\s*[nN]\s*[0-9]+(\.[0-9]*)?)");
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string t = Trim(line);
    if (t.empty() || t == "%") {
      out += line + "\n";
      continue;
    }
    line = std::regex_replace(line, print_re,
                              std::string("(debug,") + kReportPrefix);
    std::smatch m;
    std::string slash;
    if (std::regex_search(line, m, number_re)) {
      slash = m[1].str();
      line = m.suffix().str();
    } else if (t[0] == '/') {
      slash = "/";
      line = line.substr(line.find('/') + 1);
    }
    out += fmt::format("{}N{} {}\n", slash, number, line);
  }
  return out;
}

struct CanonCall {
  int line = 0;
  std::string name;
  std::string args;
  int canon_line = 0;
};

std::vector<double> Numbers(const CanonCall& call, const std::string& source) {
  std::vector<double> out;
  std::string a = call.args;
  for (char& ch : a)
    if (ch == ',') ch = ' ';
  std::stringstream ss(a);
  std::string tok;
  while (ss >> tok) {
    try {
      out.push_back(std::stod(tok));
    } catch (const std::exception&) {
      throw InputError(source, call.canon_line, call.name,
                       "bad number '" + tok + "'");
    }
  }
  return out;
}

std::string StringArg(const CanonCall& call) {
  const size_t a = call.args.find('"');
  const size_t b = call.args.rfind('"');
  if (a == std::string::npos || b <= a) return call.args;
  return call.args.substr(a + 1, b - a - 1);
}

}  // namespace

bool Rs274Available() { return access(kRs274Path, X_OK) == 0; }

std::vector<CanonStatement> ParseRs274Canon(const std::string& canon_text,
                                            const std::string& source,
                                            int c_clamp_output,
                                            const Eigen::Vector3d& start_mm) {
  static const std::regex line_re(
      R"(^\s*\d+\s+N(\.+|\d+)\s*([A-Z_0-9]+)\((.*)\)\s*.*$)");
  std::vector<CanonCall> calls;
  std::stringstream in(canon_text);
  std::string line;
  int canon_line = 0;
  int end_line = -1;
  while (std::getline(in, line)) {
    ++canon_line;
    if (Trim(line).empty()) continue;
    std::smatch m;
    // The closing ")" is the last one on the line (messages may hold some).
    const size_t close = line.rfind(')');
    const std::string head =
        close == std::string::npos ? line : line.substr(0, close + 1);
    if (!std::regex_match(head, m, line_re))
      throw InputError(source, canon_line, "", "not a canon line: " + line);
    CanonCall call;
    call.line = m[1].str()[0] == '.' ? 0 : std::stoi(m[1].str());
    call.name = m[2];
    call.args = m[3];
    call.canon_line = canon_line;
    if (call.name == "PROGRAM_END") end_line = call.line;
    calls.push_back(call);
  }

  CanonBuilder builder;
  builder.SetStart(start_mm);
  int selected_tool = -1;
  double units = 1.0;
  double feed = 0;
  for (const CanonCall& call : calls) {
    // M30 resets spindles, feed and offsets on its own line: not actions of
    // the program (our reader emits only kEnd for M30).
    if (end_line >= 0 && call.line == end_line && call.name != "PROGRAM_END")
      continue;
    builder.SetLine(call.line);
    const std::string& n = call.name;
    if (n == "USE_LENGTH_UNITS") {
      units = call.args.find("INCHES") != std::string::npos ? kMmPerInch : 1.0;
    } else if (n == "SET_FEED_RATE") {
      feed = Numbers(call, source).at(0);
    } else if (n == "STRAIGHT_TRAVERSE" || n == "STRAIGHT_FEED" ||
               n == "STRAIGHT_PROBE") {
      const auto v = Numbers(call, source);
      if (v.size() < 6)
        throw InputError(source, call.canon_line, n, "expected 6 coordinates");
      const Eigen::Vector3d to(v[0] * units, v[1] * units, v[2] * units);
      const bool pure_c = (to - builder.position_mm()).norm() == 0;
      const double f = pure_c ? feed : feed * units;
      if (n == "STRAIGHT_TRAVERSE")
        builder.Traverse(to, v[5]);
      else if (n == "STRAIGHT_FEED")
        builder.Feed(to, v[5], f);
      else
        builder.Probe(to, v[5], f);
    } else if (n == "DWELL") {
      builder.Dwell(Numbers(call, source).at(0));
    } else if (n == "SET_SPINDLE_SPEED") {
      const auto v = Numbers(call, source);
      builder.SetSpindleSpeed(static_cast<int>(v.at(0)), v.at(1));
    } else if (n == "START_SPINDLE_CLOCKWISE" ||
               n == "START_SPINDLE_COUNTERCLOCKWISE") {
      builder.StartSpindle(static_cast<int>(Numbers(call, source).at(0)),
                           n == "START_SPINDLE_CLOCKWISE");
    } else if (n == "STOP_SPINDLE_TURNING") {
      builder.StopSpindle(static_cast<int>(Numbers(call, source).at(0)));
    } else if (n == "FLOOD_ON") {
      builder.SetCoolant(true);
    } else if (n == "FLOOD_OFF") {
      builder.SetCoolant(false);
    } else if (n == "SELECT_TOOL") {
      selected_tool = static_cast<int>(Numbers(call, source).at(0));
    } else if (n == "CHANGE_TOOL") {
      // CHANGE_TOOL names the tool-table slot; SELECT_TOOL the tool number.
      builder.ChangeTool(selected_tool >= 0
                             ? selected_tool
                             : static_cast<int>(Numbers(call, source).at(0)));
    } else if (n == "USE_TOOL_LENGTH_OFFSET") {
      // (x y z a b c u v w), in program units (inches under G20).
      builder.SetToolLengthOffset(Numbers(call, source).at(2) * units);
    } else if (n == "SET_AUX_OUTPUT_BIT" || n == "CLEAR_AUX_OUTPUT_BIT") {
      if (static_cast<int>(Numbers(call, source).at(0)) == c_clamp_output)
        builder.SetClamp(n == "SET_AUX_OUTPUT_BIT");
    } else if (n == "MESSAGE") {
      const std::string text = StringArg(call);
      ReportText report;
      if (text.rfind(kReportPrefix, 0) == 0)
        builder.Report(text.substr(std::string(kReportPrefix).size()));
      else if (ParseReportText(text, &report))
        builder.Report(text);  // (debug,cut,...): a report queued with motion
      else
        builder.Comment(text);
    } else if (n == "COMMENT") {
      const std::string text = StringArg(call);
      if (text.rfind("interpreter:", 0) != 0) builder.Comment(text);
    } else if (n == "PROGRAM_END") {
      builder.End();
    }
    // Everything else (offsets, planes, feed modes, tool selection, mist,
    // ON_RESET...) has no canonical effect here.
  }
  return builder.Take();
}

Rs274Result RunRs274(const std::string& ngc_text, const Config& config) {
  if (!Rs274Available())
    throw std::runtime_error(std::string(kRs274Path) + " is not installed");
  TempDir dir;
  WriteFileAtomic(dir.path / "ttp.ini", IniText());
  WriteFileAtomic(dir.path / "ttp.tbl", ToolTableText(config));
  WriteFileAtomic(dir.path / "ttp.var", VarFileText(config));
  WriteFileAtomic(dir.path / "prog.ngc", PrepareProgram(ngc_text));
  const std::string cmd = fmt::format(
      "cd '{}' && {} -g -n 2 -i ttp.ini -v ttp.var -t ttp.tbl prog.ngc "
      "out.canon "
      "</dev/null >stdout.txt 2>stderr.txt",
      dir.path.string(), kRs274Path);
  int status = 0;
  {
    // rs274 instances share a memory segment and die of a bus error when
    // two run at once (parallel ctest): one at a time per machine.
    const std::string lock_path =
        (fs::temp_directory_path() / "ttp-rs274.lock").string();
    const int lock_fd = open(lock_path.c_str(), O_CREAT | O_RDWR, 0666);
    if (lock_fd >= 0) flock(lock_fd, LOCK_EX);
    status = std::system(cmd.c_str());
    if (lock_fd >= 0) close(lock_fd);  // releases the lock
  }
  Rs274Result result;
  result.stderr_text = ReadTextFile(dir.path / "stderr.txt");
  if (fs::exists(dir.path / "out.canon"))
    result.canon_text = ReadTextFile(dir.path / "out.canon");
  if (status != 0) {
    // stderr: "executing", the message, then the offending block "N<line> ...".
    std::stringstream err(result.stderr_text);
    std::string l, message;
    int line = 0;
    static const std::regex block_re(R"(^N(\d+)\s.*)");
    while (std::getline(err, l)) {
      l = Trim(l);
      std::smatch m;
      if (std::regex_match(l, m, block_re))
        line = std::stoi(m[1]);
      else if (!l.empty() && l != "executing" && message.empty())
        message = l;
    }
    if (message.empty()) message = fmt::format("rs274 failed ({})", status);
    throw InputError("rs274", line, "", message);
  }
  const Eigen::Vector3d start(0, 0, -WorkpieceOriginHeightMm(config));
  result.inches =
      result.canon_text.find("CANON_UNITS_INCHES") != std::string::npos;
  result.statements =
      ParseRs274Canon(result.canon_text, "rs274 canon",
                      config.machine.linuxcnc_c_clamp_output, start);
  ApplyTimeModel(result.statements, config.machine, start);
  return result;
}

}  // namespace ttp::gcode
