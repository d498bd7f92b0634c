// Digital twin of a thermal test run (issue 4, item 5): a machine whose
// seven C-axis errors follow thermal dynamics (second-order lags of the
// C-axis load plus a first-order lag of a drifting environment), the test
// cycle's load profile and cut schedule (test-piece.md section 3), R-tests
// with the noise of thesis table 5.4, optional compensation by an imperfect
// model, the piece cut under those errors and a hidden effect, and the
// measured piece as per-feature results with the noise of a cloud fit.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/diagnosis/effects.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"
#include "ttp/inspect/point_io.h"

namespace ttp::diagnosis {

struct TwinOptions {
  Cause effect = Cause::kNone;
  // The effect's size in its own unit: workpiece_expansion gain (-),
  // tool_wear um/m, clamping_distortion amplitude um, c_axis_indexing
  // amplitude urad. Other parameters (tau, phases) are drawn from the seed.
  double size = 0;
  std::uint64_t seed = 1;
  bool compensation = false;
  double rtest_interval_s = 300;
  // Measurement: per-point noise of the CMM (um) and points in the cloud.
  double point_noise_um = 0.4;
  int cloud_points = 20000;
  double stray_fraction = 0.002;  // of the cloud's points
};

struct TwinRun {
  std::string log_text;               // TALC log, talc-log.md format v1
  FeatureResults true_results;        // noise-free cut geometry
  FeatureResults measured;            // with the noise of a cloud fit
  std::vector<double> effect_params;  // CauseParameterNames order
  nlohmann::json truth;               // as the samples' truth.json
};

// Throws std::invalid_argument for invalid options.
TwinRun RunTwin(const Config& config, const TwinOptions& options);

// The measured piece as a CMM would export it: the true cut geometry of
// the run (true_results) sampled by the inspect module's synthetic CMM
// (inspect/synth.h: facets, strips and datums), with the run's point noise
// and count, stray points and a random pose drawn from the seed. Inspecting
// it (inspect::InspectCloud) is what a user does with a real piece.
inspect::PointCloud TwinCloud(const Config& config, const TwinRun& run,
                              const TwinOptions& options);

// How the twin writes the measured piece: a cloud (binary PLY with double
// coordinates or .xyz text, as CMM exports come) or the inspection JSON.
enum class TwinMeasurement { kPly, kXyz, kJson };
// "ply", "xyz", "json" (also "cloud" = ply); throws std::invalid_argument.
TwinMeasurement TwinMeasurementFromName(const std::string& name);

// Writes talc.csv, truth.json and the measured piece (piece.ply, piece.xyz
// or measured.json) into dir (created); returns the measurement's path.
std::string WriteTwin(const Config& config, const TwinRun& run,
                      const TwinOptions& options, const std::string& dir,
                      TwinMeasurement measurement = TwinMeasurement::kPly);

// The measured piece as `ttp inspect --json` writes it (issue 3 format:
// "figures" with U, "facets" {distance_mm, angle_error_urad, U_*},
// "strips" {depth_mm, beta_urad, U_*}).
nlohmann::json MeasuredInspectionJson(const PartSpec& part,
                                      const FeatureResults& measured);

// Per-point noise -> standard uncertainty of a fitted facet/strip (the
// number of points a cloud of `cloud_points` puts on it).
struct FitNoise {
  FitScatter facet, strip;  // FeatureFitScatter of the point noise
  int facet_points, strip_points;
};
FitNoise CloudFitNoise(const PartSpec& part, double point_noise_um,
                       int cloud_points);

}  // namespace ttp::diagnosis
