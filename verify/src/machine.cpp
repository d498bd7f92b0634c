#include "ttp/verify/machine.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ttp/gcode/execution.h"
#include "ttp/geometry/constants.h"
#include "ttp/geometry/frames.h"

namespace ttp::verify {
namespace {

using gcode::CanonKind;
using gcode::CanonStatement;
// Sampling of a move: at most this far in XYZ and this much C.
constexpr double kStepMm = 1.0;
constexpr double kStepRad = 0.5 * kDeg;

double Clamp01(double v) { return std::max(0.0, std::min(1.0, v)); }

// Horizontal distance from q to the rectangle [u0,u1] x [-w/2, w/2] of a
// clamp whose u axis points along phi.
double ClampDistance(const ClampSpec& k, const Eigen::Vector2d& q) {
  const Eigen::Vector2d u(std::cos(k.phi_deg * kDeg),
                          std::sin(k.phi_deg * kDeg));
  const Eigen::Vector2d v(-u.y(), u.x());
  const double a = q.dot(u), b = q.dot(v);
  const double du = std::max({0.0, k.r_inner_mm - a, a - k.r_outer_mm});
  const double dv = std::max(0.0, std::abs(b) - k.width_mm / 2);
  return std::hypot(du, dv);
}

struct Body {
  double r, z0, z1;  // radius and height range above the tip
};

}  // namespace

std::vector<AxisPoint> RapidPath(const AxisPoint& from, const AxisPoint& to,
                                 const MachineProfile& m, bool per_axis) {
  if (!per_axis) return {from, to};
  // Minutes each axis needs at its own rate.
  double d[4], rate[4], t[4];
  for (int a = 0; a < 3; ++a) {
    d[a] = to.p_mm[a] - from.p_mm[a];
    rate[a] = m.rapid_axis_mm_min[a];
  }
  d[3] = (to.c_rad - from.c_rad) / kDeg;
  rate[3] = m.c_index_deg_s * 60.0;
  std::vector<double> times = {0.0};
  for (int a = 0; a < 4; ++a) {
    t[a] = std::abs(d[a]) / rate[a];
    times.push_back(t[a]);
  }
  std::sort(times.begin(), times.end());
  std::vector<AxisPoint> out;
  for (double tt : times) {
    AxisPoint q;
    double v[4];
    for (int a = 0; a < 4; ++a)
      v[a] = t[a] > 0 ? d[a] * Clamp01(tt / t[a]) : 0.0;
    q.p_mm = from.p_mm + Eigen::Vector3d(v[0], v[1], v[2]);
    q.c_rad = from.c_rad + v[3] * kDeg;
    if (out.empty() || (q.p_mm - out.back().p_mm).norm() > 1e-12 ||
        std::abs(q.c_rad - out.back().c_rad) > 1e-15)
      out.push_back(q);
  }
  if (out.size() == 1) out.push_back(to);
  return out;
}

double FixturePenetrationMm(const Config& config, const ToolSpec& tool,
                            const Eigen::Vector3d& tip_w, std::string* which) {
  const MachineProfile& m = config.machine;
  const double origin_z = WorkpieceOriginHeightMm(config);
  const double table_w = m.table_top_z_mm - origin_z;
  const Body bodies[2] = {
      {tool.diameter_mm / 2, 0.0, tool.stick_out_mm},
      {tool.holder_diameter_mm / 2, tool.stick_out_mm, tool.length_mm}};
  const Eigen::Vector2d q = tip_w.head<2>();
  double worst = -1e300;
  const auto take = [&](double pen, const std::string& name) {
    if (pen > worst) {
      worst = pen;
      if (which) *which = name;
    }
  };
  // Sphere and stem.
  const double phi = m.sphere_phi_deg * kDeg;
  const Eigen::Vector3d centre(m.sphere_distance_mm * std::cos(phi),
                               m.sphere_distance_mm * std::sin(phi),
                               table_w + m.sphere_height_mm);
  const double h = (q - centre.head<2>()).norm();
  for (const Body& b : bodies) {
    const double z0 = tip_w.z() + b.z0, z1 = tip_w.z() + b.z1;
    const double v = std::max({0.0, z0 - centre.z(), centre.z() - z1});
    const double dist = std::hypot(std::max(0.0, h - b.r), v);
    take(m.sphere_radius_mm - dist, "R-test sphere");
    if (z0 < centre.z())
      take(b.r + m.sphere_stem_diameter_mm / 2 - h, "R-test sphere stem");
    for (size_t i = 0; i < m.clamps.size(); ++i) {
      const ClampSpec& k = m.clamps[i];
      if (z0 >= table_w + k.height_mm) continue;
      take(b.r - ClampDistance(k, q), fmt::format("clamp {}", i + 1));
    }
  }
  // Table: the tip below its top, over the table.
  if (q.norm() < m.table_diameter_mm / 2 + tool.diameter_mm / 2)
    take(table_w - tip_w.z(), "table");
  return worst;
}

std::vector<Finding> CheckMachine(const std::vector<CanonStatement>& statements,
                                  const Config& config) {
  const MachineProfile& m = config.machine;
  const ProcessSpec& pr = config.process;
  const auto to_w = [&](const AxisPoint& a) {
    return Eigen::Vector3d(
        WorkpieceToMachineRotation(a.c_rad, m.c_sense).transpose() * a.p_mm);
  };
  double worst_fixture = -1e300, worst_ring = -1e300, worst_change = -1e300;
  int fixture_at = -1, ring_at = -1, change_at = -1;
  std::string fixture_what, ring_what;
  // The tool in the spindle during the statement being checked.
  const ToolSpec* tool = nullptr;

  double blank_reach = config.part.blank_diameter_mm / 2;
  double max_holder = 0;
  for (const ToolSpec* t : pr.Tools())
    max_holder = std::max(max_holder, t->holder_diameter_mm / 2);

  const auto check_at = [&](const AxisPoint& a, int i) {
    if (!tool) return;
    std::string what;
    const double pen = FixturePenetrationMm(config, *tool, to_w(a), &what);
    if (pen > worst_fixture) {
      worst_fixture = pen;
      fixture_at = i;
      fixture_what = what;
    }
  };
  const auto check_path = [&](const std::vector<AxisPoint>& path, int i) {
    for (size_t k = 0; k + 1 < path.size(); ++k) {
      const AxisPoint& a = path[k];
      const AxisPoint& b = path[k + 1];
      const int n =
          std::max(1, static_cast<int>(std::max(
                          std::ceil((b.p_mm - a.p_mm).norm() / kStepMm),
                          std::ceil(std::abs(b.c_rad - a.c_rad) / kStepRad))));
      for (int s = 0; s <= n; ++s) {
        const double f = double(s) / n;
        check_at(
            {a.p_mm + f * (b.p_mm - a.p_mm), a.c_rad + f * (b.c_rad - a.c_rad)},
            i);
      }
    }
  };
  const auto check_ring = [&](const AxisPoint& at, int i) {
    if (!tool) return;
    // C turning: the tool sweeps its whole circle about the C axis in W.
    for (int s = 0; s < 720; ++s) {
      AxisPoint a = at;
      a.c_rad = s * 0.5 * kDeg;
      std::string what;
      const double pen = FixturePenetrationMm(config, *tool, to_w(a), &what);
      if (pen > worst_ring) {
        worst_ring = pen;
        ring_at = i;
        ring_what = what;
      }
    }
  };

  // Driven by the executor's state: tool, C turning, positions.
  const auto states = gcode::ExecutionStates(statements);
  for (int i = 0; i < static_cast<int>(statements.size()); ++i) {
    const CanonStatement& st = statements[i];
    const gcode::ExecutionState& before = states[i];
    const gcode::ExecutionState& after = states[i + 1];
    const AxisPoint here{before.position_mm, before.c_rad};
    const AxisPoint next{after.position_mm, after.c_rad};
    tool = pr.ToolByNumber(after.tool);
    switch (st.kind) {
      case CanonKind::kToolChange: {
        // The gauge line where M6 happens must be off the piece.
        const double pen =
            blank_reach + max_holder - here.p_mm.head<2>().norm();
        if (pen > worst_change) {
          worst_change = pen;
          change_at = i;
        }
        break;
      }
      case CanonKind::kCSpin:
        if (after.c_turning_rpm > 0) check_ring(here, i);
        break;
      case CanonKind::kTraverse:
        if (before.c_turning_rpm > 0) check_ring(here, i);
        check_path(RapidPath(here, next, m, false), i);
        check_path(RapidPath(here, next, m, true), i);
        break;
      case CanonKind::kFeed:
      case CanonKind::kProbe:
        check_path({here, next}, i);
        break;
      default:
        break;
    }
    if (after.c_turning_rpm > 0 && st.kind != CanonKind::kCSpin &&
        st.kind != CanonKind::kTraverse)
      check_ring(next, i);
  }

  const auto finding = [&](const char* check, double pen, int at,
                           const std::string& detail) {
    Finding f;
    f.check = check;
    f.measured = std::max(0.0, pen);
    f.limit = 0;
    f.unit = "mm";
    f.pass = pen <= 0;
    f.statement = at;
    f.source_line = at >= 0 ? statements[at].source_line : 0;
    if (!f.pass) f.detail = detail;
    return f;
  };
  return {
      finding("tool and holder clear the fixtures", worst_fixture, fixture_at,
              "tool or holder enters the " + fixture_what +
                  " (rapids checked straight and per axis)"),
      finding("clear of what C sweeps while turning", worst_ring, ring_at,
              "the " + ring_what + " passes through the tool while C turns"),
      finding("tool change away from the piece", worst_change, change_at,
              "tool change with the spindle over the piece")};
}

}  // namespace ttp::verify
