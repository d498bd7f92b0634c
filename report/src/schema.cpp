// Validation of the report data (docs/REPORT.md). Every problem names the
// JSON path of the offending value so a producer can find it.
#include <cmath>
#include <set>
#include <string>

#include "report_schema.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/report/report.h"

namespace ttp {
namespace {

using nlohmann::json;

class Checker {
 public:
  explicit Checker(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void Fail(const std::string& path,
                         const std::string& problem) const {
    throw InputError(source_, 0, path.empty() ? "(root)" : path, problem);
  }
  static std::string Join(const std::string& path, const std::string& key) {
    return path.empty() ? key : path + "." + key;
  }
  static std::string Index(const std::string& path, size_t i) {
    return path + "[" + std::to_string(i) + "]";
  }

  void Object(const json& v, const std::string& path) const {
    if (!v.is_object()) Fail(path, "must be an object");
  }
  void Array(const json& v, const std::string& path) const {
    if (!v.is_array()) Fail(path, "must be an array");
  }
  void String(const json& v, const std::string& path) const {
    if (!v.is_string()) Fail(path, "must be a string");
  }
  double Number(const json& v, const std::string& path) const {
    if (!v.is_number()) Fail(path, "must be a number");
    const double x = v.get<double>();
    if (!std::isfinite(x)) Fail(path, "must be finite");
    return x;
  }
  void NumberOrNull(const json& v, const std::string& path) const {
    if (!v.is_null()) Number(v, path);
  }
  void OnlyKeys(const json& v, const std::string& path,
                const std::set<std::string>& allowed) const {
    for (const auto& [key, value] : v.items()) {
      if (!allowed.count(key)) {
        Fail(Join(path, key), "unknown key (see docs/REPORT.md)");
      }
    }
  }
  const json& Required(const json& v, const std::string& path,
                       const std::string& key) const {
    if (!v.contains(key)) Fail(Join(path, key), "missing");
    return v.at(key);
  }

 private:
  std::string source_;
};

void CheckFigureList(const Checker& c, const json& list,
                     const std::string& path, bool u_required, int cycles) {
  c.Array(list, path);
  std::set<int> seen;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string p = Checker::Index(path, i);
    const json& entry = list[i];
    c.Object(entry, p);
    std::set<std::string> allowed(report_internal::kFigureKeys.begin(),
                                  report_internal::kFigureKeys.end());
    allowed.insert({"cycle", "U"});
    c.OnlyKeys(entry, p, allowed);
    const json& cycle = c.Required(entry, p, "cycle");
    if (!cycle.is_number_integer() || cycle.get<int>() < 1 ||
        cycle.get<int>() > cycles) {
      c.Fail(Checker::Join(p, "cycle"),
             "must be an integer in 1.." + std::to_string(cycles));
    }
    if (!seen.insert(cycle.get<int>()).second) {
      c.Fail(Checker::Join(p, "cycle"), "repeats an earlier cycle");
    }
    for (const auto& key : report_internal::kFigureKeys) {
      c.NumberOrNull(c.Required(entry, p, key), Checker::Join(p, key));
    }
    if (!entry.contains("U")) {
      if (u_required) c.Fail(Checker::Join(p, "U"), "missing");
      continue;
    }
    const std::string pu = Checker::Join(p, "U");
    c.Object(entry["U"], pu);
    c.OnlyKeys(entry["U"], pu,
               std::set<std::string>(report_internal::kFigureKeys.begin(),
                                     report_internal::kFigureKeys.end()));
    for (const auto& key : report_internal::kFigureKeys) {
      const json& u = c.Required(entry["U"], pu, key);
      if (u.is_null()) {
        if (!entry[key].is_null()) {
          c.Fail(Checker::Join(pu, key), "null while the figure has a value");
        }
        continue;
      }
      if (c.Number(u, Checker::Join(pu, key)) < 0) {
        c.Fail(Checker::Join(pu, key), "must be >= 0");
      }
    }
  }
}

void CheckColumns(const Checker& c, const json& table, const std::string& path,
                  const std::set<std::string>& columns) {
  c.Object(table, path);
  c.OnlyKeys(table, path, columns);
  const json& t = c.Required(table, path, "t_s");
  c.Array(t, Checker::Join(path, "t_s"));
  double previous = -INFINITY;
  for (size_t i = 0; i < t.size(); ++i) {
    const std::string p = Checker::Index(Checker::Join(path, "t_s"), i);
    const double x = c.Number(t[i], p);
    if (x < previous) c.Fail(p, "time goes backwards");
    previous = x;
  }
  for (const auto& [key, column] : table.items()) {
    const std::string p = Checker::Join(path, key);
    c.Array(column, p);
    if (column.size() != t.size()) {
      c.Fail(p, "has " + std::to_string(column.size()) + " values, t_s has " +
                    std::to_string(t.size()));
    }
    for (size_t i = 0; i < column.size(); ++i) {
      c.NumberOrNull(column[i], Checker::Index(p, i));
    }
  }
}

void CheckLog(const Checker& c, const json& log) {
  c.Object(log, "log");
  c.OnlyKeys(log, "log", {"start", "samples", "rtests", "cuts"});
  if (log.contains("start")) c.String(log["start"], "log.start");
  if (log.contains("samples")) {
    CheckColumns(
        c, log["samples"], "log.samples",
        {"t_s", "T_env", "T_ws", "T_mwf", "dT_cool", "c_rpm", "spindle_rpm"});
  }
  if (log.contains("rtests")) {
    std::set<std::string> columns(report_internal::kRtestKeys.begin(),
                                  report_internal::kRtestKeys.end());
    columns.insert("t_s");
    CheckColumns(c, log["rtests"], "log.rtests", columns);
  }
  if (log.contains("cuts")) {
    const json& cuts = log["cuts"];
    c.Array(cuts, "log.cuts");
    for (size_t i = 0; i < cuts.size(); ++i) {
      const std::string p = Checker::Index("log.cuts", i);
      c.Object(cuts[i], p);
      c.OnlyKeys(cuts[i], p, {"t_s", "feature", "c_deg"});
      c.Number(c.Required(cuts[i], p, "t_s"), Checker::Join(p, "t_s"));
      const json& feature = c.Required(cuts[i], p, "feature");
      c.String(feature, Checker::Join(p, "feature"));
      FeatureKind kind;
      Segment segment;
      int index = 0;
      if (!ParseFeatureId(feature.get<std::string>(), &kind, &segment,
                          &index)) {
        c.Fail(Checker::Join(p, "feature"),
               "'" + feature.get<std::string>() +
                   "' is not a feature name (talc-log.md section 5)");
      }
      if (cuts[i].contains("c_deg")) {
        c.Number(cuts[i]["c_deg"], Checker::Join(p, "c_deg"));
      }
    }
  }
}

// name -> number map (fitted parameters, their uncertainties).
void CheckNumberMap(const Checker& c, const json& map,
                    const std::string& path) {
  c.Object(map, path);
  for (const auto& [name, value] : map.items()) {
    c.Number(value, Checker::Join(path, name));
  }
}

void CheckResiduals(const Checker& c, const json& r, const std::string& path) {
  c.Object(r, path);
  c.OnlyKeys(r, path, {"cycles", "before", "after", "sigma"});
  const json& cycles = c.Required(r, path, "cycles");
  c.Array(cycles, Checker::Join(path, "cycles"));
  for (size_t i = 0; i < cycles.size(); ++i) {
    if (!cycles[i].is_number_integer()) {
      c.Fail(Checker::Index(Checker::Join(path, "cycles"), i),
             "must be an integer");
    }
  }
  const std::set<std::string> keys = {"E_X", "E_Y", "E_Z", "E_TTP"};
  for (const char* part : {"before", "after", "sigma"}) {
    const std::string p = Checker::Join(path, part);
    if (std::string(part) != "sigma" || r.contains(part)) {
      const json& table = c.Required(r, path, part);
      c.Object(table, p);
      c.OnlyKeys(table, p, keys);
      for (const auto& [key, column] : table.items()) {
        const std::string pk = Checker::Join(p, key);
        c.Array(column, pk);
        if (column.size() != cycles.size()) {
          c.Fail(pk, "has " + std::to_string(column.size()) +
                         " values, cycles has " +
                         std::to_string(cycles.size()));
        }
        for (size_t i = 0; i < column.size(); ++i) {
          c.NumberOrNull(column[i], Checker::Index(pk, i));
        }
      }
    }
  }
}

// The diagnosis is DiagnosisToJson (diagnosis/diagnose.h) plus "summary",
// "threshold" and "residuals" added by AssembleReportData.
void CheckDiagnosis(const Checker& c, const json& d) {
  c.Object(d, "diagnosis");
  c.OnlyKeys(d, "diagnosis",
             {"status",           "reason",       "cause",
              "summary",          "baseline",     "extended",
              "gain_pct",         "gain",         "evidence",
              "threshold",        "chi2_per_dof", "observations",
              "estimator",        "warnings",     "candidates",
              "residuals",        "unexplained",  "residual_by_location",
              "simulation_slope", "decision"});
  c.String(c.Required(d, "diagnosis", "status"), "diagnosis.status");
  // No cause when refused (diagnosis.md section 3).
  if (d["status"] != "refused")
    c.String(c.Required(d, "diagnosis", "cause"), "diagnosis.cause");
  if (d.contains("unexplained"))
    c.Array(d["unexplained"], "diagnosis.unexplained");
  if (d.contains("decision")) c.Object(d["decision"], "diagnosis.decision");
  if (d.contains("warnings")) {
    c.Array(d["warnings"], "diagnosis.warnings");
    for (const json& w : d["warnings"]) c.String(w, "diagnosis.warnings[]");
  }
  for (const char* key : {"summary", "evidence", "estimator", "reason"}) {
    if (d.contains(key)) c.String(d[key], Checker::Join("diagnosis", key));
  }
  for (const char* key : {"threshold", "observations", "chi2_per_dof"}) {
    if (d.contains(key)) c.Number(d[key], Checker::Join("diagnosis", key));
  }
  const json& baseline = c.Required(d, "diagnosis", "baseline");
  c.Object(baseline, "diagnosis.baseline");
  c.OnlyKeys(baseline, "diagnosis.baseline", {"rms_um", "rms_urad"});
  c.Number(c.Required(baseline, "diagnosis.baseline", "rms_um"),
           "diagnosis.baseline.rms_um");
  if (baseline.contains("rms_urad")) {
    c.Number(baseline["rms_urad"], "diagnosis.baseline.rms_urad");
  }
  const json& extended = c.Required(d, "diagnosis", "extended");
  c.Object(extended, "diagnosis.extended");
  c.OnlyKeys(extended, "diagnosis.extended",
             {"rms_um", "rms_urad", "params", "uncertainty"});
  c.Number(c.Required(extended, "diagnosis.extended", "rms_um"),
           "diagnosis.extended.rms_um");
  if (extended.contains("rms_urad")) {
    c.Number(extended["rms_urad"], "diagnosis.extended.rms_urad");
  }
  for (const char* key : {"params", "uncertainty"}) {
    if (extended.contains(key)) {
      CheckNumberMap(c, extended[key],
                     Checker::Join("diagnosis.extended", key));
    }
  }
  c.Number(c.Required(d, "diagnosis", "gain_pct"), "diagnosis.gain_pct");
  if (d.contains("gain")) {
    const json& gain = d["gain"];
    c.Object(gain, "diagnosis.gain");
    c.OnlyKeys(gain, "diagnosis.gain",
               {"method", "heldout_baseline_rms_um", "heldout_extended_rms_um",
                "heldout_baseline_rms_urad", "heldout_extended_rms_urad"});
    if (gain.contains("method")) {
      c.String(gain["method"], "diagnosis.gain.method");
    }
    for (const char* key :
         {"heldout_baseline_rms_um", "heldout_extended_rms_um",
          "heldout_baseline_rms_urad", "heldout_extended_rms_urad"}) {
      if (gain.contains(key)) {
        c.Number(gain[key], Checker::Join("diagnosis.gain", key));
      }
    }
  }
  const json& candidates = c.Required(d, "diagnosis", "candidates");
  c.Array(candidates, "diagnosis.candidates");
  for (size_t i = 0; i < candidates.size(); ++i) {
    const std::string p = Checker::Index("diagnosis.candidates", i);
    const json& cand = candidates[i];
    c.Object(cand, p);
    c.OnlyKeys(cand, p,
               {"cause", "delta_bic", "bic", "chi2", "parameters", "rms_um",
                "rms_urad", "params", "note"});
    c.String(c.Required(cand, p, "cause"), Checker::Join(p, "cause"));
    c.Number(c.Required(cand, p, "delta_bic"), Checker::Join(p, "delta_bic"));
    for (const char* key :
         {"bic", "chi2", "parameters", "rms_um", "rms_urad"}) {
      if (cand.contains(key)) c.Number(cand[key], Checker::Join(p, key));
    }
    if (cand.contains("params")) {
      const std::string pp = Checker::Join(p, "params");
      c.Object(cand["params"], pp);
      for (const auto& [name, value] : cand["params"].items()) {
        const std::string pn = Checker::Join(pp, name);
        c.Object(value, pn);
        c.OnlyKeys(value, pn, {"value", "uncertainty"});
        c.Number(c.Required(value, pn, "value"), Checker::Join(pn, "value"));
        if (value.contains("uncertainty")) {
          c.Number(value["uncertainty"], Checker::Join(pn, "uncertainty"));
        }
      }
    }
    if (cand.contains("note")) c.String(cand["note"], Checker::Join(p, "note"));
  }
  if (d.contains("residuals")) {
    CheckResiduals(c, d["residuals"], "diagnosis.residuals");
  }
}

// The grading, as GradeToJson (inspect/grade.h) writes it
// (schemas/grade.schema.json).
void CheckGrade(const Checker& c, const json& g) {
  c.Object(g, "grade");
  c.OnlyKeys(g, "grade",
             {"verdict", "decided_on", "summary", "rule", "limits", "counts",
              "figures", "values"});
  const json& verdict = c.Required(g, "grade", "verdict");
  c.String(verdict, "grade.verdict");
  const std::string v = verdict.get<std::string>();
  if (v != "pass" && v != "fail" && v != "undecidable") {
    c.Fail("grade.verdict", "must be pass, fail or undecidable");
  }
  c.String(c.Required(g, "grade", "rule"), "grade.rule");
  if (g.contains("summary")) c.String(g["summary"], "grade.summary");
  if (g.contains("limits")) {
    c.Object(g["limits"], "grade.limits");
    for (const char* key : {"linear_um", "angular_um_per_m"})
      c.Number(c.Required(g["limits"], "grade.limits", key),
               Checker::Join("grade.limits", key));
    if (g["limits"].contains("description"))
      c.String(g["limits"]["description"], "grade.limits.description");
  }
  if (g.contains("counts")) CheckNumberMap(c, g["counts"], "grade.counts");
  if (g.contains("decided_on")) {
    c.Array(g["decided_on"], "grade.decided_on");
    for (size_t i = 0; i < g["decided_on"].size(); ++i)
      c.String(g["decided_on"][i], Checker::Index("grade.decided_on", i));
  }
  if (g.contains("figures")) {
    c.Array(g["figures"], "grade.figures");
    for (size_t i = 0; i < g["figures"].size(); ++i) {
      const std::string p = Checker::Index("grade.figures", i);
      const json& f = g["figures"][i];
      c.Object(f, p);
      c.String(c.Required(f, p, "figure"), Checker::Join(p, "figure"));
      c.String(c.Required(f, p, "unit"), Checker::Join(p, "unit"));
      c.Number(c.Required(f, p, "limit"), Checker::Join(p, "limit"));
      if (!c.Required(f, p, "decided").is_boolean())
        c.Fail(Checker::Join(p, "decided"), "must be true or false");
      const json& reason = c.Required(f, p, "reason");
      if (!f["decided"].get<bool>() && !reason.is_string())
        c.Fail(Checker::Join(p, "reason"), "must say why it is not decided");
    }
  }
  if (g.contains("values")) {
    c.Array(g["values"], "grade.values");
    for (size_t i = 0; i < g["values"].size(); ++i) {
      const std::string p = Checker::Index("grade.values", i);
      const json& e = g["values"][i];
      c.Object(e, p);
      c.Number(c.Required(e, p, "cycle"), Checker::Join(p, "cycle"));
      c.String(c.Required(e, p, "figure"), Checker::Join(p, "figure"));
      c.String(c.Required(e, p, "unit"), Checker::Join(p, "unit"));
      c.String(c.Required(e, p, "verdict"), Checker::Join(p, "verdict"));
      c.Number(c.Required(e, p, "limit"), Checker::Join(p, "limit"));
      c.NumberOrNull(c.Required(e, p, "value"), Checker::Join(p, "value"));
      c.NumberOrNull(c.Required(e, p, "u_expanded"),
                     Checker::Join(p, "u_expanded"));
    }
  }
}

}  // namespace

PartSpec report_internal::PartFromReportData(const json& report_data,
                                             const std::string& source) {
  if (!report_data.contains("part")) return PartSpec{};
  return ConfigFromJson(json{{"part", report_data["part"]}}, source).part;
}

void ValidateReportData(const json& report_data, const std::string& source) {
  const Checker c(source);
  c.Object(report_data, "");
  c.OnlyKeys(report_data, "",
             {"schema", "title", "run", "part", "limits", "figures", "facets",
              "log", "diagnosis", "grade", "warnings"});
  const json& schema = c.Required(report_data, "", "schema");
  if (schema != kReportSchema) {
    c.Fail("schema", std::string("must be \"") + kReportSchema + "\"");
  }
  if (report_data.contains("title")) c.String(report_data["title"], "title");
  if (report_data.contains("run")) {
    c.Object(report_data["run"], "run");
    for (const auto& [key, value] : report_data["run"].items()) {
      if (!value.is_string() && !value.is_number() && !value.is_boolean()) {
        c.Fail(Checker::Join("run", key), "must be a string, number or bool");
      }
    }
  }
  const PartSpec part =
      report_internal::PartFromReportData(report_data, source);
  if (report_data.contains("limits")) {
    const json& limits = report_data["limits"];
    c.Object(limits, "limits");
    c.OnlyKeys(limits, "limits", {"linear_um", "angular_um_per_m"});
    for (const auto& [key, value] : limits.items()) {
      if (c.Number(value, Checker::Join("limits", key)) <= 0) {
        c.Fail(Checker::Join("limits", key), "must be > 0");
      }
    }
  }
  if (report_data.contains("figures")) {
    const json& figures = report_data["figures"];
    c.Object(figures, "figures");
    c.OnlyKeys(figures, "figures",
               {"measured", "simulated", "simulated_linear"});
    if (figures.contains("measured")) {
      CheckFigureList(c, figures["measured"], "figures.measured", true,
                      part.cycles());
    }
    if (figures.contains("simulated_linear")) {
      CheckFigureList(c, figures["simulated_linear"],
                      "figures.simulated_linear", false, part.cycles());
    }
    if (figures.contains("simulated")) {
      CheckFigureList(c, figures["simulated"], "figures.simulated", false,
                      part.cycles());
    }
  }
  if (report_data.contains("facets")) {
    const json& facets = report_data["facets"];
    c.Object(facets, "facets");
    for (const auto& [id, facet] : facets.items()) {
      const std::string p = Checker::Join("facets", id);
      FeatureKind kind;
      Segment segment;
      int index = 0;
      if (!ParseFeatureId(id, &kind, &segment, &index)) {
        c.Fail(p, "'" + id + "' is not a feature name");
      }
      c.Object(facet, p);
      c.OnlyKeys(facet, p, {"distance_mm", "angle_error_urad"});
      for (const auto& [key, value] : facet.items()) {
        c.NumberOrNull(value, Checker::Join(p, key));
      }
    }
  }
  if (report_data.contains("grade")) CheckGrade(c, report_data["grade"]);
  if (report_data.contains("warnings")) {
    c.Array(report_data["warnings"], "warnings");
    for (size_t i = 0; i < report_data["warnings"].size(); ++i) {
      c.String(report_data["warnings"][i], Checker::Index("warnings", i));
    }
  }
  if (report_data.contains("log")) CheckLog(c, report_data["log"]);
  if (report_data.contains("diagnosis")) {
    CheckDiagnosis(c, report_data["diagnosis"]);
  }
}

}  // namespace ttp
