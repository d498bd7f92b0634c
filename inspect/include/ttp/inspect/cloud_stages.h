// The cloud inspection as named stages with typed results, each testable
// alone (InspectCloud runs them in this order):
//
//   PointCloud (point_io.h)
//     -> CheckCloudUnits      units.cpp     a piece in millimetres?
//     -> AlignCloud           align.cpp     W from the datums: top face,
//                                           big-notch flanks, datum circle
//                                           (CYL199), engraved mark
//     -> SegmentCloud         segment.cpp   points of each facet and strip
//     -> FitFeatures          feature_fit.cpp  trimmed plane fits (geometry/
//                                           fit.h) -> FeatureResults with
//                                           variances
//     -> ComputeResultFigures inspect.cpp   E_X..E_TTP, E_C, delta_T
//
// Every stage throws InputError(cloud source, 0, field, problem) for a
// cloud it cannot take further; nothing is guessed: a datum that is
// missing or a mirror-image cloud is refused with the datum named.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/point_io.h"

namespace ttp::inspect {

// Stage 0. Throws InputError (field "units") when the cloud's robust
// extent says metres or inches, or (field "alignment") when it is not the
// piece's size at all. Does nothing when !options.check_units.
void CheckCloudUnits(const PartSpec& part, const PointCloud& cloud,
                     const InspectOptions& options);

// Stage 1: the workpiece frame W from the datums (test-piece.md section 5).
struct AlignedCloud {
  Alignment alignment;  // W = rotation * cloud + translation
  // Covariance of the origin (the datum circle's centre) in W's x, y (mm^2).
  Eigen::Matrix2d origin_covariance_mm2 = Eigen::Matrix2d::Zero();
  // The cloud's points in W (3 x N, mm; PointsInW of the alignment), made
  // in the storage the alignment worked in: a second buffer of a large
  // cloud's size is fresh memory the kernel must zero first.
  Eigen::Matrix3Xd points_w_mm;
  std::vector<std::string> warnings;
};
// Throws InputError(source, 0, "alignment", ...) when the cloud holds no
// test piece, when a datum needed for W is missing (top face, flanks, the
// datum circle CYL199, the engraved mark), when the top face is not read as
// a plane (its RMS far above the flanks', or its robust fit keeping too few
// of the points on it) or when the cloud is a mirror image of the piece
// (the mark where only a mirrored piece has it).
AlignedCloud AlignCloud(const PartSpec& part, const PointCloud& cloud,
                        const InspectOptions& options);

// The cloud's points in W (3 x N, mm), into *points_w_mm (resized to the
// cloud's; its storage reused when it has the size already).
void PointsInW(const Alignment& alignment, const Eigen::Matrix3Xd& cloud_mm,
               Eigen::Matrix3Xd* points_w_mm);

// Stage 2: the points (column indices into the W points) in each feature's
// region: facets[s * facets_per_segment + j - 1] for segment s (kSegments
// order) and index j, strips[k - 1] for strip k.
struct Segmentation {
  std::vector<std::vector<Eigen::Index>> facets;
  std::vector<std::vector<Eigen::Index>> strips;
};
Segmentation SegmentCloud(const PartSpec& part, const Eigen::Matrix3Xd& w_mm,
                          const InspectOptions& options);

// Stage 3: a trimmed plane fit per feature and its result (d, angle, tilt,
// variances from the fit covariance, the origin's uncertainty and the
// instrument's), with the per-feature diagnostics. Features with too few
// points are not present (status "missing"; "thin" below thin_points).
struct FittedFeatures {
  FeatureResults features;
  std::vector<FeatureDiagnostic> diagnostics;  // facets, then strips
  int points_assigned = 0, points_rejected = 0;
  std::vector<std::string> warnings;
};
FittedFeatures FitFeatures(const PartSpec& part, const Eigen::Matrix3Xd& w_mm,
                           const Segmentation& segmentation,
                           const Eigen::Matrix2d& origin_covariance_mm2,
                           const InspectOptions& options);

}  // namespace ttp::inspect
