#include "ttp/gcode/writer.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <type_traits>

#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

// Parentheses would end a comment early; both controls forbid nesting.
std::string SafeCommentText(const std::string& text) {
  std::string out = text;
  for (char& ch : out) {
    if (ch == '(') ch = '[';
    if (ch == ')') ch = ']';
    if (ch == '\n' || ch == '\r') ch = ' ';
  }
  return out;
}

class Writer {
 public:
  Writer(const Program& program, Dialect dialect, const Config& config)
      : program_(program), dialect_(dialect), config_(config) {}

  std::string Write() {
    const bool fanuc = dialect_ == Dialect::kFanuc;
    Line("%");
    if (fanuc) {
      Line(fmt::format("O{} ({})", program_.number,
                       SafeCommentText(program_.title)));
    } else {
      Line(fmt::format("({})", SafeCommentText(program_.title)));
    }
    // Safety block: plane, units, no cutter or length compensation, no
    // tilted plane (FANUC G69), no canned cycle, absolute, feed per minute;
    // LinuxCNC path blending within a tolerance.
    if (fanuc)
      Line("G17 G21 G40 G49 G69 G80 G90 G94");
    else if (program_.exact_stop)
      Line("G17 G21 G40 G49 G80 G90 G94 G61");
    else
      Line(fmt::format("G17 G21 G40 G49 G80 G90 G94 G64 P{:.3f}",
                       kLinuxCncBlendToleranceMm));
    Line("G54");
    for (size_t i = 0; i < program_.statements.size(); ++i) {
      index_ = i;
      const Statement& s = program_.statements[i];
      if (fanuc && !report_open_ &&
          (std::holds_alternative<Report>(s) ||
           std::holds_alternative<Probe>(s))) {
        Line("POPEN");
        report_open_ = true;
      }
      if (fanuc && report_open_ && std::holds_alternative<ProgramEnd>(s)) {
        Line("PCLOS");
        report_open_ = false;
      }
      std::visit([this](const auto& st) { Emit(st); }, s);
    }
    if (report_open_) Line("PCLOS");
    Line("%");
    return out_;
  }

 private:
  [[noreturn]] void Fail(const std::string& problem) const {
    throw InputError(program_.name, 0, fmt::format("statement {}", index_),
                     problem);
  }
  double Finite(double v, const char* what) const {
    if (!std::isfinite(v)) Fail(fmt::format("{} is not finite", what));
    return v;
  }
  void Line(const std::string& text) { out_ += text + "\n"; }
  std::string Mm(double v) { return fmt::format("{:.4f}", Finite(v, "mm")); }
  std::string Deg(double v) { return fmt::format("{:.3f}", Finite(v, "deg")); }
  long Rpm(double rpm) {
    if (!std::isfinite(rpm) || rpm < 0) Fail("rpm must be >= 0");
    return std::lround(rpm);
  }
  std::string AxisWords(const Axes& a) {
    std::string s;
    if (a.x_mm) s += " X" + Mm(*a.x_mm);
    if (a.y_mm) s += " Y" + Mm(*a.y_mm);
    if (a.z_mm) s += " Z" + Mm(*a.z_mm);
    if (a.b_deg) s += " B" + Deg(*a.b_deg);
    if (a.c_deg) s += " C" + Deg(*a.c_deg);
    if (s.empty()) Fail("move without any axis");
    return s;
  }

  // A word of a report or log row: no separator of either dialect.
  void CheckReportWord(const std::string& word) const {
    for (char ch : word)
      if (ch == '*' || ch == ',' || ch == '[' || ch == ']' || ch == '(' ||
          ch == ')' || ch == ' ')
        Fail("report word must not contain separators: " + word);
  }
  static std::string Upper(std::string s) {
    for (char& ch : s) ch = static_cast<char>(std::toupper(ch));
    return s;
  }

