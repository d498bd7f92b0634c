#include "ttp/gcode/reader.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>

#include "canon_builder.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/limits.h"

namespace ttp::gcode {
namespace {

// A macro variable's number from its digits (#5061: "5061"); -1 for more
// digits than any FANUC variable has (std::stoi would throw out_of_range).
int VariableNumber(const std::string& digits) {
  return digits.size() > 6 ? -1 : std::stoi(digits);
}

// ---- read ------------------------------------------------------------------

struct Word {
  char letter;  // upper case; '$' for the LinuxCNC spindle selector
  double value;
  bool has_point;   // FANUC: no point = least input increments
  std::string raw;  // as written, for error messages
};

struct Block {
  int line = 0;
  std::vector<Word> words;
  std::vector<std::string> comments;
  std::optional<std::string> dprnt;  // FANUC DPRNT[...] contents
  bool popen = false, pclos = false;
  // FANUC touch check of a probing program: IF [ABS[#50xx-<nominal>] GT
  // <window>] THEN #3000=<n> (<message>); no canonical effect.
  bool touch_check = false;
};

class Lexer {
 public:
  Lexer(Dialect dialect, const std::string& source)
      : dialect_(dialect), source_(source) {}

  std::optional<Block> Lex(const std::string& raw_line, int line_number) {
    line_ = line_number;
    std::string text = raw_line;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    const std::string trimmed = Trim(text);
    if (trimmed.empty() || trimmed == "%") return std::nullopt;
    if (trimmed[0] == '/') Fail("/", "block delete is not supported");
    Block block;
    block.line = line_number;
    if (dialect_ == Dialect::kFanuc) {
      const std::string up = Upper(trimmed);
      if (up == "POPEN") {
        block.popen = true;
        return block;
      }
      if (up == "PCLOS") {
        block.pclos = true;
        return block;
      }
      if (up.rfind("IF", 0) == 0) {
        // The one macro statement probing programs use: an alarm when the
        // skip position is further than a window from its nominal.
        static const std::regex kTouchCheck(
            R"(IF\s*\[\s*ABS\s*\[\s*#(\d+)\s*[-+]\s*\d+(\.\d*)?\s*\]\s*GT\s*)"
            R"(\d+(\.\d*)?\s*\]\s*THEN\s*#3000\s*=\s*\d+\s*(\([^()]*\))?)");
        std::smatch m;
        if (!std::regex_match(up, m, kTouchCheck))
          Fail("IF",
               "only IF [ABS[#50xx-<nominal>] GT <window>] THEN #3000=<n> "
               "(touch check) is supported");
        const int var = VariableNumber(m[1]);
        if (var < 5061 || var > 5068)
          Fail("IF", "the touch check must test a skip position #5061..#5068");
        block.touch_check = true;
        return block;
      }
      if (up.rfind("DPRNT", 0) == 0) {
        const size_t open = trimmed.find('[');
        const size_t close = trimmed.rfind(']');
        if (open != 5 || close == std::string::npos ||
            close != trimmed.size() - 1)
          Fail("DPRNT", "expected DPRNT[...]");
        const std::string body = trimmed.substr(open + 1, close - open - 1);
        // Only the skip-position variables of a probing report and the
        // control's clock may be printed (#5061..#5068, #3011, #3012, with an
        // [integer digits, decimals] format).
        static const std::regex kVariable(R"(#(\d+)(\[\d\d\])?)");
        for (auto it =
                 std::sregex_iterator(body.begin(), body.end(), kVariable);
             it != std::sregex_iterator(); ++it) {
          const int var = VariableNumber((*it)[1]);
          if (((var < 5061 || var > 5068) && var != 3011 && var != 3012) ||
              !(*it)[2].matched)
            Fail("DPRNT",
                 "only #5061..#5068[nn], #3011[nn] and #3012[nn] may be "
                 "printed, not " +
                     it->str());
        }
        if (std::count(body.begin(), body.end(), '#') !=
            std::distance(
                std::sregex_iterator(body.begin(), body.end(), kVariable),
                std::sregex_iterator()))
          Fail("DPRNT", "malformed #variable");
        block.dprnt = body;
        return block;
      }
    }
    size_t i = 0;
    const size_t n = text.size();
    while (i < n) {
      const char ch = text[i];
      if (ch == ' ' || ch == '\t') {
        ++i;
      } else if (ch == ';') {
        // LinuxCNC: a comment to the end of the line. FANUC: the end of the
        // block; a block after it on the same line is refused rather than
        // read under this line's number or dropped.
        if (dialect_ == Dialect::kFanuc && !Trim(text.substr(i + 1)).empty())
          Fail(Trim(text.substr(i)).substr(0, 20),
               "a block after the end of block ';' on the same line (give "
               "each block its own line)");
        break;
      } else if (ch == '(') {
        const size_t close = text.find(')', i + 1);
        if (close == std::string::npos) Fail("(", "comment is not closed");
        const std::string comment = text.substr(i + 1, close - i - 1);
        if (comment.find('(') != std::string::npos) Fail("(", "nested comment");
        block.comments.push_back(comment);
        i = close + 1;
      } else if (ch == '#') {
        Fail(text.substr(i, 4), "#variables are not supported");
      } else if (ch == '[') {
        Fail("[", "expressions are not supported");
      } else if (std::isalpha(static_cast<unsigned char>(ch)) || ch == '$') {
        block.words.push_back(LexWord(text, i));
      } else {
        Fail(std::string(1, ch), "unexpected character");
      }
    }
    if (block.words.empty() && block.comments.empty()) return std::nullopt;
    return block;
  }

