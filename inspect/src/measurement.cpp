#include "ttp/inspect/measurement.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/geometry/limits.h"
#include "ttp/inspect/dial.h"
#include "ttp/inspect/dmis.h"
#include "ttp/inspect/probe.h"

namespace ttp::inspect {
namespace {

// The whole file (ReadTextFile notes it as an input: never written over
// by this command's outputs; a pipe is read once and kept).
std::string ReadAll(const std::filesystem::path& path) {
  return ReadTextFile(path);
}

// The first line that is not blank and not a `#` comment, lower case and
// without spaces (for header sniffing).
std::string FirstDataLine(const std::string& head) {
  std::istringstream in(head);
  std::string line;
  while (std::getline(in, line)) {
    std::string t;
    for (char c : line)
      if (!std::isspace(static_cast<unsigned char>(c))) t += c;
    if (t.empty() || t[0] == '#') continue;
    return Lower(t);
  }
  return "";
}

}  // namespace

const char* MeasurementKindName(MeasurementKind kind) {
  switch (kind) {
    case MeasurementKind::kCloud:
      return "cloud";
    case MeasurementKind::kInspectionJson:
      return "inspection-json";
    case MeasurementKind::kDial:
      return "dial";
    case MeasurementKind::kDmis:
      return "dmis";
    case MeasurementKind::kProbe:
      return "probe";
  }
  return "?";
}

MeasurementKind SniffMeasurement(const std::string& head,
                                 const std::filesystem::path& path) {
  size_t b = 0;
  if (head.compare(0, 3, "\xEF\xBB\xBF") == 0) b = 3;  // UTF-8 BOM
  while (b < head.size() && std::isspace(static_cast<unsigned char>(head[b])))
    ++b;
  const std::string start = head.substr(b, 64);
  if (start.rfind("ply", 0) == 0) return MeasurementKind::kCloud;
  const std::string lower = Lower(head.substr(b, 4096));
  if (lower.rfind("# .pcd", 0) == 0 || lower.rfind("version", 0) == 0 ||
      lower.rfind("fields", 0) == 0)
    return MeasurementKind::kCloud;
  if (!start.empty() && start[0] == '{')
    return MeasurementKind::kInspectionJson;
  if (lower.rfind("dmismn", 0) == 0 ||
      lower.find("\nfa(") != std::string::npos || lower.rfind("fa(", 0) == 0 ||
      lower.find("dmismn/") != std::string::npos)
    return MeasurementKind::kDmis;
  const std::string header = FirstDataLine(head.substr(0, 4096));
  if (header.rfind("point_id", 0) == 0) return MeasurementKind::kProbe;
  // The FANUC probing program's DPRNT output (plan/probe_program.h).
  if (lower.find("ttp probe log") != std::string::npos)
    return MeasurementKind::kProbe;
  if (header.find("feature") != std::string::npos &&
      header.find("reading_um") != std::string::npos)
    return MeasurementKind::kDial;
  const std::string ext = Lower(path.extension().string());
  if (ext == ".json") return MeasurementKind::kInspectionJson;
  if (ext == ".dmi" || ext == ".dmo" || ext == ".dmis")
    return MeasurementKind::kDmis;
  return MeasurementKind::kCloud;
}

std::string SniffLogFormat(const std::string& head) {
  std::istringstream in(head);
  std::string line;
  bool first = true;
  while (std::getline(in, line)) {
    if (first && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    first = false;
    const size_t b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos) continue;
    if (line[b] != '#') return "";
    const size_t k = line.find_first_not_of(" \t", b + 1);
    if (k == std::string::npos) continue;
    for (const std::string tag : {"thermal-log", "talc-log"}) {
      const size_t colon = line.find_first_not_of(" \t", k + tag.size());
      if (Lower(line.substr(k, tag.size())) == tag &&
          colon != std::string::npos && line[colon] == ':')
        return tag;
    }
  }
  return "";
}

namespace {

// Every test feature gets an entry (missing ones present = false) and a
// diagnostic, so that the JSON lists what is missing.
void CompleteFeatures(const PartSpec& part, InspectionResult* r) {
  r->diagnostics.clear();
  for (const NominalFeature& f : TestFeatures(part)) {
    FeatureResult& fr = r->features[f.Key()];
    FeatureDiagnostic d;
    d.id = f.id;
    d.candidates = d.used = fr.points;
    d.rms_mm = fr.rms_mm;
    d.status = fr.present ? "ok" : "missing";
    if (!fr.present) r->warnings.push_back(f.id + " is missing");
    r->diagnostics.push_back(d);
  }
}

double NumberOrNaN(const nlohmann::json& obj, const char* key,
                   const std::string& source, const std::string& where) {
  if (!obj.contains(key) || obj.at(key).is_null()) return kNaN;
  if (!obj.at(key).is_number())
    throw InputError(source, 0, where + "." + key, "is not a number");
  return obj.at(key).get<double>();
}

// A value read from the JSON checked against its limit (NaN = not given
// passes): 1e308 is finite, but no measured piece of this size has it.
double Within(double v, double limit, const std::string& source,
              const std::string& field, const char* unit) {
  if (std::isfinite(v) && std::abs(v) <= limit) return v;
  if (std::isnan(v)) return v;
  throw InputError(source, 0, field,
                   fmt::format("{:g} {} is beyond the limit of {:g} {} (not a "
                               "measurement of this piece)",
                               v, unit, limit, unit));
}

// An expanded uncertainty: >= 0 when given.
double Uncertainty(double u, const std::string& source,
                   const std::string& field) {
  if (std::isnan(u)) return u;
  if (!(u >= 0))
    throw InputError(
        source, 0, field,
        fmt::format("{:g} is negative: an uncertainty is >= 0", u));
  return Within(u, limits::kMaxFigureMicro, source, field, "um or urad");
}

// Variance (mm^2 or rad^2) from an expanded uncertainty U (k = 2) in um or
// urad; 0 when the document gives none.
double VarFromU(double u_micro) {
  if (!std::isfinite(u_micro)) return 0.0;
  const double s = u_micro * 1e-6 / 2.0;
  return s * s;
}

void ReadFeatureBlock(const nlohmann::json& doc, const char* block,
                      const char* d_key, const char* a_key, const char* ud_key,
                      const char* ua_key, const char* scatter_ud_key,
                      const char* scatter_ua_key, const std::string& source,
                      const PartSpec& part, InspectionResult* r) {
  if (!doc.contains(block)) return;
  const nlohmann::json& obj = doc.at(block);
  if (!obj.is_object())
    throw InputError(source, 0, block, "must be an object keyed by feature id");
  std::map<std::string, double> known;  // id -> nominal d
  for (const NominalFeature& f : TestFeatures(part))
    known[f.id] =
        f.kind == FeatureKind::kStrip ? -part.strip_floor_z_mm : f.size_mm;
  for (const auto& [id, v] : obj.items()) {
    const std::string where = std::string(block) + "." + id;
    if (!known.count(id))
      throw InputError(source, 0, where, "is not a feature of the piece");
    if (!v.is_object()) throw InputError(source, 0, where, "must be an object");
    const FeatureId fid = *FeatureId::Parse(id);  // a known test feature
    FeatureResult fr;
    const double d = NumberOrNaN(v, d_key, source, where);
    if (!std::isfinite(d)) {
      r->features[fid] = fr;  // missing
      continue;
    }
    fr.present = true;
    Within(d - known[id], limits::kMaxFeatureDeviationMm, source,
           where + "." + d_key + " - nominal", "mm");
    fr.d_mm = d;
    const double a = Within(NumberOrNaN(v, a_key, source, where),
                            limits::kMaxFeatureAngleRad * 1e6, source,
                            where + "." + a_key, "urad");
    fr.angle_rad = a * 1e-6;  // NaN stays NaN: that figure is missing
    // U in um (k = 2) -> variance in mm^2. A value without its U would be
    // taken as exact: every judgement on it (a grade, a diagnosis) would
    // claim more than the measurement shows.
    // (a named reference: clang before 16 does not capture a structured
    // binding in a lambda)
    const nlohmann::json& feature = v;
    auto required_u = [&](const char* key, const char* value_key) {
      const double u = Uncertainty(NumberOrNaN(feature, key, source, where),
                                   source, where + "." + key);
      if (std::isnan(u))
        throw InputError(source, 0, where + "." + key,
                         fmt::format("missing: {} needs its expanded "
                                     "uncertainty (k = 2)",
                                     value_key));
      return u;
    };
    fr.var_d_mm2 = VarFromU(required_u(ud_key, d_key)) * 1e6;
    fr.var_angle_rad2 =
        std::isfinite(a) ? VarFromU(required_u(ua_key, a_key)) : kNaN;
    const double tilt = Within(NumberOrNaN(v, "tilt_urad", source, where),
                               limits::kMaxFeatureAngleRad * 1e6, source,
                               where + ".tilt_urad", "urad");
    fr.tilt_rad = std::isfinite(tilt) ? tilt * 1e-6 : 0.0;
    const double pts = Within(NumberOrNaN(v, "points", source, where),
                              static_cast<double>(limits::kMaxCloudPoints),
                              source, where + ".points", "points");
    fr.points = std::isfinite(pts) && pts > 0 ? static_cast<int>(pts) : 0;
    const double rms =
        Within(NumberOrNaN(v, "rms_um", source, where), limits::kMaxFigureMicro,
               source, where + ".rms_um", "um");
    fr.rms_mm = std::isfinite(rms) ? rms * 1e-3 : 0.0;
    // The fit's own part of U (`ttp inspect --json` of a cloud): optional,
    // and never more than the whole.
    const auto scatter_var = [&](const char* key, double whole, double unit) {
      const double u = Uncertainty(NumberOrNaN(feature, key, source, where),
                                   source, where + "." + key);
      if (std::isnan(u)) return 0.0;
      const double var = VarFromU(u) * unit;
      if (var > whole * (1 + 1e-9) + 1e-30)
        throw InputError(source, 0, where + "." + key,
                         fmt::format("{:g} is larger than the whole "
                                     "uncertainty it is a part of",
                                     u));
      return var;
    };
    fr.scatter_var_d_mm2 = scatter_var(scatter_ud_key, fr.var_d_mm2, 1e6);
    if (fr.scatter_var_d_mm2 > 0 && std::isfinite(fr.var_angle_rad2))
      fr.scatter_var_angle_rad2 =
          scatter_var(scatter_ua_key, fr.var_angle_rad2, 1.0);
    r->features[fid] = fr;
  }
}

// A JSON with only "figures" (e.g. hand-written or simulated): taken as is.
// A figure given without its U counts as exact (U = 0); its place
// (figures[i].U.E_X) is added to `without_u` when given.
std::vector<CycleFigures> FiguresFromJson(
    const nlohmann::json& doc, const std::string& source, int cycles,
    std::vector<std::string>* without_u = nullptr) {
  const nlohmann::json& arr = doc.at("figures");
  if (!arr.is_array())
    throw InputError(source, 0, "figures", "must be an array of cycles");
  std::vector<CycleFigures> out;
  for (size_t i = 0; i < arr.size(); ++i) {
    const nlohmann::json& f = arr[i];
    const std::string where = "figures[" + std::to_string(i) + "]";
    if (!f.is_object() || !f.contains("cycle") ||
        !f["cycle"].is_number_integer())
      throw InputError(source, 0, where + ".cycle",
                       "missing or not an integer");
    CycleFigures cf;
    const double cycle = f["cycle"].get<double>();
    if (!(cycle >= 1 && cycle <= cycles))
      throw InputError(source, 0, where + ".cycle",
                       "outside 1.." + std::to_string(cycles));
    cf.cycle = static_cast<int>(cycle);
    if (cf.cycle < 1 || cf.cycle > cycles)
      throw InputError(source, 0, where + ".cycle",
                       "outside 1.." + std::to_string(cycles));
    // A cycle given twice has no one value: each command would pick another.
    for (size_t k = 0; k < out.size(); ++k)
      if (out[k].cycle == cf.cycle)
        throw InputError(source, 0, where + ".cycle",
                         fmt::format("cycle {} is given twice (also in "
                                     "figures[{}])",
                                     cf.cycle, k));
    const nlohmann::json u = f.contains("U") && f["U"].is_object()
                                 ? f["U"]
                                 : nlohmann::json::object();
    auto get = [&](const char* key, double scale, double* v, double* uv) {
      *v = Within(NumberOrNaN(f, key, source, where), limits::kMaxFigureMicro,
                  source, where + "." + key, "um or um/m") *
           scale;
      const double uu = Uncertainty(NumberOrNaN(u, key, source, where + ".U"),
                                    source, where + ".U." + key);
      *uv = std::isfinite(uu) ? uu * scale / 2.0 : 0.0;
      if (std::isfinite(*v) && !std::isfinite(uu) && without_u)
        without_u->push_back(where + ".U." + key);
    };
    get("E_X", 1e-3, &cf.e_x_mm, &cf.u_x_mm);
    get("E_Y", 1e-3, &cf.e_y_mm, &cf.u_y_mm);
    get("E_Z", 1e-3, &cf.e_z_mm, &cf.u_z_mm);
    get("E_B", 1e-6, &cf.e_b_rad, &cf.u_b_rad);
    get("E_TTP", 1e-3, &cf.e_ttp_mm, &cf.u_ttp_mm);
    out.push_back(cf);
  }
  return out;
}

// "facet_angle_err_urad": {facet id: urad} beside the figures (truth.json).
std::map<FeatureId, double> FacetAnglesFromJson(const nlohmann::json& doc,
                                                const std::string& source,
                                                const PartSpec& part) {
  std::map<FeatureId, double> out;
  if (!doc.contains("facet_angle_err_urad")) return out;
  const nlohmann::json& obj = doc.at("facet_angle_err_urad");
  if (!obj.is_object())
    throw InputError(source, 0, "facet_angle_err_urad",
                     "must be an object keyed by facet id");
  std::map<std::string, FeatureId> facets;  // by name, as in the file
  for (const NominalFeature& f : TestFeatures(part))
    if (f.kind == FeatureKind::kFacet) facets.emplace(f.id, f.Key());
  for (const auto& [id, v] : obj.items()) {
    const std::string where = "facet_angle_err_urad." + id;
    const auto facet = facets.find(id);
    if (facet == facets.end())
      throw InputError(source, 0, where, "is not a facet of the piece");
    if (!v.is_number() || !std::isfinite(v.get<double>()))
      throw InputError(source, 0, where, "is not a finite number");
    out[facet->second] =
        Within(v.get<double>(), limits::kMaxFeatureAngleRad * 1e6, source,
               where, "urad") *
        1e-6;
  }
  return out;
}

// A JSON with features and figures (`ttp inspect --json` writes both): the
// figures follow from the features, so the file's own are only compared.
// When they differ (the features were edited, or the file was put together
// from two results) the user is told which the evaluation used.
void WarnOnStaleFigures(const nlohmann::json& doc, const std::string& source,
                        const PartSpec& part, InspectionResult* r) {
  std::vector<CycleFigures> given;
  try {
    given = FiguresFromJson(doc, source, part.cycles());
  } catch (const InputError& e) {
    r->warnings.push_back(std::string("the JSON's \"figures\" were not read "
                                      "(the features were used): ") +
                          e.what());
    return;
  }
  // Largest difference, um (um/m for E_B); the file's figures are written
  // to far better than 0.01.
  double worst = 0.01;
  std::string where;
  for (const CycleFigures& g : given) {
    for (const CycleFigures& f : r->figures) {
      if (f.cycle != g.cycle) continue;
      const std::pair<const char*, double> diffs[] = {
          {"E_X", (g.e_x_mm - f.e_x_mm) * 1e3},
          {"E_Y", (g.e_y_mm - f.e_y_mm) * 1e3},
          {"E_Z", (g.e_z_mm - f.e_z_mm) * 1e3},
          {"E_B", (g.e_b_rad - f.e_b_rad) * 1e6},
          {"E_TTP", (g.e_ttp_mm - f.e_ttp_mm) * 1e3}};
      for (const auto& d : diffs) {
        if (!(std::abs(d.second) > worst)) continue;  // NaN: one is missing
        worst = std::abs(d.second);
        where =
            fmt::format("{} of cycle {} by {:.2f}", d.first, g.cycle, d.second);
      }
    }
  }
  if (!where.empty())
    r->warnings.push_back(
        "the JSON's \"figures\" differ from those of its features (" + where +
        " at most): the figures were computed from the features");
}

InspectionResult FromInspectionJson(const PartSpec& part,
                                    const std::string& text,
                                    const std::string& source) {
  const nlohmann::json doc = ParseJsonText(text, source);
  if (!doc.is_object())
    throw InputError(source, 0, "", "the JSON document is not an object");
  // The answer of a simulated run (`ttp twin`, samples/*/truth.json) holds
  // noise-free figures: grading or diagnosing it would judge the
  // simulation, not a piece.
  if (doc.contains("cause") &&
      (doc.contains("noise_um") || doc.contains("params")))
    throw InputError(source, 0, "cause",
                     "this is a truth file (the answer of a simulated run), "
                     "not a measurement: give the measured piece (e.g. "
                     "piece.ply or measured.json beside it)");
  InspectionResult r;
  r.source = source;
  if (doc.contains("facets") || doc.contains("strips")) {
    ReadFeatureBlock(doc, "facets", "distance_mm", "angle_error_urad",
                     "U_distance_um", "U_angle_urad", "U_scatter_distance_um",
                     "U_scatter_angle_urad", source, part, &r);
    ReadFeatureBlock(doc, "strips", "depth_mm", "beta_urad", "U_depth_um",
                     "U_beta_urad", "U_scatter_depth_um", "U_scatter_beta_urad",
                     source, part, &r);
    CompleteFeatures(part, &r);
    ComputeResultFigures(part, &r);
    if (doc.contains("figures")) WarnOnStaleFigures(doc, source, part, &r);
  } else if (doc.contains("figures")) {
    std::vector<std::string> without_u;
    r.figures = FiguresFromJson(doc, source, part.cycles(), &without_u);
    if (!without_u.empty()) {
      // Judged as exact they would make every comparison stricter than
      // the measurement allows: say so.
      r.warnings.push_back(fmt::format(
          "{} figure(s) without an uncertainty ({}{}): taken as exact (U = "
          "0); give each figure's expanded U (k = 2) under \"U\", as `ttp "
          "inspect --json` writes it",
          without_u.size(), without_u.front(),
          without_u.size() > 1 ? ", ..." : ""));
    }
    r.facet_angle_rad = FacetAnglesFromJson(doc, source, part);
    for (const CycleFigures& cf : r.figures) {
      CycleExtras ex;
      ex.cycle = cf.cycle;
      ex.e_c_rad = ex.u_c_rad = kNaN;
      ex.delta_t_k = TemperatureChangeK(cf.e_ttp_mm, part.alpha_per_k,
                                        part.facet_final_distance_mm);
      ex.u_delta_t_k = TemperatureChangeK(cf.u_ttp_mm, part.alpha_per_k,
                                          part.facet_final_distance_mm);
      r.extras.push_back(ex);
    }
    r.warnings.push_back(
        "the JSON holds figures only: per-feature results are not known");
  } else {
    throw InputError(source, 0, "",
                     "JSON without \"facets\", \"strips\" or \"figures\": not "
                     "an inspection result");
  }
  if (doc.contains("warnings") && doc["warnings"].is_array()) {
    for (const auto& w : doc["warnings"])
      if (w.is_string()) r.warnings.push_back(w.get<std::string>());
  }
  return r;
}

InspectionResult FromFeatures(const PartSpec& part, FeatureResults features,
                              const std::string& source,
                              std::vector<std::string> warnings) {
  InspectionResult r;
  r.source = source;
  r.features = std::move(features);
  r.warnings = std::move(warnings);
  int present = 0;
  for (const auto& [id, f] : r.features) present += f.present;
  if (present == 0)
    throw InputError(source, 0, "",
                     "no facet or strip of the piece is in the file");
  CompleteFeatures(part, &r);
  ComputeResultFigures(part, &r);
  return r;
}

}  // namespace

bool MeasurementOptions::IsValid(std::string* error) const {
  std::string inner;
  const auto fail = [&](const char* member) {
    if (error)
      *error = std::string("MeasurementOptions.") + member + "." + inner;
    return false;
  };
  if (!inspect.IsValid(&inner)) return fail("inspect");
  if (!dial.IsValid(&inner)) return fail("dial");
  if (!probe.IsValid(&inner)) return fail("probe");
  if (!dmis.IsValid(&inner)) return fail("dmis");
  return true;
}

Measurement LoadMeasurement(const Config& config,
                            const std::filesystem::path& path,
                            const MeasurementOptions& options) {
  Measurement m;
  m.source = path.string();
  const PartSpec& part = config.part;
  if (!std::filesystem::exists(path))
    throw InputError(m.source, 0, "", "no such file");
  if (std::filesystem::is_directory(path))
    throw InputError(m.source, 0, "", "is a directory, not a measurement");
  const std::string head = ReadFileHead(path, 4096);
  if (head.find_first_not_of(" \t\r\n") == std::string::npos)
    throw InputError(m.source, 0, "", "the file is empty");
  // A log given where the piece goes (`ttp inspect talc.csv`, the
  // arguments of `ttp check` swapped) would otherwise be read as a text
  // cloud and fail on its header row.
  const std::string log_format = SniffLogFormat(head);
  if (log_format == "thermal-log")
    throw InputError(m.source, 1, "# thermal-log",
                     "a thermal test log (thermal-log.md), not a measured "
                     "piece: `ttp thermal fit`, `thermal compare` and `talc "
                     "replay` read it, and `ttp report " +
                         m.source + " -o page.html` makes its page");
  if (log_format == "talc-log")
    throw InputError(m.source, 1, "# talc-log",
                     "a TALC log (talc-log.md), not a measured piece: give it "
                     "with --log, and the measured piece (point cloud, "
                     "inspection JSON, dial or probe CSV, DMIS output) as the "
                     "measurement");
  m.kind = SniffMeasurement(head, path);
  switch (m.kind) {
    case MeasurementKind::kCloud: {
      const PointCloud cloud = ReadPointCloud(path, options.read);
      InspectOptions io = options.inspect;
      if (options.read.units_given) io.check_units = false;
      m.result = InspectCloud(part, cloud, io);
      break;
    }
    case MeasurementKind::kInspectionJson:
      m.result = FromInspectionJson(part, ReadAll(path), m.source);
      break;
    case MeasurementKind::kDial: {
      FeatureResults f =
          ReadDialReadings(ReadAll(path), m.source, part, options.dial);
      m.result = FromFeatures(part, std::move(f), m.source,
                              {"dial gauge: angles are not measured, E_B and "
                               "E_C are missing"});
      break;
    }
    case MeasurementKind::kDmis: {
      const DmisResults dmis = ParseDmisOutput(ReadAll(path), m.source);
      DmisImport imp = DmisToFeatureResults(dmis, part, options.dmis);
      m.result = FromFeatures(part, std::move(imp.results), m.source,
                              std::move(imp.warnings));
      break;
    }
    case MeasurementKind::kProbe: {
      const ProbeImport imp =
          ReadProbeResults(config, ReadAll(path), m.source, options.probe);
      m.result = FromFeatures(part, imp.results, m.source, imp.warnings);
      break;
    }
  }
  m.result.source = m.source;
  return m;
}

nlohmann::json MeasurementToJson(const Measurement& m) {
  nlohmann::json doc = InspectionToJson(m.result);
  doc["kind"] = MeasurementKindName(m.kind);
  if (m.kind != MeasurementKind::kCloud) doc.erase("alignment");
  return doc;
}

}  // namespace ttp::inspect
