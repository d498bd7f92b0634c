#include "ttp/plan/dmis_writer.h"

#include <fmt/format.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"

namespace ttp::plan {
namespace {

std::string Num(double v) { return fmt::format("{:.4f}", v + 0.0); }
std::string Xyz(const Eigen::Vector3d& p) {
  return Num(p.x()) + "," + Num(p.y()) + "," + Num(p.z());
}

// "DmisOptions.<field>: <problem>" -> InputError naming the field.
[[noreturn]] void ThrowInvalid(const std::string& why) {
  const size_t dot = why.find('.'), colon = why.find(": ");
  throw InputError("DmisOptions", 0, why.substr(dot + 1, colon - dot - 1),
                   why.substr(colon + 2));
}

// Spread of points in their second principal direction.
double SecondSpan(const std::vector<const PlannedPoint*>& pts) {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const PlannedPoint* p : pts) c += p->point_w_mm;
  c /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const PlannedPoint* p : pts)
    cov += (p->point_w_mm - c) * (p->point_w_mm - c).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  const Eigen::Vector3d d = es.eigenvectors().col(1);
  double lo = 1e300, hi = -1e300;
  for (const PlannedPoint* p : pts) {
    lo = std::min(lo, d.dot(p->point_w_mm - c));
    hi = std::max(hi, d.dot(p->point_w_mm - c));
  }
  return hi - lo;
}

// Writes the program text, tracking where the ball centre is.
class Writer {
 public:
  Writer(const DmisOptions& o, double circle_diameter_mm)
      : o_(o), r_(o.stylus_diameter_mm / 2), circle_d_(circle_diameter_mm) {}
  std::string& text() { return text_; }

  // DMIS lines hold at most 80 characters: a longer statement goes on with
  // `$` after a comma (outside quotes).
  void Line(const std::string& s) {
    std::string rest = s;
    while (rest.size() > 80) {
      size_t cut = std::string::npos;
      bool quoted = false;
      for (size_t i = 0; i < rest.size() && i < 78; ++i) {
        if (rest[i] == '\'') quoted = !quoted;
        if (!quoted && rest[i] == ',') cut = i;
      }
      if (cut == std::string::npos) break;
      text_ += rest.substr(0, cut + 1) + "$\n";
      rest = "  " + rest.substr(cut + 1);
    }
    text_ += rest + "\n";
  }
  // An operator message in statements that fit a line.
  void Text(const std::string& message) {
    std::istringstream words(message);
    std::string chunk;
    for (std::string w; words >> w;) {
      if (!chunk.empty() && chunk.size() + 1 + w.size() > 60) {
        Line("TEXT/OPER,'" + chunk + "'");
        chunk.clear();
      }
      chunk += (chunk.empty() ? "" : " ") + w;
    }
    if (!chunk.empty()) Line("TEXT/OPER,'" + chunk + "'");
  }