 private:
  [[noreturn]] void Fail(const std::string& field,
                         const std::string& problem) const {
    throw InputError(source_, line_, field, problem);
  }

  Word LexWord(const std::string& text, size_t& i) {
    const size_t start = i;
    Word w;
    w.letter = static_cast<char>(std::toupper(text[i]));
    ++i;
    if (i < text.size() && std::isalpha(static_cast<unsigned char>(text[i]))) {
      size_t end = i;
      while (end < text.size() &&
             std::isalpha(static_cast<unsigned char>(text[end])))
        ++end;
      const std::string keyword = Upper(text.substr(start, end - start));
      Fail(keyword, "keyword or macro statement is not supported");
    }
    // Both controls ignore spaces between the letter and its number.
    while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    std::string number;
    if (i < text.size() && (text[i] == '+' || text[i] == '-')) {
      number += text[i++];
      while (i < text.size() && (text[i] == ' ' || text[i] == '\t')) ++i;
    }
    size_t digits = 0;
    w.has_point = false;
    while (i < text.size() &&
           (std::isdigit(static_cast<unsigned char>(text[i])) ||
            (text[i] == '.' && !w.has_point))) {
      if (text[i] == '.')
        w.has_point = true;
      else
        ++digits;
      number += text[i++];
    }
    size_t end = i;
    // Anything glued to the number other than the next word is garbage.
    while (end < text.size() &&
           !std::isspace(static_cast<unsigned char>(text[end])) &&
           !std::isalpha(static_cast<unsigned char>(text[end])) &&
           text[end] != '(' && text[end] != ';' && text[end] != '$')
      ++end;
    w.raw = Trim(text.substr(start, end - start));
    if (digits == 0 || end != i) Fail(w.raw, "bad number");
    // Limits (docs/ARCHITECTURE.md): no control takes more digits, and
    // beyond them doubles lose the 0.1 um the programs are written in.
    if (digits > 15) Fail(w.raw, "more than 15 digits in a number");
    w.value = std::strtod(number.c_str(), nullptr);
    if (!std::isfinite(w.value)) Fail(w.raw, "bad number");
    // FANUC values without a point count least increments (0.001 mm or
    // finer): the limit is on the length they give.
    const double length =
        dialect_ == Dialect::kFanuc && !w.has_point ? w.value * 0.001 : w.value;
    if (std::string("XYZABCUVWIJKR").find(w.letter) != std::string::npos &&
        std::abs(length) > limits::kMaxProgramCoordinate)
      Fail(w.raw, "coordinate beyond the limit of " +
                      std::to_string(
                          static_cast<long>(limits::kMaxProgramCoordinate)));
    return w;
  }

