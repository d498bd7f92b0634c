// Cylinder and cone: Ceres fits of true orthogonal distances, parameterised
// minimally in a local frame (w = current axis, u, v perpendicular): axis
// shifts along u, v and tilts of the axis towards u, v. The frame is moved
// to the solution and the solve repeated until the tilts vanish, so the
// covariance is that of small rotations/shifts of the final axis. Seeds: each
// principal axis of the scatter in turn, with an algebraic circle in the
// perpendicular plane; the lowest cost wins.
#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <optional>

#include "fit_internal.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/fit.h"

namespace ttp::fit {
namespace {

struct AxisFrame {
  Eigen::Vector3d q0, u, v, w;
};

template <class T>
void AxisFromParams(const AxisFrame& f, const T* p, Eigen::Matrix<T, 3, 1>* q,
                    Eigen::Matrix<T, 3, 1>* d) {
  *d = f.w.cast<T>() + p[2] * f.u.cast<T>() + p[3] * f.v.cast<T>();
  *d /= d->norm();
  *q = f.q0.cast<T>() + p[0] * f.u.cast<T>() + p[1] * f.v.cast<T>();
}

// The offset of x from the axis point for parameters p, and the axis
// direction.
template <class T>
Eigen::Matrix<T, 3, 1> OffsetFromAxis(const AxisFrame& f, const T* p,
                                      const Eigen::Vector3d& x,
                                      Eigen::Matrix<T, 3, 1>* d) {
  Eigen::Matrix<T, 3, 1> q;
  AxisFromParams(f, p, &q, d);
  return x.cast<T>() - q;
}

// One centred point against the axis of the frame's parameters.
struct AxisPointResidual {
  static constexpr int kResiduals = 1;
  Eigen::Vector3d x;
  const AxisFrame* frame;
};

struct CylinderResidual : AxisPointResidual {
  template <class T>
  bool operator()(const T* p, T* r) const {
    Eigen::Matrix<T, 3, 1> d;
    const Eigen::Matrix<T, 3, 1> off = OffsetFromAxis(*frame, p, x, &d);
    const Eigen::Matrix<T, 3, 1> perp = off - off.dot(d) * d;
    r[0] = sqrt(perp.squaredNorm()) - p[4];
    return true;
  }
};

// Orthogonal distance to the cone whose radius is p[4] at the axis point q
// and grows by tan(p[5]) per mm along d: in the (h, rho) half plane the
// generator is the line rho = r0 + h tan(theta).
struct ConeResidual : AxisPointResidual {
  template <class T>
  bool operator()(const T* p, T* r) const {
    Eigen::Matrix<T, 3, 1> d;
    const Eigen::Matrix<T, 3, 1> off = OffsetFromAxis(*frame, p, x, &d);
    const T h = off.dot(d);
    const T rho = sqrt((off - h * d).squaredNorm());
    r[0] = (rho - p[4] - h * tan(p[5])) * cos(p[5]);
    return true;
  }
};

struct AxialResult {
  AxisFrame frame;  // final frame: q0 on the axis closest to the centroid
  double radius_mm = 0;
  double half_angle_rad = 0;
  FitSummary summary;
  double cost = 0;
};

// Refines one seed; P = 5 (cylinder) or 6 (cone).
template <int P, class Functor>
AxialResult Refine(const Eigen::Matrix3Xd& centred, AxisFrame frame,
                   double radius, double half_angle, const FitOptions& options,
                   const std::vector<std::string>& names,
                   bool want_covariance) {
  AxialResult out;
  for (int pass = 0;; ++pass) {
    const bool last = pass >= 8;
    std::vector<Functor> functors(centred.cols());
    for (long i = 0; i < centred.cols(); ++i) {
      functors[i].x = centred.col(i);
      functors[i].frame = &frame;
    }
    std::array<double, P> p{};
    p[4] = radius;
    if constexpr (P == 6) p[5] = half_angle;
    internal::SolveResult solved =
        internal::Solve<P>(functors, &p, options, names, want_covariance);
    Eigen::Vector3d q, d;
    AxisFromParams(frame, p.data(), &q, &d);
    const double moved =
        std::max({std::abs(p[0]), std::abs(p[1]), std::abs(p[2]) * (1 + radius),
                  std::abs(p[3]) * (1 + radius)});
    radius = p[4];
    if constexpr (P == 6) half_angle = p[5];
    // Slide the axis point to the foot of the centroid (the origin).
    const double slide = -q.dot(d);
    q += slide * d;
    if constexpr (P == 6) radius += slide * std::tan(half_angle);
    out.summary = std::move(solved.summary);
    out.cost = solved.cost;
    if (moved < 1e-11 || last) {
      // This pass was solved in (almost) the final frame: keep its
      // covariance, which is about the frame's own axes.
      out.summary.iterations += pass;  // count the re-framing passes too
      if (moved >= 1e-11) {
        // Out of passes: report this pass's axis (which its radius and
        // angle belong to), and say that the re-framing did not settle.
        frame.q0 = q;
        frame.w = d;
        internal::CompleteFrame(d, &frame.u, &frame.v);
        out.summary.converged = false;
        if (out.summary.status == FitStatus::kConverged)
          out.summary.status = FitStatus::kNoConvergence;
        out.summary.message =
            "the axis was still moving after 9 re-framing passes";
      }
      break;
    }
    frame.q0 = q;
    frame.w = d;
    internal::CompleteFrame(d, &frame.u, &frame.v);
  }
  out.frame = frame;
  out.radius_mm = radius;
  out.half_angle_rad = half_angle;
  return out;
}

// Seed axis through the algebraic circle of the points projected along w.
std::optional<AxisFrame> SeedFrame(const Eigen::Matrix3Xd& centred,
                                   const Eigen::Vector3d& w, double* radius) {
  AxisFrame f;
  f.w = w;
  internal::CompleteFrame(w, &f.u, &f.v);
  Eigen::Matrix2Xd projected(2, centred.cols());
  projected.row(0) = f.u.transpose() * centred;
  projected.row(1) = f.v.transpose() * centred;
  Eigen::Vector2d c;
  if (!internal::AlgebraicSphere<2>(projected, &c, radius)) return {};
  f.q0 = c.x() * f.u + c.y() * f.v;
  return f;
}

void CheckSpread(const char* shape, const internal::Scatter<3>& s) {
  if (!(s.eigenvalues(1) > internal::kDegenerateRatio * s.eigenvalues(2))) {
    throw InputError("fit", 0, shape, "points are collinear or coincide");
  }
}

Eigen::Vector3d Canonical(const Eigen::Vector3d& axis) {
  Eigen::Index largest;
  axis.cwiseAbs().maxCoeff(&largest);
  return axis(largest) < 0 ? Eigen::Vector3d(-axis) : axis;
}

// Points the seeds are ranked on: a seed whose axis lies across the true
// one crawls for hundreds of iterations (500 on a 20k-point cylinder,
// against 10 for the right seed), so on a large cloud they crawl on an
// evenly strided subset, and only the winner is refined on every point.
constexpr long kSeedRankingPoints = 2000;

Eigen::Matrix3Xd StridedSubset(const Eigen::Matrix3Xd& points, long count) {
  if (points.cols() <= count) return points;
  Eigen::Matrix3Xd out(3, count);
  for (long i = 0; i < count; ++i)
    out.col(i) = points.col(i * points.cols() / count);
  return out;
}

// Every principal axis of the scatter as a seed (its algebraic circle in
// the perpendicular plane; `seed_shape` turns it into the shape's radius
// and half angle, or refuses it), refined (on at most kSeedRankingPoints);
// the lowest cost wins, and only the winner is refined on every point and
// again for its covariance (the other seeds may sit on a saddle).
template <int P, class Functor, class SeedShape>
AxialResult BestOfSeeds(const char* shape, const Eigen::Matrix3Xd& centred,
                        const internal::Scatter<3>& s,
                        const FitOptions& options,
                        const std::vector<std::string>& names,
                        SeedShape seed_shape) {
  const Eigen::Matrix3Xd ranking = StridedSubset(centred, kSeedRankingPoints);
  std::optional<AxialResult> best;
  for (int k = 0; k < 3; ++k) {
    double radius = 0;
    const auto frame = SeedFrame(centred, s.eigenvectors.col(k), &radius);
    if (!frame) continue;
    double half_angle = 0;
    if (!seed_shape(*frame, &radius, &half_angle)) continue;
    AxialResult r = Refine<P, Functor>(ranking, *frame, radius, half_angle,
                                       options, names, false);
    if (!std::isfinite(r.cost) || !r.frame.w.allFinite() ||
        std::abs(r.half_angle_rad) >= M_PI / 2) {
      continue;
    }
    if (!best || r.cost < best->cost) best = std::move(r);
  }
  if (!best) throw InputError("fit", 0, shape, "points are degenerate");
  // One refinement on every point: for the covariance, or because the
  // seeds were ranked on a subset.
  if (options.compute_covariance || ranking.cols() < centred.cols()) {
    const int iterations = best->summary.iterations;
    best = Refine<P, Functor>(centred, best->frame, best->radius_mm,
                              best->half_angle_rad, options, names,
                              options.compute_covariance);
    best->summary.iterations += iterations;
  }
  return *std::move(best);
}

}  // namespace

CylinderFit FitCylinder(const Eigen::Matrix3Xd& points,
                        const FitOptions& options) {
  options.Validate();
  internal::RequirePoints("cylinder", points.cols(), 5, points.allFinite());
  const auto s = internal::ComputeScatter<3>(points);
  CheckSpread("cylinder", s);
  const Eigen::Matrix3Xd centred = points.colwise() - s.centroid;
  const std::vector<std::string> names = {"shift_u_mm", "shift_v_mm",
                                          "tilt_u_rad", "tilt_v_rad", "r_mm"};
  const AxialResult best = BestOfSeeds<5, CylinderResidual>(
      "cylinder", centred, s, options, names,
      [](const AxisFrame&, double*, double*) { return true; });
  CylinderFit fit;
  const Eigen::Vector3d axis = Canonical(best.frame.w);
  fit.point = s.centroid + best.frame.q0;
  fit.axis = axis;
  fit.radius_mm = std::abs(best.radius_mm);
  fit.u = best.frame.u;
  fit.v = best.frame.v;
  if (axis.dot(best.frame.w) < 0) fit.v = -fit.v;  // keep u x v = axis
  fit.summary = best.summary;
  if (axis.dot(best.frame.w) < 0 && fit.summary.covariance.size() == 25) {
    // v and the axis flipped: tilt and shift along v change sign.
    Eigen::MatrixXd flip = Eigen::MatrixXd::Identity(5, 5);
    flip(1, 1) = flip(3, 3) = -1;
    fit.summary.covariance = flip * fit.summary.covariance * flip;
  }
  return fit;
}

ConeFit FitCone(const Eigen::Matrix3Xd& points, const FitOptions& options) {
  options.Validate();
  internal::RequirePoints("cone", points.cols(), 6, points.allFinite());
  const auto s = internal::ComputeScatter<3>(points);
  CheckSpread("cone", s);
  const Eigen::Matrix3Xd centred = points.colwise() - s.centroid;
  const std::vector<std::string> names = {
      "shift_u_mm", "shift_v_mm",         "tilt_u_rad",
      "tilt_v_rad", "radius_at_point_mm", "half_angle_rad"};
  const AxialResult best = BestOfSeeds<6, ConeResidual>(
      "cone", centred, s, options, names,
      [&centred](const AxisFrame& frame, double* radius, double* half_angle) {
        // Radius against height along the seed axis: a straight line whose
        // slope is tan(half angle).
        const long n = centred.cols();
        Eigen::MatrixXd a(n, 2);
        Eigen::VectorXd rho(n);
        for (long i = 0; i < n; ++i) {
          const Eigen::Vector3d off = centred.col(i) - frame.q0;
          const double h = off.dot(frame.w);
          a(i, 0) = 1;
          a(i, 1) = h;
          rho(i) = (off - h * frame.w).norm();
        }
        const Eigen::Vector2d line = a.colPivHouseholderQr().solve(rho);
        if (!line.allFinite()) return false;
        *radius = line(0);
        *half_angle = std::atan(line(1));
        return true;
      });
  ConeFit fit;
  Eigen::Vector3d axis = best.frame.w;
  double half_angle = best.half_angle_rad;
  fit.u = best.frame.u;
  fit.v = best.frame.v;
  fit.summary = best.summary;
  if (half_angle < 0) {
    // Point the axis towards increasing radius.
    axis = -axis;
    half_angle = -half_angle;
    fit.v = -fit.v;
    if (fit.summary.covariance.size() == 36) {
      Eigen::MatrixXd flip = Eigen::MatrixXd::Identity(6, 6);
      flip(1, 1) = flip(3, 3) = flip(5, 5) = -1;
      fit.summary.covariance = flip * fit.summary.covariance * flip;
    }
  }
  fit.axis = axis;
  fit.half_angle_rad = half_angle;
  fit.point = s.centroid + best.frame.q0;
  fit.radius_at_point_mm = best.radius_mm;
  // A half angle of (almost) zero is a cylinder: the apex is at infinity
  // and no cone is determined. 1e-9 rad puts the apex a billion radii away.
  if (!(half_angle > 1e-9)) {
    fit.apex =
        Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    fit.summary.status = FitStatus::kDegenerate;
    fit.summary.converged = false;
    fit.summary.message =
        "the half angle is 0: the points lie on a cylinder and the cone's "
        "apex is undefined (fit a cylinder)";
    fit.summary.covariance.resize(0, 0);
  } else if (!(half_angle < M_PI / 2 - 1e-4)) {
    // Within 0.1 mrad of 90 degrees the cone is a plane: its apex slides
    // freely in it.
    fit.apex =
        fit.point - axis * (fit.radius_at_point_mm / std::tan(half_angle));
    fit.summary.status = FitStatus::kDegenerate;
    fit.summary.converged = false;
    fit.summary.message =
        "the half angle is 90 degrees: the points lie on a plane and the "
        "cone's apex is undefined (fit a plane)";
    fit.summary.covariance.resize(0, 0);
  } else {
    fit.apex =
        fit.point - axis * (fit.radius_at_point_mm / std::tan(half_angle));
  }
  return fit;
}

}  // namespace ttp::fit
