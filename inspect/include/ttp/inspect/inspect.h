// From a measured point cloud of the finished piece to the thermal figures:
// find the workpiece frame W from the datums (test-piece.md section 5) in any
// pose, assign points to the nominal features, reject strays, fit planes and
// compute E_X..E_TTP (plus E_C from the facets) with their uncertainty.
//
// Stated rules (also in docs/INSPECT.md):
// - Regions: a point belongs to a facet / strip when it lies inside the
//   feature's nominal extent in W shrunk by edge margins (facets 1.0 mm
//   tangentially, 0.5 mm in z; strips 0.5 mm in y, and 0.5 mm from the small
//   notch and the rim in x) and within capture_band_mm of its nominal surface.
// - Strays: after a first fit, points with |residual| > max(stray_sigma *
//   robust sigma (1.4826 MAD), stray_floor_mm) are dropped and the fit is
//   repeated until nothing changes (at most 8 rounds).
// - A feature with fewer than min_points points left is missing (its
//   figures are null); fewer than thin_points is reported thin.
// - Uncertainty (k = 1 in FeatureResult, k = 2 in the JSON): the plane fit's
//   covariance (residual variance times (A^T A)^-1 of the linear plane
//   model) propagated to d and the angle, plus for a CMM the instrument:
//   MPE_E = a + L / b (1.2 um + L/400 mm, thesis 7.3) read as a rectangular
//   bound, u = MPE / sqrt(3), with L the feature's distance from the datum
//   origin for d; for angles only the length-proportional part, u_angle =
//   (1 / b) / sqrt(3) = 1.44 um/m (the constant part is probing scatter that
//   the fit residuals already hold); all
//   taken independent between features (conservative: correlated CMM errors
//   would cancel in the figures' differences).
#pragma once

#include <Eigen/Core>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"
#include "ttp/inspect/point_io.h"

namespace ttp::inspect {

enum class Instrument { kNone, kCmm };

struct InspectOptions {
  double facet_edge_margin_mm = 1.0;
  double edge_margin_mm = 0.5;
  double capture_band_mm = 0.15;
  double stray_sigma = 5.0;
  double stray_floor_mm = 0.003;
  int min_points = 10;
  int thin_points = 30;
  Instrument instrument = Instrument::kCmm;
  double cmm_mpe_um = 1.2;      // a of MPE = a + L / b
  double cmm_mpe_l_mm = 400.0;  // b
  // Check that the cloud is a piece in millimetres (not metres or inches).
  bool check_units = true;
};

// Cloud frame -> W: w = rotation * p + translation.
struct Alignment {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  int top_points = 0;
  double top_rms_mm = 0;
  int flank_points[2] = {0, 0};
  int circle_points = 0;
  double circle_diameter_mm = 0;
  double circle_rms_mm = 0;
  int mark_points = 0;  // points in the groove at phi = mark_phi
  int mark_points_opposite = 0;
  bool mark_found = false;
};

struct FeatureDiagnostic {
  std::string id;
  int candidates = 0;  // points in the feature's region
  int used = 0;        // after stray rejection
  double rms_mm = 0;
  std::string status;  // "ok", "thin", "missing"
};

struct CycleExtras {
  int cycle = 0;
  double e_c_rad = 0, u_c_rad = 0;        // mean facet angle change (k = 1)
  double delta_t_k = 0, u_delta_t_k = 0;  // E_TTP / (alpha R) (k = 1)
};

struct InspectionResult {
  std::string source;
  Alignment alignment;
  FeatureResults features;  // the 36 facets and 9 strips
  std::vector<FeatureDiagnostic> diagnostics;
  std::vector<CycleFigures> figures;
  std::vector<CycleExtras> extras;
  // Facet angle errors (rad) given without per-feature results: a JSON of
  // figures with "facet_angle_err_urad", as the samples' truth.json. Where
  // features are known, their angles are in `features`.
  std::map<std::string, double> facet_angle_rad;
  int points_total = 0, points_assigned = 0, points_rejected = 0;
  std::vector<std::string> warnings;
};

// Throws InputError (source = cloud.source, field "alignment"/"units") when
// the cloud is not a test piece in millimetres.
InspectionResult InspectCloud(const PartSpec& part, const PointCloud& cloud,
                              const InspectOptions& options = {});

// Fills result->figures (ComputeFigures) and result->extras (E_C as the mean
// over the four segments of the facet angle change against the reference
// facet; delta_T from E_TTP, thesis 7.10) from result->features. Shared by
// every measurement path so that all report the same figures the same way.
void ComputeResultFigures(const PartSpec& part, InspectionResult* result);

// The issue 3 interface: {"figures": [...], "facets": {...}, "strips": {...},
// "alignment": {...}, "segmentation": {...}, "warnings": [...]}, um, um/m.
nlohmann::json InspectionToJson(const InspectionResult& result);

// A table a person can read.
std::string InspectionTable(const InspectionResult& result);

}  // namespace ttp::inspect