  Dialect dialect_;
  const std::string& source_;
  int line_ = 0;
};

// ---- check + convert -------------------------------------------------------

// G-codes times 10 (G38.2 = 382) and their modal groups.
enum class GGroup {
  kNonModal,
  kMotion,
  kPlane,
  kUnits,
  kCutter,
  kLength,
  kCoord,
  kDistance,
  kFeedMode,
  kMachineCoords,  // G53, one-shot
  kPlaneRotation,  // FANUC G69
  kPathMode,       // LinuxCNC G61 / G64
};

enum class Motion { kNone, kRapid, kFeed, kProbe };

class Interpreter {
 public:
  Interpreter(Dialect dialect, const Config& config, const std::string& source)
      : dialect_(dialect), config_(config), source_(source) {
    // The machine starts at machine zero (as rs274 does with G54's offset).
    builder_.SetStart(Eigen::Vector3d(0, 0, -WorkpieceOriginHeightMm(config)));
  }

  // Returns false after M30 (the rest of the text is not read).
  bool Run(const Block& block) {
    line_ = block.line;
    builder_.SetLine(block.line);
    if (block.popen) {
      if (port_open_) Fail("POPEN", "port already open");
      port_open_ = true;
      return true;
    }
    if (block.pclos) {
      if (!port_open_) Fail("PCLOS", "PCLOS without POPEN");
      port_open_ = false;
      return true;
    }
    if (block.touch_check) return true;
    if (block.dprnt) {
      if (!port_open_) Fail("DPRNT", "DPRNT before POPEN");
      builder_.Report(DprntText(*block.dprnt));
      return true;
    }
    Check(block);
    return Convert(block);
  }

  std::vector<CanonStatement> Take() { return builder_.Take(); }

 private:
  [[noreturn]] void Fail(const std::string& field,
                         const std::string& problem) const {
    throw InputError(source_, line_, field, problem);
  }
  bool Fanuc() const { return dialect_ == Dialect::kFanuc; }

  static int GCode(const Word& w) {
    return static_cast<int>(std::lround(w.value * 10));
  }

  std::optional<GGroup> GroupOf(int g10) const {
    switch (g10) {
      case 0:
      case 10:
      case 800:
        return GGroup::kMotion;
      case 40:
        return GGroup::kNonModal;
      case 170:
        return GGroup::kPlane;
      case 200:
      case 210:
        return GGroup::kUnits;
      case 400:
        return GGroup::kCutter;
      case 430:
      case 490:
        return GGroup::kLength;
      case 540:
        return GGroup::kCoord;
      case 900:
      case 910:
        return GGroup::kDistance;
      case 940:
        return GGroup::kFeedMode;
      case 530:
        return GGroup::kMachineCoords;
      case 690:
        if (Fanuc()) return GGroup::kPlaneRotation;
        break;
      case 610:
      case 640:
        if (!Fanuc()) return GGroup::kPathMode;
        break;
      case 310:
        if (Fanuc()) return GGroup::kMotion;
        break;
      case 382:
        if (!Fanuc()) return GGroup::kMotion;
        break;
    }
    return std::nullopt;
  }

  // M-code groups: spindle 1 (M19 orients it: no canonical effect), tool 2,
  // coolant 3, end 4, C turning 5, clamp 6, digital outputs 7, B clamp 8,
  // probe on/off 9, FANUC non-buffered M-code of the profile 10.
  std::optional<int> MGroupOf(int m) const {
    const MachineProfile& p = config_.machine;
    if (m == 3 || m == 4 || m == 5 || m == 19) return 1;
    if (m == 6) return 2;
    if (m == 8 || m == 9) return 3;
    if (m == 30 || m == 2) return 4;
    if (Fanuc()) {
      if (m == p.m_c_turning_on || m == p.m_c_turning_off) return 5;
      if (m == p.m_table_clamp || m == p.m_table_unclamp) return 6;
      if (m == p.m_b_clamp || m == p.m_b_unclamp) return 8;
      if (m == p.m_probe_on || m == p.m_probe_off) return 9;
      if (p.fanuc_sync_block == fmt::format("M{}", m)) return 10;
    } else if (m == 64 || m == 65) {
      return 7;
    }
    return std::nullopt;
  }

