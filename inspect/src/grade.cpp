#include "ttp/inspect/grade.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "ttp/geometry/error.h"

namespace ttp::inspect {

void GradeLimits::Validate() const {
  if (!(linear_um > 0) || !std::isfinite(linear_um)) {
    throw InputError("--limit-linear-um", 0, "limit",
                     "must be a positive number");
  }
  if (!(angular_um_per_m > 0) || !std::isfinite(angular_um_per_m)) {
    throw InputError("--limit-angular-um-per-m", 0, "limit",
                     "must be a positive number");
  }
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
  }
  return "?";
}

Verdict Decide(double value, double u, double limit) {
  if (!std::isfinite(value)) return Verdict::kMissing;
  if (!std::isfinite(u) || u < 0) u = std::numeric_limits<double>::infinity();
  const double a = std::abs(value);
  if (a <= limit - u) return Verdict::kPass;
  if (a > limit + u) return Verdict::kFail;
  return Verdict::kUndecidable;
}

GradeResult GradeFigures(const nlohmann::json& doc, const GradeLimits& limits,
                         const std::string& source) {
  limits.Validate();
  GradeResult r;
  if (!doc.is_object() || !doc.contains("figures") ||
      !doc["figures"].is_array()) {
    throw InputError(source, 0, "figures",
                     "missing: not an inspection result (ttp inspect --json)");
  }
  const struct {
    const char* name;
    bool angular;
  } kFigures[] = {{"E_X", false}, {"E_Y", false},   {"E_Z", false},
                  {"E_B", true},  {"E_TTP", false}, {"E_C", true}};
  int k = 0;
  for (const auto& f : doc["figures"]) {
    ++k;
    if (!f.is_object() || !f.contains("cycle") ||
        !f["cycle"].is_number_integer()) {
      throw InputError(source, 0,
                       "figures[" + std::to_string(k - 1) + "].cycle",
                       "missing or not an integer");
    }
    for (const auto& fig : kFigures) {
      if (!f.contains(fig.name)) {
        if (std::string(fig.name) == "E_C") continue;  // optional
        throw InputError(source, 0,
                         "figures[" + std::to_string(k - 1) + "]." + fig.name,
                         "missing");
      }
      GradedValue g;
      g.cycle = f["cycle"].get<int>();
      g.figure = fig.name;
      g.limit = fig.angular ? limits.angular_um_per_m : limits.linear_um;
      const auto& v = f[fig.name];
      const nlohmann::json u = f.contains("U") && f["U"].contains(fig.name)
                                   ? f["U"][fig.name]
                                   : nullptr;
      if (!v.is_null() && !v.is_number()) {
        throw InputError(source, 0,
                         "figures[" + std::to_string(k - 1) + "]." + fig.name,
                         "not a number");
      }
      g.value = v.is_number() ? v.get<double>() : std::nan("");
      g.u = u.is_number() ? u.get<double>()
                          : (v.is_number() ? 0.0 : std::nan(""));
      g.verdict = Decide(g.value, g.u, g.limit);
      ++r.counts[static_cast<int>(g.verdict)];
      r.values.push_back(g);
    }
  }
  if (r.values.empty()) throw InputError(source, 0, "figures", "empty");
  if (r.counts[static_cast<int>(Verdict::kFail)] > 0)
    r.overall = Verdict::kFail;
  else if (r.counts[static_cast<int>(Verdict::kPass)] ==
           static_cast<int>(r.values.size()))
    r.overall = Verdict::kPass;
  else
    r.overall = Verdict::kUndecidable;
  return r;
}

nlohmann::json GradeToJson(const GradeResult& r, const GradeLimits& limits) {
  nlohmann::json values = nlohmann::json::array();
  for (const auto& g : r.values) {
    values.push_back(
        {{"cycle", g.cycle},
         {"figure", g.figure},
         {"value", std::isfinite(g.value) ? nlohmann::json(g.value)
                                          : nlohmann::json(nullptr)},
         {"U",
          std::isfinite(g.u) ? nlohmann::json(g.u) : nlohmann::json(nullptr)},
         {"limit", g.limit},
         {"verdict", VerdictName(g.verdict)}});
  }
  return {{"verdict", VerdictName(r.overall)},
          {"rule",
           "ISO 14253-1: pass if |value| <= limit - U, fail if |value| > limit "
           "+ U, else undecidable"},
          {"limits",
           {{"linear_um", limits.linear_um},
            {"angular_um_per_m", limits.angular_um_per_m}}},
          {"counts",
           {{"pass", r.counts[0]},
            {"fail", r.counts[1]},
            {"undecidable", r.counts[2]},
            {"missing", r.counts[3]}}},
          {"values", values}};
}

std::string GradeTable(const GradeResult& r, const GradeLimits& limits) {
  std::ostringstream s;
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "Limits: %.3g um linear, %.3g um/m angular; ISO 14253-1 (zone "
                "reduced by U, k = 2)\n",
                limits.linear_um, limits.angular_um_per_m);
  s << buf;
  s << "cycle figure      value        U    limit  verdict\n";
  for (const auto& g : r.values) {
    if (std::isfinite(g.value)) {
      std::snprintf(buf, sizeof buf, "%5d %-6s %9.3f %8.3f %8.3g  %s\n",
                    g.cycle, g.figure.c_str(), g.value, g.u, g.limit,
                    VerdictName(g.verdict));
    } else {
      std::snprintf(buf, sizeof buf, "%5d %-6s %9s %8s %8.3g  %s\n", g.cycle,
                    g.figure.c_str(), "-", "-", g.limit,
                    VerdictName(g.verdict));
    }
    s << buf;
  }
  std::string verdict = VerdictName(r.overall);
  for (char& c : verdict)
    c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  std::snprintf(buf, sizeof buf,
                "VERDICT: %s (%d pass, %d fail, %d undecidable, %d missing)\n",
                verdict.c_str(), r.counts[0], r.counts[1], r.counts[2],
                r.counts[3]);
  s << buf;
  return s.str();
}

}  // namespace ttp::inspect
