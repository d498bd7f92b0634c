// The project's one fitting layer: least-squares geometry fits with true
// orthogonal distances, double precision on centred data (Ceres for every
// nonlinear fit; the plane and line have closed forms that are the exact
// orthogonal solution), and stray rejection around a plane or circle fit.
// Every measurement path fits through it: the cloud inspection (datums and
// features), the probe results, and `ttp fit`. Each result carries a
// summary: residual statistics, the covariance of its parameters (scaled by
// the residual variance) in the order the struct documents, and a status
// taken from Ceres' Solver::Summary, so that a caller can refuse a fit that
// did not converge or whose parameters the points do not determine.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace ttp::fit {

struct FitOptions {
  enum class Loss { kNone, kHuber, kCauchy };
  Loss loss = Loss::kNone;
  double loss_scale_mm = 1e-3;  // robust loss scale (residual units)
  bool compute_covariance = true;
  int max_iterations = 100;
  // Ceres style: false with a message naming the field
  // (e.g. "FitOptions.loss_scale_mm: ...").
  bool IsValid(std::string* error) const;
  // Throws InputError naming the field when !IsValid.
  void Validate() const;
};

enum class FitStatus {
  kConverged,      // closed form, or Ceres reported CONVERGENCE
  kNoConvergence,  // Ceres stopped at its iteration limit (usable, not final)
  kFailed,         // Ceres' solution is not usable (FAILURE, non-finite cost)
  kDegenerate,     // the points do not determine every parameter (the
                   // Jacobian is rank deficient at the solution, or the
                   // shape degenerates, e.g. a cone of half angle 0)
};
const char* FitStatusName(FitStatus status);  // "converged", ...

struct FitSummary {
  int points = 0;
  double rms_mm = 0;      // RMS of the orthogonal residuals
  double max_abs_mm = 0;  // largest |residual|
  FitStatus status = FitStatus::kConverged;
  bool converged = true;  // status == kConverged
  // Ceres' termination type ("CONVERGENCE", "NO_CONVERGENCE", "FAILURE",
  // ...) or "closed form"; Summary::IsSolutionUsable().
  std::string termination = "closed form";
  bool solution_usable = true;
  int iterations = 0;
  std::string message;  // Ceres' message, or why the fit is degenerate
  // Covariance of the parameters listed in parameter_names (mm, rad);
  // empty when the fit is degenerate. The names are the shape's free
  // parameters, one each (a plane: offset and two tilts).
  Eigen::MatrixXd covariance;
  std::vector<std::string> parameter_names;
  // A result the caller may use: converged and every parameter determined.
  bool Usable() const { return status == FitStatus::kConverged; }
  // Residual components per point: 1, or 2 for a 3D line and a 3D circle
  // (off the line in two directions; off the circle in and across its
  // plane).
  int residuals_per_point = 1;
  // Residual degrees of freedom: residual components beyond the free
  // parameters. At 0 or below the shape passes through every point exactly
  // and nothing is left to estimate the covariance from (it is then not
  // zero but unknown).
  int DegreesOfFreedom() const {
    return residuals_per_point * points -
           static_cast<int>(parameter_names.size());
  }
};

struct LineFit2D {  // point on the line (centroid) and unit direction
  Eigen::Vector2d point, direction;
  FitSummary summary;  // params: offset_mm (normal), angle_rad
};
struct LineFit3D {
  Eigen::Vector3d point, direction;
  // params: offset_u_mm, offset_v_mm (axis shift), tilt_u_rad, tilt_v_rad
  // (rotations of the direction towards the unit vectors u, v below).
  Eigen::Vector3d u, v;
  FitSummary summary;
};
struct PlaneFit {  // point on the plane (centroid), unit normal
  Eigen::Vector3d point, normal;
  // params: offset_mm along the normal at the centroid, tilt_u_rad,
  // tilt_v_rad (rotations of the normal towards two in-plane axes u, v).
  Eigen::Vector3d u, v;
  FitSummary summary;
};
struct CircleFit2D {
  Eigen::Vector2d centre;
  double radius_mm = 0;
  FitSummary summary;  // params: cx_mm, cy_mm, r_mm
};
struct CircleFit3D {  // plane first, then the circle in that plane
  Eigen::Vector3d centre, normal;
  double radius_mm = 0;
  // params: centre_u_mm, centre_v_mm, centre_normal_mm, tilt_u_rad,
  // tilt_v_rad, r_mm (u, v: in-plane unit vectors of the plane fit).
  Eigen::Vector3d u, v;
  FitSummary summary;
};
struct SphereFit {
  Eigen::Vector3d centre;
  double radius_mm = 0;
  FitSummary summary;  // params: cx_mm, cy_mm, cz_mm, r_mm
};
struct CylinderFit {  // axis point closest to the data centroid
  Eigen::Vector3d point, axis;
  double radius_mm = 0;
  // params: shift_u_mm, shift_v_mm (of the axis point), tilt_u_rad,
  // tilt_v_rad (of the axis towards u, v), r_mm.
  Eigen::Vector3d u, v;
  FitSummary summary;
};
struct ConeFit {  // apex, unit axis pointing into the cone, half angle
  Eigen::Vector3d apex, axis;
  double half_angle_rad = 0;
  // Axis point closest to the data centroid and the cone radius there
  // (well defined even for a nearly cylindrical cone whose apex is far).
  Eigen::Vector3d point;
  double radius_at_point_mm = 0;
  // params: shift_u_mm, shift_v_mm, tilt_u_rad, tilt_v_rad,
  // radius_at_point_mm, half_angle_rad.
  Eigen::Vector3d u, v;
  FitSummary summary;
};

