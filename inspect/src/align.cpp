// Stage 1 of the cloud inspection: the workpiece frame W from the datums
// (test-piece.md section 5), in any pose of the cloud:
//   1. the top face (Z and z = 0): the end of the disc's axis that is a
//      plane (the largest plane across the axis there, by RANSAC: the
//      walls that meet it outnumber its points near the edge) no wider
//      than the piece (a wider one is a table or fixture plate: left out);
//   2. a rough centre from the reference cylinders (else the facets);
//   3. the big-notch flanks: their symmetry plane gives X, Y;
//   4. the origin: the centre of the datum circle (the 199 cylinder between
//      z -16 and -14);
//   5. the engraved mark decides the 180 degree ambiguity (which end is
//      X1) and shows a mirror image (a mark where only a mirrored piece has
//      it).
// A datum that is missing (or a top face that is not a plane) is not
// replaced by a guess: the cloud is refused naming it (a rough origin moves
// E_Y by micrometres; a wrong end swaps the segments and reverses the
// cycles; a tilted Z moves every figure).
//
// PCL's RANSAC templates are compiled here from their impl headers (below,
// header-only use): linking libpcl_sample_consensus would cost every ttp
// process ~7 ms of symbol relocation at start-up for two small classes.
#include <fmt/format.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_circle.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <pcl/sample_consensus/impl/ransac.hpp>
#include <pcl/sample_consensus/impl/sac_model_circle.hpp>
#include <pcl/sample_consensus/impl/sac_model_perpendicular_plane.hpp>
#include <pcl/sample_consensus/impl/sac_model_plane.hpp>

#include "cloud_util.h"
#include "quiet_pcl.h"
#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/fit.h"
#include "ttp/inspect/cloud_stages.h"

