// Stray rejection around the plane and circle fits, and the re-expression
// of a plane fit in axes the caller chooses (the cloud inspection wants the
// tilt of a facet's normal about Z, not about the scatter's axes).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "ttp/geometry/error.h"
#include "ttp/geometry/fit.h"

namespace ttp::fit {
namespace {

using Index = Eigen::Index;

double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

// The robust sigma (1.4826 MAD about zero) from at most 20,000 of the
// absolute residuals, evenly spaced.
double RobustSigma(const std::vector<double>& abs_residuals) {
  const size_t step = std::max<size_t>(1, abs_residuals.size() / 20000);
  std::vector<double> some;
  some.reserve(abs_residuals.size() / step + 1);
  for (size_t j = 0; j < abs_residuals.size(); j += step)
    some.push_back(abs_residuals[j]);
  return 1.4826 * Median(std::move(some));
}

void Require(const RejectionOptions& rejection) {
  std::string error;
  if (!rejection.IsValid(&error)) {
    const size_t colon = error.find(':');
    throw InputError("RejectionOptions", 0, error.substr(0, colon),
                     error.substr(colon + 2));
  }
}

void MarkDegenerate(FitSummary* s, const std::string& why) {
  s->status = FitStatus::kDegenerate;
  s->converged = false;
  s->message = why;
}

// `fit` of the indexed columns; a degenerate summary instead of an
// exception when they are too few or degenerate for the shape (a region of
// a cloud that holds no feature is an outcome, not bad input).
template <class Result, class Points, class Fit>
Result FitSubset(const Points& points, const std::vector<Index>& indices,
                 Fit fit) {
  Result out;
  out.summary.points = static_cast<int>(indices.size());
  if (indices.size() < 3) {
    MarkDegenerate(&out.summary, "fewer than 3 points");
    return out;
  }
  Points subset(points.rows(), static_cast<Index>(indices.size()));
  for (size_t k = 0; k < indices.size(); ++k)
    subset.col(static_cast<Index>(k)) = points.col(indices[k]);
  try {
    return fit(subset);
  } catch (const InputError& e) {
    MarkDegenerate(&out.summary, e.what());
    return out;
  }
}

PlaneFit PlaneOf(const Eigen::Matrix3Xd& points,
                 const std::vector<Index>& indices,
                 const Eigen::Vector3d& hint_normal,
                 const Eigen::Vector3d& hint_u) {
  return FitSubset<PlaneFit>(points, indices, [&](const Eigen::Matrix3Xd& p) {
    return OrientPlane(FitPlane(p), hint_normal, hint_u);
  });
}

// with_covariance false: the rounds before the last, whose covariance no
// one reads (a circle's covariance costs an SVD of its Jacobian, as much
// as the fit of a large ring itself).
CircleFit2D CircleOf(const Eigen::Matrix2Xd& points,
                     const std::vector<Index>& indices, bool with_covariance) {
  FitOptions options;
  options.compute_covariance = with_covariance;
  return FitSubset<CircleFit2D>(
      points, indices,
      [&](const Eigen::Matrix2Xd& p) { return FitCircle2D(p, options); });
}

}  // namespace

PlaneFit OrientPlane(const PlaneFit& fit, const Eigen::Vector3d& hint_normal,
                     const Eigen::Vector3d& hint_u) {
  PlaneFit out = fit;
  const bool flip = fit.normal.dot(hint_normal) < 0;
  if (flip) out.normal = -fit.normal;
  const Eigen::Vector3d& n = out.normal;
  Eigen::Vector3d u = hint_u - hint_u.dot(n) * n;
  if (u.norm() < 1e-6) u = n.unitOrthogonal();
  u.normalize();
  out.u = u;
  out.v = n.cross(u);
  if (fit.summary.covariance.rows() == 3) {
    // Parameters (offset, tilt_u, tilt_v): flipping the normal flips all
    // three (the covariance is unchanged); turning the in-plane axes turns
    // the tilt pair: delta_n = t_u u + t_v v = t_u' u' + t_v' v'.
    Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
    j(1, 1) = out.u.dot(fit.u);
    j(1, 2) = out.u.dot(fit.v);
    j(2, 1) = out.v.dot(fit.u);
    j(2, 2) = out.v.dot(fit.v);
    if (flip) j *= -1;
    out.summary.covariance = j * fit.summary.covariance * j.transpose();
  }
  return out;
}

TrimmedPlane FitPlaneTrimmed(const Eigen::Matrix3Xd& points,
                             std::vector<Index> indices,
                             const Eigen::Vector3d& hint_normal,
                             const Eigen::Vector3d& hint_u,
                             const RejectionOptions& rejection) {
  Require(rejection);
  TrimmedPlane out;
  out.plane = PlaneOf(points, indices, hint_normal, hint_u);
  const std::vector<Index> all = indices;
  std::vector<double> res(all.size());
  for (int round = 0; round < rejection.max_rounds &&
                      out.plane.summary.status == FitStatus::kConverged;
       ++round) {
    const PlaneFit& pl = out.plane;
    for (size_t j = 0; j < all.size(); ++j)
      res[j] = std::abs((points.col(all[j]) - pl.point).dot(pl.normal));
    const double limit =
        std::max(rejection.k_sigma * RobustSigma(res), rejection.floor_mm);
    std::vector<Index> keep;
    keep.reserve(all.size());
    for (size_t j = 0; j < all.size(); ++j)
      if (res[j] <= limit) keep.push_back(all[j]);
    const bool same = keep == indices;
    indices = std::move(keep);
    if (same && round > 0) break;
    out.plane = PlaneOf(points, indices, hint_normal, hint_u);
  }
  out.rejected = static_cast<int>(all.size() - indices.size());
  out.inliers = std::move(indices);
  return out;
}

TrimmedCircle FitCircle2DTrimmed(const Eigen::Matrix2Xd& points,
                                 const std::vector<double>& bands_mm,
                                 const RejectionOptions& rejection) {
  Require(rejection);
  TrimmedCircle out;
  std::vector<Index> keep(static_cast<size_t>(points.cols()));
  for (Index i = 0; i < points.cols(); ++i) keep[static_cast<size_t>(i)] = i;
  // Without rounds the first fit is the last: with its covariance at once.
  const bool rounds = !bands_mm.empty() || rejection.max_rounds > 0;
  out.circle = CircleOf(points, keep, !rounds);
  auto usable = [&] {
    return out.circle.summary.status == FitStatus::kConverged;
  };
  for (double band : bands_mm) {
    if (!usable()) {
      out.inliers = std::move(keep);
      return out;
    }
    std::vector<Index> next;
    for (Index i = 0; i < points.cols(); ++i) {
      const double r =
          (points.col(i) - out.circle.centre).norm() - out.circle.radius_mm;
      if (std::abs(r) < band) next.push_back(i);
    }
    keep = std::move(next);
    out.circle = CircleOf(points, keep, false);
  }
  for (int round = 0; round < rejection.max_rounds && usable(); ++round) {
    std::vector<double> res(keep.size());
    for (size_t j = 0; j < keep.size(); ++j)
      res[j] = std::abs((points.col(keep[j]) - out.circle.centre).norm() -
                        out.circle.radius_mm);
    const double limit =
        std::max(rejection.k_sigma * 1.4826 * Median(res), rejection.floor_mm);
    std::vector<Index> next;
    for (size_t j = 0; j < keep.size(); ++j)
      if (res[j] <= limit) next.push_back(keep[j]);
    if (next.size() == keep.size()) break;
    keep = std::move(next);
    out.circle = CircleOf(points, keep, false);
  }
  // The last round's fit again, now with its covariance (the same points:
  // the same circle).
  if (rounds && usable()) out.circle = CircleOf(points, keep, true);
  out.inliers = std::move(keep);
  return out;
}

}  // namespace ttp::fit
