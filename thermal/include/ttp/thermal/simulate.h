// The simulated piece (test-piece.md section 6): every feature cut in the
// log is displaced by the machine's errors at its cut time through the
// rigid-table model, refitted as a plane, and turned into the figures.
// `ttp check`, `ttp diagnose` and `ttp twin` reuse CutGeometry and
// SimulatePiece (extensions add their own shift per material point).
#pragma once

#include <Eigen/Core>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/figures.h"
#include "ttp/thermal/estimator.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::thermal {

// Thermal expansion of the cast-iron table (test-piece.md section 4,
// thesis 7.10): E_R0T at the R-test sphere radius over it is the table's
// temperature change.
constexpr double kTableAlphaPerK = 11e-6;

// Where a feature is cut: material points on its nominal surface (W and M
// at table angle c), the tool-axis position q for each (facet: p + r n with
// r the finishing cutter's radius; strip: the tool tip at p) and the
// outward normal. (u, v) are the in-surface coordinates used for the plane
// refit: facets (tangential t, z), strips (x, y - y_k). The one place the
// cut positions come from, so they can be checked against the CAM program.
struct CutGeometry {
  NominalFeature feature;
  double c_rad = 0;
  std::vector<Eigen::Vector3d> p_w_mm, p_m_mm, q_m_mm;
  std::vector<Eigen::Vector2d> uv_mm;
  Eigen::Vector3d n_w = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d n_m = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d tangent_w = Eigen::Vector3d::UnitX();  // u direction
};
// Throws std::invalid_argument for a feature that is not a test feature of
// the piece.
CutGeometry ComputeCutGeometry(const Config& config, const FeatureId& feature,
                               double c_rad, int samples_u = 7,
                               int samples_v = 4);

// Plane refit of normal shifts s (mm, along the outward normal) at the
// geometry's points -> FeatureResult (d, strip beta / facet angle, tilt).
FeatureResult ShiftsToFeatureResult(const PartSpec& part,
                                    const CutGeometry& geometry,
                                    const std::vector<double>& shifts_mm);

// The feature as cut under the machine's errors and the compensation in
// force: the rigid-table shift of each of the geometry's points (plus
// extra_mm[i] when given), refitted as a plane. SimulatePiece and the twin
// both cut this way.
FeatureResult CutFeatureResult(const PartSpec& part,
                               const CutGeometry& geometry,
                               const CAxisErrors& machine,
                               const CAxisErrors& predicted,
                               double sphere_distance_mm,
                               const std::vector<double>& extra_mm = {});

struct SimulatedCut {
  FeatureId feature;
  int line = 0;
  double t_s = 0;
  double c_rad = 0;
  CAxisErrors machine;         // estimator (ARX smoother)
  CAxisErrors machine_linear;  // straight line between R-tests
  CAxisErrors predicted;       // compensation in force (zero if off)
  FeatureResult result, result_linear;
};

struct SimulationOptions {
  EstimatorOptions estimator;
  int samples_u = 7, samples_v = 4;
  // Extra normal shift (mm) per material point, for model extensions
  // (diagnosis): (cut, geometry, point index) -> mm. Empty = none.
  std::function<double(const SimulatedCut&, const CutGeometry&, int)>
      extra_shift_mm;
};

struct Simulation {
  std::string estimator_description;
  // MachineErrorEstimator::Warnings (R-tests left out as gross errors),
  // and one for cuts after the last R-test (their machine errors are
  // extrapolated through the estimator's model).
  std::vector<std::string> warnings;
  nlohmann::json estimator_json;
  std::vector<SimulatedCut> cuts;
  FeatureResults results, results_linear;
  std::vector<CycleFigures> figures, figures_linear;
};

// Throws InputError (naming the cut row) when a cut lies before the first
// R-test (nothing anchors the estimate there: the log does not cover the
// cut times). Cuts after the last R-test are simulated from the
// estimator's extrapolation, with a warning.
Simulation SimulatePiece(const TalcLog& log, const Config& config,
                         const SimulationOptions& options = {});
Simulation SimulatePiece(const TalcLog& log, const Config& config,
                         const MachineErrorEstimator& estimator,
                         const SimulationOptions& options);

// Per cut also the estimator's standard uncertainty of each machine error
// (`machine_errors_u`, ErrorSigmaAt), computed here for the file only: the
// simulations `ttp check` perturbs do not need it.
nlohmann::json SimulationToJson(const Simulation& sim,
                                const MachineErrorEstimator& estimator);
std::string SimulationText(const Simulation& sim);

}  // namespace ttp::thermal
