#include "ttp/inspect/inspect.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <sstream>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/inspect/plane_result.h"
#include "ttp/inspect/point_io.h"

namespace ttp::inspect {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

using Index = Eigen::Index;
using Indices = std::vector<Index>;

double Median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  return v[mid];
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * v.size()));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

// Every k-th index of 0..n-1 so that at most `max` remain (all if n <= max).
Indices Subsample(Index n, Index max) {
  const Index step = std::max<Index>(1, (n + max - 1) / max);
  Indices out;
  out.reserve(static_cast<size_t>(n / step + 1));
  for (Index i = 0; i < n; i += step) out.push_back(i);
  return out;
}

// Closed-form orthogonal plane fit of centred data (the exact least-squares
// answer) with the covariance of w = a + b u + c v about the centroid.
struct Plane {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d u = Eigen::Vector3d::UnitX(), v = Eigen::Vector3d::UnitY();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // a, b, c
  double rms_mm = 0;
  int points = 0;
  bool ok = false;
};

// `hint_u` fixes the in-plane axes (projected), so that b is the rotation
// towards u; the normal is oriented along `hint_n`.
Plane FitPlane(const Eigen::Matrix3Xd& p, const Indices& idx,
               const Eigen::Vector3d& hint_n, const Eigen::Vector3d& hint_u) {
  Plane pl;
  pl.points = static_cast<int>(idx.size());
  if (idx.size() < 3) return pl;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (Index i : idx) c += p.col(i);
  c /= static_cast<double>(idx.size());
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  for (Index i : idx) {
    const Eigen::Vector3d d = p.col(i) - c;
    s.noalias() += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(s);
  Eigen::Vector3d n = es.eigenvectors().col(0);
  if (n.dot(hint_n) < 0) n = -n;
  Eigen::Vector3d u = hint_u - hint_u.dot(n) * n;
  if (u.norm() < 1e-6) u = n.unitOrthogonal();
  u.normalize();
  const Eigen::Vector3d v = n.cross(u);
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  double ss = 0;
  for (Index i : idx) {
    const Eigen::Vector3d d = p.col(i) - c;
    const Eigen::Vector3d a(1.0, d.dot(u), d.dot(v));
    ata.noalias() += a * a.transpose();
    const double r = d.dot(n);
    ss += r * r;
  }
  const int dof = std::max(1, pl.points - 3);
  pl.centroid = c;
  pl.normal = n;
  pl.u = u;
  pl.v = v;
  pl.rms_mm = std::sqrt(ss / pl.points);
  Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
  pl.ok = lu.rank() == 3;
  if (pl.ok) pl.covariance = lu.inverse() * (ss / dof);
  return pl;
}

// Fits, then drops points beyond max(k sigma_robust, floor) and refits until
// the set is stable. `idx` becomes the inliers.
Plane FitPlaneRobust(const Eigen::Matrix3Xd& p, Indices* idx,
                     const Eigen::Vector3d& hint_n,
                     const Eigen::Vector3d& hint_u, double k_sigma,
                     double floor_mm, int* rejected) {
  Plane pl = FitPlane(p, *idx, hint_n, hint_u);
  const Indices all = *idx;
  for (int round = 0; round < 8 && pl.points >= 3; ++round) {
    std::vector<double> res;
    res.reserve(all.size());
    for (Index i : all)
      res.push_back(std::abs((p.col(i) - pl.centroid).dot(pl.normal)));
    // The robust sigma from at most 20,000 of the residuals.
    const size_t step = std::max<size_t>(1, res.size() / 20000);
    std::vector<double> some;
    some.reserve(res.size() / step + 1);
    for (size_t j = 0; j < res.size(); j += step) some.push_back(res[j]);
    const double sigma = 1.4826 * Median(std::move(some));
    const double limit = std::max(k_sigma * sigma, floor_mm);
    Indices keep;
    keep.reserve(all.size());
    for (size_t j = 0; j < all.size(); ++j) {
      if (res[j] <= limit) keep.push_back(all[j]);
    }
    const bool same = keep == *idx;
    *idx = std::move(keep);
    if (same && round > 0) break;
    pl = FitPlane(p, *idx, hint_n, hint_u);
  }
  if (rejected) *rejected = static_cast<int>(all.size() - idx->size());
  return pl;
}

// Orthogonal 2D circle fit: Kasa start, then Gauss-Newton on the true
// distances. Returns centre, radius and rms; covariance of (cx, cy, r).
struct Circle {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0, rms = 0;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int points = 0;
  bool ok = false;
};

Circle FitCircle(const std::vector<Eigen::Vector2d>& q) {
  Circle c;
  c.points = static_cast<int>(q.size());
  if (q.size() < 3) return c;
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (const auto& x : q) m += x;
  m /= static_cast<double>(q.size());
  // Kasa: x^2 + y^2 + D x + E y + F = 0 on centred data.
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (const auto& x : q) {
    const Eigen::Vector2d d = x - m;
    const Eigen::Vector3d a(d.x(), d.y(), 1.0);
    ata.noalias() += a * a.transpose();
    atb += a * (-d.squaredNorm());
  }
  Eigen::FullPivLU<Eigen::Matrix3d> lu(ata);
  if (lu.rank() < 3) return c;
  const Eigen::Vector3d s = lu.solve(atb);
  Eigen::Vector2d ctr(-s(0) / 2, -s(1) / 2);
  double r = std::sqrt(std::max(0.0, ctr.squaredNorm() - s(2)));
  double ss = 0;
  Eigen::Matrix3d jtj;
  for (int it = 0; it < 20; ++it) {
    jtj.setZero();
    Eigen::Vector3d jtr = Eigen::Vector3d::Zero();
    ss = 0;
    for (const auto& x : q) {
      const Eigen::Vector2d d = x - m - ctr;
      const double dist = d.norm();
      if (dist == 0) continue;
      const double res = dist - r;
      const Eigen::Vector3d j(-d.x() / dist, -d.y() / dist, -1.0);
      jtj.noalias() += j * j.transpose();
      jtr += j * res;
      ss += res * res;
    }
    const Eigen::Vector3d step = jtj.ldlt().solve(-jtr);
    ctr += step.head<2>();
    r += step(2);
    if (step.norm() < 1e-12) break;
  }
  c.centre = ctr + m;
  c.radius = r;
  c.rms = std::sqrt(ss / q.size());
  c.covariance = jtj.inverse() * (ss / std::max(1, c.points - 3));
  c.ok = std::isfinite(r) && r > 0;
  return c;
}

// Robust circle: refit on points within shrinking bands of the radius.
Circle FitCircleRobust(const std::vector<Eigen::Vector2d>& q, double k_sigma,
                       double floor_mm) {
  Circle c = FitCircle(q);
  std::vector<Eigen::Vector2d> keep = q;
  for (double band : {5.0, 1.0, 0.3}) {
    if (!c.ok) return c;
    std::vector<Eigen::Vector2d> next;
    for (const auto& x : q) {
      if (std::abs((x - c.centre).norm() - c.radius) < band) next.push_back(x);
    }
    keep = next;
    c = FitCircle(keep);
  }
  for (int round = 0; round < 6 && c.ok; ++round) {
    std::vector<double> res;
    for (const auto& x : keep)
      res.push_back(std::abs((x - c.centre).norm() - c.radius));
    const double limit = std::max(k_sigma * 1.4826 * Median(res), floor_mm);
    std::vector<Eigen::Vector2d> next;
    for (size_t j = 0; j < keep.size(); ++j) {
      if (res[j] <= limit) next.push_back(keep[j]);
    }
    if (next.size() == keep.size()) break;
    keep = next;
    c = FitCircle(keep);
  }
  return c;
}

struct Frame {  // temporary frame: z along the top normal, origin on top
  Eigen::Matrix3d rot;  // rows e1 e2 n
  Eigen::Vector3d origin;
  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const {
    return rot * (p - origin);
  }
};

[[noreturn]] void NoPiece(const std::string& source, const std::string& why) {
  throw InputError(source, 0, "alignment",
                   "no test piece found in the cloud: " + why);
}

// The top face datum: the end of the axis whose cross-section is a plane.
Plane FindTopFace(const Eigen::Matrix3Xd& p, const InspectOptions& o,
                  const std::string& source, std::vector<std::string>* warnings,
                  Indices* top_idx) {
  // The search runs on an even subsample of at most 100,000 points (a
  // million-point scan holds far more top-face points than the datum
  // needs); the final robust fit uses the sample's top-face points.
  const Indices sub = Subsample(p.cols(), 100000);
  const Index n = static_cast<Index>(sub.size());
  // Robust centre and the disc's axis (smallest PCA axis), ignoring points
  // far from the median (fixture, far strays).
  Eigen::Vector3d med;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> v(n);
    for (Index k = 0; k < n; ++k) v[k] = p(a, sub[k]);
    med(a) = Median(std::move(v));
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d s = Eigen::Matrix3d::Zero();
  Index used = 0;
  for (Index i : sub) {
    const Eigen::Vector3d d = p.col(i) - med;
    if (d.squaredNorm() > 160.0 * 160.0) continue;
    mean += d;
    s.noalias() += d * d.transpose();
    ++used;
  }
  if (used < 100)
    NoPiece(source,
            "fewer than 100 points within 160 mm of the cloud's median");
  mean /= static_cast<double>(used);
  s = s / static_cast<double>(used) - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(s);
  const Eigen::Vector3d axis = es.eigenvectors().col(0);
  const Eigen::Vector3d centre = med + mean;
  std::vector<double> h(n);
  for (Index k = 0; k < n; ++k) h[k] = (p.col(sub[k]) - centre).dot(axis);
  // Try both ends: fit a plane to the points near the end, tightening the
  // band; the top face is the end with a plane of many points.
  Plane best;
  Indices best_idx;
  for (double sign : {+1.0, -1.0}) {
    std::vector<double> hs(n);
    for (Index k = 0; k < n; ++k) hs[k] = sign * h[k];
    const double end = Quantile(hs, 0.995);
    Indices idx;
    for (Index k = 0; k < n; ++k) {
      if (hs[k] > end - 2.0 && hs[k] < end + 2.0) idx.push_back(sub[k]);
    }
    Plane pl = FitPlane(p, idx, sign * axis, axis.unitOrthogonal());
    for (double band : {1.0, 0.3, 0.1, 0.03}) {
      if (!pl.ok) break;
      Indices next;
      for (Index i : sub) {
        if (std::abs((p.col(i) - pl.centroid).dot(pl.normal)) < band)
          next.push_back(i);
      }
      idx = std::move(next);
      pl = FitPlane(p, idx, sign * axis, axis.unitOrthogonal());
    }
    if (pl.ok && pl.points > best.points) {
      best = pl;
      best_idx = idx;
    }
  }
  if (!best.ok || best.points < 20)
    NoPiece(source, "no flat top face at either end of the disc's axis");
  // The bulk of the piece lies below the top face.
  double below = 0;
  for (Index i : sub) below += (p.col(i) - best.centroid).dot(best.normal) < 0;
  if (below < 0.5 * n) {
    warnings->push_back(
        "most points lie above the plane taken as the top face");
  }
  int rejected = 0;
  best = FitPlaneRobust(p, &best_idx, best.normal, best.u, o.stray_sigma,
                        o.stray_floor_mm, &rejected);
  *top_idx = best_idx;
  return best;
}

}  // namespace