  void Check(const Block& block) {
    std::set<char> seen;
    std::map<GGroup, const Word*> g_groups;
    std::map<int, const Word*> m_groups;
    const std::string allowed = Fanuc() ? "NOGMXYZBCFSTHP" : "NGMXYZBCFSTHP$";
    for (const Word& w : block.words) {
      // LinuxCNC M19 R<angle>: spindle orientation angle.
      const bool orient_angle = !Fanuc() && w.letter == 'R' && HasM(block, 19);
      if (allowed.find(w.letter) == std::string::npos && !orient_angle) {
        if (w.letter == 'O') Fail(w.raw, "O-word control is not supported");
        Fail(w.raw, "unsupported word");
      }
      if (w.letter == 'G') {
        if (std::abs(w.value * 10 - std::round(w.value * 10)) > 1e-9)
          Fail(w.raw, "unsupported G-code");
        const auto group = GroupOf(GCode(w));
        if (!group) Fail(w.raw, "unsupported G-code");
        auto [it, inserted] = g_groups.emplace(*group, &w);
        if (!inserted)
          Fail(w.raw,
               "conflicts with " + it->second->raw + " (same modal group)");
      } else if (w.letter == 'M') {
        if (w.value != std::floor(w.value) || !(std::abs(w.value) < 1e6))
          Fail(w.raw, "unsupported M-code");
        const auto group = MGroupOf(static_cast<int>(w.value));
        if (!group) Fail(w.raw, "unsupported M-code");
        auto [it, inserted] = m_groups.emplace(*group, &w);
        if (!inserted)
          Fail(w.raw,
               "conflicts with " + it->second->raw + " (same modal group)");
      } else {
        if (!seen.insert(w.letter).second) Fail(w.raw, "word given twice");
      }
      switch (w.letter) {
        case 'F':
          if (w.value <= 0) Fail(w.raw, "feed must be > 0");
          break;
        case 'S':
          if (w.value < 0) Fail(w.raw, "speed must be >= 0");
          break;
        case 'T':
        case 'H':
        case 'N':
        case 'O':
        case '$':
          if (w.value < 0 || w.value != std::floor(w.value))
            Fail(w.raw, "must be a whole number >= 0");
          break;
        default:
          break;
      }
    }
    if (g_groups.count(GGroup::kNonModal) && g_groups.count(GGroup::kMotion))
      Fail(g_groups[GGroup::kMotion]->raw, "conflicts with dwell in the block");
    if (Fanuc() && m_groups.count(1) && m_groups.count(5))
      Fail(m_groups[5]->raw, "S would be ambiguous with " + m_groups[1]->raw);
  }

  static const Word* Find(const Block& b, char letter) {
    for (const Word& w : b.words)
      if (w.letter == letter) return &w;
    return nullptr;
  }
  static bool HasG(const Block& b, int g10) {
    for (const Word& w : b.words)
      if (w.letter == 'G' && GCode(w) == g10) return true;
    return false;
  }
  static bool HasM(const Block& b, int m) {
    for (const Word& w : b.words)
      if (w.letter == 'M' && w.value == static_cast<double>(m)) return true;
    return false;
  }

  // FANUC values without a point are least input increments: 0.001 mm,
  // 0.0001 inch, 0.001 deg, 0.001 s.
  double Scaled(const Word& w, bool length = false) const {
    if (!Fanuc() || w.has_point) return w.value;
    return w.value * (length && units_mm_ != 1.0 ? 0.0001 : 0.001);
  }

