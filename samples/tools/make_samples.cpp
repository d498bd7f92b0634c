// Writes the other measurements of one twin run (samples/README.md): from
// the twin's per-feature results (`ttp twin --measurement json`, the cut
// piece as a cloud fit sees it) and its TALC log, the files the other
// instruments would give for the same piece, each simulated from the
// instrument's own physics (not through the project's readers):
//   dial.csv    dial-gauge readings against the reference facet/strip,
//               rounded to the gauge's 1 um resolution;
//   probe.csv   on-machine probing: for every planned point the stylus
//               ball moves along one axis until it touches the piece's
//               plane; the controller's skip position in the machine frame
//               (measurements.md section 2), with trigger noise;
//   piece.dmo   a CMM's DMIS output: every feature as FEAT/PLANE (the
//               datums at nominal, FEAT/CIRCLE for CYL199) in W;
//   spheres.csv R-test sphere centres at the log's first and a later R-test
//               (cycle, c_deg, x, y, z in the machine frame).
// Usage: make_samples MEASURED.json TALC.csv OUT_DIR SEED
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <random>

#include "probe_touch.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/rigid_table.h"
#include "ttp/geometry/rtest.h"
#include "ttp/inspect/measurement.h"
#include "ttp/plan/plan.h"
#include "ttp/thermal/talc_log.h"