namespace ttp::inspect {
namespace {

using internal::Index;
using internal::Indices;
using internal::Median;
using internal::Quantile;
using internal::Subsample;

[[noreturn]] void NoPiece(const std::string& source, const std::string& why) {
  throw InputError(source, 0, "alignment",
                   "no test piece found in the cloud: " + why);
}

[[noreturn]] void Refuse(const std::string& source, const std::string& why) {
  throw InputError(source, 0, "alignment", why);
}

bool Usable(const fit::PlaneFit& f) { return f.summary.Usable(); }
bool Usable(const fit::CircleFit2D& f) {
  return f.summary.Usable() && std::isfinite(f.radius_mm) && f.radius_mm > 0;
}

// The plane through the indexed points, normal towards hint_n, tilt axes
// from hint_u; degenerate (not an exception) when they are too few.
fit::PlaneFit PlaneThrough(const Eigen::Matrix3Xd& p, const Indices& idx,
                           const Eigen::Vector3d& hint_n,
                           const Eigen::Vector3d& hint_u) {
  fit::RejectionOptions none;
  none.max_rounds = 0;
  return fit::FitPlaneTrimmed(p, idx, hint_n, hint_u, none).plane;
}

Eigen::Matrix2Xd ToMatrix(const std::vector<Eigen::Vector2d>& pts) {
  Eigen::Matrix2Xd m(2, static_cast<Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) m.col(static_cast<Index>(i)) = pts[i];
  return m;
}

// A plain circle (no rejection) of the points; degenerate when too few.
fit::CircleFit2D CircleThrough(const std::vector<Eigen::Vector2d>& pts) {
  fit::RejectionOptions none;
  none.max_rounds = 0;
  return fit::FitCircle2DTrimmed(ToMatrix(pts), {}, none).circle;
}

// The circle after rejection: shrinking bands of 5, 1 and 0.3 mm about it,
// then strays beyond max(k sigma, floor) (at most 6 rounds).
fit::CircleFit2D CircleTrimmed(const std::vector<Eigen::Vector2d>& pts,
                               double k_sigma, double floor_mm) {
  fit::RejectionOptions ro;
  ro.k_sigma = k_sigma;
  ro.floor_mm = floor_mm;
  ro.max_rounds = 6;
  return fit::FitCircle2DTrimmed(ToMatrix(pts), {5.0, 1.0, 0.3}, ro).circle;
}

fit::RejectionOptions Rejection(const InspectOptions& o, double floor_mm) {
  fit::RejectionOptions ro;
  ro.k_sigma = o.stray_sigma;
  ro.floor_mm = floor_mm;
  ro.max_rounds = 8;
  return ro;
}

// The largest plane among the points idx whose normal lies within
// max_tilt_rad of `axis` (PCL's RANSAC with the perpendicular-plane model:
// points within threshold_mm count), when it holds at least min_share of
// them: the search stops once a plane of that share would have been drawn
// with probability 0.9999. It runs on at most 5,000 of the points (plenty
// to tell the largest plane), moved to their centroid in double before
// PCL's float copy (the cloud's coordinates may be metres from its
// origin). Returns false when no plane was found.
bool LargestPlaneAcross(const Eigen::Matrix3Xd& p, const Indices& idx,
                        const Eigen::Vector3d& axis, double max_tilt_rad,
                        double threshold_mm, double min_share,
                        Eigen::Vector3d* point, Eigen::Vector3d* normal) {
  if (idx.size() < 3) return false;
  const Indices pick = Subsample(static_cast<Index>(idx.size()), 5000);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (Index k : pick) c += p.col(idx[k]);
  c /= static_cast<double>(pick.size());
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(pick.size());
  for (Index k : pick) {
    const Eigen::Vector3f d = (p.col(idx[k]) - c).cast<float>();
    cloud->push_back(pcl::PointXYZ(d.x(), d.y(), d.z()));
  }
  // PCL's fixed seed (random = false): the same cloud gives the same plane.
  auto model = std::make_shared<
      pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>>(cloud);
  model->setAxis(axis.cast<float>());
  model->setEpsAngle(max_tilt_rad);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, threshold_mm);
  constexpr double kProbability = 0.9999;
  ransac.setProbability(kProbability);
  const double w3 = std::pow(std::clamp(min_share, 0.01, 1.0), 3);
  const double draws =
      w3 < 1 ? std::log(1 - kProbability) / std::log1p(-w3) : 1.0;
  ransac.setMaxIterations(static_cast<int>(std::clamp(draws, 100.0, 10000.0)));
  const internal::QuietPcl quiet;
  if (!ransac.computeModel()) return false;
  Eigen::VectorXf coeff;
  ransac.getModelCoefficients(coeff);
  if (coeff.size() != 4 || !coeff.allFinite()) return false;
  const double norm = coeff.head<3>().cast<double>().norm();
  if (!(norm > 0)) return false;
  *normal = coeff.head<3>().cast<double>() / norm;
  *point = c - (static_cast<double>(coeff[3]) / norm) * *normal;
  return true;
}

// The points of `pts` within band_mm of the circle of radius within 3 mm
// of radius_mm that most of them lie on (PCL's RANSAC with the 2-D circle
// model, on at most 5,000 of them, moved to their centroid in double
// before PCL's float copy): other surfaces at the same heights (a vise's
// jaws, an angle plate or clamp posts beside the piece) must not pull the
// rough centre. All of pts when no such circle holds 20 of them.
std::vector<Eigen::Vector2d> NearCircleOfRadius(
    const std::vector<Eigen::Vector2d>& pts, double radius_mm, double band_mm) {
  if (pts.size() < 20) return pts;
  const Indices pick = Subsample(static_cast<Index>(pts.size()), 5000);
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (Index k : pick) c += pts[static_cast<size_t>(k)];
  c /= static_cast<double>(pick.size());
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(pick.size());
  for (Index k : pick) {
    const Eigen::Vector2f d = (pts[static_cast<size_t>(k)] - c).cast<float>();
    cloud->push_back(pcl::PointXYZ(d.x(), d.y(), 0.0f));
  }
  // PCL's fixed seed (random = false): the same cloud gives the same circle.
  auto model =
      std::make_shared<pcl::SampleConsensusModelCircle2D<pcl::PointXYZ>>(cloud);
  model->setRadiusLimits(radius_mm - 3, radius_mm + 3);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, band_mm);
  ransac.setProbability(0.9999);
  ransac.setMaxIterations(5000);
  const internal::QuietPcl quiet;
  if (!ransac.computeModel()) return pts;
  Eigen::VectorXf coeff;
  ransac.getModelCoefficients(coeff);
  if (coeff.size() != 3 || !coeff.allFinite()) return pts;
  const Eigen::Vector2d centre = c + coeff.head<2>().cast<double>();
  const double radius = coeff[2];
  std::vector<Eigen::Vector2d> near;
  for (const auto& x : pts)
    if (std::abs((x - centre).norm() - radius) < band_mm) near.push_back(x);
  return near.size() >= 20 ? near : pts;
}