void ComputeResultFigures(const PartSpec& part, InspectionResult* result) {
  InspectionResult& out = *result;
  const double d_facet = part.facet_final_distance_mm;
  out.figures = ComputeFigures(part, out.features);
  out.extras.clear();
  for (const CycleFigures& cf : out.figures) {
    CycleExtras ex;
    ex.cycle = cf.cycle;
    const int j = IndexForCycle(part, cf.cycle);
    double sum = 0, var = 0;
    bool all = true;
    for (Segment s : kSegments) {
      const auto a = out.features.find(FacetId(s, j));
      const auto b = out.features.find(FacetId(s, part.reference_index));
      if (a == out.features.end() || b == out.features.end() ||
          !a->second.present || !b->second.present) {
        all = false;
        break;
      }
      sum += (a->second.angle_rad - b->second.angle_rad) / 4;
      var += (a->second.var_angle_rad2 + b->second.var_angle_rad2) / 16;
    }
    ex.e_c_rad = all ? sum : kNaN;
    ex.u_c_rad = all ? std::sqrt(var) : kNaN;
    ex.delta_t_k = TemperatureChangeK(cf.e_ttp_mm, part.alpha_per_k, d_facet);
    ex.u_delta_t_k = TemperatureChangeK(cf.u_ttp_mm, part.alpha_per_k, d_facet);
    out.extras.push_back(ex);
  }
}

