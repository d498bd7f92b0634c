// The cloud inspection's driver (the stages are in cloud_stages.h, each in
// its own file), the figures of any measurement path, and the inspection's
// JSON and table.
#include "ttp/inspect/inspect.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <sstream>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/format.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {

bool InspectOptions::IsValid(std::string* error) const {
  const auto fail = [error](const char* field, const char* problem) {
    if (error) *error = std::string("InspectOptions.") + field + ": " + problem;
    return false;
  };
  const auto positive = [](double v) { return std::isfinite(v) && v > 0; };
  if (!positive(facet_edge_margin_mm) && facet_edge_margin_mm != 0)
    return fail("facet_edge_margin_mm", "must be a finite length >= 0");
  if (!positive(edge_margin_mm) && edge_margin_mm != 0)
    return fail("edge_margin_mm", "must be a finite length >= 0");
  if (!positive(capture_band_mm))
    return fail("capture_band_mm", "must be a positive finite length");
  if (!positive(stray_sigma))
    return fail("stray_sigma", "must be a positive finite number of sigmas");
  if (!positive(stray_floor_mm) && stray_floor_mm != 0)
    return fail("stray_floor_mm", "must be a finite length >= 0");
  if (min_points < 3) return fail("min_points", "must be at least 3");
  if (thin_points < min_points)
    return fail("thin_points", "must be at least min_points");
  if (instrument != Instrument::kNone && instrument != Instrument::kCmm)
    return fail("instrument", "unknown instrument");
  if (!positive(cmm_mpe_um) && cmm_mpe_um != 0)
    return fail("cmm_mpe_um", "must be a finite value >= 0 in um");
  if (!positive(cmm_mpe_l_mm))
    return fail("cmm_mpe_l_mm", "must be a positive finite length");
  return true;
}

void InspectOptions::Validate() const {
  std::string error;
  if (IsValid(&error)) return;
  const size_t colon = error.find(':');
  throw InputError("InspectOptions", 0, error.substr(0, colon),
                   error.substr(colon + 2));
}

void ComputeResultFigures(const PartSpec& part, InspectionResult* result) {
  InspectionResult& out = *result;
  const double d_facet = part.facet_final_distance_mm;
  out.figures = ComputeFigures(part, out.features);
  out.extras.clear();
  for (const CycleFigures& cf : out.figures) {
    CycleExtras ex;
    ex.cycle = cf.cycle;
    const int j = IndexForCycle(part, cf.cycle);
    double sum = 0, var = 0;
    bool all = true;
    for (Segment s : kSegments) {
      const auto a = out.features.find(FeatureId::Facet(s, j));
      const auto b =
          out.features.find(FeatureId::Facet(s, part.reference_index));
      if (a == out.features.end() || b == out.features.end() ||
          !a->second.present || !b->second.present) {
        all = false;
        break;
      }
      sum += (a->second.angle_rad - b->second.angle_rad) / 4;
      var += (a->second.var_angle_rad2 + b->second.var_angle_rad2) / 16;
    }
    ex.e_c_rad = all ? sum : kNaN;
    ex.u_c_rad = all ? std::sqrt(var) : kNaN;
    ex.delta_t_k = TemperatureChangeK(cf.e_ttp_mm, part.alpha_per_k, d_facet);
    ex.u_delta_t_k = TemperatureChangeK(cf.u_ttp_mm, part.alpha_per_k, d_facet);
    out.extras.push_back(ex);
  }
}

