#include "toolpath.h"

#include <algorithm>
#include <cmath>

namespace ttp::cam {
namespace {

void RouteRecursive(const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                    double keep_radius_mm, double route_radius_mm, int depth,
                    std::vector<Eigen::Vector2d>* out) {
  // 16 halvings split any arc far below what a clearance needs.
  if (depth >= 16 || SegmentDistanceFromOrigin(a, b) >= keep_radius_mm) {
    out->push_back(b);
    return;
  }
  const double angle_a = std::atan2(a.y(), a.x());
  const double angle_b = std::atan2(b.y(), b.x());
  // Shorter way round; exactly opposite ends go counter-clockwise.
  double delta = std::remainder(angle_b - angle_a, 2 * M_PI);
  if (std::abs(std::abs(delta) - M_PI) < 1e-12) delta = M_PI;
  const double mid = angle_a + delta / 2;
  Eigen::Vector2d m(route_radius_mm * std::cos(mid),
                    route_radius_mm * std::sin(mid));
  // Exact zeros, so that the text never shows -0.0000.
  for (int i = 0; i < 2; ++i)
    if (std::abs(m[i]) < 1e-9) m[i] = 0.0;
  RouteRecursive(a, m, keep_radius_mm, route_radius_mm, depth + 1, out);
  RouteRecursive(m, b, keep_radius_mm, route_radius_mm, depth + 1, out);
}

}  // namespace

double SegmentDistanceFromOrigin(const Eigen::Vector2d& a,
                                 const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = b - a;
  const double len2 = d.squaredNorm();
  if (len2 == 0) return a.norm();
  const double t = std::clamp(-a.dot(d) / len2, 0.0, 1.0);
  return (a + t * d).norm();
}

std::vector<Eigen::Vector2d> RouteAround(const Eigen::Vector2d& from,
                                         const Eigen::Vector2d& to,
                                         double keep_radius_mm,
                                         double route_radius_mm) {
  std::vector<Eigen::Vector2d> out;
  RouteRecursive(from, to, keep_radius_mm, route_radius_mm, 0, &out);
  return out;
}

Eigen::Vector2d ClimbHeading(const Eigen::Vector2d& material_dir) {
  // M3 turns clockwise seen from +Z: a tooth at the contact point moves
  // against the feed (climb) when the material is on the heading's right,
  // i.e. right(h) = (h.y, -h.x) = material_dir.
  const Eigen::Vector2d m = material_dir.normalized();
  return Eigen::Vector2d(-m.y(), m.x());
}

namespace {
gcode::Axes XYZ(const Eigen::Vector3d& p) {
  gcode::Axes a;
  a.x_mm = p.x();
  a.y_mm = p.y();
  a.z_mm = p.z();
  return a;
}
}  // namespace

void PathWriter::StraightRapid(const Eigen::Vector3d& to) {
  if ((to - position_mm_).norm() < 1e-12) return;  // already there
  out_->push_back(gcode::Rapid{XYZ(to)});
  position_mm_ = to;
}
void PathWriter::Rapid(const Eigen::Vector3d& to) {
  if ((to - position_mm_).norm() < 1e-12) return;
  const bool xy = (to.head<2>() - position_mm_.head<2>()).norm() > 1e-12;
  const bool z = std::abs(to.z() - position_mm_.z()) > 1e-12;
  if (xy && z) {
    if (to.z() > position_mm_.z()) {
      Rapid(Eigen::Vector3d(position_mm_.x(), position_mm_.y(), to.z()));
      Rapid(to);
    } else {
      Rapid(Eigen::Vector3d(to.x(), to.y(), position_mm_.z()));
      Rapid(to);
    }
    return;
  }
  if (xy && position_mm_.z() < clearance_z_mm_ - 1e-9) {
    Feed(to, positioning_feed_mm_min_);
    return;
  }
  StraightRapid(to);
}
void PathWriter::RapidXY(const Eigen::Vector2d& to) {
  Rapid(Eigen::Vector3d(to.x(), to.y(), position_mm_.z()));
}
void PathWriter::RapidZ(double z_mm) {
  Rapid(Eigen::Vector3d(position_mm_.x(), position_mm_.y(), z_mm));
}
void PathWriter::RapidC(double c_deg) {
  const double delta = std::remainder(c_deg - c_deg_, 360.0);
  if (std::abs(delta) < 1e-9) return;
  gcode::Axes a;
  a.c_deg = delta;
  out_->push_back(gcode::Rapid{a, true});
  c_deg_ += delta;
}
void PathWriter::RapidCAbsolute(double c_deg) {
  gcode::Axes a;
  a.c_deg = c_deg;
  out_->push_back(gcode::Rapid{a});
  c_deg_ = c_deg;
}
void PathWriter::ClampC(bool clamp) {
  if (clamp == c_clamped_) return;
  out_->push_back(gcode::TableClamp{clamp});
  c_clamped_ = clamp;
}
void PathWriter::IndexC(double c_deg) {
  if (std::abs(std::remainder(c_deg - c_deg_, 360.0)) > 1e-9) {
    ClampC(false);
    RapidC(c_deg);
  }
  ClampC(true);
}
double PathWriter::c_deg_normalised() const {
  double c = std::fmod(c_deg_, 360.0);
  if (c < 0) c += 360.0;
  if (c >= 360.0 - 5e-4) c = 0;  // what the writer prints as 360.000
  return c;
}
void PathWriter::MachineRapid(const gcode::Axes& to, double origin_z_mm) {
  const Eigen::Vector3d target(
      to.x_mm.value_or(position_mm_.x()), to.y_mm.value_or(position_mm_.y()),
      to.z_mm ? *to.z_mm - origin_z_mm : position_mm_.z());
  if ((target - position_mm_).norm() < 1e-12 && !length_offset_on_) return;
  length_offset_on_ = false;
  out_->push_back(gcode::MachineRapid{to});
  if (to.x_mm) position_mm_.x() = *to.x_mm;
  if (to.y_mm) position_mm_.y() = *to.y_mm;
  if (to.z_mm) position_mm_.z() = *to.z_mm - origin_z_mm;
}
void PathWriter::LengthOffset(int tool, double z_mm) {
  out_->push_back(gcode::LengthOffset{tool, z_mm});
  length_offset_on_ = true;
  position_mm_.z() = z_mm;
}
void PathWriter::Feed(const Eigen::Vector3d& to, double feed_mm_min) {
  out_->push_back(gcode::Feed{XYZ(to), feed_mm_min});
  position_mm_ = to;
}
void PathWriter::FeedXY(const Eigen::Vector2d& to, double feed_mm_min) {
  Feed(Eigen::Vector3d(to.x(), to.y(), position_mm_.z()), feed_mm_min);
}
void PathWriter::FeedZ(double z_mm, double feed_mm_min) {
  Feed(Eigen::Vector3d(position_mm_.x(), position_mm_.y(), z_mm), feed_mm_min);
}
void PathWriter::FeedC(double delta_deg, double feed_deg_min) {
  gcode::Axes a;
  a.c_deg = delta_deg;
  out_->push_back(gcode::Feed{a, feed_deg_min, true});
  c_deg_ += delta_deg;
}
void PathWriter::RapidAround(const Eigen::Vector2d& to, double keep_radius_mm,
                             double route_radius_mm) {
  const Eigen::Vector2d from = position_mm_.head<2>();
  for (const Eigen::Vector2d& p :
       RouteAround(from, to, keep_radius_mm, route_radius_mm)) {
    RapidXY(p);
  }
}

void MillSlot(PathWriter& path, const SlotPass& slot) {
  const int along = slot.along;
  const int cross = 1 - along;
  Eigen::Vector2d cross_dir = Eigen::Vector2d::Zero();
  cross_dir[cross] = 1;
  // Cross positions of the tool centre, lowest first; an even count so
  // that the first and the last pass both climb-mill their wall.
  const double half =
      slot.half_width_mm - slot.tool_radius_mm - slot.allowance_mm;
  std::vector<double> cross_positions;
  if (half <= 1e-9) {
    cross_positions.push_back(0.0);
  } else {
    int n = static_cast<int>(std::ceil(2 * half / slot.stepover_mm - 1e-9)) + 1;
    if (n % 2) ++n;
    for (int i = 0; i < n; ++i)
      cross_positions.push_back(-half + 2 * half * i / (n - 1));
  }
  const double first_sign = ClimbHeading(-cross_dir)[along];
  // Levels from the top face down to floor + allowance.
  const double bottom = slot.floor_z_mm + slot.allowance_mm;
  const double depth = -bottom;
  int levels = 1;
  if (slot.step_down_mm > 0)
    levels = std::max(
        1, static_cast<int>(std::ceil(depth / slot.step_down_mm - 1e-9)));
  const auto point = [&](double u, double v) {
    Eigen::Vector2d p;
    p[cross] = u;
    p[along] = v;
    return p;
  };
  for (int level = 0; level < levels; ++level) {
    const double z = -depth * (level + 1) / levels;
    for (size_t i = 0; i < cross_positions.size(); ++i) {
      const double sign = (i % 2 == 0) ? first_sign : -first_sign;
      const Eigen::Vector2d start =
          point(cross_positions[i], -sign * slot.length_mm);
      const Eigen::Vector2d end =
          point(cross_positions[i], sign * slot.length_mm);
      const Eigen::Vector2d here = path.position().head<2>();
      if (i == 0 && level == 0) {
        path.RapidZ(slot.safe_z_mm);
        path.RapidXY(start);
        path.RapidZ(z);
      } else if (std::abs(here[along] - start[along]) < 1e-9) {
        // Same end of the slot, outside the piece: shift across, go down.
        path.RapidXY(start);
        path.RapidZ(z);
      } else {
        path.RapidZ(slot.safe_z_mm);
        path.RapidXY(start);
        path.RapidZ(z);
      }
      path.FeedXY(end, slot.feed_mm_min);
    }
  }
  path.RapidZ(slot.safe_z_mm);
}

}  // namespace ttp::cam