InspectionResult InspectCloud(const PartSpec& part, const PointCloud& cloud,
                              const InspectOptions& o) {
  InspectionResult out;
  out.source = cloud.source;
  out.warnings = cloud.warnings;
  const Eigen::Matrix3Xd& p = cloud.xyz_mm;
  const Index n = p.cols();
  out.points_total = static_cast<int>(n);
  const std::string& source = cloud.source;
  if (n == 0) throw InputError(source, 0, "", "the cloud has no points");
  // Units: the piece is about 203 mm across. Look at the robust extent.
  if (o.check_units) {
    double extent = 0;
    const Indices some = Subsample(n, 100000);
    for (int a = 0; a < 3; ++a) {
      std::vector<double> v(some.size());
      for (size_t k = 0; k < some.size(); ++k) v[k] = p(a, some[k]);
      extent = std::max(extent, Quantile(v, 0.99) - Quantile(v, 0.01));
    }
    const double expected = part.blank_diameter_mm;
    if (extent < expected / 200 && extent > expected / 5000) {
      throw InputError(source, 0, "units",
                       "the cloud is " + std::to_string(extent) +
                           " units across where the piece is " +
                           std::to_string(expected) +
                           " mm: it looks like metres; pass --units m");
    }
    if (extent > expected / 40 && extent < expected / 10) {
      throw InputError(source, 0, "units",
                       "the cloud is " + std::to_string(extent) +
                           " units across where the piece is " +
                           std::to_string(expected) +
                           " mm: it looks like inches; pass --units in");
    }
    if (extent < expected / 3 || extent > expected * 5) {
      NoPiece(source, "the cloud is " + std::to_string(extent) +
                          " mm across, the piece " + std::to_string(expected) +
                          " mm");
    }
  }

  // 1. Top face -> Z and z = 0.
  Indices top_idx;
  const Plane top = FindTopFace(p, o, source, &out.warnings, &top_idx);
  out.alignment.top_points = top.points;
  out.alignment.top_rms_mm = top.rms_mm;
  Frame f;
  {
    const Eigen::Vector3d z = top.normal;
    const Eigen::Vector3d x = z.unitOrthogonal();
    f.rot.row(0) = x.transpose();
    f.rot.row(1) = z.cross(x).transpose();
    f.rot.row(2) = z.transpose();
    f.origin = top.centroid;
  }
  Eigen::Matrix3Xd q(3, n);
  AdviseHugePages(q.data(), sizeof(double) * 3 * n);
  for (Index i = 0; i < n; ++i) q.col(i) = f.Apply(p.col(i));

  // 2. Approximate centre from the outermost surfaces under the segments
  // (reference cylinders), else from the facets.
  const double r_cyl = part.ref_cylinders.front().diameter_mm / 2;
  // (A rough centre: an even subsample of at most 200,000 points will do.)
  const Indices rough_sample = Subsample(n, 200000);
  auto ring = [&](double z_lo, double z_hi) {
    std::vector<Eigen::Vector2d> pts;
    for (Index i : rough_sample) {
      if (q(2, i) > z_lo && q(2, i) < z_hi) pts.emplace_back(q(0, i), q(1, i));
    }
    return pts;
  };
  Circle rough;
  {
    auto pts = ring(-part.height_mm() + 0.3, part.big_notch_floor_z_mm - 0.3);
    // Keep the outer points: interior floors would pull a first fit.
    if (pts.size() >= 20) {
      Circle c0 = FitCircle(pts);
      if (c0.ok) {
        std::vector<Eigen::Vector2d> outer;
        for (const auto& x : pts) {
          if ((x - c0.centre).norm() > 0.8 * r_cyl) outer.push_back(x);
        }
        rough = FitCircleRobust(outer, o.stray_sigma, 0.05);
      }
    }
    if (!rough.ok || rough.points < 20 || std::abs(rough.radius - r_cyl) > 3) {
      auto facet_pts = ring(part.facet_bottom_z_mm + 0.5, -0.5);
      Circle c0 = FitCircle(facet_pts);
      std::vector<Eigen::Vector2d> outer;
      if (c0.ok) {
        for (const auto& x : facet_pts) {
          if ((x - c0.centre).norm() > 0.9 * part.facet_final_distance_mm)
            outer.push_back(x);
        }
      }
      rough = FitCircleRobust(outer, o.stray_sigma, 0.2);
      if (!rough.ok || rough.points < 20 ||
          std::abs(rough.radius - part.facet_final_distance_mm) > 3) {
        NoPiece(source,
                "neither the reference cylinders nor the facets form a circle "
                "of the piece's size");
      }
      out.warnings.push_back(
          "reference cylinders not found; rough centre from the facets");
    }
  }

  // 3. Flanks -> X direction (their symmetry plane).
  const double half_notch = part.big_notch_half_width_mm;
  Indices wall;
  std::vector<Eigen::Vector2d> wall2;
  for (Index i = 0; i < n; ++i) {
    if (q(2, i) < part.big_notch_floor_z_mm + 1.0 || q(2, i) > -1.0) continue;
    const Eigen::Vector2d d(q(0, i) - rough.centre.x(),
                            q(1, i) - rough.centre.y());
    const double r = d.norm();
    if (r < half_notch - 2 || r > part.facet_final_distance_mm - 2) continue;
    wall.push_back(i);
    wall2.push_back(d);
  }
  if (wall.size() < 20)
    NoPiece(source, "the big-notch flanks (datum for X) are missing");
  Eigen::Vector2d flank_normal;
  {
    // The direction across the notch: the one for which most wall points
    // sit 53 mm either side of the rough centre (a 1-D Hough search over
    // 0.25 deg steps on at most 4000 of the points, then the best of its
    // neighbours within 0.05 deg).
    const size_t step = std::max<size_t>(1, wall2.size() / 4000);
    auto count_at = [&](double theta) {
      const Eigen::Vector2d e(std::cos(theta), std::sin(theta));
      int count = 0;
      for (size_t j = 0; j < wall2.size(); j += step)
        count += std::abs(std::abs(wall2[j].dot(e)) - half_notch) < 0.5;
      return count;
    };
    int best_count = -1;
    double best_theta = 0;
    for (int k = 0; k < 720; ++k) {
      const double theta = k * 0.25 * kDeg;
      const int c = count_at(theta);
      if (c > best_count) {
        best_count = c;
        best_theta = theta;
      }
    }
    for (int k = -5; k <= 5; ++k) {
      const double theta = best_theta + k * 0.05 * kDeg;
      const int c = count_at(theta);
      if (c > best_count) {
        best_count = c;
        best_theta = theta;
      }
    }
    flank_normal = Eigen::Vector2d(std::cos(best_theta), std::sin(best_theta));
    if (best_count * static_cast<int>(step) < 20)
      NoPiece(source, "no pair of parallel flanks 2 x 53 mm apart");
  }
  Eigen::Vector3d y_dir;
  {
    Eigen::Vector3d fn[2];
    for (int side = 0; side < 2; ++side) {
      const double sign = side == 0 ? 1.0 : -1.0;
      const Eigen::Vector3d hint(sign * flank_normal.x(),
                                 sign * flank_normal.y(), 0);
      // The PCA direction is only rough (uneven coverage along the flanks
      // tilts it): take a wide band, fit, then narrow the band around the
      // fitted plane and refit.
      Indices idx;
      for (size_t j = 0; j < wall.size(); ++j) {
        if (std::abs(wall2[j].dot(flank_normal) - sign * half_notch) < 1.0)
          idx.push_back(wall[j]);
      }
      int rej = 0;
      Plane pl = FitPlaneRobust(q, &idx, hint, Eigen::Vector3d::UnitZ(),
                                o.stray_sigma, 0.05, &rej);
      for (double band : {0.5, 0.1}) {
        if (!pl.ok) break;
        idx.clear();
        for (Index i : wall) {
          if (std::abs((q.col(i) - pl.centroid).dot(pl.normal)) < band)
            idx.push_back(i);
        }
        pl = FitPlaneRobust(q, &idx, pl.normal, Eigen::Vector3d::UnitZ(),
                            o.stray_sigma, o.stray_floor_mm, &rej);
      }
      if (!pl.ok || pl.points < o.min_points)
        NoPiece(source, "a big-notch flank has too few points");
      out.alignment.flank_points[side] = pl.points;
      fn[side] = pl.normal;  // outward from the notch centre
    }
    y_dir = fn[0] - fn[1];
    y_dir.z() = 0;  // in the top face plane
    y_dir.normalize();
  }
  Eigen::Vector3d x_dir = y_dir.cross(Eigen::Vector3d::UnitZ());
  // Frame rotation (temporary frame -> W up to the 180 deg flip).
  Eigen::Matrix3d rz;
  rz.row(0) = x_dir.transpose();
  rz.row(1) = y_dir.transpose();
  rz.row(2) = Eigen::Vector3d::UnitZ().transpose();

  // 4. Origin: least-squares circle of the 199 cylinder between z -16..-14.
  Eigen::Vector2d origin2 = rough.centre;
  Eigen::Matrix2d origin_cov = Eigen::Matrix2d::Zero();  // mm^2, q frame
  {
    std::vector<Eigen::Vector2d> pts;
    for (Index i = 0; i < n; ++i) {
      if (q(2, i) < part.datum_circle_z_min_mm + 0.1 ||
          q(2, i) > part.datum_circle_z_max_mm - 0.1)
        continue;
      const Eigen::Vector2d d(q(0, i), q(1, i));
      if (std::abs((d - rough.centre).norm() - r_cyl) < 0.5) pts.push_back(d);
    }
    Circle c = FitCircleRobust(pts, o.stray_sigma, o.stray_floor_mm);
    if (c.ok && c.points >= o.min_points && std::abs(c.radius - r_cyl) < 0.5) {
      origin2 = c.centre;
      origin_cov = c.covariance.topLeftCorner<2, 2>();
      out.alignment.circle_points = c.points;
      out.alignment.circle_diameter_mm = 2 * c.radius;
      out.alignment.circle_rms_mm = c.rms;
    } else {
      out.warnings.push_back(
          "datum circle (199 cylinder, z -16..-14) not found: origin from the "
          "rough centre");
    }
  }

  // 5. The mark decides the 180 deg ambiguity.
  {
    const double phi = part.mark_phi_deg * kDeg;
    int count[2] = {0, 0};
    for (Index i = 0; i < n; ++i) {
      const double z = q(2, i);
      if (z > -0.02 || z < -part.mark_depth_mm - 0.05) continue;
      const Eigen::Vector3d d =
          rz * Eigen::Vector3d(q(0, i) - origin2.x(), q(1, i) - origin2.y(), 0);
      for (int k = 0; k < 2; ++k) {
        const double a = phi + k * M_PI;
        const double along = d.x() * std::cos(a) + d.y() * std::sin(a);
        const double across = -d.x() * std::sin(a) + d.y() * std::cos(a);
        if (along > part.mark_r_start_mm - 1 &&
            along < part.mark_r_end_mm + 1 &&
            std::abs(across) < part.mark_width_mm) {
          ++count[k];
        }
      }
    }
    out.alignment.mark_points = std::max(count[0], count[1]);
    out.alignment.mark_points_opposite = std::min(count[0], count[1]);
    out.alignment.mark_found =
        std::max(count[0], count[1]) >= 3 && count[0] != count[1];
    if (count[1] > count[0]) {
      rz.row(0) *= -1;
      rz.row(1) *= -1;
    }
    if (!out.alignment.mark_found) {
      out.warnings.push_back(
          "engraved mark not found: +X (which end is X1) is a guess");
    }
  }
  out.alignment.rotation = rz * f.rot;
  const Eigen::Vector3d origin_q(origin2.x(), origin2.y(), 0.0);
  out.alignment.translation = -rz * (f.rot * f.origin + origin_q);
  const Eigen::Matrix2d rz2 = rz.topLeftCorner<2, 2>();
  const Eigen::Matrix2d origin_cov_w = rz2 * origin_cov * rz2.transpose();

  // 6. Segmentation in W.
  // W = rotation p + translation = rz (q - origin): transform q in place (no
  // second copy of a million-point cloud).
  Eigen::Matrix3Xd& w = q;
  for (Index i = 0; i < n; ++i) {
    const Eigen::Vector3d d = q.col(i) - origin_q;
    w.col(i).noalias() = rz * d;
  }
  const int facets = part.facets_per_segment;
  std::vector<Indices> facet_pts(4 * facets), strip_pts(facets);
  const double d_facet = part.facet_final_distance_mm;
  const double half_facet = d_facet * std::tan(part.facet_step_deg / 2 * kDeg);
  const double fz_lo = part.facet_bottom_z_mm + o.edge_margin_mm;
  const double fz_hi = -o.edge_margin_mm;
  const double strip_half = part.strip_width_mm / 2 - o.edge_margin_mm;
  std::vector<Eigen::Vector2d> facet_dir(4 * facets);
  for (int s = 0; s < 4; ++s) {
    for (int j = 1; j <= facets; ++j) {
      const double a = FacetPhiDeg(part, kSegments[s], j) * kDeg;
      facet_dir[s * facets + j - 1] = Eigen::Vector2d(std::cos(a), std::sin(a));
    }
  }
  const double facet_r2_min = std::pow(d_facet - o.capture_band_mm, 2);
  const double facet_r2_max =
      std::pow(d_facet + o.capture_band_mm, 2) + half_facet * half_facet;
  for (Index i = 0; i < n; ++i) {
    const double x = w(0, i), y = w(1, i), z = w(2, i);
    if (z > fz_lo && z < fz_hi) {
      // Only points near the facets' radius can be on one.
      const double r2 = x * x + y * y;
      if (r2 < facet_r2_min || r2 > facet_r2_max) continue;
      double phi = std::atan2(y, x) / kDeg;
      for (int s = 0; s < 4; ++s) {
        double rel = phi - part.segment_centre_deg[s];
        rel = std::remainder(rel, 360.0);
        const int j = static_cast<int>(std::lround(rel / part.facet_step_deg)) +
                      part.reference_index;
        if (j < 1 || j > facets) continue;
        const Eigen::Vector2d& dir = facet_dir[s * facets + j - 1];
        const double radial = x * dir.x() + y * dir.y();
        const double tang = -x * dir.y() + y * dir.x();
        if (std::abs(radial - d_facet) < o.capture_band_mm &&
            std::abs(tang) < half_facet - o.facet_edge_margin_mm) {
          facet_pts[s * facets + j - 1].push_back(i);
        }
      }
    } else if (std::abs(z - part.strip_floor_z_mm) < o.capture_band_mm) {
      const int k = static_cast<int>(std::lround(y / part.strip_pitch_mm)) +
                    part.reference_index;
      if (k < 1 || k > facets) continue;
      if (std::abs(y - StripY(part, k)) > strip_half) continue;
      const double ye = std::abs(StripY(part, k)) + part.strip_width_mm / 2;
      const double x_end = std::sqrt(std::max(0.0, r_cyl * r_cyl - ye * ye));
      if (std::abs(x) < part.small_notch_half_width_mm + o.edge_margin_mm ||
          std::abs(x) > x_end - o.edge_margin_mm) {
        continue;
      }
      strip_pts[k - 1].push_back(i);
    }
  }

  // 7. Fits and per-feature results.
  auto instrument_u = [&](double length_mm) {
    if (o.instrument == Instrument::kNone) return 0.0;
    return (o.cmm_mpe_um + length_mm / o.cmm_mpe_l_mm) * 1e-3 / std::sqrt(3.0);
  };
  // Angles: only the length-proportional part of the MPE (a scale-like
  // error, 1/b per unit length) tilts a fitted plane; the constant part is
  // probing scatter that the fit already sees in its residuals.
  const double instrument_u_angle =
      o.instrument == Instrument::kNone
          ? 0.0
          : 1e-3 / o.cmm_mpe_l_mm / std::sqrt(3.0);
  auto fit_feature = [&](const std::string& id, Indices idx,
                         const Eigen::Vector3d& n_nom,
                         const Eigen::Vector3d& u_nom, auto&& finish) {
    FeatureDiagnostic diag;
    diag.id = id;
    diag.candidates = static_cast<int>(idx.size());
    FeatureResult r;
    if (static_cast<int>(idx.size()) >= o.min_points) {
      int rej = 0;
      Plane pl = FitPlaneRobust(w, &idx, n_nom, u_nom, o.stray_sigma,
                                o.stray_floor_mm, &rej);
      out.points_rejected += rej;
      if (pl.ok && pl.points >= o.min_points) {
        r.present = true;
        r.points = pl.points;
        r.rms_mm = pl.rms_mm;
        finish(pl, &r);
        out.points_assigned += pl.points;
      }
    }
    diag.used = r.points;
    diag.rms_mm = r.rms_mm;
    diag.status = !r.present                 ? "missing"
                  : r.points < o.thin_points ? "thin"
                                             : "ok";
    if (diag.status != "ok") {
      out.warnings.push_back(id + " is " + diag.status + " (" +
                             std::to_string(diag.candidates) +
                             " points in its region)");
    }
    out.features[id] = r;
    out.diagnostics.push_back(diag);
  };
  std::map<std::string, NominalFeature> nominal;
  for (const NominalFeature& f : TestFeatures(part)) nominal[f.id] = f;
  // d, angle and tilt as every measurement path has them; the variances
  // are this fit's.
  const auto set_shape = [](const FeatureResult& shape, FeatureResult* r) {
    r->d_mm = shape.d_mm;
    r->angle_rad = shape.angle_rad;
    r->tilt_rad = shape.tilt_rad;
  };
  for (int s = 0; s < 4; ++s) {
    for (int j = 1; j <= facets; ++j) {
      const NominalFeature& nom = nominal.at(FacetId(kSegments[s], j));
      const Eigen::Vector3d& n_nom = nom.normal;
      const Eigen::Vector3d u_nom = Eigen::Vector3d::UnitZ().cross(n_nom);
      fit_feature(
          nom.id, facet_pts[s * facets + j - 1], n_nom, u_nom,
          [&](const Plane& pl, FeatureResult* r) {
            set_shape(FeatureResultFromPlane(nom, {pl.centroid, pl.normal}), r);
            const Eigen::Vector3d lever = -pl.centroid;  // origin rel. centroid
            const Eigen::Vector3d g(1.0, lever.dot(pl.u), lever.dot(pl.v));
            // w(origin) = a + b u_o + c v_o, d = -w(origin)
            // The origin's uncertainty moves the plane along its normal
            // (common to all facets; taken independent: conservative).
            const Eigen::Vector2d n2 = pl.normal.head<2>();
            r->var_d_mm2 = g.dot(pl.covariance * g) +
                           n2.dot(origin_cov_w * n2) +
                           std::pow(instrument_u(d_facet), 2);
            r->var_angle_rad2 =
                pl.covariance(1, 1) + std::pow(instrument_u_angle, 2);
          });
    }
  }
  for (int k = 1; k <= facets; ++k) {
    const NominalFeature& nom = nominal.at(StripId(k));
    fit_feature(
        nom.id, strip_pts[k - 1], Eigen::Vector3d::UnitZ(),
        Eigen::Vector3d::UnitX(), [&](const Plane& pl, FeatureResult* r) {
          const Eigen::Vector3d& nn = pl.normal;
          set_shape(FeatureResultFromPlane(nom, {pl.centroid, pl.normal}), r);
          // The depth is taken at (0, y_k, -d).
          const Eigen::Vector3d at(0, nom.point.y(), -r->d_mm);
          const Eigen::Vector3d lever = at - pl.centroid;
          const Eigen::Vector3d g(1.0, lever.dot(pl.u), lever.dot(pl.v));
          r->var_d_mm2 =
              g.dot(pl.covariance * g) / (nn.z() * nn.z()) +
              std::pow(instrument_u(std::abs(part.strip_floor_z_mm)), 2);
          r->var_angle_rad2 =
              pl.covariance(1, 1) + std::pow(instrument_u_angle, 2);
        });
  }

  // 8. Figures, E_C and the temperature change.
  ComputeResultFigures(part, &out);
  int present = 0;
  for (const auto& [id, r] : out.features) present += r.present;
  if (present == 0)
    NoPiece(source,
            "aligned, but no facet or strip has points where the drawing puts "
            "them");
  return out;
}