  // One feature: nominal, MEAS block with its points, OUTPUT (unless the
  // output waits for the part frame). Manual blocks carry no moves.
  void Feature(const std::string& label, const FeatureId& id,
               const std::vector<const PlannedPoint*>& pts, bool manual,
               bool output) {
    const bool circle = id.kind == FeatureKind::kCylinder;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const PlannedPoint* p : pts) centre += p->point_w_mm;
    centre /= static_cast<double>(pts.size());
    if (circle) {
      Line(
          fmt::format("F({})=FEAT/CIRCLE,OUTER,CART,0.0000,0.0000,{},0.0000,"
                      "0.0000,1.0000,{}",
                      label, Num(centre.z()), Num(circle_d_)));
    } else {
      Line(fmt::format("F({})=FEAT/PLANE,CART,{},{}", label, Xyz(centre),
                       Xyz(pts.front()->normal_w)));
    }
    const Eigen::Vector3d first = Approach(*pts.front());
    if (!manual)
      Line(fmt::format("GOTO/{},{},{}", Num(first.x()), Num(first.y()),
                       Num(o_.clearance_height_mm)));
    Line(fmt::format("MEAS/{},F({}),{}", circle ? "CIRCLE" : "PLANE", label,
                     pts.size()));
    if (!manual) Line("  GOTO/" + Xyz(first));
    for (size_t k = 0; k < pts.size(); ++k) {
      const PlannedPoint& p = *pts[k];
      if (!manual && circle && k > 0) ArcTo(*pts[k - 1], p);
      Line(fmt::format("  PTMEAS/CART,{},{}", Xyz(p.point_w_mm),
                       Xyz(p.normal_w)));
    }
    if (!manual) {
      const Eigen::Vector3d last = Retract(*pts.back());
      Line(fmt::format("  GOTO/{},{},{}", Num(last.x()), Num(last.y()),
                       Num(o_.clearance_height_mm)));
    }
    Line("ENDMES");
    if (output) Line(fmt::format("OUTPUT/FA({})", label));
  }

  // A point feature on the top face, approached from above.
  void Point(const std::string& label, const PlannedPoint& p) {
    const Eigen::Vector3d a = Approach(p);
    Line(fmt::format("F({})=FEAT/POINT,CART,{},{}", label, Xyz(p.point_w_mm),
                     Xyz(p.normal_w)));
    Line(fmt::format("GOTO/{},{},{}", Num(a.x()), Num(a.y()),
                     Num(o_.clearance_height_mm)));
    Line(fmt::format("MEAS/POINT,F({}),1", label));
    Line("  GOTO/" + Xyz(a));
    Line(
        fmt::format("  PTMEAS/CART,{},{}", Xyz(p.point_w_mm), Xyz(p.normal_w)));
    Line(fmt::format("  GOTO/{},{},{}", Num(a.x()), Num(a.y()),
                     Num(o_.clearance_height_mm)));
    Line("ENDMES");
    Line(fmt::format("OUTPUT/FA({})", label));
  }

 private:
  Eigen::Vector3d Approach(const PlannedPoint& p) const {
    return p.point_w_mm + p.normal_w * (r_ + o_.approach_mm);
  }
  Eigen::Vector3d Retract(const PlannedPoint& p) const {
    return p.point_w_mm + p.normal_w * (r_ + o_.retract_mm);
  }
  // Around a cylinder: from the retract point of a to the approach point
  // of b along the approach circle, in steps of at most 10 deg (the chord
  // then stays within 0.4 % of the radius of the circle).
  void ArcTo(const PlannedPoint& a, const PlannedPoint& b) {
    const Eigen::Vector3d from = Retract(a), to = Approach(b);
    const double r0 = std::hypot(from.x(), from.y());
    const double r1 = std::hypot(to.x(), to.y());
    const double a0 = std::atan2(from.y(), from.x());
    double da = std::remainder(std::atan2(to.y(), to.x()) - a0, 2 * kPi);
    const int steps = std::max(
        1, static_cast<int>(std::ceil(std::abs(da) / (10 * kPi / 180))));
    for (int s = 1; s < steps; ++s) {
      const double t = static_cast<double>(s) / steps;
      const double ang = a0 + da * t, rad = r0 + (r1 - r0) * t;
      Line(fmt::format("  GOTO/{},{},{}", Num(rad * std::cos(ang)),
                       Num(rad * std::sin(ang)),
                       Num(from.z() + (to.z() - from.z()) * t)));
    }
  }

  const DmisOptions& o_;
  double r_;
  double circle_d_;
  std::string text_;
};

}  // namespace

bool DmisOptions::IsValid(std::string* error) const {
  const auto bad = [&](const char* field, const std::string& why) {
    if (error) *error = std::string("DmisOptions.") + field + ": " + why;
    return false;
  };
  if (!(stylus_diameter_mm >= 0.3 && stylus_diameter_mm <= 10))
    return bad("stylus_diameter_mm", "must be in [0.3, 10] mm");
  if (!(stylus_length_mm >= 10 && stylus_length_mm <= 500))
    return bad("stylus_length_mm", "must be in [10, 500] mm");
  if (!(approach_mm >= 0.5 && approach_mm <= 20))
    return bad("approach_mm", "must be in [0.5, 20] mm");
  if (!(retract_mm >= 0.5 && retract_mm <= 20))
    return bad("retract_mm", "must be in [0.5, 20] mm");
  if (!(search_mm >= 0.1 && search_mm <= 20))
    return bad("search_mm", "must be in [0.1, 20] mm");
  if (!(clearance_height_mm >= 5 && clearance_height_mm <= 500))
    return bad("clearance_height_mm", "must be in [5, 500] mm");
  if (!(positioning_speed_mm_s > 0 && positioning_speed_mm_s <= 1000))
    return bad("positioning_speed_mm_s", "must be in (0, 1000] mm/s");
  if (!(measuring_speed_mm_s > 0 && measuring_speed_mm_s <= 50))
    return bad("measuring_speed_mm_s", "must be in (0, 50] mm/s");
  if (results_file.empty() ||
      results_file.find_first_of("'\n\r") != std::string::npos)
    return bad("results_file", "must be a file name without quotes");
  return true;
}

