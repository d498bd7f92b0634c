// The thermal figures of test-piece.md section 4 from per-feature results.
// Both inspection (measured planes) and simulation (predicted planes) feed
// FeatureResult values here, so the two are computed by the same code.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"

namespace ttp {

struct FeatureResult {
  bool present = false;
  // Facets: distance of the plane to W's origin along its outward normal.
  // Strips: depth below the top face at (0, y_k), positive downwards.
  double d_mm = 0;
  double var_d_mm2 = 0;  // variance of d
  // Strips: slope angle beta = atan(dz/dx) in W (rad). Facets: the normal's
  // angle error about Z (rad, positive counter-clockwise seen from +Z).
  double angle_rad = 0;
  double var_angle_rad2 = 0;
  // Facets: tilt of the normal out of the XY plane (rad).
  double tilt_rad = 0;
  int points = 0;
  double rms_mm = 0;
  // The part of var_d_mm2 and var_angle_rad2 that the fitted points' own
  // scatter gives: the plane fit's covariance carried to where d is taken
  // (W's origin for a facet, whose points lie 1-11 mm below it, so the
  // fit's tilt moves d; (0, y_k) for a strip), without the datums' and the
  // instrument's parts, which are common to every feature. 0 when the
  // result did not come from a fit to points.
  double scatter_var_d_mm2 = 0;
  double scatter_var_angle_rad2 = 0;
};

// Keyed by the typed id; the names ("X1-5", "Z3") appear only where
// results are read or written (FeatureId::ToString / Parse).
using FeatureResults = std::map<FeatureId, FeatureResult>;

// The ids of `results` in the order of their names ("X1-1" < "X2-1" <
// "Y1-1" < "Z1"): the order in which seeded noise is drawn and lists are
// written, so that a seed and an input keep giving the same output.
std::vector<FeatureId> IdsInNameOrder(const FeatureResults& results);

// Which figures a cycle has; NaN marks a figure that cannot be computed
// (a feature it needs is missing).
struct CycleFigures {
  int cycle = 0;
  double e_x_mm = 0, e_y_mm = 0, e_z_mm = 0, e_b_rad = 0, e_ttp_mm = 0;
  // Standard uncertainties (k = 1) propagated from the feature variances.
  double u_x_mm = 0, u_y_mm = 0, u_z_mm = 0, u_b_rad = 0, u_ttp_mm = 0;
};

// Figures for cycles 1..cycles() from results keyed by feature id.
std::vector<CycleFigures> ComputeFigures(const PartSpec& part,
                                         const FeatureResults& results);

// Temperature change implied by a radial growth (thesis 7.10), K.
double TemperatureChangeK(double radial_growth_mm, double alpha_per_k,
                          double radius_mm);

// {"figures": [{"cycle":1,"E_X":..(um),...,"E_B":..(um/m),"U":{...}}]};
// U is the expanded uncertainty (k = 2). Missing figures are null.
nlohmann::json FiguresToJson(const std::vector<CycleFigures>& figures);

}  // namespace ttp