  void Emit(const Comment& c) { Line("(" + SafeCommentText(c.text) + ")"); }
  void Emit(const Rapid& r) {
    Line((r.incremental ? "G91 G0" : "G0") + AxisWords(r.to));
    if (r.incremental) Line("G90");
  }
  void Emit(const Feed& f) {
    if (!std::isfinite(f.feed_per_min) || f.feed_per_min <= 0)
      Fail("feed must be > 0");
    std::string line = (f.incremental ? "G91 G1" : "G1") + AxisWords(f.to);
    const std::string feed = fmt::format("{:.1f}", f.feed_per_min);
    if (feed != last_feed_) line += " F" + feed;
    last_feed_ = feed;
    Line(line);
    if (f.incremental) Line("G90");
  }
  void Emit(const MachineRapid& r) {
    if (r.to.c_deg || r.to.b_deg) Fail("G53 moves only X, Y and Z here");
    Line("G49 G53 G0" + AxisWords(r.to));
  }
  void Emit(const LengthOffset& l) {
    if (l.tool < 0) Fail("tool number must be >= 0");
    Line(fmt::format("G0 G43 H{} Z{}", l.tool, Mm(l.z_mm)));
  }
  void Emit(const LengthCompensation& l) {
    Line(l.tool >= 0 ? fmt::format("G43 H{}", l.tool) : std::string("G49"));
  }
  void Emit(const BZeroClamp&) {
    const MachineProfile& m = config_.machine;
    if (dialect_ == Dialect::kFanuc) {
      Line(fmt::format("M{}", m.m_b_unclamp));
      Line("G0 B0.000");
      Line(fmt::format("M{}", m.m_b_clamp));
    } else {
      Line(fmt::format("M65 P{}", m.linuxcnc_b_clamp_output));
      Line("G0 B0.000");
      Line(fmt::format("M64 P{}", m.linuxcnc_b_clamp_output));
    }
  }
  void Emit(const Dwell& d) {
    if (!std::isfinite(d.seconds) || d.seconds < 0) Fail("dwell must be >= 0");
    if (dialect_ == Dialect::kFanuc)
      Line(fmt::format("G04 X{:.3f}", d.seconds));
    else
      Line(fmt::format("G4 P{:.3f}", d.seconds));
  }
  void Emit(const SpindleOn& s) {
    Line(fmt::format("{} S{}", s.clockwise ? "M3" : "M4", Rpm(s.rpm)));
  }
  void Emit(const SpindleOff&) { Line("M5"); }
  void Emit(const Coolant& c) { Line(c.on ? "M8" : "M9"); }
  void Emit(const ToolChange& t) {
    if (t.tool < 0) Fail("tool number must be >= 0");
    if (!t.description.empty())
      Line(fmt::format("(T{} {})", t.tool, SafeCommentText(t.description)));
    Line(fmt::format("T{} M6", t.tool));
  }
  void Emit(const CSpin& c) {
    const long rpm = Rpm(c.rpm);
    const MachineProfile& m = config_.machine;
    if (dialect_ == Dialect::kFanuc) {
      if (rpm == 0)
        Line(fmt::format("M{}", m.m_c_turning_off));
      else
        Line(fmt::format("M{} S{}", m.m_c_turning_on, rpm));
    } else {
      if (rpm == 0)
        Line("M5 $1");
      else
        Line(fmt::format("M3 $1 S{}", rpm));
    }
  }
  void Emit(const TableClamp& t) {
    if (dialect_ == Dialect::kFanuc)
      Line(fmt::format("M{}", t.clamp ? config_.machine.m_table_clamp
                                      : config_.machine.m_table_unclamp));
    else
      Line(fmt::format("{} P{}", t.clamp ? "M64" : "M65",
                       config_.machine.linuxcnc_c_clamp_output));
  }
  void Emit(const Report& r) {
    CheckReportWord(r.event);
    CheckReportWord(r.feature);
    if (dialect_ == Dialect::kFanuc) {
      const std::string event = Upper(r.event);
      // DPRNT is a macro statement: without a non-buffered block before it
      // the control runs it while the previous move is still going.
      Line(config_.machine.fanuc_sync_block);
      Line(fmt::format("DPRNT[{}*{}*C{}*T#3012[60]]", event, r.feature,
                       Deg(r.c_deg)));
    } else {
      // (debug,...) is queued with the motion; (print,...) would fire when
      // the interpreter reads the line.
      Line(fmt::format("(debug,{},{},{})", r.event, r.feature, Deg(r.c_deg)));
    }
  }
  void Emit(const Probe& p) {
    if (!std::isfinite(p.feed_per_min) || p.feed_per_min <= 0)
      Fail("probe feed must be > 0");
    if (p.point_id < 0) Fail("probe point id must be >= 0");
    CheckReportWord(p.feature);
    CheckReportWord(p.pass);
    const int axes =
        (p.to.x_mm ? 1 : 0) + (p.to.y_mm ? 1 : 0) + (p.to.z_mm ? 1 : 0);
    if (axes != 1 || p.to.b_deg || p.to.c_deg)
      Fail("a probe move runs along one linear axis");
    const int axis = p.to.x_mm ? 0 : p.to.y_mm ? 1 : 2;
    const std::string feed = fmt::format("{:.1f}", p.feed_per_min);
    if (dialect_ == Dialect::kFanuc) {
      Line("G31" + AxisWords(p.to) + " F" + feed);
      // Skip positions of X, Y, Z and C in the control's axis order (C is
      // #5065 on an XYZBC machine).
      const auto& v = config_.machine.fanuc_skip_variables;
      const std::string pass = Upper(p.pass);
      // A probe move read from a LinuxCNC program carries no nominal
      // contact: the touch check below cannot be written.
      if (!std::isfinite(p.nominal_mm))
        Fail(
            "a probe move without its nominal contact (read from a G38.2): "
            "the FANUC touch check after G31 cannot be written");
      // #var - nominal with the sign folded into the operator (no "--").
      const double nominal = p.nominal_mm + 0.0;
      Line(
          fmt::format("IF [ABS[#{}{}{}] GT {:.4f}] THEN #3000={} (NO TOUCH "
                      "{} {})",
                      v[axis], nominal < 0 ? "+" : "-", Mm(std::abs(nominal)),
                      p.touch_window_mm, p.alarm, pass, p.point_id));
      Line(
          fmt::format("DPRNT[{}*{}*{}*X#{}[44]*Y#{}[44]*Z#{}[44]*C#{}[33]*"
                      "T#3012[60]]",
                      pass, p.point_id, p.feature, v[0], v[1], v[2], v[3]));
    } else {
      Line("G38.2" + AxisWords(p.to) + " F" + feed);
      // LinuxCNC probe results by letter: #5061 X .. #5066 C.
      const auto& v = config_.machine.linuxcnc_probe_variables;
      Line(fmt::format("(LOG,{},#{},#{},#{},#{},{},{})", p.point_id, v[0], v[1],
                       v[2], v[3], p.feature, p.pass));
    }
    last_feed_ = feed;
  }
  void Emit(const SpindleOrient&) {
    Line(dialect_ == Dialect::kFanuc ? "M19" : "M19 R0");
  }
  void Emit(const ProbeSignal& p) {
    const MachineProfile& m = config_.machine;
    if (dialect_ == Dialect::kFanuc)
      Line(fmt::format("M{}", p.on ? m.m_probe_on : m.m_probe_off));
    else
      Line(
          fmt::format("{} P{}", p.on ? "M64" : "M65", m.linuxcnc_probe_output));
  }
  void Emit(const ProbeLog& l) {
    const bool fanuc = dialect_ == Dialect::kFanuc;
    if (l.open) {
      if (fanuc) {
        if (!report_open_) Line("POPEN");
        Line(fmt::format("DPRNT[TTP*PROBE*LOG*O{}*D#3011[80]*T#3012[60]]",
                         program_.number));
      } else {
        if (l.file.empty() ||
            l.file.find_first_of(" \t,()\n\r") != std::string::npos)
          Fail(
              "the probing log file needs a name without spaces, commas "
              "or parentheses");
        Line(fmt::format("(LOGOPEN,{})", l.file));
        Line("(LOG,point_id,x,y,z,c_deg,feature,pass)");
      }
      report_open_ = fanuc;
    } else {
      Line(fanuc ? "PCLOS" : "(LOGCLOSE)");
      report_open_ = false;
    }
  }
  void Emit(const ProgramEnd&) { Line("M30"); }

  const Program& program_;
  Dialect dialect_;
  const Config& config_;
  size_t index_ = 0;
  bool report_open_ = false;  // FANUC: POPEN given, PCLOS not yet
  std::string last_feed_;
  std::string out_;
};

}  // namespace

std::string WriteProgram(const Program& program, Dialect dialect,
                         const Config& config) {
  return Writer(program, dialect, config).Write();
}

}  // namespace ttp::gcode