  std::string DprntText(const std::string& body) {
    // DPRNT prints '*' as a space; we write EVENT*FEATURE*C<deg>.
    std::vector<std::string> parts;
    std::stringstream ss(body);
    std::string part;
    while (std::getline(ss, part, '*')) parts.push_back(part);
    // A fourth part T#3012[..] is the control's clock.
    if ((parts.size() == 3 ||
         (parts.size() == 4 && parts[3].rfind("T#", 0) == 0)) &&
        parts[2].size() > 1 &&
        std::toupper(static_cast<unsigned char>(parts[2][0])) == 'C') {
      return Lower(parts[0]) + "," + parts[1] + "," + parts[2].substr(1);
    }
    std::string text;
    for (size_t i = 0; i < parts.size(); ++i) text += (i ? "," : "") + parts[i];
    return text;
  }

  void Comments(const Block& block) {
    for (const std::string& c : block.comments) {
      if (!Fanuc()) {
        const std::string low = Lower(c);
        const auto prefix = [&](const char* p) { return low.rfind(p, 0) == 0; };
        if (prefix("print,")) {
          builder_.Report(c.substr(6));
          continue;
        }
        if (prefix("msg,") || prefix("debug,")) {
          const std::string body = c.substr(c.find(',') + 1);
          ReportText r;
          if (prefix("debug,") && ParseReportText(body, &r))
            builder_.Report(body);
          else
            builder_.Comment(body);
          continue;
        }
      }
      builder_.Comment(c);
    }
  }

  bool Convert(const Block& block) {
    Comments(block);
    if (HasG(block, 200)) units_mm_ = 25.4;
    if (HasG(block, 210)) units_mm_ = 1.0;
    if (const Word* f = Find(block, 'F')) feed_ = f->value;
    int spindle = 0;
    if (const Word* sel = Find(block, '$')) {
      if (!(sel->value >= 0 && sel->value <= 1))
        Fail(sel->raw, "only spindles 0 and 1 exist");
      spindle = static_cast<int>(sel->value);
    }
    const MachineProfile& p = config_.machine;
    const bool c_on = Fanuc() && HasM(block, p.m_c_turning_on);
    const Word* s_word = Find(block, 'S');
    if (s_word && !c_on) builder_.SetSpindleSpeed(spindle, s_word->value);
    if (const Word* t = Find(block, 'T')) {
      // Checked before the conversion: a double out of int's range
      // converts to nothing defined.
      if (!(t->value >= 0 && t->value <= 99999))
        Fail(t->raw, "tool number must be 0..99999");
      selected_tool_ = static_cast<int>(t->value);
    }
    if (HasM(block, 6)) {
      if (selected_tool_ < 0) Fail("M6", "tool change without T");
      builder_.StopSpindle(0);
      builder_.StopSpindle(1);
      builder_.ChangeTool(selected_tool_);
      loaded_tool_ = selected_tool_;
    }
    if (HasM(block, 3)) builder_.StartSpindle(spindle, true);
    if (HasM(block, 4)) builder_.StartSpindle(spindle, false);
    if (HasM(block, 5)) builder_.StopSpindle(spindle);
    if (HasM(block, 8)) builder_.SetCoolant(true);
    if (HasM(block, 9)) builder_.SetCoolant(false);
    if (Fanuc()) {
      if (c_on) {
        if (!s_word)
          Fail(fmt::format("M{}", p.m_c_turning_on), "needs S (C rpm)");
        builder_.SetSpindleSpeed(1, s_word->value);
        builder_.StartSpindle(1, true);
      }
      if (HasM(block, p.m_c_turning_off)) builder_.StopSpindle(1);
      if (HasM(block, p.m_table_clamp)) builder_.SetClamp(true);
      if (HasM(block, p.m_table_unclamp)) builder_.SetClamp(false);
    } else if (HasM(block, 64) || HasM(block, 65)) {
      const Word* pw = Find(block, 'P');
      const int m = HasM(block, 64) ? 64 : 65;
      if (pw && pw->value == p.linuxcnc_c_clamp_output)
        builder_.SetClamp(m == 64);
      else if (!pw || (pw->value != p.linuxcnc_b_clamp_output &&
                       pw->value != p.linuxcnc_probe_output))
        Fail(fmt::format("M{}", m),
             fmt::format("only outputs P{} (C clamp), P{} (B clamp) and P{} "
                         "(probe) are used",
                         p.linuxcnc_c_clamp_output, p.linuxcnc_b_clamp_output,
                         p.linuxcnc_probe_output));
    }
    if (const Word* b = Find(block, 'B')) {
      if (Scaled(*b) != 0)
        Fail(b->raw, "B must stay at 0 (the programs do not tilt the spindle)");
    }
    if (HasG(block, 430)) {
      const Word* h = Find(block, 'H');
      if (h && !(h->value >= 0 && h->value <= 99999))
        Fail(h->raw, "H must be 0..99999");
      // Without H: LinuxCNC takes the tool in the spindle (a tool selected
      // since, T without M6, is not it); FANUC's H is modal.
      int tool =
          h ? static_cast<int>(h->value) : (Fanuc() ? modal_h_ : loaded_tool_);
      if (tool < 0)
        Fail("G43", Fanuc() ? "G43 without H and no H given before"
                            : "G43 without H and no tool in the spindle");
      if (h) modal_h_ = tool;
      const ToolSpec* spec = config_.process.ToolByNumber(tool);
      if (!spec)
        Fail(h ? h->raw : "G43",
             fmt::format("no tool {} in the process", tool));
      builder_.SetToolLengthOffset(spec->length_mm, tool);
    }
    if (HasG(block, 490)) {
      builder_.SetToolLengthOffset(0.0);
      length_offset_on_ = false;
    }
    if (HasG(block, 430)) length_offset_on_ = true;
    if (HasG(block, 40)) Dwell(block);
    if (HasG(block, 900)) absolute_ = true;
    if (HasG(block, 910)) absolute_ = false;
    Move(block);
    if (HasM(block, 30) || HasM(block, 2)) {
      builder_.End();
      return false;
    }
    return true;
  }

