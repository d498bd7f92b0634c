#include "ttp/inspect/probe.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <sstream>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"
#include "ttp/inspect/inspect.h"
#include "ttp/plan/plan.h"
#include "feature_ids.h"

namespace ttp::inspect {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct ProbingRun {
  std::string csv;
  InspectionResult truth;
};

// A probing run on the machine, simulated independently of the reader: the
// piece's facets and strips deviate by known amounts; the piece sits on the
// table shifted by `placement` (so the datums matter); for every planned
// point the stylus ball moves along the plan's one axis until it touches
// the true surface; the controller reports its centre in M, with trigger
// noise of `noise_um` along the probing axis, to `decimals` places.
ProbingRun SimulateProbing(const Config& config, uint32_t seed, double noise_um,
                           int decimals) {
  const PartSpec& part = config.part;
  std::mt19937 rng(seed);
  std::normal_distribution<double> dev_d(0.0, 5e-3), dev_a(0.0, 20e-6),
      noise(0.0, noise_um * 1e-3);
  // True planes in W: facets n . x = d (n rotated by angle about Z), strips
  // z = -d + tan(beta) x; datums nominal.
  struct TruePlane {
    Eigen::Vector3d n;
    double d;
  };
  std::map<std::string, TruePlane> planes;
  ProbingRun run;
  for (const NominalFeature& f : TestFeatures(part)) {
    FeatureResult r;
    r.present = true;
    r.d_mm = f.kind == FeatureKind::kStrip ? -part.strip_floor_z_mm + dev_d(rng)
                                           : f.size_mm + dev_d(rng);
    r.angle_rad = dev_a(rng);
    run.truth.features[f.Key()] = r;
    if (f.kind == FeatureKind::kStrip) {
      // z = -d + s x  <=>  (-s, 0, 1) . x = -d, normalised.
      const Eigen::Vector3d n(-std::tan(r.angle_rad), 0, 1);
      planes[f.id] = {n.normalized(), -r.d_mm / n.norm()};
    } else {
      const double phi = std::atan2(f.normal.y(), f.normal.x()) + r.angle_rad;
      planes[f.id] = {Eigen::Vector3d(std::cos(phi), std::sin(phi), 0), r.d_mm};
    }
  }
  ComputeResultFigures(part, &run.truth);
  // The piece on the table: W_true -> W_nominal.
  Eigen::Isometry3d placement = Eigen::Isometry3d::Identity();
  placement.rotate(Eigen::AngleAxisd(150e-6, Eigen::Vector3d::UnitZ()));
  placement.rotate(Eigen::AngleAxisd(30e-6, Eigen::Vector3d::UnitX()));
  placement.translation() = Eigen::Vector3d(0.020, -0.015, 0.010);

  const double r = config.process.probe.diameter_mm / 2;
  std::string csv = "point_id,x,y,z,c_deg\n";
  for (const plan::PlannedPoint& p : plan::PlanPoints(part)) {
    const Eigen::Vector3d n = p.normal_w;
    const bool vertical = std::abs(n.z()) > 0.999;
    double c_rad = 0;
    if (!vertical)
      c_rad =
          TableAngleFor(std::atan2(n.y(), n.x()), 0.0, config.machine.c_sense);
    c_rad = std::remainder(c_rad, 2 * M_PI);
    // The probing line in W_nominal: the ball centre moves along -n
    // through planned point + r n. In the piece's own frame:
    const Eigen::Isometry3d to_piece = placement.inverse();
    const Eigen::Vector3d start = to_piece * (p.point_w_mm + r * n);
    const Eigen::Vector3d dir = to_piece.linear() * n;
    Eigen::Vector3d centre;
    auto it = planes.find(p.feature);
    if (it != planes.end()) {
      const TruePlane& tp = it->second;
      // tp.n . (start + t dir) - tp.d = r
      const double t = (r + tp.d - tp.n.dot(start)) / tp.n.dot(dir);
      centre = start + t * dir;
    } else if (p.feature == "CYL199") {
      // |xy(start + t dir)| = R + r
      const double big = part.ref_cylinders.front().diameter_mm / 2 + r;
      const Eigen::Vector2d s2 = start.head<2>(), d2 = dir.head<2>();
      const double a = d2.squaredNorm(), b = 2 * s2.dot(d2),
                   c = s2.squaredNorm() - big * big;
      const double t = (-b + std::sqrt(b * b - 4 * a * c)) / (2 * a);
      centre = start + t * dir;
    } else {
      // TOP and the flanks: the nominal planes through the planned points.
      const Eigen::Vector3d nn = p.normal_w;
      const double d = nn.dot(p.point_w_mm);
      const double t = (r + d - nn.dot(start)) / nn.dot(dir);
      centre = start + t * dir;
    }
    centre = placement * centre + noise(rng) * n;
    const Eigen::Vector3d m = WorkpieceToMachine(config, centre, c_rad);
    csv +=
        fmt::format("{},{:.{}f},{:.{}f},{:.{}f},{:.4f}\n", p.id, m.x(),
                    decimals, m.y(), decimals, m.z(), decimals, c_rad / kDeg);
  }
  run.csv = csv;
  return run;
}

InspectionResult Read(const Config& config, const std::string& csv,
                      double repeatability_um) {
  ProbeReadOptions o;
  o.repeatability_um = repeatability_um;
  const ProbeImport imp = ReadProbeResults(config, csv, "probe.csv", o);
  InspectionResult r;
  r.features = imp.results;
  ComputeResultFigures(config.part, &r);
  return r;
}

// Without noise (6 decimals), the figures come back exactly: the frames,
// the table angles, the stylus compensation and the datum alignment are
// right.
TEST(ProbeTest, ExactWithoutNoise) {
  const Config config;
  const ProbingRun run = SimulateProbing(config, 1, 0.0, 6);
  const InspectionResult r = Read(config, run.csv, 0.5);
  ASSERT_EQ(r.figures.size(), run.truth.figures.size());
  for (size_t c = 0; c < r.figures.size(); ++c) {
    const CycleFigures &a = r.figures[c], &t = run.truth.figures[c];
    EXPECT_NEAR(a.e_x_mm, t.e_x_mm, 0.01e-3) << c;
    EXPECT_NEAR(a.e_y_mm, t.e_y_mm, 0.01e-3) << c;
    EXPECT_NEAR(a.e_z_mm, t.e_z_mm, 0.01e-3) << c;
    EXPECT_NEAR(a.e_ttp_mm, t.e_ttp_mm, 0.01e-3) << c;
    EXPECT_NEAR(a.e_b_rad, t.e_b_rad, 0.05e-6) << c;
  }
  for (const auto& [id, f] : run.truth.features) {
    EXPECT_NEAR(r.features.at(id).d_mm, f.d_mm, 0.01e-3) << id;
    EXPECT_NEAR(r.features.at(id).angle_rad, f.angle_rad, 0.5e-6) << id;
  }
}

// With 0.5 um trigger noise the figures come back within their stated
// expanded uncertainty (k = 2) twice over, over several runs, and the U is
// of the size the noise implies (not inflated).
TEST(ProbeTest, WithinNoiseAndStatedUncertainty) {
  const Config config;
  int inside = 0, total = 0;
  for (uint32_t seed = 10; seed < 30; ++seed) {
    const ProbingRun run = SimulateProbing(config, seed, 0.5, 4);
    const InspectionResult r = Read(config, run.csv, 0.5);
    for (size_t c = 0; c < r.figures.size(); ++c) {
      const CycleFigures &a = r.figures[c], &t = run.truth.figures[c];
      const std::pair<double, double> vals[] = {
          {a.e_x_mm - t.e_x_mm, a.u_x_mm},
          {a.e_y_mm - t.e_y_mm, a.u_y_mm},
          {a.e_z_mm - t.e_z_mm, a.u_z_mm},
          {a.e_b_rad - t.e_b_rad, a.u_b_rad},
          {a.e_ttp_mm - t.e_ttp_mm, a.u_ttp_mm}};
      for (const auto& [err, u] : vals) {
        ++total;
        inside += std::abs(err) <= 2 * u;
        EXPECT_LE(std::abs(err), 4 * u) << "seed " << seed << " cycle " << c;
      }
      EXPECT_LT(a.u_x_mm, 1e-3);  // 6 points per facet at 0.5 um
    }
  }
  EXPECT_GE(static_cast<double>(inside) / total, 0.93);
}

// The probing program prints the skip position in the work offset (G54):
// such a file is recognised and gives the same results, with a warning.
TEST(ProbeTest, ProgramFrameFileIsRecognised) {
  const Config config;
  const ProbingRun run = SimulateProbing(config, 4, 0.0, 6);
  std::istringstream in(run.csv);
  std::string line, csv;
  std::getline(in, line);
  csv = line + "\n";
  while (std::getline(in, line)) {
    std::vector<std::string> c;
    std::istringstream cells(line);
    std::string cell;
    while (std::getline(cells, cell, ',')) c.push_back(cell);
    const Eigen::Vector3d p = MachineToProgram(
        config,
        Eigen::Vector3d(std::stod(c[1]), std::stod(c[2]), std::stod(c[3])));
    csv += fmt::format("{},{:.6f},{:.6f},{:.6f},{}\n", c[0], p.x(), p.y(),
                       p.z(), c[4]);
  }
  const ProbeImport m = ReadProbeResults(config, run.csv, "m.csv");
  const ProbeImport p = ReadProbeResults(config, csv, "p.csv");
  for (const auto& [id, f] : m.results)
    EXPECT_NEAR(p.results.at(id).d_mm, f.d_mm, 1e-9) << id;
  ASSERT_FALSE(p.warnings.empty());
  EXPECT_NE(p.warnings[0].find("program-frame"), std::string::npos);
  // Told it is the machine frame, the same file is an error.
  ProbeReadOptions o;
  o.frame = ProbeFrame::kMachine;
  EXPECT_THROW(ReadProbeResults(config, csv, "p.csv", o), InputError);
}

std::string ErrorOf(const std::string& csv) {
  try {
    ReadProbeResults(Config{}, csv, "probe.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ProbeTest, BadRowsNameLineAndField) {
  const Config config;
  const ProbingRun run = SimulateProbing(config, 2, 0.0, 4);
  std::vector<std::string> lines;
  {
    std::istringstream in(run.csv);
    std::string l;
    while (std::getline(in, l)) lines.push_back(l);
  }
  auto join = [](const std::vector<std::string>& v) {
    std::string s;
    for (const auto& l : v) s += l + "\n";
    return s;
  };
  // Unknown point id on line 3.
  {
    auto v = lines;
    v[2] = "99999" + v[2].substr(v[2].find(','));
    const std::string e = ErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:3: point_id"), std::string::npos) << e;
    EXPECT_NE(e.find("not in the point list"), std::string::npos) << e;
  }
  // A point given twice.
  {
    auto v = lines;
    v.push_back(v[1]);
    EXPECT_NE(ErrorOf(join(v)).find("given twice"), std::string::npos);
  }
  // Missing column.
  {
    auto v = lines;
    v[0] = "point_id,x,y,z";
    for (size_t i = 1; i < v.size(); ++i)
      v[i] = v[i].substr(0, v[i].rfind(','));
    const std::string e = ErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:1: c_deg"), std::string::npos) << e;
  }
  // NaN and text.
  {
    auto v = lines;
    v[4] = v[4].substr(0, v[4].find(',') + 1) + "nan" +
           v[4].substr(v[4].find(',', v[4].find(',') + 1));
    const std::string e = ErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:5: x"), std::string::npos) << e;
  }
  {
    auto v = lines;
    v[6] = v[6].substr(0, v[6].rfind(',') + 1) + "ninety";
    EXPECT_NE(ErrorOf(join(v)).find("probe.csv:7: c_deg"), std::string::npos);
  }
  // One row in the program frame among machine-frame rows (z 54 mm off).
  {
    auto v = lines;
    std::vector<std::string> cells;
    std::istringstream in(v[2]);
    std::string c;
    while (std::getline(in, c, ',')) cells.push_back(c);
    cells[3] = fmt::format("{:.4f}", std::stod(cells[3]) - 54.0);
    v[2] = cells[0] + "," + cells[1] + "," + cells[2] + "," + cells[3] + "," +
           cells[4];
    const std::string e = ErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:3: x,y,z"), std::string::npos) << e;
    EXPECT_NE(e.find("machine frame"), std::string::npos) << e;
  }
  EXPECT_NE(ErrorOf("point_id,x,y,z,c_deg\n").find("no probe results"),
            std::string::npos);
  // A facet with too few points is missing, with a warning.
  {
    ProbeImport imp;
    auto v = lines;
    std::vector<std::string> keep{v[0]};
    const auto pts = plan::PlanPoints(config.part);
    int kept = 0;
    for (size_t i = 1; i < v.size(); ++i)
      if (pts[i - 1].feature != "X2-4" || kept++ < 2) keep.push_back(v[i]);
    imp = ReadProbeResults(config, join(keep), "probe.csv");
    EXPECT_EQ(imp.results.count(test::Fid("X2-4")), 0u);
    EXPECT_EQ(imp.results.count(test::Fid("X2-3")), 1u);
    ASSERT_FALSE(imp.warnings.empty());
    EXPECT_NE(imp.warnings[0].find("X2-4 has 2 points"), std::string::npos);
  }
}

}  // namespace
}  // namespace ttp::inspect