// 1. The top face datum: the end of the axis whose cross-section is a plane.
struct TopFace {
  fit::PlaneFit plane;
  // Points of the searched sample within kTopConsensusMm of the face's
  // first plane (the RANSAC consensus, refined): what the final fit was
  // expected to keep.
  int consensus = 0;
};

// Points within this distance of a candidate plane are on it (RANSAC
// threshold and first band of the refinement): far above the instrument's
// noise, far below the 0.3 mm groove and the walls' height.
constexpr double kTopConsensusMm = 0.05;

// The widest extent of the points idx in the plane (point, normal): the
// 1 % to 99 % quantile range along 12 directions 15 deg apart (walls that
// cross the plane far away, such as a post's beside a fixture's top, add
// a few points to its band: not its extent).
double ExtentInPlane(const Eigen::Matrix3Xd& p, const Indices& idx,
                     const Eigen::Vector3d& point,
                     const Eigen::Vector3d& normal) {
  const Eigen::Vector3d u = normal.unitOrthogonal();
  const Eigen::Vector3d v = normal.cross(u);
  double widest = 0;
  std::vector<double> along(idx.size());
  for (int k = 0; k < 12; ++k) {
    const double a = k * 15 * kDeg;
    const Eigen::Vector3d e = std::cos(a) * u + std::sin(a) * v;
    for (size_t j = 0; j < idx.size(); ++j)
      along[j] = (p.col(idx[j]) - point).dot(e);
    widest = std::max(widest, Quantile(along, 0.99) - Quantile(along, 0.01));
  }
  return widest;
}

// A plane at an end of the axis wider than the blank by this factor is
// another surface (measurements.md: other surfaces may be present and are
// ignored): the table the piece or its adapter stands on, a fixture plate.
// The top face is at most the blank's diameter across.
constexpr double kTopMaxExtentFactor = 1.1;

// A plane at an end of the axis that is wider than the piece.
struct WidePlane {
  Eigen::Vector3d point, normal;
  double extent_mm = 0;
  int points = 0;
};

