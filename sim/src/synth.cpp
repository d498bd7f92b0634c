#include "ttp/sim/synth.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <optional>
#include <random>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"

namespace ttp::sim {
namespace {

// Deterministic across standard libraries: mt19937 with hand-made
// uniform / normal draws.
struct Rng {
  explicit Rng(uint32_t seed) : gen(seed) {}
  double Uniform() { return (gen() + 0.5) / 4294967296.0; }
  double Normal() {
    const double u1 = Uniform(), u2 = Uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  std::mt19937 gen;
};

// What a CMM program measures: the test features and the datums (not the
// notch floors, the bottom or the bolt holes).
bool Measured(const std::string& id) {
  const std::optional<FeatureId> f = FeatureId::Parse(id);
  return f && f->kind != FeatureKind::kNotchFloor;
}

}  // namespace

bool SynthOptions::IsValid(std::string* error) const {
  const auto fail = [error](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (points < 1) return fail("SynthOptions.points: must be at least 1");
  if (!(noise_um >= 0) || !std::isfinite(noise_um))
    return fail("SynthOptions.noise_um: must be a finite value >= 0");
  if (!(stray_fraction >= 0 && stray_fraction <= 1))
    return fail("SynthOptions.stray_fraction: must be in [0, 1]");
  if (!(deviation_d_um >= 0) || !std::isfinite(deviation_d_um))
    return fail("SynthOptions.deviation_d_um: must be a finite value >= 0");
  if (!(deviation_angle_urad >= 0) || !std::isfinite(deviation_angle_urad))
    return fail(
        "SynthOptions.deviation_angle_urad: must be a finite value >= 0");
  if (sampling != SynthSampling::kScanner && sampling != SynthSampling::kCmm)
    return fail("SynthOptions.sampling: unknown sampling");
  return true;
}

namespace {
void RequireValid(const SynthOptions& o) {
  std::string error;
  if (o.IsValid(&error)) {
    return;
  }
  const size_t colon = error.find(':');
  throw InputError("SynthOptions", 0, error.substr(0, colon),
                   error.substr(colon + 2));
}
}  // namespace

FeatureResults RandomDeviations(const PartSpec& part, const SynthOptions& o) {
  RequireValid(o);
  Rng rng(o.seed * 7919u + 17u);
  FeatureResults out;
  for (const NominalFeature& f : TestFeatures(part)) {
    FeatureResult r;
    r.present = true;
    const double nominal = f.kind == FeatureKind::kStrip
                               ? -part.strip_floor_z_mm
                               : part.facet_final_distance_mm;
    r.d_mm = nominal + o.deviation_d_um * 1e-3 * rng.Normal();
    r.angle_rad = o.deviation_angle_urad * 1e-6 * rng.Normal();
    out[f.Key()] = r;
  }
  return out;
}

SynthPiece SynthesizePiece(const PartSpec& part, const PartMesh& mesh,
                           const FeatureResults& deviations,
                           const SynthOptions& o) {
  RequireValid(o);
  Rng rng(o.seed);
  // Which triangles may carry points.
  std::vector<bool> use_feature(mesh.feature_ids.size());
  for (size_t k = 0; k < mesh.feature_ids.size(); ++k) {
    const std::string& id = mesh.feature_ids[k];
    bool use = id != "BOTTOM" && id != "BOLT_HOLE";  // the piece sits on it
    if (o.sampling == SynthSampling::kCmm) use = use && Measured(id);
    if (std::find(o.missing.begin(), o.missing.end(), id) != o.missing.end())
      use = false;
    use_feature[k] = use;
  }
  // Triangles by feature, with cumulative areas.
  struct Pool {
    std::vector<int> tris;
    std::vector<double> cumulative;
    double area = 0;
  };
  std::vector<Pool> pools(mesh.feature_ids.size());
  Pool all;
  for (size_t t = 0; t < mesh.triangles.size(); ++t) {
    const int k = mesh.triangle_feature[t];
    if (!use_feature[k]) continue;
    const double a = mesh.TriangleAreaMm2(static_cast<int>(t));
    for (Pool* pool : {&pools[k], &all}) {
      pool->area += a;
      pool->tris.push_back(static_cast<int>(t));
      pool->cumulative.push_back(pool->area);
    }
  }
  // Which pool each point comes from: a scanner samples the surface by
  // area; a CMM program gives every facet and strip its own share (45 % of
  // the points over the facets, 25 % over the strips, the rest over the
  // datums by area), as real CMM exports do.
  std::vector<std::pair<const Pool*, int>> plan;
  if (o.sampling == SynthSampling::kScanner) {
    plan.emplace_back(&all, o.points);
  } else {
    int facets = 0, strips = 0;
    std::vector<std::optional<FeatureId>> ids(pools.size());
    for (size_t k = 0; k < pools.size(); ++k) {
      ids[k] = FeatureId::Parse(mesh.feature_ids[k]);
      if (pools[k].tris.empty() || !ids[k] || !ids[k]->IsTestFeature())
        continue;
      ++(ids[k]->kind == FeatureKind::kStrip ? strips : facets);
    }
    // Datums: top face 12 %, each flank 4 %, the 199 circle 4 %, the other
    // reference cylinders 2 % each, the mark 2 %.
    const std::optional<FeatureId> datum =
        FeatureId::Parse(DatumCylinderId(part));
    const auto datum_share = [&datum](const std::optional<FeatureId>& id) {
      if (!id) return 0.0;
      if (id->kind == FeatureKind::kTopFace) return 0.12;
      if (id->kind == FeatureKind::kFlank || id == datum) return 0.04;
      if (id->kind == FeatureKind::kMark || id->kind == FeatureKind::kCylinder)
        return 0.02;
      return 0.0;
    };
    int used = 0;
    size_t last = 0;
    for (size_t k = 0; k < pools.size(); ++k) {
      if (pools[k].tris.empty()) continue;
      const std::optional<FeatureId>& id = ids[k];
      const int n =
          !id || !id->IsTestFeature()
              ? static_cast<int>(datum_share(id) * o.points)
          : id->kind == FeatureKind::kStrip
              ? static_cast<int>(0.25 * o.points / std::max(1, strips))
              : static_cast<int>(0.45 * o.points / std::max(1, facets));
      if (n == 0) continue;
      plan.emplace_back(&pools[k], n);
      used += n;
      last = plan.size() - 1;
    }
    if (!plan.empty()) plan[last].second += std::max(0, o.points - used);
  }
  // The deviated planes of the test features, by mesh feature index.
  struct Dev {
    bool on = false;
    bool strip = false;
    Eigen::Vector3d n;  // facet: true normal
    double d = 0;       // facet: n . x = d; strip: z = -d + s x
    double slope = 0;
  };
  std::vector<Dev> dev(mesh.feature_ids.size());
  for (const NominalFeature& f : TestFeatures(part)) {
    const int k = mesh.FeatureIndex(f.id);
    auto it = deviations.find(f.Key());
    if (k < 0 || it == deviations.end() || !it->second.present) continue;
    Dev& d = dev[k];
    d.on = true;
    d.d = it->second.d_mm;
    if (f.kind == FeatureKind::kStrip) {
      d.strip = true;
      d.slope = std::tan(it->second.angle_rad);
    } else {
      const double phi =
          std::atan2(f.normal.y(), f.normal.x()) + it->second.angle_rad;
      d.n = Eigen::Vector3d(std::cos(phi), std::sin(phi), 0.0);
    }
  }

  std::vector<double> cyl_radius(mesh.feature_ids.size(), 0.0);
  for (size_t k = 0; k < mesh.feature_ids.size(); ++k) {
    const std::optional<FeatureId> id = FeatureId::Parse(mesh.feature_ids[k]);
    if (id && id->kind == FeatureKind::kCylinder)
      cyl_radius[k] = id->index / 1000.0 / 2;  // index: diameter in um
  }
  SynthPiece out;
  if (o.random_pose) {
    Eigen::Quaterniond q(rng.Normal(), rng.Normal(), rng.Normal(),
                         rng.Normal());
    q.normalize();
    out.rotation = q.toRotationMatrix();
    for (int a = 0; a < 3; ++a)
      out.translation(a) = 1000.0 * (rng.Uniform() - 0.5);
  }
  const int strays =
      static_cast<int>(std::lround(o.points * std::max(0.0, o.stray_fraction)));
  Eigen::Matrix3Xd w(3, o.points + strays);
  const double sigma = o.noise_um * 1e-3;
  int i = 0;
  for (const auto& [pool, count] : plan) {
    for (int c = 0; c < count; ++c, ++i) {
      if (pool->tris.empty()) {
        w.col(i).setZero();  // nothing to sample: filled below
        continue;
      }
      const double pick = rng.Uniform() * pool->area;
      const size_t at =
          std::min<size_t>(std::lower_bound(pool->cumulative.begin(),
                                            pool->cumulative.end(), pick) -
                               pool->cumulative.begin(),
                           pool->tris.size() - 1);
      const int t = pool->tris[at];
      double u = rng.Uniform(), v = rng.Uniform();
      if (u + v > 1) {
        u = 1 - u;
        v = 1 - v;
      }
      const auto& tri = mesh.triangles[t];
      const Eigen::Vector3d& a = mesh.vertices[tri[0]];
      Eigen::Vector3d p =
          a + u * (mesh.vertices[tri[1]] - a) + v * (mesh.vertices[tri[2]] - a);
      // The mesh's circles are polygons (chord error): put the points of the
      // reference cylinders on the true circle.
      if (cyl_radius[mesh.triangle_feature[t]] > 0) {
        const double r = std::hypot(p.x(), p.y());
        p.head<2>() *= cyl_radius[mesh.triangle_feature[t]] / r;
      }
      const Dev& d = dev[mesh.triangle_feature[t]];
      if (d.on && d.strip) {
        p.z() = -d.d + d.slope * p.x();
      } else if (d.on) {
        const Eigen::Vector3d n0 = mesh.TriangleNormal(t);
        p += (d.d - d.n.dot(p)) / d.n.dot(n0) * n0;
      }
      for (int a = 0; a < 3; ++a) p(a) += sigma * rng.Normal();
      w.col(i) = p;
    }
  }
  // Strays: half dust / double hits just off a surface (10-300 um out),
  // half fixture and air points anywhere around the piece.
  for (int i = 0; i < strays; ++i) {
    Eigen::Vector3d p;
    if (i % 2 == 0 && o.points > 0) {
      const Eigen::Vector3d base = w.col(static_cast<Eigen::Index>(
          std::min<double>(o.points - 1, rng.Uniform() * o.points)));
      Eigen::Vector3d dir(rng.Normal(), rng.Normal(), rng.Normal());
      p = base + (0.01 + 0.29 * rng.Uniform()) * dir.normalized();
    } else {
      const double r = part.blank_diameter_mm / 2 + 20.0;
      p = Eigen::Vector3d((2 * rng.Uniform() - 1) * r,
                          (2 * rng.Uniform() - 1) * r,
                          -40.0 + 50.0 * rng.Uniform());
    }
    w.col(o.points + i) = p;
  }
  out.cloud.xyz_mm = (out.rotation * w).colwise() + out.translation;
  out.cloud.source = "synthetic piece, seed " + std::to_string(o.seed);

  inspect::InspectionResult& truth = out.truth;
  truth.source = out.cloud.source;
  for (const NominalFeature& f : TestFeatures(part)) {
    FeatureResult r;
    auto it = deviations.find(f.Key());
    if (it != deviations.end()) {
      r = it->second;
    } else {
      r.present = true;
      r.d_mm = f.kind == FeatureKind::kStrip ? -part.strip_floor_z_mm
                                             : part.facet_final_distance_mm;
    }
    r.var_d_mm2 = r.var_angle_rad2 = 0;
    r.tilt_rad = 0;
    if (std::find(o.missing.begin(), o.missing.end(), f.id) != o.missing.end())
      r.present = false;
    truth.features[f.Key()] = r;
  }
  inspect::ComputeResultFigures(part, &truth);
  return out;
}

}  // namespace ttp::sim