  void Dwell(const Block& block) {
    const Word* x = Find(block, 'X');
    const Word* pw = Find(block, 'P');
    for (const Word& w : block.words)
      if (std::string("YZC").find(w.letter) != std::string::npos)
        Fail(w.raw, "axis word in a dwell block");
    double seconds = 0;
    if (Fanuc()) {
      if (x && pw) Fail(pw->raw, "G04 takes X or P, not both");
      if (x)
        seconds = Scaled(*x);
      else if (pw)
        seconds = pw->value * 0.001;  // P is in ms
      else
        Fail("G04", "dwell without X or P");
    } else {
      if (x) Fail(x->raw, "axis word in a dwell block");
      if (!pw) Fail("G4", "dwell without P");
      seconds = pw->value;
    }
    if (seconds < 0) Fail(x ? x->raw : pw->raw, "dwell must be >= 0");
    if (seconds > limits::kMaxDwellS)
      Fail(x ? x->raw : pw->raw,
           "dwell of " + std::to_string(seconds) +
               " s is beyond the limit of " +
               std::to_string(static_cast<long>(limits::kMaxDwellS)) + " s");
    builder_.Dwell(seconds);
  }

  void Move(const Block& block) {
    const Word* g_motion = nullptr;
    for (const Word& w : block.words)
      if (w.letter == 'G' && GroupOf(GCode(w)) == GGroup::kMotion)
        g_motion = &w;
    Motion motion = motion_;
    if (g_motion) {
      switch (GCode(*g_motion)) {
        case 0:
          motion = Motion::kRapid;
          break;
        case 10:
          motion = Motion::kFeed;
          break;
        case 800:
          motion = Motion::kNone;
          break;
        default:
          motion = Motion::kProbe;
          break;
      }
      // FANUC G31 is one-shot; LinuxCNC G38.2 is modal.
      if (!(Fanuc() && motion == Motion::kProbe)) motion_ = motion;
    }
    if (HasG(block, 40)) return;
    const Word* axes[4] = {Find(block, 'X'), Find(block, 'Y'), Find(block, 'Z'),
                           Find(block, 'C')};
    const bool any_axis = axes[0] || axes[1] || axes[2] || axes[3];
    // B is held at 0 (checked in Convert): a B-only move is a move of
    // length zero, as rs274 sees it.
    if (!any_axis && Find(block, 'B') && motion == Motion::kRapid) {
      builder_.Traverse(builder_.position_mm(), builder_.c_deg());
      return;
    }
    if (!any_axis) {
      if (g_motion && motion == Motion::kProbe)
        Fail(g_motion->raw, "probe move without a target");
      return;
    }
    if (motion == Motion::kNone)
      Fail(FirstAxis(axes)->raw, "axis words without a motion mode (G0/G1)");
    Eigen::Vector3d to = builder_.position_mm();
    double c = builder_.c_deg();
    const bool machine = HasG(block, 530);
    if (machine) {
      // G53: machine coordinates of the gauge line; program Z is machine Z
      // less W's origin height (G54 has X = Y = 0).
      if (length_offset_on_)
        Fail("G53", "G53 with tool-length compensation on (give G49)");
      if (motion != Motion::kRapid && motion != Motion::kFeed)
        Fail("G53", "G53 needs G0 or G1");
      if (axes[3]) Fail(axes[3]->raw, "G53 moves only X, Y and Z here");
    }
    const double origin_z = WorkpieceOriginHeightMm(config_);
    for (int a = 0; a < 3; ++a) {
      if (!axes[a]) continue;
      const double v = Scaled(*axes[a], true) * units_mm_;
      if (machine)
        to[a] = v - (a == 2 ? origin_z : 0.0);
      else
        to[a] = absolute_ ? v : to[a] + v;
    }
    if (axes[3]) {
      const double v = Scaled(*axes[3]);
      c = absolute_ ? v : c + v;
    }
    if (motion == Motion::kRapid) {
      builder_.Traverse(to, c);
      return;
    }
    if (!feed_) {
      const std::string g =
          g_motion ? g_motion->raw : (motion == Motion::kFeed ? "G1" : "probe");
      Fail(g, "feed move without a feed rate (F)");
    }
    const bool pure_c = (to - builder_.position_mm()).norm() == 0;
    const double feed = pure_c ? *feed_ : *feed_ * units_mm_;
    if (motion == Motion::kFeed)
      builder_.Feed(to, c, feed);
    else
      builder_.Probe(to, c, feed);
  }

