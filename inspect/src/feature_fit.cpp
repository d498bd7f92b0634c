// Stage 3 of the cloud inspection: a plane per facet and strip (trimmed
// least squares, geometry/fit.h) and its result for the figures.
//
// Uncertainty (k = 1): the plane fit's covariance (offset and tilts about
// the centroid, residual variance times the inverse Hessian of the
// orthogonal problem) propagated to d and the angle; for facets also the
// origin's uncertainty along the normal; for a CMM the instrument,
// MPE_E = a + L / b read as a rectangular bound, u = MPE / sqrt(3), with L
// the feature's distance from the datum origin for d, and for angles only
// the length-proportional part, u_angle = (1 / b) / sqrt(3) (the constant
// part is probing scatter that the fit residuals already hold). Features
// are taken independent (conservative: correlated CMM errors would cancel
// in the figures' differences).
#include <Eigen/Geometry>
#include <cmath>
#include <map>

#include "ttp/geometry/features.h"
#include "ttp/geometry/fit.h"
#include "ttp/inspect/cloud_stages.h"
#include "ttp/inspect/plane_result.h"

namespace ttp::inspect {

FittedFeatures FitFeatures(const PartSpec& part, const Eigen::Matrix3Xd& w,
                           const Segmentation& seg,
                           const Eigen::Matrix2d& origin_cov_w,
                           const InspectOptions& o) {
  FittedFeatures out;
  const int facets = part.facets_per_segment;
  const double d_facet = part.facet_final_distance_mm;
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
  fit::RejectionOptions rejection;
  rejection.k_sigma = o.stray_sigma;
  rejection.floor_mm = o.stray_floor_mm;
  rejection.max_rounds = 8;
  auto fit_feature = [&](const NominalFeature& nominal_feature,
                         const std::vector<Eigen::Index>& idx,
                         const Eigen::Vector3d& n_nom,
                         const Eigen::Vector3d& u_nom, auto&& finish) {
    const std::string& id = nominal_feature.id;
    FeatureDiagnostic diag;
    diag.id = id;
    diag.candidates = static_cast<int>(idx.size());
    FeatureResult r;
    if (static_cast<int>(idx.size()) >= o.min_points) {
      const fit::TrimmedPlane t =
          fit::FitPlaneTrimmed(w, idx, n_nom, u_nom, rejection);
      out.points_rejected += t.rejected;
      const fit::PlaneFit& pl = t.plane;
      if (pl.summary.Usable() && pl.summary.points >= o.min_points) {
        r.present = true;
        r.points = pl.summary.points;
        r.rms_mm = pl.summary.rms_mm;
        finish(pl, &r);
        out.points_assigned += pl.summary.points;
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
    out.features[nominal_feature.Key()] = r;
    out.diagnostics.push_back(diag);
  };
  std::map<FeatureId, NominalFeature> nominal;
  for (const NominalFeature& f : TestFeatures(part)) nominal[f.Key()] = f;
  // d, angle and tilt as every measurement path has them; the variances
  // are this fit's.
  const auto set_shape = [](const FeatureResult& shape, FeatureResult* r) {
    r->d_mm = shape.d_mm;
    r->angle_rad = shape.angle_rad;
    r->tilt_rad = shape.tilt_rad;
  };
  // Variance of the plane's height along its normal at `at`: the fit's
  // parameters are the offset at the centroid and the tilts of the normal
  // towards u, v, so the height there moves by offset - t_u s - t_v t.
  const auto height_variance = [](const fit::PlaneFit& pl,
                                  const Eigen::Vector3d& at) {
    const Eigen::Vector3d lever = at - pl.point;
    const Eigen::Vector3d g(1.0, -lever.dot(pl.u), -lever.dot(pl.v));
    return g.dot(pl.summary.covariance * g);
  };
  for (int s = 0; s < 4; ++s) {
    for (int j = 1; j <= facets; ++j) {
      const NominalFeature& nom = nominal.at(FeatureId::Facet(kSegments[s], j));
      const Eigen::Vector3d& n_nom = nom.normal;
      const Eigen::Vector3d u_nom = Eigen::Vector3d::UnitZ().cross(n_nom);
      fit_feature(
          nom, seg.facets[s * facets + j - 1], n_nom, u_nom,
          [&](const fit::PlaneFit& pl, FeatureResult* r) {
            set_shape(FeatureResultFromPlane(nom, {pl.point, pl.normal}), r);
            // d is the plane's distance from the origin; the origin's
            // uncertainty moves the plane along its normal (common to all
            // facets; taken independent: conservative).
            const Eigen::Vector2d n2 = pl.normal.head<2>();
            r->scatter_var_d_mm2 = height_variance(pl, Eigen::Vector3d::Zero());
            r->scatter_var_angle_rad2 = pl.summary.covariance(1, 1);
            r->var_d_mm2 = r->scatter_var_d_mm2 + n2.dot(origin_cov_w * n2) +
                           std::pow(instrument_u(d_facet), 2);
            r->var_angle_rad2 =
                r->scatter_var_angle_rad2 + std::pow(instrument_u_angle, 2);
          });
    }
  }
  for (int k = 1; k <= facets; ++k) {
    const NominalFeature& nom = nominal.at(FeatureId::Strip(k));
    fit_feature(
        nom, seg.strips[k - 1], Eigen::Vector3d::UnitZ(),
        Eigen::Vector3d::UnitX(),
        [&](const fit::PlaneFit& pl, FeatureResult* r) {
          const Eigen::Vector3d& nn = pl.normal;
          set_shape(FeatureResultFromPlane(nom, {pl.point, pl.normal}), r);
          // The depth is taken at (0, y_k, -d), vertically.
          const Eigen::Vector3d at(0, nom.point.y(), -r->d_mm);
          r->scatter_var_d_mm2 = height_variance(pl, at) / (nn.z() * nn.z());
          r->scatter_var_angle_rad2 = pl.summary.covariance(1, 1);
          r->var_d_mm2 =
              r->scatter_var_d_mm2 +
              std::pow(instrument_u(std::abs(part.strip_floor_z_mm)), 2);
          r->var_angle_rad2 =
              r->scatter_var_angle_rad2 + std::pow(instrument_u_angle, 2);
        });
  }
  return out;
}

}  // namespace ttp::inspect
