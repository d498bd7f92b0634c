#include <fmt/format.h>

#include <map>

#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

// DMIS labels allow letters, digits and '_'.
std::string DmisLabel(const std::string& feature) {
  if (feature == "FLANK+Y") return "FLANK_PY";
  if (feature == "FLANK-Y") return "FLANK_NY";
  std::string s = feature;
  for (char& c : s)
    if (c == '-' || c == '+') c = '_';
  return s;
}

std::string Num(double v) { return fmt::format("{:.6f}", v + 0.0); }

}  // namespace

std::string PointsToDmis(const std::vector<PlannedPoint>& points,
                         const PartSpec& part) {
  // Features in plan order, each with its points.
  std::vector<std::string> order;
  std::map<std::string, std::vector<const PlannedPoint*>> by_feature;
  for (const PlannedPoint& p : points) {
    if (!by_feature.count(p.feature)) order.push_back(p.feature);
    by_feature[p.feature].push_back(&p);
  }
  std::string out;
  out += "DMISMN/'ttp thermal test piece',5.0\n";
  out += "FILNAM/'ttp thermal test piece results',5.0\n";
  out += "UNITS/MM,ANGDEC\n";
  out += "D(MCS)=DATSET/MCS\n";
  out +=
      "$$ Nominals are in the workpiece frame W (test-piece.md section 5):\n"
      "$$ align to W before running (top face = XY, notch flanks = X,\n"
      "$$ 199 circle = origin, engraved mark on +X). ttp realigns from the\n"
      "$$ datum results TOP, FLANK_PY, FLANK_NY, CYL199 when it reads the\n"
      "$$ output, so a rough alignment is enough.\n";
  for (const std::string& feature : order) {
    const auto& pts = by_feature[feature];
    const std::string label = DmisLabel(feature);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const PlannedPoint* p : pts) centre += p->point_w_mm;
    centre /= static_cast<double>(pts.size());
    const bool circle = feature.rfind("CYL", 0) == 0;
    if (circle) {
      const double diameter = part.ref_cylinders.front().diameter_mm;
      out += fmt::format(
          "F({})=FEAT/CIRCLE,OUTER,CART,0.000000,0.000000,{},"
          "0.000000,0.000000,1.000000,{}\n",
          label, Num(centre.z()), Num(diameter));
      out += fmt::format("MEAS/CIRCLE,F({}),{}\n", label, pts.size());
    } else {
      const Eigen::Vector3d& n = pts.front()->normal_w;
      out += fmt::format("F({})=FEAT/PLANE,CART,{},{},{},{},{},{}\n", label,
                         Num(centre.x()), Num(centre.y()), Num(centre.z()),
                         Num(n.x()), Num(n.y()), Num(n.z()));
      out += fmt::format("MEAS/PLANE,F({}),{}\n", label, pts.size());
    }
    for (const PlannedPoint* p : pts) {
      // PTMEAS carries the surface normal (pointing out of the material);
      // the probe approaches against it.
      out += fmt::format("  PTMEAS/CART,{},{},{},{},{},{}\n",
                         Num(p->point_w_mm.x()), Num(p->point_w_mm.y()),
                         Num(p->point_w_mm.z()), Num(p->normal_w.x()),
                         Num(p->normal_w.y()), Num(p->normal_w.z()));
    }
    out += "ENDMES\n";
    out += fmt::format("OUTPUT/FA({})\n", label);
  }
  out += "ENDFIL\n";
  return out;
}

}  // namespace ttp::plan