  static const Word* FirstAxis(const Word* const axes[4]) {
    for (int a = 0; a < 4; ++a)
      if (axes[a]) return axes[a];
    return nullptr;
  }

  Dialect dialect_;
  const Config& config_;
  const std::string& source_;
  CanonBuilder builder_;
  int line_ = 0;
  bool port_open_ = false;
  double units_mm_ = 1.0;
  bool absolute_ = true;
  Motion motion_ = Motion::kNone;
  std::optional<double> feed_;
  int selected_tool_ = -1;  // T: the next M6's tool
  int loaded_tool_ = -1;    // in the spindle (M6)
  int modal_h_ = -1;        // FANUC: H stays until another is given
  bool length_offset_on_ = false;
};

}  // namespace

std::optional<Dialect> DecideDialect(const std::string& text) {
  const std::string up = Upper(text);
  std::stringstream ss(up);
  std::string line;
  while (std::getline(ss, line)) {
    const std::string t = Trim(line);
    if (t.size() > 1 && t[0] == 'O' &&
        std::isdigit(static_cast<unsigned char>(t[1])))
      return Dialect::kFanuc;
    if (t.rfind("DPRNT", 0) == 0 || t == "POPEN" ||
        t.find("G04 X") != std::string::npos)
      return Dialect::kFanuc;
    if (t.find('$') != std::string::npos ||
        t.find("(PRINT,") != std::string::npos ||
        t.find("(DEBUG,") != std::string::npos ||
        t.find("G64 P") != std::string::npos ||
        t.find("G4 P") != std::string::npos ||
        t.find("M64") != std::string::npos ||
        t.find("M65") != std::string::npos)
      return Dialect::kLinuxCnc;
  }
  return std::nullopt;
}

Dialect DetectDialect(const std::string& text) {
  return DecideDialect(text).value_or(Dialect::kLinuxCnc);
}

Dialect ResolveDialect(const std::string& text, const std::string& source) {
  if (const auto decided = DecideDialect(text)) return *decided;
  // Nothing decides: LinuxCNC's own file extension does; else LinuxCNC
  // unless a word means something else on a FANUC control. A line that
  // does not lex is left to the reader, which names its problem.
  if (Upper(std::filesystem::path(source).extension().string()) == ".NGC")
    return Dialect::kLinuxCnc;
  Lexer lexer(Dialect::kLinuxCnc, source);
  std::stringstream ss(text);
  std::string line;
  int line_number = 0;
  while (std::getline(ss, line)) {
    ++line_number;
    if (line_number > limits::kMaxProgramLines) break;
    std::optional<Block> block;
    try {
      block = lexer.Lex(line, line_number);
    } catch (const InputError&) {
      continue;
    }
    if (!block) continue;
    bool dwell = false;
    for (const Word& w : block->words) dwell |= w.letter == 'G' && w.value == 4;
    for (const Word& w : block->words) {
      std::string meaning;
      if (std::string("XYZC").find(w.letter) != std::string::npos &&
          !w.has_point && w.value != 0 && !dwell) {
        meaning = fmt::format(
            "{} is {:g} {} in LinuxCNC but {:g} {} on a FANUC control (a value "
            "without a decimal point counts least input increments there)",
            w.raw, w.value, w.letter == 'C' ? "deg" : "mm", w.value * 0.001,
            w.letter == 'C' ? "deg" : "mm");
      } else if (w.letter == 'P' && dwell) {
        meaning = fmt::format(
            "the dwell {} is {:g} s in LinuxCNC but {:g} s on a FANUC control "
            "(P in milliseconds)",
            w.raw, w.value, w.value * 0.001);
      }
      if (!meaning.empty()) {
        throw InputError(
            source, line_number, w.raw,
            "the program does not show its dialect (no O-number, DPRNT, "
            "G04 X, $, (print,...), G4 P or M64/M65) and " +
                meaning + ": give --dialect fanuc or --dialect linuxcnc");
      }
    }
  }
  return Dialect::kLinuxCnc;
}

std::vector<CanonStatement> ReadProgram(const std::string& text,
                                        Dialect dialect, const Config& config,
                                        const std::string& source) {
  Lexer lexer(dialect, source);
  Interpreter interpreter(dialect, config, source);
  std::stringstream ss(text);
  std::string line;
  int line_number = 0;
  int blocks = 0;
  while (std::getline(ss, line)) {
    ++line_number;
    if (line_number > limits::kMaxProgramLines)
      throw InputError(source, line_number, "",
                       "more than " + std::to_string(limits::kMaxProgramLines) +
                           " lines is beyond the limit");
    if (static_cast<std::int64_t>(line.size()) > limits::kMaxProgramLineChars)
      throw InputError(
          source, line_number, "",
          fmt::format("a line of {} characters is beyond the limit of {}",
                      line.size(), limits::kMaxProgramLineChars));
    const auto block = lexer.Lex(line, line_number);
    if (!block) continue;
    ++blocks;
    if (!interpreter.Run(*block)) break;
  }
  // Nothing to read, check, simulate or run: the same answer (bad input)
  // from every command that reads programs.
  if (blocks == 0)
    throw InputError(source, 0, "", "the program is empty (no blocks)");
  auto statements = interpreter.Take();
  ApplyTimeModel(statements, config.machine,
                 Eigen::Vector3d(0, 0, -WorkpieceOriginHeightMm(config)));
  return statements;
}

}  // namespace ttp::gcode