std::vector<PlannedPoint> CmmPoints(const PartSpec& part,
                                    const PlanOptions& options,
                                    const DmisOptions& dmis) {
  std::string why;
  if (!dmis.IsValid(&why)) ThrowInvalid(why);
  std::vector<PlannedPoint> points = PlanPoints(part, options);
  // The datum circle: the ball (radius r) touching the cylinder at height
  // z clears the step of the next cylinder below (s proud, at z_b) when
  // (r - s)^2 + (z - z_b)^2 >= r^2.
  const double r = dmis.stylus_diameter_mm / 2;
  const RefCylinder& datum = part.ref_cylinders.front();
  double circle_z =
      (part.datum_circle_z_min_mm + part.datum_circle_z_max_mm) / 2;
  for (const RefCylinder& c : part.ref_cylinders) {
    const double step = (c.diameter_mm - datum.diameter_mm) / 2;
    if (c.z_top_mm > datum.z_bottom_mm + 1e-9 || step <= 0) continue;
    const double rise =
        std::sqrt(std::max(0.0, r * r - std::pow(std::max(0.0, r - step), 2)));
    circle_z = std::max(circle_z, c.z_top_mm + rise + 0.1);
  }
  if (circle_z > part.datum_circle_z_max_mm)
    throw InputError("DmisOptions", 0, "stylus_diameter_mm",
                     fmt::format("a {:.3f} mm ball touching the datum "
                                 "cylinder clears the step below it only "
                                 "above z = {:.3f}, over the datum band's "
                                 "top {:.3f}",
                                 dmis.stylus_diameter_mm, circle_z,
                                 part.datum_circle_z_max_mm));
  const FeatureId circle_id = FeatureId::DatumCylinder(part);
  // Flanks: alternately a third and two thirds down the wall; strips:
  // alternately a quarter of the strip width either side of its centre.
  std::map<FeatureId, int> seen;
  for (PlannedPoint& p : points) {
    const int k = seen[p.feature]++;
    if (p.feature == circle_id) p.point_w_mm.z() = circle_z;
    if (p.feature.kind == FeatureKind::kFlank) {
      p.point_w_mm.z() = part.big_notch_floor_z_mm * (k % 2 ? 2.0 : 1.0) / 3;
    } else if (p.feature.kind == FeatureKind::kStrip) {
      const double y = p.point_w_mm.y();
      p.point_w_mm.y() = y + (k % 2 ? 0.25 : -0.25) * part.strip_width_mm;
    }
  }
  for (size_t i = 0; i < points.size(); ++i)
    points[i].id = static_cast<int>(i) + 1;
  return points;
}