namespace {
nlohmann::json Num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}
}  // namespace

nlohmann::json InspectionToJson(const InspectionResult& r) {
  nlohmann::json doc = FiguresToJson(r.figures);
  for (size_t i = 0; i < r.extras.size() && i < doc["figures"].size(); ++i) {
    auto& f = doc["figures"][i];
    f["E_C"] = Num(r.extras[i].e_c_rad * 1e6);
    f["U"]["E_C"] = Num(2 * r.extras[i].u_c_rad * 1e6);
    f["delta_T_K"] = Num(r.extras[i].delta_t_k);
    f["U"]["delta_T_K"] = Num(2 * r.extras[i].u_delta_t_k);
  }
  nlohmann::json facets = nlohmann::json::object(),
                 strips = nlohmann::json::object();
  for (const auto& [id, fr] : r.features) {
    FeatureKind kind;
    Segment seg;
    int index;
    if (!ParseFeatureId(id, &kind, &seg, &index)) continue;
    if (kind == FeatureKind::kFacet) {
      facets[id] = {
          {"distance_mm", fr.present ? Num(fr.d_mm) : nlohmann::json(nullptr)},
          {"angle_error_urad",
           fr.present ? Num(fr.angle_rad * 1e6) : nlohmann::json(nullptr)},
          {"tilt_urad",
           fr.present ? Num(fr.tilt_rad * 1e6) : nlohmann::json(nullptr)},
          {"U_distance_um", fr.present ? Num(2e3 * std::sqrt(fr.var_d_mm2))
                                       : nlohmann::json(nullptr)},
          {"U_angle_urad", fr.present ? Num(2e6 * std::sqrt(fr.var_angle_rad2))
                                      : nlohmann::json(nullptr)},
          {"points", fr.points},
          {"rms_um", fr.rms_mm * 1e3}};
    } else {
      strips[id] = {
          {"depth_mm", fr.present ? Num(fr.d_mm) : nlohmann::json(nullptr)},
          {"beta_urad",
           fr.present ? Num(fr.angle_rad * 1e6) : nlohmann::json(nullptr)},
          {"U_depth_um", fr.present ? Num(2e3 * std::sqrt(fr.var_d_mm2))
                                    : nlohmann::json(nullptr)},
          {"U_beta_urad", fr.present ? Num(2e6 * std::sqrt(fr.var_angle_rad2))
                                     : nlohmann::json(nullptr)},
          {"points", fr.points},
          {"rms_um", fr.rms_mm * 1e3}};
    }
  }
  // A result of figures only (read from such a JSON) stays one when read
  // back: no empty feature blocks, and its facet angles as given.
  if (!r.features.empty() || r.facet_angle_rad.empty()) {
    doc["facets"] = facets;
    doc["strips"] = strips;
  }
  if (!r.facet_angle_rad.empty()) {
    nlohmann::json angles = nlohmann::json::object();
    for (const auto& [id, a] : r.facet_angle_rad) angles[id] = a * 1e6;
    doc["facet_angle_err_urad"] = angles;
  }
  const Alignment& a = r.alignment;
  nlohmann::json rot = nlohmann::json::array();
  for (int i = 0; i < 3; ++i)
    rot.push_back({a.rotation(i, 0), a.rotation(i, 1), a.rotation(i, 2)});
  doc["alignment"] = {
      {"rotation", rot},
      {"translation_mm",
       {a.translation.x(), a.translation.y(), a.translation.z()}},
      {"convention", "W = rotation * cloud + translation"},
      {"top_face_points", a.top_points},
      {"top_face_rms_um", a.top_rms_mm * 1e3},
      {"flank_points", {a.flank_points[0], a.flank_points[1]}},
      {"datum_circle_points", a.circle_points},
      {"datum_circle_diameter_mm", a.circle_diameter_mm},
      {"datum_circle_rms_um", a.circle_rms_mm * 1e3},
      {"mark_found", a.mark_found},
      {"mark_points", a.mark_points},
      {"mark_points_opposite", a.mark_points_opposite}};
  nlohmann::json missing = nlohmann::json::array(),
                 thin = nlohmann::json::array();
  for (const auto& d : r.diagnostics) {
    if (d.status == "missing") missing.push_back(d.id);
    if (d.status == "thin") thin.push_back(d.id);
  }
  doc["segmentation"] = {{"points_total", r.points_total},
                         {"points_used", r.points_assigned},
                         {"points_rejected_as_stray", r.points_rejected},
                         {"missing", missing},
                         {"thin", thin}};
  doc["warnings"] = r.warnings;
  doc["source"] = r.source;
  doc["units"] = {{"figures", "um, E_B and E_C in um/m, delta_T_K in K"},
                  {"U", "expanded uncertainty, k = 2"}};
  return doc;
}

