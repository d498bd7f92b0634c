// Digital twin of a thermal test run: a machine whose seven C-axis errors
// follow thermal dynamics (second-order lags of the C-axis load plus a
// first-order lag of a drifting environment, after a pre-machining phase
// and a hold, so the log does not start at rest), the test cycle's load
// profile and cut schedule (test-piece.md section 3), R-tests with the
// noise of thesis table 5.4 at any spacing, optional compensation by an
// imperfect model, and the piece cut by the geometric simulation
// (thermal::CutFeatureResult) under those errors and the hidden effects.
//
// The hidden effects are written from their physical description
// (diagnosis.md section 1) with their own parameterisation, independent of
// the diagnosis' fitting models: a lumped thermal mass for the piece, wear
// growing along the cutter's path, three bolts deforming the piece
// elastically (with a height dependence that tilts the facets), a C-axis
// stop error from encoder eccentricity, worm and bearing harmonics; and
// effects outside the catalogue (a step between cycles, a two-lobe
// distortion). Each acts on the material points of a cut surface.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/figures.h"
#include "ttp/inspect/point_io.h"

namespace ttp::sim {

struct TwinOptions {
  // Hidden effects, each absent at 0 and in its own unit. Catalogue:
  // Piece (and adapter) temperature rise over the table's in steady
  // state; the piece follows through its own thermal time constant.
  double workpiece_gain = 0;
  double workpiece_tau_s = 0;  // 0: drawn from the seed (1200..5400 s)
  double tool_wear_um_per_m = 0;       // cutter radius loss per metre cut
  double clamping_amplitude_um = 0;    // three-lobe radial spring-back
  double c_indexing_amplitude_urad = 0;  // C stop error, largest harmonic sum
  // Outside the catalogue:
  double step_um = 0;  // every facet from cycle step_from_cycle on
  int step_from_cycle = 0;  // 0: drawn from the seed (3..7)
  double two_lobe_amplitude_um = 0;

  std::uint64_t seed = 1;
  bool compensation = false;
  double rtest_interval_s = 300;
  // Measurement: per-point noise of the CMM (um) and points in the cloud.
  double point_noise_um = 0.4;
  int cloud_points = 20000;
  double stray_fraction = 0.002;  // of the cloud's points

  // False with a message naming the field when the options cannot be used.
  bool IsValid(std::string* error) const;
  // What a correct diagnosis says: "none", the catalogue causes joined by
  // '+' in alphabetical order, or "unexplained" when an effect outside the
  // catalogue is present.
  std::string ExpectedOutcome() const;
};

// A catalogue effect the twin can hide, with the largest size it takes (in
// the effect's unit): far beyond any machine's, where the piece would leave
// the measurement's plausible range (features within 5 mm of nominal) or
// the model's.
struct EffectRange {
  const char* name;
  double max_size;
  const char* unit;
};
// The effect of that name, or nullptr ("none" is no effect: nullptr).
const EffectRange* FindEffect(const std::string& name);

// Options with one catalogue effect by name ("none", "workpiece_expansion",
// "tool_wear", "clamping_distortion", "c_axis_indexing") of the given
// size in that effect's unit (gain, um/m, um, urad); throws
// std::invalid_argument for an unknown name or a size outside
// 0..EffectRange::max_size.
void SetEffect(TwinOptions* options, const std::string& name, double size);

struct TwinRun {
  std::string log_text;          // TALC log, talc-log.md format v1
  FeatureResults true_results;   // noise-free cut geometry
  FeatureResults measured;       // with the noise of a cloud fit
  nlohmann::json truth;          // as the samples' truth.json
};

// Throws std::invalid_argument for invalid options.
TwinRun RunTwin(const Config& config, const TwinOptions& options);

// The measured piece as a CMM would export it: the true cut geometry of
// the run (true_results) sampled by the synthetic CMM
// (sim/synth.h: facets, strips and datums), with the run's point noise
// and count, stray points and a random pose drawn from the seed.
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

// The measured piece as `ttp inspect --json` writes it.
nlohmann::json MeasuredInspectionJson(const PartSpec& part,
                                      const FeatureResults& measured);

// Per-point noise -> standard uncertainty of a fitted facet/strip (the
// number of points a cloud of `cloud_points` puts on it).
struct FitNoise {
  double facet_d_mm = 0, facet_angle_rad = 0;
  double strip_d_mm = 0, strip_angle_rad = 0;
  int facet_points = 0, strip_points = 0;
};
FitNoise CloudFitNoise(const PartSpec& part, double point_noise_um,
                       int cloud_points);

// The other instruments, from the same true cut geometry: a touch probe
// (a few points per feature: distances and angles with larger noise), a
// dial gauge (distances only, no angles) and DMIS output (distances and
// angles with the stated uncertainty). Seeded.
enum class Instrument { kCloudFit, kProbe, kDial, kDmis };
const char* InstrumentName(Instrument instrument);
FeatureResults MeasureWith(const PartSpec& part, const FeatureResults& truth,
                           Instrument instrument, double point_noise_um,
                           std::uint64_t seed);

}  // namespace ttp::sim