// One search for the top face among the points sub (FindTopFace): false
// when there is none; a plane wider than the piece is not taken but kept
// in *wide (the one with the most points). The axis is axis_hint when
// given (the normal of a plane left out before: a table or a fixture's
// top is parallel to the top face, and the principal axis of what is left
// may lean by degrees towards posts or a fixture beside the piece).
bool SearchTopFace(const PartSpec& part, const Eigen::Matrix3Xd& p,
                   const Indices& sub, const std::string& source,
                   const std::optional<Eigen::Vector3d>& axis_hint,
                   TopFace* found, Indices* found_idx, WidePlane* wide) {
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
  if (used < 100) {
    // How far the points lie tells a cloud in other units (a piece 203 mm
    // across read from metres or inches) from one with too few points.
    std::vector<double> r(n);
    for (Index k = 0; k < n; ++k) r[k] = (p.col(sub[k]) - med).norm();
    NoPiece(source,
            fmt::format("fewer than 100 points within 160 mm of the cloud's "
                        "median (half of them lie within {:.4g} mm of it; the "
                        "piece is {:g} mm across: are the cloud's units "
                        "right? --units mm|m|in)",
                        n > 0 ? Median(std::move(r)) : 0.0,
                        part.blank_diameter_mm));
  }
  mean /= static_cast<double>(used);
  s = s / static_cast<double>(used) - mean * mean.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(s);
  const Eigen::Vector3d axis =
      axis_hint ? *axis_hint : Eigen::Vector3d(es.eigenvectors().col(0));
  const Eigen::Vector3d centre = med + mean;
  std::vector<double> h(n);
  for (Index k = 0; k < n; ++k) h[k] = (p.col(sub[k]) - centre).dot(axis);
  // Try both ends. Near an end lie the top face and the highest
  // millimetres of every wall that meets it (facets, flanks, notch walls:
  // a scanner sees them up to the edge, and they may outnumber the face's
  // points), the groove's floor and strays. A least-squares plane through
  // all of them is tilted towards the walls, and narrowing bands about it
  // then keep only a strip of the face. So the face is found as the plane
  // across the axis that holds the most points (RANSAC, normal within
  // 10 deg of the axis: walls cannot be it, and a tilted plane holds only
  // a strip of the face); bands of 0.05 and 0.02 mm about it refine it.
  // The end whose face holds more points is the top.
  TopFace best;
  best.plane.summary.status = fit::FitStatus::kDegenerate;
  Indices best_idx;
  // Each end's height: the 0.995 quantile along the axis, which lies on the
  // face when fewer than 0.5 % of the points are strays above it. When more
  // are (dust, a fixture's edge, double hits above the face), no face is
  // found there; the second attempt takes the highest 0.25 mm layer that
  // holds at least 1 % of the points (a face is a dense layer, strays are
  // spread out).
  for (int attempt = 0;
       attempt < 2 && (!Usable(best.plane) || best.plane.summary.points < 20);
       ++attempt) {
    // The points near each end; the end with more of them is searched first,
    // the other only for a larger face than the first end's.
    Indices near_end[2];
    for (int e = 0; e < 2; ++e) {
      const double sign = e == 0 ? 1.0 : -1.0;
      std::vector<double> hs(n);
      for (Index k = 0; k < n; ++k) hs[k] = sign * h[k];
      double end = Quantile(hs, 0.995);
      if (attempt == 1) {
        constexpr double kLayerMm = 0.25;
        const double lo = *std::min_element(hs.begin(), hs.end());
        std::map<long, Index> layers;
        for (double v : hs)
          ++layers[std::lround(std::floor((v - lo) / kLayerMm))];
        const Index dense = std::max<Index>(20, n / 100);
        for (auto it = layers.rbegin(); it != layers.rend(); ++it)
          if (it->second >= dense) {
            end = lo + (it->first + 1) * kLayerMm;
            break;
          }
      }
      for (Index k = 0; k < n; ++k) {
        if (hs[k] > end - 3.0 && hs[k] < end + 2.0)
          near_end[e].push_back(sub[k]);
      }
    }
    const int first = near_end[1].size() > near_end[0].size() ? 1 : 0;
    for (int e : {first, 1 - first}) {
      const double sign = e == 0 ? 1.0 : -1.0;
      const Indices& cand = near_end[e];
      // A face of at least 10 % of the points near its end is found.
      const double min_share =
          std::max(0.1, static_cast<double>(best.plane.summary.points) /
                            std::max<size_t>(1, cand.size()));
      if (min_share > 1) continue;
      Eigen::Vector3d point, normal;
      if (!LargestPlaneAcross(p, cand, sign * axis, 10 * kDeg, kTopConsensusMm,
                              min_share, &point, &normal)) {
        continue;
      }
      fit::PlaneFit pl;
      Indices idx;
      int consensus = 0;
      // The consensus plane may lean by a fraction of a milliradian (the
      // walls' top edges fill its band too): a strip of the face and some
      // wall points. Each refit through the band leans less, so the 0.02 mm
      // band is refitted until it keeps the same points (a few rounds).
      constexpr int kMaxRefits = 10;
      for (int round = 0; round <= kMaxRefits; ++round) {
        const double band = round == 0 ? kTopConsensusMm : 0.02;
        Indices next;
        for (Index i : sub) {
          if (std::abs((p.col(i) - point).dot(normal)) < band)
            next.push_back(i);
        }
        if (round == 0) consensus = static_cast<int>(next.size());
        if (round > 1 && next == idx) break;
        idx = std::move(next);
        pl = PlaneThrough(p, idx, sign * axis, axis.unitOrthogonal());
        if (!Usable(pl)) break;
        point = pl.point;
        normal = pl.normal;
      }
      // The second attempt's layer may be a floor inside the piece (the big
      // notch's): a face is the piece's end, with nothing but strays beyond
      // it (at most 2 % of the points more than 2 mm outside).
      if (attempt == 1 && Usable(pl)) {
        // Only points over the face count: posts or a fixture beside the
        // piece may stand higher than its top.
        const double reach_mm = part.blank_diameter_mm / 2 + 2.0;
        Index beyond = 0;
        for (Index i : sub) {
          const Eigen::Vector3d d = p.col(i) - pl.point;
          const double up = d.dot(pl.normal);
          beyond += std::abs(up) > 2.0 &&
                    (d - up * pl.normal).squaredNorm() < reach_mm * reach_mm &&
                    d.dot(sign * axis) > 0;
        }
        if (beyond > n / 50) continue;
      }
      // A plane wider than the piece is a table or a fixture plate under
      // it: the top face is the other end's.
      if (Usable(pl)) {
        const double extent_mm = ExtentInPlane(p, idx, pl.point, pl.normal);
        if (extent_mm > kTopMaxExtentFactor * part.blank_diameter_mm) {
          if (pl.summary.points > wide->points) {
            *wide = {pl.point, pl.normal, extent_mm, pl.summary.points};
          }
          continue;
        }
      }
      if (Usable(pl) && pl.summary.points > best.plane.summary.points) {
        best.plane = pl;
        best.consensus = consensus;
        best_idx = idx;
      }
    }
  }
  if (!Usable(best.plane) || best.plane.summary.points < 20) return false;
  *found = best;
  *found_idx = std::move(best_idx);
  return true;
}