std::string WriteDmisProgram(const PartSpec& part,
                             const std::vector<PlannedPoint>& points,
                             const DmisOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) ThrowInvalid(why);
  std::vector<FeatureId> order;
  std::map<FeatureId, std::vector<const PlannedPoint*>> by_feature;
  for (const PlannedPoint& p : points) {
    if (!by_feature.count(p.feature)) order.push_back(p.feature);
    by_feature[p.feature].push_back(&p);
  }
  const FeatureId cyl = FeatureId::DatumCylinder(part);
  const std::vector<FeatureId> datums = {FeatureId::Top(), FeatureId::Flank(+1),
                                         FeatureId::Flank(-1), cyl};
  for (const FeatureId& datum : datums)
    if (!by_feature.count(datum))
      throw InputError("points", 0, datum.ToString(),
                       "the datum is not among the points: the part frame "
                       "cannot be built");
  // Checked in name order: the first bad feature by name is reported.
  std::vector<FeatureId> by_name = order;
  std::sort(by_name.begin(), by_name.end(),
            [](const FeatureId& a, const FeatureId& b) {
              return a.ToString() < b.ToString();
            });
  for (const FeatureId& feature : by_name) {
    const auto& pts = by_feature[feature];
    const bool circle = feature.kind == FeatureKind::kCylinder;
    if (pts.size() < 3 || (!circle && SecondSpan(pts) < 1.0))
      throw InputError("points", 0, feature.ToString(),
                       "its points lie on a line (or are fewer than 3): a "
                       "plane needs points spanning two directions (more "
                       "rows or points: --facet-rows, --strip-points)");
  }

  Writer w(options, part.ref_cylinders.front().diameter_mm);
  const auto& o = options;
  w.Line("$$ CMM program of the thermal test piece (ttp). Units mm, part");
  w.Line("$$ frame W (test-piece.md): origin on the axis of the reference");
  w.Line("$$ cylinders in the top face, +Z out of the top face, +X along the");
  w.Line("$$ big notch towards the segments with the engraved mark (X1).");
  w.Line("DMISMN/'ttp thermal test piece',05.0");
  w.Line("FILNAM/'ttp thermal test piece results',05.0");
  w.Line("UNITS/MM,ANGDEC");
  w.Line("PRCOMP/ON");
  w.Line(fmt::format("DID(RESULTS)=DEVICE/STOR,'{}'", o.results_file));
  w.Line("OPEN/DID(RESULTS),FDATA,DMIS,OUTPUT");
  w.Line("D(MCS)=DATSET/MCS");
  w.Line(
      fmt::format("S(STYLUS)=SNSDEF/PROBE,FIXED,CART,0.0000,0.0000,{},"
                  "0.0000,0.0000,-1.0000,{}",
                  Num(o.stylus_length_mm), Num(o.stylus_diameter_mm)));
  w.Line("SNSLCT/S(STYLUS)");
  w.Line(fmt::format("FEDRAT/POSVEL,MMPS,{}", Num(o.positioning_speed_mm_s)));
  w.Line(fmt::format("FEDRAT/MESVEL,MMPS,{}", Num(o.measuring_speed_mm_s)));
  w.Line(fmt::format("SNSET/APPRCH,{}", Num(o.approach_mm)));
  w.Line(fmt::format("SNSET/RETRCT,{}", Num(o.retract_mm)));
  w.Line(fmt::format("SNSET/SEARCH,{}", Num(o.search_mm)));

  // 1. Preliminary alignment by hand, on the same datums.
  w.Line("$$ 1. Preliminary alignment, by hand.");
  w.Line("MODE/MAN");
  w.Text(
      "Top face up on its adapter, the engraved mark (segment X1) "
      "towards machine +X. Take the points shown: 3 on the top face, 4 "
      "on the -Y flank of the big notch, 4 around the 199 mm cylinder. "
      "Leave the stylus above the piece.");
  const auto& top = by_feature[FeatureId::Top()];
  const size_t per_segment = std::max<size_t>(1, top.size() / 4);
  std::vector<const PlannedPoint*> top_m;
  for (size_t s = 0; s < 3 && s * per_segment < top.size(); ++s)
    top_m.push_back(top[s * per_segment]);
  const auto& flank = by_feature[FeatureId::Flank(-1)];
  std::vector<const PlannedPoint*> flank_m(
      flank.begin(), flank.begin() + std::min<size_t>(flank.size(), 4));
  const auto& circle = by_feature[cyl];
  std::vector<const PlannedPoint*> circle_m;
  for (size_t k = 0; k < 4; ++k)
    circle_m.push_back(circle[k * circle.size() / 4]);
  w.Feature("TOP_M", FeatureId::Top(), top_m, true, false);
  w.Feature("FLANK_M", FeatureId::Flank(-1), flank_m, true, false);
  w.Feature("CYL_M", cyl, circle_m, true, false);
  w.Line("DATDEF/FA(TOP_M),DAT(AM)");
  w.Line("DATDEF/FA(FLANK_M),DAT(BM)");
  w.Line("DATDEF/FA(CYL_M),DAT(CM)");
  w.Line("D(MAN)=DATSET/DAT(AM),ZDIR,ZORIG,DAT(BM),YDIR,DAT(CM),XORIG,YORIG");

  // 2. The datums, automatically, and the part frame W from them.
  w.Line("$$ 2. Datums in automatic mode; the part frame W from them.");
  w.Line("MODE/PROG,MAN");
  for (const FeatureId& d : datums)
    w.Feature(DmisLabel(d), d, by_feature[d], false, false);
  w.Line(
      fmt::format("F(FLANK_MID)=FEAT/PLANE,CART,0.0000,0.0000,{},0.0000,"
                  "1.0000,0.0000",
                  Num(part.big_notch_floor_z_mm / 2)));
  w.Line("CONST/PLANE,F(FLANK_MID),MIDPL,FA(FLANK_NY),FA(FLANK_PY)");
  w.Line("DATDEF/FA(TOP),DAT(A)");
  w.Line("DATDEF/FA(FLANK_MID),DAT(B)");
  w.Line(fmt::format("DATDEF/FA({}),DAT(C)", DmisLabel(cyl)));
  w.Line("D(W)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),YDIR,DAT(C),XORIG,YORIG");
  for (const FeatureId& d : datums)
    w.Line(fmt::format("OUTPUT/FA({})", DmisLabel(d)));
  // The half-turn: one point in the engraved mark (the ball sinks into the
  // groove) and one at the same place turned by 180 deg, if that lies on a
  // segment's top face; `ttp inspect` compares their heights.
  {
    const double r_mark = (part.mark_r_start_mm + part.mark_r_end_mm) / 2;
    const double phi = part.mark_phi_deg * kPi / 180;
    PlannedPoint mark, opp;
    mark.feature = FeatureId::Datum(FeatureKind::kMark);
    mark.point_w_mm = {r_mark * std::cos(phi), r_mark * std::sin(phi), 0};
    opp.feature = FeatureId::Top();  // the top face, half a turn away
    opp.point_w_mm = {-mark.point_w_mm.x(), -mark.point_w_mm.y(), 0};
    const auto on_top = [&](const Eigen::Vector3d& p) {
      const double ang = std::atan2(p.y(), p.x()) * 180 / kPi;
      bool on_segment = false;
      for (double c : part.segment_centre_deg)
        on_segment = on_segment || std::abs(std::remainder(ang - c, 360.0)) <
                                       part.segment_span_deg / 2 - 2;
      return on_segment &&
             std::abs(p.y()) >
                 part.big_notch_half_width_mm + 2 * o.stylus_diameter_mm &&
             p.head<2>().norm() <
                 part.facet_final_distance_mm - 2 * o.stylus_diameter_mm;
    };
    if (on_top(mark.point_w_mm) && on_top(opp.point_w_mm)) {
      w.Point("MARK", mark);
      w.Point("MARK_OPP", opp);
    }
  }

  // 3. Strips, then the facets segment by segment.
  w.Line("$$ 3. Strips and facets in W.");
  std::vector<FeatureId> rest;
  for (const FeatureId& f : order)
    if (std::find(datums.begin(), datums.end(), f) == datums.end())
      rest.push_back(f);
  // Strips first, then by name: X1-1 .. X1-9, X2-1 .., Y1-1 .., Y2-1 ..
  std::stable_sort(rest.begin(), rest.end(),
                   [](const FeatureId& a, const FeatureId& b) {
                     const bool sa = a.kind == FeatureKind::kStrip,
                                sb = b.kind == FeatureKind::kStrip;
                     if (sa != sb) return sa;
                     return a.ToString() < b.ToString();
                   });
  for (const FeatureId& f : rest)
    w.Feature(DmisLabel(f), f, by_feature[f], false, true);
  w.Line(fmt::format("GOTO/0.0000,0.0000,{}",
                     Num(o.clearance_height_mm + o.stylus_length_mm)));
  w.Line("CLOSE/DID(RESULTS)");
  w.Line("ENDFIL");
  return w.text();
}

std::string PointsToDmis(const std::vector<PlannedPoint>& points,
                         const PartSpec& part) {
  return WriteDmisProgram(part, points, DmisOptions{});
}

}  // namespace ttp::plan
