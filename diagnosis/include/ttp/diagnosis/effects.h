// Physical effects the rigid-table model leaves out (diagnosis.md section
// 1), each a model extension with parameters (units in their names) that
// predicts per-feature deviations (facet distance and normal angle, strip
// depth) from the cut states of a run: cut time, table angle, the machine's
// temperature history (from E_R0T) and the cut length so far. The twin cuts
// pieces with these models; the diagnosis fits them to residuals.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/thermal/simulate.h"

namespace ttp::diagnosis {

enum class Cause {
  kNone,
  kWorkpieceExpansion,
  kToolWear,
  kClampingDistortion,
  kCAxisIndexing
};
constexpr Cause kAllCauses[5] = {Cause::kNone, Cause::kWorkpieceExpansion,
                                 Cause::kToolWear, Cause::kClampingDistortion,
                                 Cause::kCAxisIndexing};
const char* CauseName(Cause cause);
// Throws std::invalid_argument for an unknown name.
Cause CauseFromName(const std::string& name);

using thermal::kTableAlphaPerK;

// One test feature as cut.
struct CutState {
  FeatureId id;  // the test feature (X1-3, Z3)
  bool is_facet = false;
  double t_s = 0;                    // end of the cut
  double c_rad = 0;                  // commanded table angle
  double phi_w_rad = 0;              // facet normal angle in W (facets)
  double radius_mm = 0;              // facet distance from the axis (facets)
  double height_above_table_mm = 0;  // strip floor above the table surface
  double cut_length_mid_m = 0;  // finishing-cutter path cut before its middle
};

// What the effects need from a run.
struct EffectContext {
  std::vector<CutState> cuts;  // every test feature, in cut order
  // Machine (table) temperature change since the run's reference, K, on a
  // uniform time grid: E_R0T / (alpha_table * sphere distance).
  double grid_t0_s = 0, grid_step_s = 10;
  std::vector<double> machine_dT_K;
  // Standard uncertainty of machine_dT_K on the same grid (the estimator's
  // error of E_R0T) and the time over which that error stays correlated:
  // what the workpiece expansion's regressor inherits (empty: not known).
  std::vector<double> machine_dT_sigma_K;
  double machine_dT_correlation_s = 0;
  double piece_alpha_per_k = 23.4e-6;
  int c_sense = 1;
};

// Cut lengths and heights of the features from the part spec; the machine
// temperature is filled by the caller.
EffectContext MakeEffectContext(const Config& config,
                                const std::vector<CutState>& cuts_in_order);
// Fills cut geometry fields of a cut state (facet angle, radius, height).
CutState MakeCutState(const Config& config, const FeatureId& feature,
                      double t_s, double c_rad);

struct FeatureDelta {
  double d_mm = 0;       // facet distance / strip depth change
  double angle_rad = 0;  // facet normal rotation about Z
};
using EffectDeltas = std::map<FeatureId, FeatureDelta>;

// Parameters per cause (units in the names):
//  workpiece_expansion: tau_wp_s, gain_K_per_K (piece temperature change
//    = gain x machine temperature change through a first-order lag tau_wp_s)
//  tool_wear: wear_um_per_m (cutter radius loss per metre cut)
//  clamping_distortion: cos3_um, sin3_um (facet distance change
//    cos3 cos(3 phi) + sin3 sin(3 phi), and the facet's turn about Z that
//    the lobes' slope implies; amplitude/phase for reports)
//  c_axis_indexing: cos1_urad, sin1_urad, cos2_urad, ... (C stop error
//    sum_k cos_k cos(k c) + sin_k sin(k c), harmonics 1..K with K =
//    params / 2, turning facet normals about Z; a fit of a set of
//    harmonics names its coefficients by CAxisParameterNames)
std::vector<std::string> CauseParameterNames(Cause cause);
// The C stop error's coefficient names for the given harmonics per turn.
std::vector<std::string> CAxisParameterNames(const std::vector<int>& harmonics);
EffectDeltas PredictEffect(Cause cause, const std::vector<double>& params,
                           const EffectContext& context);

// Standard uncertainty of a plane fitted to `points` points scattered by
// rms_mm on a test feature, its points spread evenly over it: its distance
// (a facet's at W's origin, above its points, where the fitted tilt moves
// it too), and its angle from the points' spread across the facet (inside
// the inspection's 1 mm margins) or along the strip (~180 mm across the
// piece). What the diagnosis takes for a fitted feature whose result does
// not carry its fit's own scatter (FeatureResult::scatter_var_d_mm2).
struct FitScatter {
  double d_mm = 0, angle_rad = 0;
};
FitScatter FeatureFitScatter(const PartSpec& part, FeatureKind kind,
                             double rms_mm, int points);

// First-order lag (time constant tau_s) of a series sampled every step_s.
std::vector<double> LagFilter(const std::vector<double>& input, double step_s,
                              double tau_s);

}  // namespace ttp::diagnosis