std::string InspectionTable(const InspectionResult& r) {
  std::ostringstream s;
  char buf[256];
  auto cell = [](double v, double u) {
    char b[48];
    if (!std::isfinite(v)) return std::string("       missing");
    std::snprintf(b, sizeof b, "%7.2f +-%5.2f", v, u);
    return std::string(b);
  };
  s << "Inspection of " << r.source << ": " << r.points_total << " points, "
    << r.points_assigned << " used, " << r.points_rejected
    << " rejected as stray\n";
  s << "cycle           E_X um          E_Y um          E_Z um        E_B um/m "
       "       E_TTP um        E_C um/m    dT K\n";
  for (size_t i = 0; i < r.figures.size(); ++i) {
    const auto& f = r.figures[i];
    const auto& e = r.extras[i];
    std::snprintf(buf, sizeof buf, "%5d  ", f.cycle);
    s << buf << cell(f.e_x_mm * 1e3, 2e3 * f.u_x_mm) << "  "
      << cell(f.e_y_mm * 1e3, 2e3 * f.u_y_mm) << "  "
      << cell(f.e_z_mm * 1e3, 2e3 * f.u_z_mm) << "  "
      << cell(f.e_b_rad * 1e6, 2e6 * f.u_b_rad) << "  "
      << cell(f.e_ttp_mm * 1e3, 2e3 * f.u_ttp_mm) << "  "
      << cell(e.e_c_rad * 1e6, 2e6 * e.u_c_rad);
    std::snprintf(buf, sizeof buf, "  %6.3f\n", e.delta_t_k);
    s << buf;
  }
  s << "(+- is the expanded uncertainty U, k = 2)\n";
  for (const auto& w : r.warnings) s << "warning: " << w << "\n";
  return s.str();
}

}  // namespace ttp::inspect