// Points within this distance of a plane wider than the piece are left out
// of the search for the top face (a table's or fixture plate's scan, with
// its noise and its unevenness): they would tilt the axis and hold the
// quantiles that find the ends.
constexpr double kOtherPlaneBandMm = 1.0;
// At most this many such planes (a table, a fixture plate) are left out.
constexpr int kMaxOtherPlanes = 3;

void LeaveOutPlane(const Eigen::Matrix3Xd& p, const Eigen::Vector3d& point,
                   const Eigen::Vector3d& normal, Indices* sub) {
  Indices keep;
  for (Index i : *sub)
    if (std::abs((p.col(i) - point).dot(normal)) > kOtherPlaneBandMm)
      keep.push_back(i);
  sub->swap(keep);
}

// The top face among the points *sub (an even subsample of the cloud);
// planes wider than the piece are left out of *sub on the way.
TopFace FindTopFace(const PartSpec& part, const Eigen::Matrix3Xd& p,
                    const InspectOptions& o, const std::string& source,
                    Indices* sub_io, std::optional<Eigen::Vector3d>* axis_hint,
                    std::vector<std::string>* warnings) {
  Indices& sub = *sub_io;
  TopFace best;
  Indices best_idx;
  std::vector<WidePlane> left_out;
  bool found = false;
  for (int round = 0; round <= kMaxOtherPlanes; ++round) {
    WidePlane wide;
    found = SearchTopFace(part, p, sub, source, *axis_hint, &best, &best_idx,
                          &wide);
    if (wide.points > 0) left_out.push_back(wide);
    if (found || wide.points == 0 || round == kMaxOtherPlanes) break;
    // A table or fixture plate in the cloud: search again without it,
    // along its normal.
    LeaveOutPlane(p, wide.point, wide.normal, &sub);
    *axis_hint = wide.normal;
  }
  // Each plane left out, as the refusal and the warnings name it.
  auto describe = [&](const WidePlane& w) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "a plane %.0f mm across (%d points), wider than the %g mm "
                  "blank, was taken for a table or fixture and left out",
                  w.extent_mm, w.points, part.blank_diameter_mm);
    return std::string(text);
  };
  if (!found) {
    std::string why = "no flat top face at either end of the disc's axis";
    for (const WidePlane& w : left_out) why += "; " + describe(w);
    NoPiece(source, why);
  }
  for (const WidePlane& w : left_out) warnings->push_back(describe(w));
  // The bulk of the piece lies below the top face.
  const Index n = static_cast<Index>(sub.size());
  double below = 0;
  for (Index i : sub)
    below += (p.col(i) - best.plane.point).dot(best.plane.normal) < 0;
  if (below < 0.5 * n) {
    warnings->push_back(
        "most points lie above the plane taken as the top face");
  }
  best.plane =
      fit::FitPlaneTrimmed(p, best_idx, best.plane.normal, best.plane.u,
                           Rejection(o, o.stray_floor_mm))
          .plane;
  return best;
}

// The top face datum is refused when it is not a plane at the instrument's
// noise: its RMS is more than kTopRmsFactor times the flanks' (the same
// instrument on the same cloud; a face-milled top is as flat as a milled
// flank) and more than the stray floor, or the robust fit kept less than
// kTopMinShare of the points on its first plane. Either way the points
// taken for it are not the face (or the face is not flat), and Z, z = 0
// and every figure after them would be off with nothing to show it.
constexpr double kTopRmsFactor = 4.0;
constexpr double kTopMinShare = 0.8;

