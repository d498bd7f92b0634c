// Lines and planes in closed form (eigen decomposition of the centred
// scatter: the exact orthogonal least-squares solution) with a Ceres
// refinement only for robust losses; circles and spheres with Ceres seeded
// by the algebraic fit. Every fit works on data centred at the centroid.
#include "ttp/geometry/fit.h"

#include <ceres/ceres.h>
#include <glog/logging.h>

#include <Eigen/Dense>
#include <cmath>
#include <cstdio>

#include "fit_internal.h"
#include "ttp/geometry/error.h"

namespace ttp::fit {

namespace {

bool Invalid(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

}  // namespace

bool FitOptions::IsValid(std::string* error) const {
  if (!(loss_scale_mm > 0) || !std::isfinite(loss_scale_mm))
    return Invalid(error,
                   "FitOptions.loss_scale_mm: must be a positive finite "
                   "length in mm");
  if (max_iterations < 1)
    return Invalid(error, "FitOptions.max_iterations: must be at least 1");
  if (loss != Loss::kNone && loss != Loss::kHuber && loss != Loss::kCauchy)
    return Invalid(error, "FitOptions.loss: unknown loss");
  return true;
}

void FitOptions::Validate() const {
  std::string error;
  if (IsValid(&error)) return;
  const size_t colon = error.find(':');
  throw InputError("FitOptions", 0, error.substr(0, colon),
                   error.substr(colon + 2));
}

bool RejectionOptions::IsValid(std::string* error) const {
  if (!(k_sigma > 0) || !std::isfinite(k_sigma))
    return Invalid(error,
                   "RejectionOptions.k_sigma: must be a positive finite "
                   "number of sigmas");
  if (!(floor_mm >= 0) || !std::isfinite(floor_mm))
    return Invalid(error,
                   "RejectionOptions.floor_mm: must be a finite length >= 0");
  if (max_rounds < 0)
    return Invalid(error, "RejectionOptions.max_rounds: must be >= 0");
  return true;
}

const char* FitStatusName(FitStatus status) {
  switch (status) {
    case FitStatus::kConverged:
      return "converged";
    case FitStatus::kNoConvergence:
      return "not converged";
    case FitStatus::kFailed:
      return "failed";
    case FitStatus::kDegenerate:
      return "degenerate";
  }
  return "unknown";
}

namespace internal {

void SilenceCeresLogging() {
  static const bool silenced = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)silenced;
}

void SetStatusFromCeres(const ceres::Solver::Summary& summary, FitSummary* s) {
  s->termination = ceres::TerminationTypeToString(summary.termination_type);
  s->solution_usable =
      summary.IsSolutionUsable() && std::isfinite(summary.final_cost);
  s->iterations = static_cast<int>(summary.iterations.size()) - 1;
  s->message = summary.message;
  if (!s->solution_usable)
    s->status = FitStatus::kFailed;
  else if (summary.termination_type == ceres::CONVERGENCE)
    s->status = FitStatus::kConverged;
  else
    s->status = FitStatus::kNoConvergence;
  s->converged = s->status == FitStatus::kConverged;
}

bool CheckRank(const Eigen::MatrixXd& jacobian,
               const std::vector<std::string>& names, FitSummary* s) {
  // The singular values and right vectors of the tall Jacobian (a row per
  // point) are those of its QR factor R (square, a row per parameter): an
  // SVD of R costs nothing, one of 10^5 rows as much as the fit.
  Eigen::MatrixXd r = jacobian;
  if (jacobian.rows() > jacobian.cols()) {
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(jacobian);
    r = qr.matrixQR().topRows(jacobian.cols()).triangularView<Eigen::Upper>();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(r, Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const double largest = sv.size() ? sv(0) : 0.0;
  const double ratio =
      largest > 0 ? std::pow(sv(sv.size() - 1) / largest, 2) : 0.0;
  if (ratio >= 1e-14 && std::isfinite(ratio)) return true;
  Eigen::Index weakest = 0;
  if (sv.size()) svd.matrixV().col(sv.size() - 1).cwiseAbs().maxCoeff(&weakest);
  const std::string name = static_cast<size_t>(weakest) < names.size()
                               ? names[static_cast<size_t>(weakest)]
                               : "a parameter";
  s->status = FitStatus::kDegenerate;
  s->converged = false;
  char condition[32];
  std::snprintf(condition, sizeof condition, "%.3g", ratio);
  s->message = "the points do not determine " + name +
               " (reciprocal condition number " + condition + ")";
  s->covariance.resize(0, 0);
  return false;
}

void RequirePoints(const char* shape, long count, long minimum,
                   bool all_finite) {
  if (count < minimum) {
    throw InputError("fit", 0, shape,
                     "needs at least " + std::to_string(minimum) +
                         " points, got " + std::to_string(count));
  }
  if (!all_finite) {
    throw InputError("fit", 0, shape, "points contain NaN or infinity");
  }
}

void CompleteFrame(const Eigen::Vector3d& w, Eigen::Vector3d* u,
                   Eigen::Vector3d* v) {
  Eigen::Index smallest;
  w.cwiseAbs().minCoeff(&smallest);
  const Eigen::Vector3d seed = Eigen::Vector3d::Unit(smallest);
  *u = (seed - seed.dot(w) * w).normalized();
  *v = w.cross(*u);
}

std::unique_ptr<ceres::LossFunction> MakeLoss(const FitOptions& options) {
  switch (options.loss) {
    case FitOptions::Loss::kHuber:
      return std::make_unique<ceres::HuberLoss>(options.loss_scale_mm);
    case FitOptions::Loss::kCauchy:
      return std::make_unique<ceres::CauchyLoss>(options.loss_scale_mm);
    case FitOptions::Loss::kNone:
      break;
  }
  return nullptr;
}

}  // namespace internal

using internal::ComputeScatter;
using internal::kDegenerateRatio;
using internal::RequirePoints;

namespace {

// Signed distance of a centred 2D point to the line rotated by angle_rad
// from the seed direction and shifted by offset_mm along its normal.
struct Line2DResidual {
  static constexpr int kResiduals = 1;
  Eigen::Vector2d x, direction0;
  template <class T>
  bool operator()(const T* p, T* r) const {
    const T c = cos(p[1]), s = sin(p[1]);
    // direction = R(angle) d0; normal = direction rotated by +90 degrees.
    const T dx = c * direction0.x() - s * direction0.y();
    const T dy = s * direction0.x() + c * direction0.y();
    r[0] = -dy * x.x() + dx * x.y() - p[0];
    return true;
  }
};

// Two perpendicular components of the offset of a centred point from the
// line through u*p0 + v*p1 with direction normalize(w + p2 u + p3 v).
struct Line3DResidual {
  static constexpr int kResiduals = 2;
  Eigen::Vector3d x, u, v, w;
  template <class T>
  bool operator()(const T* p, T* r) const {
    Eigen::Matrix<T, 3, 1> d =
        w.cast<T>() + p[2] * u.cast<T>() + p[3] * v.cast<T>();
    d /= d.norm();
    const Eigen::Matrix<T, 3, 1> q = p[0] * u.cast<T>() + p[1] * v.cast<T>();
    const Eigen::Matrix<T, 3, 1> off = x.cast<T>() - q;
    Eigen::Matrix<T, 3, 1> e1 = u.cast<T>() - u.cast<T>().dot(d) * d;
    e1 /= e1.norm();
    const Eigen::Matrix<T, 3, 1> e2 = d.cross(e1);
    r[0] = off.dot(e1);
    r[1] = off.dot(e2);
    return true;
  }
};

// Signed distance of a centred point to the plane with normal
// normalize(n + p1 u + p2 v) at offset p0.
struct PlaneResidual {
  static constexpr int kResiduals = 1;
  Eigen::Vector3d x, u, v, n;
  template <class T>
  bool operator()(const T* p, T* r) const {
    Eigen::Matrix<T, 3, 1> m =
        n.cast<T>() + p[1] * u.cast<T>() + p[2] * v.cast<T>();
    m /= m.norm();
    r[0] = m.dot(x.cast<T>()) - p[0];
    return true;
  }
};

template <int D>
struct SphereResidual {
  static constexpr int kResiduals = 1;
  Eigen::Matrix<double, D, 1> x;
  template <class T>
  bool operator()(const T* p, T* r) const {
    T sq = T(0);
    for (int k = 0; k < D; ++k) {
      const T d = T(x(k)) - p[k];
      sq += d * d;
    }
    r[0] = sqrt(sq) - p[D];
    return true;
  }
};

void FillCovariance(FitSummary* s, Eigen::MatrixXd covariance,
                    std::vector<std::string> names) {
  s->covariance = std::move(covariance);
  s->parameter_names = std::move(names);
}

bool Robust(const FitOptions& o) { return o.loss != FitOptions::Loss::kNone; }

// The summary of a closed-form (unweighted least-squares) fit from its
// orthogonal residuals.
void SetClosedFormSummary(const Eigen::VectorXd& residuals_mm, FitSummary* s) {
  const long n = residuals_mm.size();
  s->points = static_cast<int>(n);
  s->rms_mm = std::sqrt(residuals_mm.squaredNorm() / n);
  s->max_abs_mm = residuals_mm.cwiseAbs().maxCoeff();
  s->message = "closed form";
}

// Circle through centred 2D points (shared by FitCircle2D and FitCircle3D).
CircleFit2D FitCentredCircle(const Eigen::Matrix2Xd& centred,
                             const FitOptions& options) {
  Eigen::Vector2d centre;
  double radius = 0;
  if (!internal::AlgebraicSphere<2>(centred, &centre, &radius)) {
    throw InputError("fit", 0, "circle", "points are degenerate (collinear)");
  }
  std::vector<SphereResidual<2>> functors(centred.cols());
  for (long i = 0; i < centred.cols(); ++i) functors[i].x = centred.col(i);
  std::array<double, 3> p = {centre.x(), centre.y(), radius};
  internal::SolveResult solved =
      internal::Solve<3>(functors, &p, options, {"cx_mm", "cy_mm", "r_mm"},
                         options.compute_covariance);
  CircleFit2D fit;
  fit.centre = Eigen::Vector2d(p[0], p[1]);
  fit.radius_mm = std::abs(p[2]);
  fit.summary = std::move(solved.summary);
  return fit;
}

}  // namespace

LineFit2D FitLine2D(const Eigen::Matrix2Xd& points, const FitOptions& options) {
  options.Validate();
  RequirePoints("line2d", points.cols(), 2, points.allFinite());
  const auto s = ComputeScatter<2>(points);
  if (!internal::Spread(s.eigenvalues(1), points.cols(), s.centroid.norm())) {
    throw InputError("fit", 0, "line2d", "all points coincide");
  }
  LineFit2D fit;
  fit.point = s.centroid;
  fit.direction = s.eigenvectors.col(1);
  const long n = points.cols();
  const Eigen::Matrix2Xd centred = points.colwise() - s.centroid;
  if (Robust(options)) {
    std::vector<Line2DResidual> functors(n);
    for (long i = 0; i < n; ++i) functors[i] = {centred.col(i), fit.direction};
    std::array<double, 2> p = {0, 0};
    auto solved =
        internal::Solve<2>(functors, &p, options, {"offset_mm", "angle_rad"},
                           options.compute_covariance);
    const double c = std::cos(p[1]), sn = std::sin(p[1]);
    const Eigen::Vector2d d0 = fit.direction;
    fit.direction =
        Eigen::Vector2d(c * d0.x() - sn * d0.y(), sn * d0.x() + c * d0.y());
    fit.point += p[0] * Eigen::Vector2d(-fit.direction.y(), fit.direction.x());
    fit.summary = std::move(solved.summary);
    return fit;
  }
  const Eigen::Vector2d normal = s.eigenvectors.col(0);
  const Eigen::VectorXd r = normal.transpose() * centred;
  FitSummary& sum = fit.summary;
  SetClosedFormSummary(r, &sum);
  if (options.compute_covariance) {
    // Exact Hessian of the orthogonal problem: N for the offset and
    // (lambda_max - lambda_min) for the angle.
    const double variance = n > 2 ? r.squaredNorm() / (n - 2) : 0.0;
    Eigen::Matrix2d c = Eigen::Matrix2d::Zero();
    c(0, 0) = variance / n;
    c(1, 1) = variance / (s.eigenvalues(1) - s.eigenvalues(0));
    FillCovariance(&sum, c, {"offset_mm", "angle_rad"});
  }
  return fit;
}

LineFit3D FitLine3D(const Eigen::Matrix3Xd& points, const FitOptions& options) {
  options.Validate();
  RequirePoints("line3d", points.cols(), 2, points.allFinite());
  const auto s = ComputeScatter<3>(points);
  if (!internal::Spread(s.eigenvalues(2), points.cols(), s.centroid.norm())) {
    throw InputError("fit", 0, "line3d", "all points coincide");
  }
  LineFit3D fit;
  fit.point = s.centroid;
  fit.direction = s.eigenvectors.col(2);
  fit.u = s.eigenvectors.col(0);
  fit.v = fit.direction.cross(fit.u);
  const long n = points.cols();
  const Eigen::Matrix3Xd centred = points.colwise() - s.centroid;
  const std::vector<std::string> names = {"offset_u_mm", "offset_v_mm",
                                          "tilt_u_rad", "tilt_v_rad"};
  if (Robust(options)) {
    std::vector<Line3DResidual> functors(n);
    for (long i = 0; i < n; ++i) {
      functors[i] = {centred.col(i), fit.u, fit.v, fit.direction};
    }
    std::array<double, 4> p = {0, 0, 0, 0};
    auto solved = internal::Solve<4>(functors, &p, options, names,
                                     options.compute_covariance);
    const Eigen::Vector3d d =
        (fit.direction + p[2] * fit.u + p[3] * fit.v).normalized();
    const Eigen::Vector3d q = p[0] * fit.u + p[1] * fit.v;
    fit.point = s.centroid + q - q.dot(d) * d;
    fit.direction = d;
    fit.summary = std::move(solved.summary);
    fit.summary.residuals_per_point = 2;
    return fit;
  }
  const Eigen::Matrix3Xd perpendicular =
      centred - fit.direction * (fit.direction.transpose() * centred);
  const Eigen::VectorXd dist = perpendicular.colwise().norm();
  FitSummary& sum = fit.summary;
  SetClosedFormSummary(dist, &sum);
  sum.residuals_per_point = 2;
  if (options.compute_covariance) {
    // Two residual components per point, four parameters.
    const double dof = 2.0 * n - 4;
    const double variance = dof > 0 ? dist.squaredNorm() / dof : 0.0;
    Eigen::Matrix4d c = Eigen::Matrix4d::Zero();
    c(0, 0) = c(1, 1) = variance / n;
    c(2, 2) = variance / (s.eigenvalues(2) - s.eigenvalues(0));
    c(3, 3) = variance / (s.eigenvalues(2) - s.eigenvalues(1));
    FillCovariance(&sum, c, names);
  }
  return fit;
}

PlaneFit FitPlane(const Eigen::Matrix3Xd& points, const FitOptions& options) {
  options.Validate();
  RequirePoints("plane", points.cols(), 3, points.allFinite());
  const auto s = ComputeScatter<3>(points);
  if (!(s.eigenvalues(1) > kDegenerateRatio * s.eigenvalues(2))) {
    throw InputError("fit", 0, "plane", "points are collinear or coincide");
  }
  PlaneFit fit;
  fit.point = s.centroid;
  fit.normal = s.eigenvectors.col(0);
  fit.u = s.eigenvectors.col(2);
  fit.v = fit.normal.cross(fit.u);
  const long n = points.cols();
  const Eigen::Matrix3Xd centred = points.colwise() - s.centroid;
  const std::vector<std::string> names = {"offset_mm", "tilt_u_rad",
                                          "tilt_v_rad"};
  if (Robust(options)) {
    std::vector<PlaneResidual> functors(n);
    for (long i = 0; i < n; ++i) {
      functors[i] = {centred.col(i), fit.u, fit.v, fit.normal};
    }
    std::array<double, 3> p = {0, 0, 0};
    auto solved = internal::Solve<3>(functors, &p, options, names,
                                     options.compute_covariance);
    const Eigen::Vector3d m =
        (fit.normal + p[1] * fit.u + p[2] * fit.v).normalized();
    fit.normal = m;
    fit.point = s.centroid + p[0] * m;
    fit.u = (fit.u - fit.u.dot(m) * m).normalized();
    fit.v = m.cross(fit.u);
    fit.summary = std::move(solved.summary);
    return fit;
  }
  const Eigen::VectorXd r = fit.normal.transpose() * centred;
  FitSummary& sum = fit.summary;
  SetClosedFormSummary(r, &sum);
  if (options.compute_covariance) {
    // Exact Hessian of sum (n.x - d)^2 at the optimum: N for the offset,
    // lambda_axis - lambda_min for a rotation of the normal towards an axis.
    const double variance = n > 3 ? r.squaredNorm() / (n - 3) : 0.0;
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    c(0, 0) = variance / n;
    c(1, 1) = variance / (s.eigenvalues(2) - s.eigenvalues(0));
    c(2, 2) = variance / (s.eigenvalues(1) - s.eigenvalues(0));
    FillCovariance(&sum, c, names);
  }
  return fit;
}

CircleFit2D FitCircle2D(const Eigen::Matrix2Xd& points,
                        const FitOptions& options) {
  options.Validate();
  RequirePoints("circle2d", points.cols(), 3, points.allFinite());
  const auto s = ComputeScatter<2>(points);
  if (!(s.eigenvalues(0) > kDegenerateRatio * s.eigenvalues(1))) {
    throw InputError("fit", 0, "circle2d", "points are collinear");
  }
  CircleFit2D fit = FitCentredCircle(points.colwise() - s.centroid, options);
  fit.centre += s.centroid;
  return fit;
}

CircleFit3D FitCircle3D(const Eigen::Matrix3Xd& points,
                        const FitOptions& options) {
  options.Validate();
  RequirePoints("circle3d", points.cols(), 3, points.allFinite());
  FitOptions plane_options = options;
  const PlaneFit plane = FitPlane(points, plane_options);
  // Project onto the plane, in its (u, v) coordinates about its point.
  const Eigen::Matrix3Xd centred = points.colwise() - plane.point;
  Eigen::Matrix2Xd in_plane(2, points.cols());
  in_plane.row(0) = plane.u.transpose() * centred;
  in_plane.row(1) = plane.v.transpose() * centred;
  const auto s2 = ComputeScatter<2>(in_plane);
  if (!(s2.eigenvalues(0) > kDegenerateRatio * s2.eigenvalues(1))) {
    throw InputError("fit", 0, "circle3d", "points are collinear");
  }
  const CircleFit2D circle =
      FitCentredCircle(in_plane.colwise() - s2.centroid, options);
  const Eigen::Vector2d c2 = circle.centre + s2.centroid;
  CircleFit3D fit;
  fit.centre = plane.point + c2.x() * plane.u + c2.y() * plane.v;
  fit.normal = plane.normal;
  fit.radius_mm = circle.radius_mm;
  fit.u = plane.u;
  fit.v = plane.v;
  fit.summary = circle.summary;
  fit.summary.residuals_per_point = 2;
  // Residuals: in-plane circle distance and out-of-plane distance combined.
  const long n = points.cols();
  double sum_sq = 0, max_abs = 0;
  for (long i = 0; i < n; ++i) {
    const Eigen::Vector3d d = points.col(i) - fit.centre;
    const double h = d.dot(fit.normal);
    const double rho = (d - h * fit.normal).norm() - fit.radius_mm;
    const double e = std::hypot(h, rho);
    sum_sq += e * e;
    max_abs = std::max(max_abs, e);
  }
  fit.summary.rms_mm = std::sqrt(sum_sq / n);
  fit.summary.max_abs_mm = max_abs;
  if (options.compute_covariance && circle.summary.covariance.size() == 9 &&
      plane.summary.covariance.size() == 9) {
    // Centre along u, v from the circle, along the normal from the plane
    // offset; tilts of the normal from the plane (plane and circle treated
    // as independent, as in the two-step definition).
    Eigen::MatrixXd c = Eigen::MatrixXd::Zero(6, 6);
    c.block<2, 2>(0, 0) = circle.summary.covariance.block<2, 2>(0, 0);
    c(2, 2) = plane.summary.covariance(0, 0);
    c.block<2, 2>(3, 3) = plane.summary.covariance.block<2, 2>(1, 1);
    c(5, 5) = circle.summary.covariance(2, 2);
    c.block<2, 1>(0, 5) = circle.summary.covariance.block<2, 1>(0, 2);
    c.block<1, 2>(5, 0) = circle.summary.covariance.block<1, 2>(2, 0);
    FillCovariance(&fit.summary, c,
                   {"centre_u_mm", "centre_v_mm", "centre_normal_mm",
                    "tilt_u_rad", "tilt_v_rad", "r_mm"});
  }
  return fit;
}

SphereFit FitSphere(const Eigen::Matrix3Xd& points, const FitOptions& options) {
  options.Validate();
  RequirePoints("sphere", points.cols(), 4, points.allFinite());
  const auto s = ComputeScatter<3>(points);
  if (!(s.eigenvalues(0) > kDegenerateRatio * s.eigenvalues(2))) {
    throw InputError("fit", 0, "sphere", "points are coplanar");
  }
  const Eigen::Matrix3Xd centred = points.colwise() - s.centroid;
  Eigen::Vector3d centre;
  double radius = 0;
  if (!internal::AlgebraicSphere<3>(centred, &centre, &radius)) {
    throw InputError("fit", 0, "sphere", "points are degenerate");
  }
  std::vector<SphereResidual<3>> functors(centred.cols());
  for (long i = 0; i < centred.cols(); ++i) functors[i].x = centred.col(i);
  std::array<double, 4> p = {centre.x(), centre.y(), centre.z(), radius};
  auto solved = internal::Solve<4>(functors, &p, options,
                                   {"cx_mm", "cy_mm", "cz_mm", "r_mm"},
                                   options.compute_covariance);
  SphereFit fit;
  fit.centre = s.centroid + Eigen::Vector3d(p[0], p[1], p[2]);
  fit.radius_mm = std::abs(p[3]);
  fit.summary = std::move(solved.summary);
  return fit;
}

}  // namespace ttp::fit
