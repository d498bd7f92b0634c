#include "ttp/diagnosis/effects.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ttp/geometry/features.h"
#include "ttp/geometry/series.h"

namespace ttp::diagnosis {

const char* CauseName(Cause cause) {
  switch (cause) {
    case Cause::kNone:
      return "none";
    case Cause::kWorkpieceExpansion:
      return "workpiece_expansion";
    case Cause::kToolWear:
      return "tool_wear";
    case Cause::kClampingDistortion:
      return "clamping_distortion";
    case Cause::kCAxisIndexing:
      return "c_axis_indexing";
  }
  return "?";
}

Cause CauseFromName(const std::string& name) {
  for (Cause c : kAllCauses)
    if (name == CauseName(c)) return c;
  throw std::invalid_argument(
      "unknown cause '" + name +
      "' (none, workpiece_expansion, tool_wear, clamping_distortion, "
      "c_axis_indexing)");
}

std::vector<std::string> CauseParameterNames(Cause cause) {
  switch (cause) {
    case Cause::kNone:
      return {};
    case Cause::kWorkpieceExpansion:
      return {"tau_wp_s", "gain_K_per_K"};
    case Cause::kToolWear:
      return {"wear_um_per_m"};
    case Cause::kClampingDistortion:
      return {"cos3_um", "sin3_um"};
    case Cause::kCAxisIndexing:
      return CAxisParameterNames({1});
  }
  return {};
}

std::vector<std::string> CAxisParameterNames(
    const std::vector<int>& harmonics) {
  std::vector<std::string> out;
  for (int k : harmonics) {
    out.push_back("cos" + std::to_string(k) + "_urad");
    out.push_back("sin" + std::to_string(k) + "_urad");
  }
  return out;
}

CutState MakeCutState(const Config& config, const FeatureId& feature,
                      double t_s, double c_rad) {
  const PartSpec& part = config.part;
  CutState s;
  s.t_s = t_s;
  s.c_rad = c_rad;
  if (!feature.IsTestFeature())
    throw std::invalid_argument("not a test feature: " + feature.ToString());
  const Segment segment = feature.segment;
  const int index = feature.index;
  s.is_facet = feature.kind == FeatureKind::kFacet;
  s.id = feature;
  if (s.is_facet) {
    s.phi_w_rad = FacetPhiDeg(part, segment, index) * M_PI / 180.0;
    s.radius_mm = part.facet_final_distance_mm;
  }
  // W's origin (top face) sits adapter + piece above the table.
  s.height_above_table_mm =
      part.adapter_height_mm + part.height_mm() + part.strip_floor_z_mm;
  return s;
}

EffectContext MakeEffectContext(const Config& config,
                                const std::vector<CutState>& cuts_in_order) {
  EffectContext context;
  context.piece_alpha_per_k = config.part.alpha_per_k;
  context.c_sense = config.machine.c_sense;
  const PartSpec& part = config.part;
  // Path lengths of the finishing passes: a facet is cut across its width
  // plus about 1 mm overrun on each side; a strip along its centre line
  // across the outer profile at the floor's height (the first reference
  // cylinder, as the strip's nominal extent: features.cpp) minus the small
  // notch. The chord shortens away from the axis: strip 1 or 9 is about
  // 12 % shorter than strip 5, and a wear fitted with one length for
  // every strip came out about 2 % low and left a drift in E_TTP.
  const double facet_width_mm =
      2 * part.facet_final_distance_mm *
      std::tan(part.facet_step_deg / 2 * M_PI / 180.0);
  const double facet_path_mm = facet_width_mm + 2.0;
  const double floor_radius_mm =
      part.ref_cylinders.empty() ? part.blank_diameter_mm / 2
                                 : part.ref_cylinders.front().diameter_mm / 2;
  auto strip_path_mm = [&](int k) {
    const double y = StripY(part, k);
    return std::max(
        0.0, 2 * std::sqrt(
                     std::max(0.0, floor_radius_mm * floor_radius_mm - y * y)) -
                 2 * part.small_notch_half_width_mm);
  };
  double cut_m = 0;
  for (CutState s : cuts_in_order) {
    const double path_m =
        (s.is_facet ? facet_path_mm : strip_path_mm(s.id.index)) / 1000;
    s.cut_length_mid_m = cut_m + path_m / 2;
    cut_m += path_m;
    context.cuts.push_back(s);
  }
  return context;
}

std::vector<double> LagFilter(const std::vector<double>& input, double step_s,
                              double tau_s) {
  return ttp::LagFilter(input, step_s, tau_s);
}

FitScatter FeatureFitScatter(const PartSpec& part, FeatureKind kind,
                             double rms_mm, int points) {
  FitScatter s;
  s.d_mm = rms_mm / std::sqrt(points);
  if (kind == FeatureKind::kFacet) {
    // A facet's d is taken at W's origin (z = 0), its points spread over
    // its height inside the inspection's 1 mm margins: the fitted tilt's
    // scatter (rms / sqrt(points) over that spread) moves d by the
    // centroid's depth, about 2.3 times rms / sqrt(points) in all.
    const double depth_mm = -part.facet_bottom_z_mm / 2;
    const double height_mm =
        std::max(2.0, -part.facet_bottom_z_mm - 2.0) / std::sqrt(12.0);
    s.d_mm *= std::hypot(1.0, depth_mm / height_mm);
  }
  // Facets: across the facet; strips: along x over the piece (~180 mm).
  const double spread_mm =
      (kind == FeatureKind::kFacet
           ? std::max(2.0,
                      2 * (part.facet_final_distance_mm *
                               std::tan(part.facet_step_deg / 2 * M_PI / 180) -
                           1.0))
           : 180.0) /
      std::sqrt(12.0);
  s.angle_rad = rms_mm / std::sqrt(points) / spread_mm;
  return s;
}

EffectDeltas PredictEffect(Cause cause, const std::vector<double>& params,
                           const EffectContext& context) {
  EffectDeltas out;
  std::vector<double> lagged;
  if (cause == Cause::kWorkpieceExpansion)
    lagged = LagFilter(context.machine_dT_K, context.grid_step_s, params[0]);
  for (const CutState& s : context.cuts) {
    FeatureDelta d;
    switch (cause) {
      case Cause::kNone:
        break;
      case Cause::kWorkpieceExpansion: {
        // The piece (and adapter) grow with their own temperature instead
        // of the table's: a hot piece is cut to the programmed size and
        // shrinks when it cools.
        const double dT_piece =
            params[1] * InterpolateUniform(lagged, context.grid_t0_s,
                                           context.grid_step_s, s.t_s);
        const double dT_table =
            InterpolateUniform(context.machine_dT_K, context.grid_t0_s,
                               context.grid_step_s, s.t_s);
        if (s.is_facet) {
          d.d_mm = -s.radius_mm * (context.piece_alpha_per_k * dT_piece -
                                   kTableAlphaPerK * dT_table);
        } else {
          d.d_mm =
              s.height_above_table_mm * context.piece_alpha_per_k * dT_piece;
        }
        break;
      }
      case Cause::kToolWear:
        // A smaller cutter leaves the facet further out; strips are cut
        // with the cutter's end, whose wear is not modelled.
        if (s.is_facet) d.d_mm = params[0] * 1e-3 * s.cut_length_mid_m;
        break;
      case Cause::kClampingDistortion:
        // Radial spring-back u(phi) = cos3 cos 3phi + sin3 sin 3phi: the
        // facet moves by u at its centre and turns about Z by -u'(phi)/R,
        // the slope of the three lobes across it.
        if (s.is_facet) {
          const double c3 = std::cos(3 * s.phi_w_rad),
                       s3 = std::sin(3 * s.phi_w_rad);
          d.d_mm = 1e-3 * (params[0] * c3 + params[1] * s3);
          const double du_dphi_mm = 1e-3 * 3 * (-params[0] * s3 + params[1] * c3);
          d.angle_rad = -du_dphi_mm / s.radius_mm;
        }
        break;
      case Cause::kCAxisIndexing:
        // The table stops at c + dc(c), dc a sum of harmonics of c: the
        // facet is cut turned by dc about Z (sense of the table); its
        // distance from the axis is unchanged.
        if (s.is_facet) {
          double dc_urad = 0;
          for (size_t k = 0; k + 1 < params.size(); k += 2) {
            const double h = static_cast<double>(k / 2 + 1);
            dc_urad += params[k] * std::cos(h * s.c_rad) +
                       params[k + 1] * std::sin(h * s.c_rad);
          }
          d.angle_rad = context.c_sense * 1e-6 * dc_urad;
        }
        break;
    }
    out[s.id] = d;
  }
  return out;
}

}  // namespace ttp::diagnosis