void CheckTopFace(const TopFace& top, const double flank_rms_mm[2],
                  const InspectOptions& o, const std::string& source) {
  const double noise_mm = std::max(flank_rms_mm[0], flank_rms_mm[1]);
  const double limit_mm = std::max(kTopRmsFactor * noise_mm, o.stray_floor_mm);
  const int kept = top.plane.summary.points;
  const double share =
      top.consensus > 0 ? static_cast<double>(kept) / top.consensus : 0.0;
  if (top.plane.summary.rms_mm <= limit_mm && share >= kTopMinShare) return;
  char why[600];
  std::snprintf(
      why, sizeof why,
      "the top face (datum for Z and z = 0) is not read as a plane: its fit "
      "keeps %d of the %d points within %g mm of it (%.0f %%, at least "
      "%.0f %% needed) with an RMS of %.2f um (the flanks' %.2f um; at most "
      "%.2f um allowed); W's Z and every figure would be off",
      kept, top.consensus, kTopConsensusMm, 100 * share, 100 * kTopMinShare,
      top.plane.summary.rms_mm * 1e3, noise_mm * 1e3, limit_mm * 1e3);
  Refuse(source, why);
}

}  // namespace

void PointsInW(const Alignment& a, const Eigen::Matrix3Xd& p,
               Eigen::Matrix3Xd* points_w_mm) {
  Eigen::Matrix3Xd& w = *points_w_mm;
  if (w.cols() != p.cols()) {
    w.resize(3, p.cols());
    AdviseHugePages(w.data(), sizeof(double) * 3 * p.cols());
  }
  for (Index i = 0; i < p.cols(); ++i)
    w.col(i).noalias() = a.rotation * p.col(i) + a.translation;
}

