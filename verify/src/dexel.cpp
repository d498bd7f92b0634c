#include "ttp/verify/dexel.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "ttp/geometry/constants.h"

namespace ttp::verify {
namespace {

using Interval = std::pair<double, double>;
using Vec2 = Eigen::Vector2d;
constexpr double kHuge = 1e12;
// Below this a length or a height difference counts as zero (mm).
constexpr double kTiny = 1e-12;
// Oblique cone sweeps are cut in pieces no taller than this (mm).
constexpr double kConeStepMm = 0.001;
// Combined moves are split where needed by the caller; rotations here are
// exact.

double Cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// s-range of the line o + s u (u unit) inside the disc (c, r).
std::optional<Interval> LineDisc(const Vec2& o, const Vec2& u, const Vec2& c,
                                 double r) {
  if (r <= 0) return std::nullopt;
  const Vec2 f = o - c;
  const double b = f.dot(u);
  const double disc = b * b - (f.squaredNorm() - r * r);
  if (disc < 0) return std::nullopt;
  const double root = std::sqrt(disc);
  return Interval{-b - root, -b + root};
}

// s-range of the line inside lo <= (o + s u) . k + off <= hi.
bool ClipSlab(double value_at_0, double rate, double lo, double hi,
              Interval* range) {
  if (std::abs(rate) < kTiny) {
    return value_at_0 >= lo && value_at_0 <= hi;
  }
  double s0 = (lo - value_at_0) / rate;
  double s1 = (hi - value_at_0) / rate;
  if (s0 > s1) std::swap(s0, s1);
  range->first = std::max(range->first, s0);
  range->second = std::min(range->second, s1);
  return range->first <= range->second;
}

// s-range of the line inside the rectangle swept by a disc of radius r from
// a to b (without the end discs).
std::optional<Interval> LineRect(const Vec2& o, const Vec2& u, const Vec2& a,
                                 const Vec2& b, double r) {
  const Vec2 w = b - a;
  const double len = w.norm();
  if (len < kTiny || r <= 0) return std::nullopt;
  const Vec2 e = w / len;
  const Vec2 n(-e.y(), e.x());
  Interval range{-kHuge, kHuge};
  const Vec2 f = o - a;
  if (!ClipSlab(f.dot(e), u.dot(e), 0, len, &range)) return std::nullopt;
  if (!ClipSlab(f.dot(n), u.dot(n), -r, r, &range)) return std::nullopt;
  return range;
}

// The stadium (disc of radius r swept from a to b) is convex: one interval.
std::optional<Interval> LineStadium(const Vec2& o, const Vec2& u, const Vec2& a,
                                    const Vec2& b, double r) {
  std::optional<Interval> out;
  for (const auto& part :
       {LineDisc(o, u, a, r), LineDisc(o, u, b, r), LineRect(o, u, a, b, r)}) {
    if (!part) continue;
    if (!out) {
      out = part;
    } else {
      out->first = std::min(out->first, part->first);
      out->second = std::max(out->second, part->second);
    }
  }
  return out;
}

bool AngleInArc(double angle, double lo, double span) {
  if (span >= 2 * kPi) return true;
  double d = std::fmod(angle - lo, 2 * kPi);
  if (d < 0) d += 2 * kPi;
  return d <= span;
}

void Push(std::vector<Interval>* out, double a, double b) {
  if (b > a) out->emplace_back(a, b);
}

void StraightVertical(const Sweep& sw, const Ray& ray,
                      std::vector<Interval>* out) {
  const Vec2 q = ray.origin.head<2>();
  const Vec2 a = sw.start_w.head<2>(), b = sw.end_w.head<2>();
  const double za = sw.start_w.z(), zb = sw.end_w.z();
  const ToolShape& tool = sw.tool;
  const Vec2 w = b - a;
  if (tool.tan_half_angle == 0) {
    // t-range where the tool axis passes within the radius of q.
    double ta = 0, tb = 1;
    const Vec2 f = q - a;
    const double ww = w.squaredNorm();
    const double cc = f.squaredNorm() - tool.radius_mm * tool.radius_mm;
    if (ww < kTiny) {
      if (cc > 0) return;
    } else {
      const double bb = f.dot(w);
      const double disc = bb * bb - ww * cc;
      if (disc < 0) return;
      const double root = std::sqrt(disc);
      ta = std::max(0.0, (bb - root) / ww);
      tb = std::min(1.0, (bb + root) / ww);
      if (ta > tb) return;
    }
    const double z0 = za + ta * (zb - za), z1 = za + tb * (zb - za);
    Push(out, std::min(z0, z1) - ray.origin.z(),
         std::max(z0, z1) + tool.length_mm - ray.origin.z());
    return;
  }
  // Cone: the caller splits oblique moves, so here z is constant or the
  // move is vertical (xy fixed).
  const double d = SegmentDistance(q, a, b);
  if (d > tool.radius_mm) return;
  Push(out, std::min(za, zb) + tool.HeightFor(d) - ray.origin.z(),
       std::max(za, zb) + tool.length_mm - ray.origin.z());
}

void StraightHorizontal(const Sweep& sw, const Ray& ray,
                        std::vector<Interval>* out) {
  const Vec2 o = ray.origin.head<2>();
  const Vec2 u = ray.direction.head<2>();
  const double z = ray.origin.z();
  const Eigen::Vector3d& pa = sw.start_w;
  const Eigen::Vector3d& pb = sw.end_w;
  const ToolShape& tool = sw.tool;
  const double dz = pb.z() - pa.z();
  std::optional<Interval> hit;
  if (tool.tan_half_angle == 0) {
    double ta = 0, tb = 1;
    if (std::abs(dz) < kTiny) {
      if (z < pa.z() || z > pa.z() + tool.length_mm) return;
    } else {
      double t0 = (z - tool.length_mm - pa.z()) / dz, t1 = (z - pa.z()) / dz;
      if (t0 > t1) std::swap(t0, t1);
      ta = std::max(0.0, t0);
      tb = std::min(1.0, t1);
      if (ta > tb) return;
    }
    const Eigen::Vector3d a = pa + ta * (pb - pa), b = pa + tb * (pb - pa);
    hit = LineStadium(o, u, a.head<2>(), b.head<2>(), tool.radius_mm);
  } else {
    // Cone, z constant or xy fixed: the widest cross-section counts.
    const double z_low = std::min(pa.z(), pb.z());
    const double z_high = std::max(pa.z(), pb.z());
    if (z < z_low || z - z_high > tool.length_mm) return;
    const double r = tool.RadiusAt(std::min(tool.length_mm, z - z_low));
    hit = LineStadium(o, u, pa.head<2>(), pb.head<2>(), r);
  }
  if (hit) Push(out, hit->first, hit->second);
}

void RotationVertical(const Sweep& sw, const Ray& ray,
                      std::vector<Interval>* out) {
  const Vec2 q = ray.origin.head<2>();
  const double lo = std::min(sw.theta_start_rad, sw.theta_end_rad);
  const double span = std::abs(sw.theta_end_rad - sw.theta_start_rad);
  const Vec2 pa = sw.radius_mm * Vec2(std::cos(sw.theta_start_rad),
                                      std::sin(sw.theta_start_rad));
  const Vec2 pb = sw.radius_mm *
                  Vec2(std::cos(sw.theta_end_rad), std::sin(sw.theta_end_rad));
  double d = std::min((q - pa).norm(), (q - pb).norm());
  if (AngleInArc(std::atan2(q.y(), q.x()), lo, span))
    d = std::min(d, std::abs(q.norm() - sw.radius_mm));
  if (d > sw.tool.radius_mm) return;
  Push(out, sw.z_mm + sw.tool.HeightFor(d) - ray.origin.z(),
       sw.z_mm + sw.tool.length_mm - ray.origin.z());
}

void RotationHorizontal(const Sweep& sw, const Ray& ray,
                        std::vector<Interval>* out) {
  const double r = sw.tool.RadiusAt(ray.origin.z() - sw.z_mm);
  if (r <= 0) return;
  const Vec2 o = ray.origin.head<2>();
  const Vec2 u = ray.direction.head<2>();
  const double lo = std::min(sw.theta_start_rad, sw.theta_end_rad);
  const double span = std::abs(sw.theta_end_rad - sw.theta_start_rad);
  for (double theta : {sw.theta_start_rad, sw.theta_end_rad}) {
    const Vec2 c = sw.radius_mm * Vec2(std::cos(theta), std::sin(theta));
    if (auto hit = LineDisc(o, u, c, r)) Push(out, hit->first, hit->second);
  }
  // Annular band between radius - r and radius + r.
  auto outer = LineDisc(o, u, Vec2::Zero(), sw.radius_mm + r);
  if (!outer) return;
  std::vector<Interval> band;
  auto inner = LineDisc(o, u, Vec2::Zero(), sw.radius_mm - r);
  if (inner && inner->first < inner->second) {
    Push(&band, outer->first, std::min(outer->second, inner->first));
    Push(&band, std::max(outer->first, inner->second), outer->second);
  } else {
    band.push_back(*outer);
  }
  if (span >= 2 * kPi) {
    for (const auto& piece : band) out->push_back(piece);
    return;
  }
  // Split where the line crosses the arc's bounding half-lines and keep the
  // pieces whose angle lies in the arc.
  std::vector<double> splits;
  for (double theta : {lo, lo + span}) {
    const Vec2 e(std::cos(theta), std::sin(theta));
    const double rate = Cross(e, u);
    if (std::abs(rate) < kTiny) continue;
    const double s = -Cross(e, o) / rate;
    if ((o + s * u).dot(e) > 0) splits.push_back(s);
  }
  for (const auto& piece : band) {
    std::vector<double> cuts{piece.first};
    for (double s : splits)
      if (s > piece.first && s < piece.second) cuts.push_back(s);
    cuts.push_back(piece.second);
    std::sort(cuts.begin(), cuts.end());
    for (size_t i = 0; i + 1 < cuts.size(); ++i) {
      const Vec2 mid = o + 0.5 * (cuts[i] + cuts[i + 1]) * u;
      if (AngleInArc(std::atan2(mid.y(), mid.x()), lo, span))
        Push(out, cuts[i], cuts[i + 1]);
    }
  }
}

}  // namespace

double SegmentDistance(const Eigen::Vector2d& q, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
  const Vec2 w = b - a;
  const double ww = w.squaredNorm();
  double t = ww < kTiny ? 0.0 : std::clamp((q - a).dot(w) / ww, 0.0, 1.0);
  return (q - a - t * w).norm();
}

double ToolShape::RadiusAt(double h_mm) const {
  if (h_mm < 0 || h_mm > length_mm) return -1;
  if (tan_half_angle == 0) return radius_mm;
  return std::min(radius_mm, h_mm * tan_half_angle);
}

double ToolShape::HeightFor(double d_mm) const {
  if (tan_half_angle == 0) return 0;
  return d_mm / tan_half_angle;
}

double Ray::MaterialLength() const {
  double sum = 0;
  for (const auto& [a, b] : material) sum += b - a;
  return sum;
}

double Ray::Subtract(double a, double b) {
  a = std::max(a, 0.0);
  b = std::min(b, length_mm);
  if (b <= a) return 0;
  double removed = 0;
  std::vector<Interval> kept;
  kept.reserve(material.size() + 1);
  for (const auto& [lo, hi] : material) {
    if (hi <= a || lo >= b) {
      kept.emplace_back(lo, hi);
      continue;
    }
    removed += std::min(hi, b) - std::max(lo, a);
    if (lo < a) kept.emplace_back(lo, a);
    if (hi > b) kept.emplace_back(b, hi);
  }
  material.swap(kept);
  return removed;
}

Sweep Sweep::Straight(const ToolShape& tool, const Eigen::Vector3d& a,
                      const Eigen::Vector3d& b) {
  Sweep s;
  s.kind = Kind::kStraight;
  s.tool = tool;
  s.start_w = a;
  s.end_w = b;
  return s;
}

Sweep Sweep::Rotation(const ToolShape& tool, double radius_mm, double z_mm,
                      double theta_start_rad, double theta_end_rad) {
  Sweep s;
  s.kind = Kind::kRotation;
  s.tool = tool;
  s.radius_mm = radius_mm;
  s.z_mm = z_mm;
  s.theta_start_rad = theta_start_rad;
  s.theta_end_rad = theta_end_rad;
  s.start_w = Eigen::Vector3d(radius_mm * std::cos(theta_start_rad),
                              radius_mm * std::sin(theta_start_rad), z_mm);
  s.end_w = Eigen::Vector3d(radius_mm * std::cos(theta_end_rad),
                            radius_mm * std::sin(theta_end_rad), z_mm);
  return s;
}

void Sweep::Bounds(Eigen::Vector3d* lo, Eigen::Vector3d* hi) const {
  const double r = tool.radius_mm;
  if (kind == Kind::kRotation) {
    const double reach = radius_mm + r;
    *lo = Eigen::Vector3d(-reach, -reach, z_mm);
    *hi = Eigen::Vector3d(reach, reach, z_mm + tool.length_mm);
    return;
  }
  *lo = start_w.cwiseMin(end_w) - Eigen::Vector3d(r, r, 0);
  *hi = start_w.cwiseMax(end_w) + Eigen::Vector3d(r, r, tool.length_mm);
}

std::vector<std::pair<double, double>> SweepIntervals(const Sweep& sweep,
                                                      const Ray& ray) {
  std::vector<Interval> out;
  if (sweep.kind == Sweep::Kind::kRotation) {
    if (ray.vertical())
      RotationVertical(sweep, ray, &out);
    else
      RotationHorizontal(sweep, ray, &out);
    return out;
  }
  const Eigen::Vector3d d = sweep.end_w - sweep.start_w;
  const bool oblique_cone = sweep.tool.tan_half_angle != 0 &&
                            std::abs(d.z()) > kTiny &&
                            d.head<2>().norm() > kTiny;
  const int pieces =
      oblique_cone
          ? std::min(20000,
                     static_cast<int>(std::ceil(std::abs(d.z()) / kConeStepMm)))
          : 1;
  for (int i = 0; i < pieces; ++i) {
    Sweep piece = sweep;
    piece.start_w = sweep.start_w + d * (double(i) / pieces);
    piece.end_w = sweep.start_w + d * (double(i + 1) / pieces);
    if (oblique_cone) {
      // Over-approximates by at most kConeStepMm in depth.
      const double z = std::min(piece.start_w.z(), piece.end_w.z());
      piece.start_w.z() = piece.end_w.z() = z;
    }
    if (ray.vertical())
      StraightVertical(piece, ray, &out);
    else
      StraightHorizontal(piece, ray, &out);
  }
  return out;
}

int DexelModel::AddRay(Ray ray) {
  rays_.push_back(std::move(ray));
  return static_cast<int>(rays_.size()) - 1;
}

void DexelModel::Finalize(double cell_mm) {
  cell_mm_ = cell_mm;
  Vec2 lo(kHuge, kHuge), hi(-kHuge, -kHuge);
  for (const Ray& r : rays_) {
    const Vec2 a = r.origin.head<2>();
    const Vec2 b = a + r.length_mm * r.direction.head<2>();
    lo = lo.cwiseMin(a.cwiseMin(b));
    hi = hi.cwiseMax(a.cwiseMax(b));
  }
  if (rays_.empty()) lo = hi = Vec2::Zero();
  grid_lo_ = lo;
  nx_ = static_cast<int>((hi.x() - lo.x()) / cell_mm_) + 1;
  ny_ = static_cast<int>((hi.y() - lo.y()) / cell_mm_) + 1;
  cells_.assign(static_cast<size_t>(nx_) * ny_, {});
  for (size_t i = 0; i < rays_.size(); ++i) {
    const Ray& r = rays_[i];
    const Vec2 a = r.origin.head<2>();
    const Vec2 b = a + r.length_mm * r.direction.head<2>();
    const Vec2 rlo = a.cwiseMin(b) - grid_lo_, rhi = a.cwiseMax(b) - grid_lo_;
    for (int ix = int(rlo.x() / cell_mm_); ix <= int(rhi.x() / cell_mm_); ++ix)
      for (int iy = int(rlo.y() / cell_mm_); iy <= int(rhi.y() / cell_mm_);
           ++iy)
        cells_[static_cast<size_t>(ix) * ny_ + iy].push_back(int(i));
  }
  stamp_.assign(rays_.size(), 0);
}

double DexelModel::Cut(const Sweep& sweep, int statement,
                       std::vector<int>* touched) {
  Eigen::Vector3d lo, hi;
  sweep.Bounds(&lo, &hi);
  const int ix0 =
      std::max(0, int(std::floor((lo.x() - grid_lo_.x()) / cell_mm_)));
  const int iy0 =
      std::max(0, int(std::floor((lo.y() - grid_lo_.y()) / cell_mm_)));
  const int ix1 =
      std::min(nx_ - 1, int(std::floor((hi.x() - grid_lo_.x()) / cell_mm_)));
  const int iy1 =
      std::min(ny_ - 1, int(std::floor((hi.y() - grid_lo_.y()) / cell_mm_)));
  ++stamp_counter_;
  double worst = 0;
  for (int ix = ix0; ix <= ix1; ++ix) {
    for (int iy = iy0; iy <= iy1; ++iy) {
      for (int index : cells_[static_cast<size_t>(ix) * ny_ + iy]) {
        if (stamp_[index] == stamp_counter_) continue;
        stamp_[index] = stamp_counter_;
        Ray& ray = rays_[index];
        if (ray.material.empty()) continue;
        const double z_top = ray.origin.z() + ray.direction.z() * ray.length_mm;
        if (std::max(ray.origin.z(), z_top) < lo.z() ||
            std::min(ray.origin.z(), z_top) > hi.z())
          continue;
        double removed = 0;
        for (const auto& [a, b] : SweepIntervals(sweep, ray))
          removed += ray.Subtract(a, b);
        if (removed > 0) {
          ray.last_cut_statement = statement;
          worst = std::max(worst, removed);
          if (touched) touched->push_back(index);
        }
      }
    }
  }
  return worst;
}

void DexelModel::SubtractEach(
    const std::function<std::vector<std::pair<double, double>>(const Ray&)>&
        intervals) {
  for (Ray& ray : rays_)
    for (const auto& [a, b] : intervals(ray)) ray.Subtract(a, b);
}

std::vector<std::pair<double, double>> ConvexIntervals(
    const std::vector<std::pair<Eigen::Vector3d, double>>& planes,
    const Ray& ray) {
  Interval range{-kHuge, kHuge};
  for (const auto& [n, d] : planes) {
    if (!ClipSlab(n.dot(ray.origin), n.dot(ray.direction), -kHuge, d, &range))
      return {};
  }
  return {range};
}

std::vector<std::pair<double, double>> OutsideCylinderIntervals(
    double radius_mm, double z0_mm, double z1_mm, const Ray& ray) {
  if (ray.vertical()) {
    if (ray.origin.head<2>().norm() < radius_mm) return {};
    return {{z0_mm - ray.origin.z(), z1_mm - ray.origin.z()}};
  }
  if (ray.origin.z() < z0_mm || ray.origin.z() > z1_mm) return {};
  auto hit = LineDisc(ray.origin.head<2>(), ray.direction.head<2>(),
                      Vec2::Zero(), radius_mm);
  if (!hit) return {{-kHuge, kHuge}};
  return {{-kHuge, hit->first}, {hit->second, kHuge}};
}

std::vector<std::pair<double, double>> InsideCylinderIntervals(double radius_mm,
                                                               double z0_mm,
                                                               double z1_mm,
                                                               const Ray& ray) {
  if (ray.vertical()) {
    if (ray.origin.head<2>().norm() > radius_mm) return {};
    return {{z0_mm - ray.origin.z(), z1_mm - ray.origin.z()}};
  }
  if (ray.origin.z() < z0_mm || ray.origin.z() > z1_mm) return {};
  auto hit = LineDisc(ray.origin.head<2>(), ray.direction.head<2>(),
                      Vec2::Zero(), radius_mm);
  if (!hit) return {};
  return {*hit};
}

}  // namespace ttp::verify