InspectionResult InspectCloud(const PartSpec& part, const PointCloud& cloud,
                              const InspectOptions& o) {
  o.Validate();
  InspectionResult out;
  out.source = cloud.source;
  out.warnings = cloud.warnings;
  out.points_total = static_cast<int>(cloud.xyz_mm.cols());
  if (cloud.xyz_mm.cols() == 0)
    throw InputError(cloud.source, 0, "", "the cloud has no points");
  CheckCloudUnits(part, cloud, o);
  AlignedCloud aligned = AlignCloud(part, cloud, o);
  out.alignment = aligned.alignment;
  out.warnings.insert(out.warnings.end(), aligned.warnings.begin(),
                      aligned.warnings.end());
  const Eigen::Matrix3Xd w = std::move(aligned.points_w_mm);
  const Segmentation segmentation = SegmentCloud(part, w, o);
  FittedFeatures fitted =
      FitFeatures(part, w, segmentation, aligned.origin_covariance_mm2, o);
  out.features = std::move(fitted.features);
  out.diagnostics = std::move(fitted.diagnostics);
  out.points_assigned = fitted.points_assigned;
  out.points_rejected = fitted.points_rejected;
  out.warnings.insert(out.warnings.end(), fitted.warnings.begin(),
                      fitted.warnings.end());
  ComputeResultFigures(part, &out);
  int present = 0;
  for (const auto& [id, r] : out.features) present += r.present;
  if (present == 0)
    throw InputError(cloud.source, 0, "alignment",
                     "no test piece found in the cloud: aligned, but no facet "
                     "or strip has points where the drawing puts them");
  return out;
}

namespace {
nlohmann::json Num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
}  // namespace

nlohmann::json InspectionToJson(const InspectionResult& r) {
  nlohmann::json doc = FiguresToJson(r.figures);
  for (size_t i = 0; i < r.extras.size() && i < doc["figures"].size(); ++i) {
    auto& f = doc["figures"][i];
    f["E_C"] = Num(r.extras[i].e_c_rad * 1e6);
    f["U"]["E_C"] = Num(2 * r.extras[i].u_c_rad * 1e6);
    f["delta_T_K"] = Num(r.extras[i].delta_t_k);
    f["U"]["delta_T_K"] = Num(2 * r.extras[i].u_delta_t_k);
  }
  nlohmann::json facets = nlohmann::json::object(),
                 strips = nlohmann::json::object();
  for (const auto& [fid, fr] : r.features) {
    if (!fid.IsTestFeature()) continue;
    const std::string id = fid.ToString();
    if (fid.kind == FeatureKind::kFacet) {
      facets[id] = {
          {"distance_mm", fr.present ? Num(fr.d_mm) : nlohmann::json(nullptr)},
          {"angle_error_urad",
           fr.present ? Num(fr.angle_rad * 1e6) : nlohmann::json(nullptr)},
          {"tilt_urad",
           fr.present ? Num(fr.tilt_rad * 1e6) : nlohmann::json(nullptr)},
          {"U_distance_um", fr.present ? Num(2e3 * std::sqrt(fr.var_d_mm2))
                                       : nlohmann::json(nullptr)},
          {"U_angle_urad", fr.present ? Num(2e6 * std::sqrt(fr.var_angle_rad2))
                                      : nlohmann::json(nullptr)},
          {"points", fr.points},
          {"rms_um", fr.rms_mm * 1e3}};
      if (fr.present && fr.scatter_var_d_mm2 > 0) {
        facets[id]["U_scatter_distance_um"] =
            Num(2e3 * std::sqrt(fr.scatter_var_d_mm2));
        facets[id]["U_scatter_angle_urad"] =
            Num(2e6 * std::sqrt(fr.scatter_var_angle_rad2));
      }
    } else {
      strips[id] = {
          {"depth_mm", fr.present ? Num(fr.d_mm) : nlohmann::json(nullptr)},
          {"beta_urad",
           fr.present ? Num(fr.angle_rad * 1e6) : nlohmann::json(nullptr)},
          {"U_depth_um", fr.present ? Num(2e3 * std::sqrt(fr.var_d_mm2))
                                    : nlohmann::json(nullptr)},
          {"U_beta_urad", fr.present ? Num(2e6 * std::sqrt(fr.var_angle_rad2))
                                     : nlohmann::json(nullptr)},
          {"points", fr.points},
          {"rms_um", fr.rms_mm * 1e3}};
      if (fr.present && fr.scatter_var_d_mm2 > 0) {
        strips[id]["U_scatter_depth_um"] =
            Num(2e3 * std::sqrt(fr.scatter_var_d_mm2));
        strips[id]["U_scatter_beta_urad"] =
            Num(2e6 * std::sqrt(fr.scatter_var_angle_rad2));
      }
    }
  }
  // A result of figures only (read from such a JSON) stays one when read
  // back: no empty feature blocks, and its facet angles as given.
  if (!r.features.empty() || r.facet_angle_rad.empty()) {
    doc["facets"] = facets;
    doc["strips"] = strips;
  }
  if (!r.facet_angle_rad.empty()) {
    nlohmann::json angles = nlohmann::json::object();
    for (const auto& [id, a] : r.facet_angle_rad)
      angles[id.ToString()] = a * 1e6;
    doc["facet_angle_err_urad"] = angles;
  }
  const Alignment& a = r.alignment;
  nlohmann::json rot = nlohmann::json::array();
  for (int i = 0; i < 3; ++i)
    rot.push_back({a.rotation(i, 0), a.rotation(i, 1), a.rotation(i, 2)});
  doc["alignment"] = {
      {"rotation", rot},
      {"translation_mm",
       {a.translation.x(), a.translation.y(), a.translation.z()}},
      {"convention", "W = rotation * cloud + translation"},
      {"top_face_points", a.top_points},
      {"top_face_rms_um", a.top_rms_mm * 1e3},
      {"flank_points", {a.flank_points[0], a.flank_points[1]}},
      {"datum_circle_points", a.circle_points},
      {"datum_circle_diameter_mm", a.circle_diameter_mm},
      {"datum_circle_rms_um", a.circle_rms_mm * 1e3},
      {"mark_found", a.mark_found},
      {"mark_points", a.mark_points},
      {"mark_points_opposite", a.mark_points_opposite}};
  nlohmann::json missing = nlohmann::json::array(),
                 thin = nlohmann::json::array();
  for (const auto& d : r.diagnostics) {
    if (d.status == "missing") missing.push_back(d.id);
    if (d.status == "thin") thin.push_back(d.id);
  }
  doc["segmentation"] = {{"points_total", r.points_total},
                         {"points_used", r.points_assigned},
                         {"points_rejected_as_stray", r.points_rejected},
                         {"missing", missing},
                         {"thin", thin}};
  doc["warnings"] = r.warnings;
  doc["source"] = r.source;
  doc["units"] = {{"figures", "um, E_B and E_C in um/m, delta_T_K in K"},
                  {"U", "expanded uncertainty, k = 2"}};
  return doc;
}

