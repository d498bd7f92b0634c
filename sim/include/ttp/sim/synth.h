// A synthetic measured piece: the finished part (geometry's
// tagged mesh) with known per-feature deviations, sampled like a scanner
// (every visible surface, by area) or a CMM (only the measured features,
// each facet and strip with its own share of the points: 45 % over the
// facets, 25 % over the strips, the rest by area over the top face with
// the mark, the flanks and the reference cylinders),
// with noise, stray points, missing features and any pose. Written in every
// supported format with WritePointCloud. Used by the tests and the bench;
// the digital twin may use it for its measured cloud.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/point_io.h"

namespace ttp::sim {

enum class SynthSampling { kScanner, kCmm };

struct SynthOptions {
  int points = 20000;             // on the piece, strays not included
  double noise_um = 0.5;          // standard deviation of each coordinate
  double stray_fraction = 0.002;  // extra stray points per piece point
  bool random_pose = true;        // any rotation, translation within 500 mm
  SynthSampling sampling = SynthSampling::kCmm;
  uint32_t seed = 1;
  // Random deviations when none are given: each facet's / strip's d and
  // angle ~ N(0, sd).
  double deviation_d_um = 5.0;
  double deviation_angle_urad = 20.0;
  std::vector<std::string> missing;  // features left without points
  // Ceres style: false with "SynthOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
};

struct SynthPiece {
  // In the measuring frame: cloud = rotation * W + t.
  inspect::PointCloud cloud;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  // The true per-feature results (what a perfect inspection returns) and
  // the figures and extras computed from them (missing features absent).
  inspect::InspectionResult truth;
};

// Random per-feature deviations of the finished piece (all 45 features).
FeatureResults RandomDeviations(const PartSpec& part, const SynthOptions& o);

// `finished` is BuildPartMesh(part, Stage::kFinished) (built once by the
// caller: it takes a while). `deviations` gives the true d / angle of each
// facet and strip (absolute, like FeatureResult); features not in it are
// at nominal.
SynthPiece SynthesizePiece(const PartSpec& part, const PartMesh& finished,
                           const FeatureResults& deviations,
                           const SynthOptions& options);

}  // namespace ttp::sim