namespace {

// Stages 2-5 from the top face found in stage 1.
AlignedCloud AlignFromTopFace(const PartSpec& part, const PointCloud& cloud,
                              const InspectOptions& o, const TopFace& top_face,
                              AlignedCloud out) {
  const std::string& source = cloud.source;
  const Eigen::Matrix3Xd& p = cloud.xyz_mm;
  const Index n = p.cols();
  const fit::PlaneFit& top = top_face.plane;
  out.alignment.top_points = top.summary.points;
  out.alignment.top_rms_mm = top.summary.rms_mm;
  Eigen::Matrix3d f_rot;  // rows e1 e2 n
  {
    const Eigen::Vector3d z = top.normal;
    const Eigen::Vector3d x = z.unitOrthogonal();
    f_rot.row(0) = x.transpose();
    f_rot.row(1) = z.cross(x).transpose();
    f_rot.row(2) = z.transpose();
  }
  const Eigen::Vector3d f_origin = top.point;
  Eigen::Matrix3Xd q(3, n);
  AdviseHugePages(q.data(), sizeof(double) * 3 * n);
  for (Index i = 0; i < n; ++i) q.col(i) = f_rot * (p.col(i) - f_origin);

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
  fit::CircleFit2D rough;
  rough.summary.status = fit::FitStatus::kDegenerate;
  {
    // The reference cylinders' radii span 1 mm (199 to 201 mm).
    auto pts = NearCircleOfRadius(
        ring(-part.height_mm() + 0.3, part.big_notch_floor_z_mm - 0.3), r_cyl,
        1.5);
    // Keep the outer points: interior floors would pull a first fit.
    if (pts.size() >= 20) {
      const fit::CircleFit2D c0 = CircleThrough(pts);
      if (Usable(c0)) {
        std::vector<Eigen::Vector2d> outer;
        for (const auto& x : pts) {
          if ((x - c0.centre).norm() > 0.8 * r_cyl) outer.push_back(x);
        }
        rough = CircleTrimmed(outer, o.stray_sigma, 0.05);
      }
    }
    if (!Usable(rough) || rough.summary.points < 20 ||
        std::abs(rough.radius_mm - r_cyl) > 3) {
      auto facet_pts =
          NearCircleOfRadius(ring(part.facet_bottom_z_mm + 0.5, -0.5),
                             part.facet_final_distance_mm, 0.5);
      const fit::CircleFit2D c0 = CircleThrough(facet_pts);
      std::vector<Eigen::Vector2d> outer;
      if (Usable(c0)) {
        for (const auto& x : facet_pts) {
          if ((x - c0.centre).norm() > 0.9 * part.facet_final_distance_mm)
            outer.push_back(x);
        }
      }
      rough = CircleTrimmed(outer, o.stray_sigma, 0.2);
      if (!Usable(rough) || rough.summary.points < 20 ||
          std::abs(rough.radius_mm - part.facet_final_distance_mm) > 3) {
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
  double flank_rms_mm[2] = {0, 0};
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
      fit::PlaneFit pl =
          fit::FitPlaneTrimmed(q, idx, hint, Eigen::Vector3d::UnitZ(),
                               Rejection(o, 0.05))
              .plane;
      for (double band : {0.5, 0.1}) {
        if (!Usable(pl)) break;
        idx.clear();
        for (Index i : wall) {
          if (std::abs((q.col(i) - pl.point).dot(pl.normal)) < band)
            idx.push_back(i);
        }
        pl = fit::FitPlaneTrimmed(q, idx, pl.normal, Eigen::Vector3d::UnitZ(),
                                  Rejection(o, o.stray_floor_mm))
                 .plane;
      }
      if (!Usable(pl) || pl.summary.points < o.min_points)
        NoPiece(source, "a big-notch flank has too few points");
      out.alignment.flank_points[side] = pl.summary.points;
      flank_rms_mm[side] = pl.summary.rms_mm;
      fn[side] = pl.normal;  // outward from the notch centre
    }
    y_dir = fn[0] - fn[1];
    y_dir.z() = 0;  // in the top face plane
    y_dir.normalize();
  }
  CheckTopFace(top_face, flank_rms_mm, o, source);
  Eigen::Vector3d x_dir = y_dir.cross(Eigen::Vector3d::UnitZ());
  // Frame rotation (temporary frame -> W up to the 180 deg flip).
  Eigen::Matrix3d rz;
  rz.row(0) = x_dir.transpose();
  rz.row(1) = y_dir.transpose();
  rz.row(2) = Eigen::Vector3d::UnitZ().transpose();

  // 4. Origin: least-squares circle of the 199 cylinder between z -16..-14.
  Eigen::Vector2d origin2;
  Eigen::Matrix2d origin_cov;  // mm^2, q frame
  {
    std::vector<Eigen::Vector2d> pts;
    for (Index i = 0; i < n; ++i) {
      if (q(2, i) < part.datum_circle_z_min_mm + 0.1 ||
          q(2, i) > part.datum_circle_z_max_mm - 0.1)
        continue;
      const Eigen::Vector2d d(q(0, i), q(1, i));
      if (std::abs((d - rough.centre).norm() - r_cyl) < 0.5) pts.push_back(d);
    }
    const fit::CircleFit2D c =
        CircleTrimmed(pts, o.stray_sigma, o.stray_floor_mm);
    if (!Usable(c) || c.summary.points < o.min_points ||
        std::abs(c.radius_mm - r_cyl) >= 0.5) {
      char why[400];
      std::snprintf(
          why, sizeof why,
          "the datum circle %s (the %g mm cylinder between z %g and %g mm) "
          "is missing: %zu points near it, %d needed; the origin of W "
          "cannot be determined",
          DatumCylinderId(part).c_str(), 2 * r_cyl, part.datum_circle_z_min_mm,
          part.datum_circle_z_max_mm, pts.size(), o.min_points);
      Refuse(source, why);
    }
    origin2 = c.centre;
    origin_cov = c.summary.covariance.topLeftCorner<2, 2>();
    out.alignment.circle_points = c.summary.points;
    out.alignment.circle_diameter_mm = 2 * c.radius_mm;
    out.alignment.circle_rms_mm = c.summary.rms_mm;
  }

  // 5. The mark decides the 180 deg ambiguity and the handedness: counted
  // where the piece has it (phi, phi + 180 deg) and where a mirror image
  // has it (-phi, 180 deg - phi).
  {
    const double phi = part.mark_phi_deg * kDeg;
    const double candidates[4] = {phi, phi + M_PI, -phi, M_PI - phi};
    int count[4] = {0, 0, 0, 0};
    for (Index i = 0; i < n; ++i) {
      const double z = q(2, i);
      if (z > -0.02 || z < -part.mark_depth_mm - 0.05) continue;
      const Eigen::Vector3d d =
          rz * Eigen::Vector3d(q(0, i) - origin2.x(), q(1, i) - origin2.y(), 0);
      for (int k = 0; k < 4; ++k) {
        const double a = candidates[k];
        const double along = d.x() * std::cos(a) + d.y() * std::sin(a);
        const double across = -d.x() * std::sin(a) + d.y() * std::cos(a);
        if (along > part.mark_r_start_mm - 1 &&
            along < part.mark_r_end_mm + 1 &&
            std::abs(across) < part.mark_width_mm) {
          ++count[k];
        }
      }
    }
    const int proper = std::max(count[0], count[1]);
    const int mirrored = std::max(count[2], count[3]);
    out.alignment.mark_points = proper;
    out.alignment.mark_points_opposite = std::min(count[0], count[1]);
    // With the mark on a symmetry axis of the flanks (phi = 0 or 90 deg)
    // the mirror positions coincide with the proper ones: no test then.
    const bool distinct =
        std::abs(std::remainder(2 * phi, 2 * M_PI)) > 1e-6 &&
        std::abs(std::remainder(2 * phi - M_PI, 2 * M_PI)) > 1e-6;
    out.alignment.mark_found =
        proper >= 3 && count[0] != count[1] && (!distinct || proper > mirrored);
    if (!out.alignment.mark_found) {
      char why[400];
      if (distinct && mirrored >= 3 && mirrored > proper) {
        std::snprintf(why, sizeof why,
                      "the cloud is a mirror image of the piece: the engraved "
                      "mark (%d points) is at %g deg where the piece has it "
                      "at %g deg; a mirrored cloud (e.g. x -> -x) reverses "
                      "the cycles",
                      mirrored, -part.mark_phi_deg, part.mark_phi_deg);
      } else {
        std::snprintf(why, sizeof why,
                      "the engraved mark (datum for +X: %g deg, r %g..%g mm) "
                      "is missing (%d and %d points at either end): which "
                      "end is X1 cannot be determined",
                      part.mark_phi_deg, part.mark_r_start_mm,
                      part.mark_r_end_mm, count[0], count[1]);
      }
      Refuse(source, why);
    }
    if (count[1] > count[0]) {
      rz.row(0) *= -1;
      rz.row(1) *= -1;
    }
  }
  out.alignment.rotation = rz * f_rot;
  const Eigen::Vector3d origin_q(origin2.x(), origin2.y(), 0.0);
  out.alignment.translation = -rz * (f_rot * f_origin + origin_q);
  const Eigen::Matrix2d rz2 = rz.topLeftCorner<2, 2>();
  out.origin_covariance_mm2 = rz2 * origin_cov * rz2.transpose();
  out.points_w_mm = std::move(q);  // q is done with: its storage takes W
  PointsInW(out.alignment, p, &out.points_w_mm);
  return out;
}

}  // namespace

AlignedCloud AlignCloud(const PartSpec& part, const PointCloud& cloud,
                        const InspectOptions& o) {
  const std::string& source = cloud.source;
  const Eigen::Matrix3Xd& p = cloud.xyz_mm;
  if (p.cols() == 0) throw InputError(source, 0, "", "the cloud has no points");
  // The searches run on an even subsample of at most 100,000 points (a
  // million-point scan holds far more top-face points than the datum
  // needs); the final robust fit uses the sample's top-face points.
  Indices sub = Subsample(p.cols(), 100000);
  // A plane taken for the top face around which the piece's other datums
  // are not found (the top of a clamp post or a fixture above the piece)
  // is left out and the search starts again; when no attempt aligns, the
  // first attempt's reason is given (the most likely top face's).
  std::exception_ptr first_failure;
  std::vector<std::string> passed_over;
  std::optional<Eigen::Vector3d> axis_hint;
  for (int attempt = 0; attempt <= kMaxOtherPlanes; ++attempt) {
    AlignedCloud out;
    TopFace top_face;
    try {
      top_face =
          FindTopFace(part, p, o, source, &sub, &axis_hint, &out.warnings);
    } catch (const InputError&) {
      if (!first_failure) first_failure = std::current_exception();
      break;  // no plane left to try
    }
    try {
      AlignedCloud aligned =
          AlignFromTopFace(part, cloud, o, top_face, std::move(out));
      aligned.warnings.insert(aligned.warnings.end(), passed_over.begin(),
                              passed_over.end());
      return aligned;
    } catch (const InputError& e) {
      if (!first_failure) first_failure = std::current_exception();
      passed_over.push_back(
          "a plane of " + std::to_string(top_face.plane.summary.points) +
          " points (a post's or a fixture's top?) was tried as the top face "
          "and left out: " +
          e.problem());
    }
    if (attempt == kMaxOtherPlanes) break;  // nothing is searched after it
    LeaveOutPlane(p, top_face.plane.point, top_face.plane.normal, &sub);
    axis_hint = top_face.plane.normal;
  }
  std::rethrow_exception(first_failure);
}

}  // namespace ttp::inspect