std::string InspectionTable(const InspectionResult& r) {
  std::ostringstream s;
  char buf[256];
  auto cell = [](double v, double u) {
    if (!std::isfinite(v)) return std::string("       missing");
    return fmt::format("{:>7} +-{:>5}", FormatNumber(v, 2), FormatNumber(u, 2));
  };
  s << "Inspection of " << r.source << ": " << r.points_total << " points, "
    << r.points_assigned << " used, " << r.points_rejected
    << " rejected as stray\n";
  s << "cycle           E_X um          E_Y um          E_Z um        E_B um/m "
       "       E_TTP um        E_C um/m    dT K\n";
  for (size_t i = 0; i < r.figures.size(); ++i) {
    const auto& f = r.figures[i];
    const auto& e = r.extras[i];
    std::snprintf(buf, sizeof buf, "%5d  ", f.cycle);
    s << buf << cell(f.e_x_mm * 1e3, 2e3 * f.u_x_mm) << "  "
      << cell(f.e_y_mm * 1e3, 2e3 * f.u_y_mm) << "  "
      << cell(f.e_z_mm * 1e3, 2e3 * f.u_z_mm) << "  "
      << cell(f.e_b_rad * 1e6, 2e6 * f.u_b_rad) << "  "
      << cell(f.e_ttp_mm * 1e3, 2e3 * f.u_ttp_mm) << "  "
      << cell(e.e_c_rad * 1e6, 2e6 * e.u_c_rad);
    s << fmt::format("  {:>6}\n", FormatNumber(e.delta_t_k, 3));
  }
  s << "(+- is the expanded uncertainty U, k = 2)\n";
  for (const auto& w : r.warnings) s << "warning: " << w << "\n";
  return s.str();
}

}  // namespace ttp::inspect
