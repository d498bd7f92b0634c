#include "ttp/inspect/grade.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <sstream>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/format.h"
#include "ttp/geometry/limits.h"

namespace ttp::inspect {
namespace {

std::string Fixed(double v, int decimals) { return FormatNumber(v, decimals); }

// Shortest text of a limit (5, 15, 2.5).
std::string Short(double v) { return fmt::format("{:g}", v); }

std::string Upper(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

std::string FigureList(const std::vector<Figure>& figures) {
  std::string s;
  for (Figure f : figures)
    s += (s.empty() ? "" : ", ") + std::string(FigureName(f));
  return s;
}

const std::vector<Figure>& ThesisFigures() {
  static const std::vector<Figure> kThesis = GradeLimits{}.figures;
  return kThesis;
}

// Where a figure of CycleFigures is and its scale to um (um/m).
struct FigureField {
  double CycleFigures::*value;
  double CycleFigures::*u;  // standard uncertainty (k = 1)
  double scale;
};
const FigureField& FieldOf(Figure f) {
  static const FigureField kX{&CycleFigures::e_x_mm, &CycleFigures::u_x_mm,
                              1e3};
  static const FigureField kY{&CycleFigures::e_y_mm, &CycleFigures::u_y_mm,
                              1e3};
  static const FigureField kZ{&CycleFigures::e_z_mm, &CycleFigures::u_z_mm,
                              1e3};
  static const FigureField kB{&CycleFigures::e_b_rad, &CycleFigures::u_b_rad,
                              1e6};
  static const FigureField kTtp{&CycleFigures::e_ttp_mm,
                                &CycleFigures::u_ttp_mm, 1e3};
  switch (f) {
    case Figure::kEX:
      return kX;
    case Figure::kEY:
      return kY;
    case Figure::kEZ:
      return kZ;
    case Figure::kEB:
      return kB;
    case Figure::kETTP:
    case Figure::kEC:  // in CycleExtras, not here: the caller reads it
      break;
  }
  return kTtp;
}

}  // namespace

const char* FigureName(Figure f) {
  switch (f) {
    case Figure::kEX:
      return "E_X";
    case Figure::kEY:
      return "E_Y";
    case Figure::kEZ:
      return "E_Z";
    case Figure::kEB:
      return "E_B";
    case Figure::kETTP:
      return "E_TTP";
    case Figure::kEC:
      return "E_C";
  }
  return "?";
}

bool IsAngular(Figure f) { return f == Figure::kEB || f == Figure::kEC; }
const char* FigureUnit(Figure f) { return IsAngular(f) ? "um/m" : "um"; }

bool ParseFigure(const std::string& name, Figure* f) {
  for (Figure g : kAllFigures) {
    if (Upper(name) == FigureName(g)) {
      *f = g;
      return true;
    }
  }
  return false;
}

std::vector<Figure> ParseFigureList(const std::string& text) {
  const std::string lower = Upper(text);
  if (lower == "THESIS") return ThesisFigures();
  if (lower == "ALL")
    return std::vector<Figure>(std::begin(kAllFigures), std::end(kAllFigures));
  std::vector<Figure> out;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    item.erase(0, item.find_first_not_of(" \t"));
    item.erase(item.find_last_not_of(" \t") + 1);
    Figure f;
    if (!ParseFigure(item, &f))
      throw InputError("--figures", 0, "figures",
                       "'" + item +
                           "' is not a figure (E_X, E_Y, E_Z, E_B, E_TTP, "
                           "E_C, or thesis / all)");
    if (std::find(out.begin(), out.end(), f) == out.end()) out.push_back(f);
  }
  if (out.empty()) throw InputError("--figures", 0, "figures", "is empty");
  return out;
}

bool GradeLimits::IsValid(std::string* error) const {
  auto fail = [&](const std::string& e) {
    if (error) *error = e;
    return false;
  };
  // A limit beyond the largest figure a measurement may hold would pass
  // every piece: no grading.
  const std::string most = fmt::format("{:g}", limits::kMaxFigureMicro);
  if (!(linear_um > 0 && linear_um <= limits::kMaxFigureMicro))
    return fail("linear_um: must be a positive number up to " + most);
  if (!(angular_um_per_m > 0 && angular_um_per_m <= limits::kMaxFigureMicro))
    return fail("angular_um_per_m: must be a positive number up to " + most);
  if (figures.empty()) return fail("figures: no figure to grade");
  return true;
}

void GradeLimits::Validate() const {
  std::string error;
  if (IsValid(&error)) return;
  const std::string field = error.substr(0, error.find(':'));
  const std::string option = field == "linear_um" ? "--limit-linear-um"
                             : field == "angular_um_per_m"
                                 ? "--limit-angular-um-per-m"
                                 : "--figures";
  throw InputError(option, 0, field, error.substr(error.find(':') + 2));
}

bool GradeLimits::Grades(Figure f) const {
  return std::find(figures.begin(), figures.end(), f) != figures.end();
}

std::string GradeLimits::Describe() const {
  const GradeLimits thesis;
  std::string b = basis;
  if (b.empty()) {
    b = linear_um == thesis.linear_um &&
                angular_um_per_m == thesis.angular_um_per_m
            ? "the thesis' TALC action control limits, 6.4"
            : "given limits";
  }
  return fmt::format("{} um linear, {} um/m angular ({})", Short(linear_um),
                     Short(angular_um_per_m), b);
}

const char* VerdictName(Verdict v) {
  switch (v) {
    case Verdict::kPass:
      return "pass";
    case Verdict::kFail:
      return "fail";
    case Verdict::kUndecidable:
      return "undecidable";
    case Verdict::kMissing:
      return "missing";
    case Verdict::kNotDecidable:
      return "not_decidable";
  }
  return "?";
}

Capability CapabilityOf(MeasurementKind kind) {
  switch (kind) {
    case MeasurementKind::kCloud:
      return {true, "CMM point cloud"};
    case MeasurementKind::kInspectionJson:
      return {true, "inspection JSON"};
    case MeasurementKind::kDial:
      return {false, "dial gauge"};
    case MeasurementKind::kDmis:
      return {true, "CMM (DMIS)"};
    case MeasurementKind::kProbe:
      return {true, "on-machine probe"};
  }
  return {true, ""};
}

Verdict Decide(double value, double u, double limit) {
  if (!std::isfinite(value)) return Verdict::kMissing;
  if (!std::isfinite(u) || u < 0) u = std::numeric_limits<double>::infinity();
  const double a = std::abs(value);
  if (a <= limit - u) return Verdict::kPass;
  if (a > limit + u) return Verdict::kFail;
  return Verdict::kUndecidable;
}

GradeResult GradeFigures(const std::vector<CycleFigures>& figures,
                         const std::vector<CycleExtras>& extras,
                         const Capability& capability,
                         const GradeLimits& limits) {
  limits.Validate();
  GradeResult r;
  r.limits = limits;
  for (Figure fig : kAllFigures) {
    FigureGrade fg;
    fg.figure = fig;
    fg.limit = limits.For(fig);
    if (!limits.Grades(fig)) {
      fg.reason = fig == Figure::kEC
                      ? "not requested (the thesis does not evaluate E_C; "
                        "--figures all grades it)"
                      : "not requested";
      r.figures.push_back(fg);
      continue;
    }
    // Values of this figure, cycle by cycle, in um or um/m (U: k = 2).
    std::vector<GradedValue> values;
    for (const CycleFigures& cf : figures) {
      GradedValue g;
      g.cycle = cf.cycle;
      g.figure = fig;
      g.limit = fg.limit;
      double v = kNaN, u = kNaN;
      if (fig == Figure::kEC) {
        for (const CycleExtras& ex : extras) {
          if (ex.cycle == cf.cycle) {
            v = ex.e_c_rad * 1e6;
            u = 2e6 * ex.u_c_rad;
          }
        }
      } else {
        const FigureField& field = FieldOf(fig);
        v = cf.*field.value * field.scale;
        u = 2 * field.scale * cf.*field.u;
      }
      g.value = std::isfinite(v) ? v : kNaN;
      g.u = std::isfinite(v) && std::isfinite(u) ? u : kNaN;
      values.push_back(g);
    }
    fg.max_u = kNaN;
    for (const GradedValue& g : values) {
      if (std::isfinite(g.u) && !(g.u <= fg.max_u)) fg.max_u = g.u;
    }
    if (IsAngular(fig) && !capability.angles) {
      fg.reason = "not measured: a " + capability.instrument +
                  " measures no facet angle";
    } else if (std::isfinite(fg.max_u) && fg.max_u >= fg.limit * (1 - 1e-12)) {
      fg.reason = fmt::format(
          "U up to {} {} is at or above the limit {} {}: the measurement "
          "cannot prove conformance",
          Fixed(fg.max_u, 1), FigureUnit(fig), Short(fg.limit),
          FigureUnit(fig));
    }
    // A figure the instrument measures but the measurement lacks stays in
    // the verdict: its missing values are not shown to conform, so it is
    // undecidable (leaving it out would let a piece pass on less data).
    fg.decided = fg.reason.empty();
    int fails = 0, passes = 0;
    for (GradedValue& g : values) {
      g.verdict =
          fg.decided ? Decide(g.value, g.u, g.limit) : Verdict::kNotDecidable;
      fails += g.verdict == Verdict::kFail;
      passes += g.verdict == Verdict::kPass;
      ++r.counts[static_cast<int>(g.verdict)];
      r.values.push_back(g);
    }
    if (fg.decided) {
      fg.verdict = fails ? Verdict::kFail
                   : passes == static_cast<int>(values.size())
                       ? Verdict::kPass
                       : Verdict::kUndecidable;
    }
    r.figures.push_back(fg);
  }
  const std::vector<Figure> decided = r.DecidedOn();
  bool any_fail = false, all_pass = !decided.empty();
  for (const FigureGrade& fg : r.figures) {
    if (!fg.decided) continue;
    any_fail = any_fail || fg.verdict == Verdict::kFail;
    all_pass = all_pass && fg.verdict == Verdict::kPass;
  }
  r.overall = any_fail   ? Verdict::kFail
              : all_pass ? Verdict::kPass
                         : Verdict::kUndecidable;
  return r;
}

GradeResult GradeMeasurement(const Measurement& m, const GradeLimits& limits) {
  return GradeFigures(m.result.figures, m.result.extras, CapabilityOf(m.kind),
                      limits);
}

GradeResult GradeFigures(const nlohmann::json& doc, const GradeLimits& limits,
                         const std::string& source) {
  if (!doc.is_object() || !doc.contains("figures") ||
      !doc["figures"].is_array()) {
    throw InputError(source, 0, "figures",
                     "missing: not an inspection result (ttp inspect --json)");
  }
  Capability capability;
  if (doc.contains("kind") && doc["kind"] == "dial")
    capability = CapabilityOf(MeasurementKind::kDial);
  std::vector<CycleFigures> figures;
  std::vector<CycleExtras> extras;
  for (size_t i = 0; i < doc["figures"].size(); ++i) {
    const nlohmann::json& f = doc["figures"][i];
    const std::string where = "figures[" + std::to_string(i) + "]";
    if (!f.is_object() || !f.contains("cycle") ||
        !f["cycle"].is_number_integer())
      throw InputError(source, 0, where + ".cycle",
                       "missing or not an integer");
    const nlohmann::json u = f.contains("U") && f["U"].is_object()
                                 ? f["U"]
                                 : nlohmann::json::object();
    // Value (um or um/m) and U (k = 2) -> CycleFigures' mm/rad and k = 1.
    auto get = [&](const char* key, double scale, double* v, double* sd) {
      if (!f.contains(key))
        throw InputError(source, 0, where + "." + key, "missing");
      const nlohmann::json& x = f[key];
      if (!x.is_null() && !x.is_number())
        throw InputError(source, 0, where + "." + key, "not a number");
      *v = x.is_number() ? x.get<double>() * scale : kNaN;
      const bool has_u = u.contains(key) && u[key].is_number();
      *sd = has_u ? u[key].get<double>() * scale / 2
                  : (x.is_number() ? 0.0 : kNaN);
    };
    CycleFigures cf;
    cf.cycle = f["cycle"].get<int>();
    get("E_X", 1e-3, &cf.e_x_mm, &cf.u_x_mm);
    get("E_Y", 1e-3, &cf.e_y_mm, &cf.u_y_mm);
    get("E_Z", 1e-3, &cf.e_z_mm, &cf.u_z_mm);
    get("E_B", 1e-6, &cf.e_b_rad, &cf.u_b_rad);
    get("E_TTP", 1e-3, &cf.e_ttp_mm, &cf.u_ttp_mm);
    figures.push_back(cf);
    CycleExtras ex;
    ex.cycle = cf.cycle;
    ex.e_c_rad = ex.u_c_rad = kNaN;
    if (f.contains("E_C")) get("E_C", 1e-6, &ex.e_c_rad, &ex.u_c_rad);
    extras.push_back(ex);
  }
  if (figures.empty()) throw InputError(source, 0, "figures", "empty");
  return GradeFigures(figures, extras, capability, limits);
}

nlohmann::json GradeToJson(const GradeResult& result, const GradeLimits&) {
  return GradeToJson(result);
}

std::vector<Figure> GradeResult::DecidedOn() const {
  std::vector<Figure> out;
  for (const FigureGrade& fg : figures)
    if (fg.decided) out.push_back(fg.figure);
  return out;
}

std::string GradeResult::Summary() const {
  const std::vector<Figure> on = DecidedOn();
  int graded = 0;
  for (const GradedValue& g : values)
    graded += g.verdict != Verdict::kNotDecidable;
  std::string s;
  if (on.empty()) {
    s = "UNDECIDABLE: no figure can be decided";
  } else {
    s = fmt::format("{} on {}: {} of {} values pass, {} fail, {} undecidable",
                    Upper(VerdictName(overall)), FigureList(on),
                    counts[static_cast<int>(Verdict::kPass)], graded,
                    counts[static_cast<int>(Verdict::kFail)],
                    counts[static_cast<int>(Verdict::kUndecidable)]);
    if (counts[static_cast<int>(Verdict::kMissing)] > 0)
      s += fmt::format(", {} missing",
                       counts[static_cast<int>(Verdict::kMissing)]);
  }
  std::string not_decided;
  for (const FigureGrade& fg : figures) {
    if (fg.decided) continue;
    not_decided += fmt::format("  {}: {}\n", FigureName(fg.figure), fg.reason);
  }
  s += "\nLimits: " + limits.Describe() +
       "; ISO 14253-1 (conformance zone reduced by U, k = 2)\n";
  if (!not_decided.empty()) s += "Not decided:\n" + not_decided;
  return s;
}

nlohmann::json GradeToJson(const GradeResult& r) {
  using nlohmann::json;
  auto num = [](double v) {
    return std::isfinite(v) ? json(v) : json(nullptr);
  };
  json values = json::array();
  for (const auto& g : r.values) {
    values.push_back({{"cycle", g.cycle},
                      {"figure", FigureName(g.figure)},
                      {"unit", FigureUnit(g.figure)},
                      {"value", num(g.value)},
                      {"u_expanded", num(g.u)},
                      {"limit", g.limit},
                      {"verdict", VerdictName(g.verdict)}});
  }
  json figures = json::array();
  for (const auto& fg : r.figures) {
    figures.push_back({{"figure", FigureName(fg.figure)},
                       {"unit", FigureUnit(fg.figure)},
                       {"limit", fg.limit},
                       {"decided", fg.decided},
                       {"verdict", fg.decided ? json(VerdictName(fg.verdict))
                                              : json(nullptr)},
                       {"reason", fg.decided ? json(nullptr) : json(fg.reason)},
                       {"max_u_expanded", num(fg.max_u)}});
  }
  json on = json::array();
  for (Figure f : r.DecidedOn()) on.push_back(FigureName(f));
  const GradeLimits thesis;
  return {{"verdict", VerdictName(r.overall)},
          {"decided_on", on},
          {"summary", r.Summary().substr(0, r.Summary().find('\n'))},
          {"rule",
           "ISO 14253-1: pass if |value| <= limit - U, fail if |value| > limit "
           "+ U, else undecidable (U expanded, k = 2)"},
          {"limits",
           {{"linear_um", r.limits.linear_um},
            {"angular_um_per_m", r.limits.angular_um_per_m},
            {"description", r.limits.Describe()}}},
          {"counts",
           {{"pass", r.counts[0]},
            {"fail", r.counts[1]},
            {"undecidable", r.counts[2]},
            {"missing", r.counts[3]},
            {"not_decidable", r.counts[4]}}},
          {"figures", figures},
          {"values", values}};
}

std::string GradeTable(const GradeResult& r, bool verbose) {
  std::ostringstream s;
  s << "VERDICT: " << r.Summary();
  if (!verbose) return s.str();
  s << "cycle figure      value        U    limit  verdict\n";
  for (const auto& g : r.values) {
    s << fmt::format("{:5d} {:<6} {:>9} {:>8} {:>8}  {}\n", g.cycle,
                     FigureName(g.figure), Fixed(g.value, 3), Fixed(g.u, 3),
                     Short(g.limit), VerdictName(g.verdict));
  }
  return s.str();
}

}  // namespace ttp::inspect
