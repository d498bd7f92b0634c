// Least-squares geometry fits with true orthogonal distances, double
// precision on centred data (Ceres for every nonlinear fit; the plane and
// line have closed forms that are the exact orthogonal solution). Each
// result carries a summary: residual statistics and the covariance of its
// parameters (scaled by the residual variance), in the order the struct
// documents.
//
// CONTRACT: the names and fields below are used by inspect and thermal;
// extend, do not rename.
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
  // Throws InputError naming the field (e.g. "FitOptions.loss_scale_mm").
  void Validate() const;
};

struct FitSummary {
  int points = 0;
  double rms_mm = 0;      // RMS of the orthogonal residuals
  double max_abs_mm = 0;  // largest |residual|
  bool converged = true;
  int iterations = 0;
  std::string message;
  // Covariance of the parameters listed in parameter_names (mm, rad).
  Eigen::MatrixXd covariance;
  std::vector<std::string> parameter_names;
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
// or they are degenerate for the shape (e.g. collinear for a plane).
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

}  // namespace ttp::fit