// Points are columns. Each throws InputError if there are too few points
// or they are degenerate for the shape in a way seen before fitting (e.g.
// collinear for a plane); degeneracies only the solution shows (a cylinder
// through points on a plane) come back as FitStatus::kDegenerate.
LineFit2D FitLine2D(const Eigen::Matrix2Xd& points,
                    const FitOptions& options = {});
LineFit3D FitLine3D(const Eigen::Matrix3Xd& points,
                    const FitOptions& options = {});
PlaneFit FitPlane(const Eigen::Matrix3Xd& points,
                  const FitOptions& options = {});
CircleFit2D FitCircle2D(const Eigen::Matrix2Xd& points,
                        const FitOptions& options = {});
CircleFit3D FitCircle3D(const Eigen::Matrix3Xd& points,
                        const FitOptions& options = {});
SphereFit FitSphere(const Eigen::Matrix3Xd& points,
                    const FitOptions& options = {});
CylinderFit FitCylinder(const Eigen::Matrix3Xd& points,
                        const FitOptions& options = {});
ConeFit FitCone(const Eigen::Matrix3Xd& points, const FitOptions& options = {});

// ---- Orientation and stray rejection (the cloud inspection's datums and
// features) ----

// The same plane with the normal turned towards `hint_normal` and u the
// projection of `hint_u` onto the plane (v = normal x u); the covariance is
// re-expressed for the new axes, so tilt_u_rad is the rotation of the
// normal towards the given direction.
PlaneFit OrientPlane(const PlaneFit& fit, const Eigen::Vector3d& hint_normal,
                     const Eigen::Vector3d& hint_u);

// Iterative stray rejection: fit, drop the points whose |residual| exceeds
// max(k_sigma * sigma, floor_mm) with sigma = 1.4826 * median |residual|
// (a robust sigma, from at most 20,000 residuals), refit, until the set is
// stable or max_rounds refits were made.
struct RejectionOptions {
  double k_sigma = 5.0;
  double floor_mm = 0.003;
  int max_rounds = 8;
  bool IsValid(std::string* error) const;
};

// The plane of `points.col(i)` for i in `indices` (oriented as OrientPlane
// does) after stray rejection; `indices` becomes the inliers. `rejected`
// counts the dropped points. Throws like FitPlane when fewer than three
// points (or collinear ones) remain.
struct TrimmedPlane {
  PlaneFit plane;
  std::vector<Eigen::Index> inliers;
  int rejected = 0;
};
TrimmedPlane FitPlaneTrimmed(const Eigen::Matrix3Xd& points,
                             std::vector<Eigen::Index> indices,
                             const Eigen::Vector3d& hint_normal,
                             const Eigen::Vector3d& hint_u,
                             const RejectionOptions& rejection);

// A circle in the plane after stray rejection: first within shrinking
// bands about the circle (`bands_mm`, e.g. {5, 1, 0.3}: points farther
// from the fitted circle are dropped before the refit), then as above (at
// most max_rounds refits).
struct TrimmedCircle {
  CircleFit2D circle;
  std::vector<Eigen::Index> inliers;  // columns of the input
};
TrimmedCircle FitCircle2DTrimmed(const Eigen::Matrix2Xd& points,
                                 const std::vector<double>& bands_mm,
                                 const RejectionOptions& rejection);

}  // namespace ttp::fit
