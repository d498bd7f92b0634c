// From a measured point cloud of the finished piece to the thermal figures:
// find the workpiece frame W from the datums (test-piece.md section 5) in any
// pose, assign points to the nominal features, reject strays, fit planes and
// compute E_X..E_TTP (plus E_C from the facets) with their uncertainty. The
// stages, each with its typed result, are in cloud_stages.h; the rules
// (regions, strays, missing and thin features, uncertainty) are stated
// there and in docs/INSPECT.md.
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
  // Ceres style: false with "InspectOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
  // Throws InputError("InspectOptions", 0, "InspectOptions.<field>", ...).
  void Validate() const;
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
  std::map<FeatureId, double> facet_angle_rad;
  int points_total = 0, points_assigned = 0, points_rejected = 0;
  std::vector<std::string> warnings;
};

// Throws InputError (source = cloud.source, field "alignment"/"units") when
// the cloud is not a test piece in millimetres, when a datum W needs is
// missing, or when the cloud is a mirror image of the piece.
InspectionResult InspectCloud(const PartSpec& part, const PointCloud& cloud,
                              const InspectOptions& options = {});

// Fills result->figures (ComputeFigures) and result->extras (E_C as the mean
// over the four segments of the facet angle change against the reference
// facet; delta_T from E_TTP, thesis 7.10) from result->features. Shared by
// every measurement path so that all report the same figures the same way.
void ComputeResultFigures(const PartSpec& part, InspectionResult* result);

// The inspection JSON: {"figures": [...], "facets": {...}, "strips": {...},
// "alignment": {...}, "segmentation": {...}, "warnings": [...]}, um, um/m.
nlohmann::json InspectionToJson(const InspectionResult& result);

// A table a person can read.
std::string InspectionTable(const InspectionResult& result);

}  // namespace ttp::inspect