namespace {

using namespace ttp;
constexpr double kDeg = M_PI / 180.0;

using test::TruePlane;

// The piece's planes in W from per-feature results (facets: distance and
// normal angle error; strips: depth and slope).
std::map<FeatureId, TruePlane> Planes(const PartSpec& part,
                                      const FeatureResults& features) {
  std::map<FeatureId, TruePlane> planes;
  for (const NominalFeature& f : TestFeatures(part)) {
    const auto it = features.find(f.Key());
    if (it == features.end() || !it->second.present) continue;
    const FeatureResult& r = it->second;
    const double angle = std::isfinite(r.angle_rad) ? r.angle_rad : 0.0;
    planes[f.Key()] = test::TrueFeaturePlane(f, r.d_mm, angle);
  }
  return planes;
}

std::string DialCsv(const PartSpec& part, const FeatureResults& features,
                    std::mt19937& rng) {
  std::normal_distribution<double> repeat(0.0, 0.5);
  std::map<std::string, double> reference;  // segment/strip reference d
  std::string csv =
      "# dial gauge readings, um, against the reference facet of each "
      "segment and the reference strip (measurements.md section 3)\n"
      "feature,reading_um\n";
  for (const NominalFeature& f : TestFeatures(part)) {
    if (f.kind != FeatureKind::kFacet && f.kind != FeatureKind::kStrip)
      continue;
    const std::string group =
        f.kind == FeatureKind::kStrip ? "Z" : f.id.substr(0, 2);
    if (f.index == part.reference_index)
      reference[group] = features.at(f.Key()).d_mm;
  }
  for (const NominalFeature& f : TestFeatures(part)) {
    if (f.kind != FeatureKind::kFacet && f.kind != FeatureKind::kStrip)
      continue;
    const std::string group =
        f.kind == FeatureKind::kStrip ? "Z" : f.id.substr(0, 2);
    double reading = 0;
    if (f.index != part.reference_index) {
      const double delta_um = (features.at(f.Key()).d_mm - reference[group]) * 1e3;
      // A facet further out reads less (the gauge is pushed in); a deeper
      // strip reads more.
      reading =
          (f.kind == FeatureKind::kStrip ? delta_um : -delta_um) + repeat(rng);
      reading = std::round(reading);  // 1 um resolution
      if (reading == 0) reading = 0;  // no "-0"
    }
    csv += fmt::format("{},{:g}\n", f.id, reading);
  }
  return csv;
}

std::string ProbeCsv(const Config& config,
                     const std::map<FeatureId, TruePlane>& planes,
                     std::mt19937& rng) {
  const PartSpec& part = config.part;
  std::normal_distribution<double> noise(0.0, 0.3e-3);
  const double r = config.process.probe.diameter_mm / 2;
  std::string csv = "point_id,x,y,z,c_deg\n";
  for (const plan::PlannedPoint& p : plan::PlanPoints(part)) {
    const Eigen::Vector3d n = p.normal_w;
    const double c_rad = test::ProbeTableAngleRad(config, p);
    // The ball centre moves along -n through the planned point + r n.
    Eigen::Vector3d centre =
        test::BallCentreAtTouch(part, planes, p, p.point_w_mm + r * n, n, r);
    centre += noise(rng) * n;
    const Eigen::Vector3d m = WorkpieceToMachine(config, centre, c_rad);
    csv += fmt::format("{},{:.4f},{:.4f},{:.4f},{:.4f}\n", p.id, m.x(), m.y(),
                       m.z(), c_rad / kDeg);
  }
  return csv;
}

std::string Label(const std::string& id) {
  std::string s = id;
  for (char& c : s) {
    if (c == '-') c = '_';
  }
  if (s == "FLANK+Y") return "FLANK_PY";
  if (s == "FLANK_Y") return "FLANK_NY";
  return s;
}

std::string DmisOutput(const PartSpec& part,
                       const std::map<FeatureId, TruePlane>& planes) {
  std::string out =
      "$$ DMIS output of the thermal test piece (samples/README.md)\n"
      "DMISMN/'ttp sample run-c',05.2\nUNITS/MM,ANGDEC\n";
  for (const NominalFeature& f : BuildNominalFeatures(part, Stage::kFinished)) {
    if (f.kind == FeatureKind::kNotchFloor || f.kind == FeatureKind::kMark)
      continue;
    Eigen::Vector3d n = f.normal, point = f.point;
    if (const auto it = planes.find(f.Key()); it != planes.end()) {
      n = it->second.n;
      point = f.point + (it->second.d - n.dot(f.point)) * n;  // on the plane
    }
    if (f.kind == FeatureKind::kCylinder) {
      if (f.Key() != FeatureId::DatumCylinder(part)) continue;
      out += fmt::format(
          "FA(CYL199)=FEAT/CIRCLE,INNER,CART,0,0,{:.4f},0,0,1,{:.4f}\n",
          point.z(), f.size_mm);
      continue;
    }
    out += fmt::format(
        "FA({})=FEAT/PLANE,CART,{:.4f},{:.4f},{:.4f},{:.7f},{:.7f},{:.7f}\n",
        Label(f.id), point.x(), point.y(), point.z(), n.x(), n.y(), n.z());
  }
  return out + "ENDFIL\n";
}

std::string SpheresCsv(const thermal::TalcLog& log) {
  RTestGeometry g;
  std::string csv =
      "# R-test sphere centres (machine frame, mm): cycle 0 at the log's "
      "first R-test, cycle 1 at its R-test nearest 4 h\n"
      "cycle,c_deg,x,y,z\n";
  const thermal::RTestRecord* first = &log.rtests.front();
  const thermal::RTestRecord* later = first;
  for (const auto& r : log.rtests)
    if (std::abs(r.t_ref_s - 4 * 3600) < std::abs(later->t_ref_s - 4 * 3600))
      later = &r;
  int cycle = 0;
  for (const thermal::RTestRecord* rec : {first, later}) {
    for (int k = 0; k < 8; ++k) {
      const double c = k * M_PI / 4;
      Eigen::Vector3d p = NominalSpherePosition(g, c);
      // Relative to the first R-test: cycle 0 is the reference.
      const CAxisErrors e = rec->measured - first->measured;
      p += TableDisplacement(e, p, g.sphere_distance_mm);
      csv += fmt::format("{},{},{:.5f},{:.5f},{:.5f}\n", cycle, k * 45, p.x(),
                         p.y(), p.z());
    }
    ++cycle;
  }
  return csv;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: make_samples MEASURED.json TALC.csv OUT_DIR SEED\n";
    return 2;
  }
  try {
    const Config config;
    const std::filesystem::path out = argv[3];
    std::mt19937 rng(static_cast<uint32_t>(std::stoul(argv[4])));
    const inspect::Measurement m = inspect::LoadMeasurement(config, argv[1]);
    const auto planes = Planes(config.part, m.result.features);
    WriteFileAtomic(out / "dial.csv",
                    DialCsv(config.part, m.result.features, rng));
    WriteFileAtomic(out / "probe.csv", ProbeCsv(config, planes, rng));
    WriteFileAtomic(out / "piece.dmo", DmisOutput(config.part, planes));
    WriteFileAtomic(out / "spheres.csv",
                    SpheresCsv(thermal::ReadTalcLog(argv[2])));
  } catch (const std::exception& e) {
    std::cerr << "make_samples: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
