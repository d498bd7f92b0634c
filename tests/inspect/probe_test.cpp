#include "ttp/inspect/probe.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>

#include "feature_ids.h"
#include "probe_touch.h"
#include "test_dir.h"
#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/measurement.h"
#include "ttp/plan/plan.h"
#include "ttp/plan/probe_program.h"

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
  std::map<FeatureId, test::TruePlane> planes;
  ProbingRun run;
  for (const NominalFeature& f : TestFeatures(part)) {
    FeatureResult r;
    r.present = true;
    r.d_mm = f.kind == FeatureKind::kStrip ? -part.strip_floor_z_mm + dev_d(rng)
                                           : f.size_mm + dev_d(rng);
    r.angle_rad = dev_a(rng);
    run.truth.features[f.Key()] = r;
    planes[f.Key()] = test::TrueFeaturePlane(f, r.d_mm, r.angle_rad);
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
    const double c_rad = test::ProbeTableAngleRad(config, p);
    // The probing line in W_nominal: the ball centre moves along -n
    // through planned point + r n. In the piece's own frame:
    const Eigen::Isometry3d to_piece = placement.inverse();
    Eigen::Vector3d centre = test::BallCentreAtTouch(
        part, planes, p, to_piece * (p.point_w_mm + r * n),
        to_piece.linear() * n, r);
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

std::string ProbeErrorOf(const std::string& csv) {
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
    const std::string e = ProbeErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:3: point_id"), std::string::npos) << e;
    EXPECT_NE(e.find("not in the point list"), std::string::npos) << e;
  }
  // A point given twice.
  {
    auto v = lines;
    v.push_back(v[1]);
    EXPECT_NE(ProbeErrorOf(join(v)).find("given twice"), std::string::npos);
  }
  // Missing column.
  {
    auto v = lines;
    v[0] = "point_id,x,y,z";
    for (size_t i = 1; i < v.size(); ++i)
      v[i] = v[i].substr(0, v[i].rfind(','));
    const std::string e = ProbeErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:1: c_deg"), std::string::npos) << e;
  }
  // NaN and text.
  {
    auto v = lines;
    v[4] = v[4].substr(0, v[4].find(',') + 1) + "nan" +
           v[4].substr(v[4].find(',', v[4].find(',') + 1));
    const std::string e = ProbeErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:5: x"), std::string::npos) << e;
  }
  {
    auto v = lines;
    v[6] = v[6].substr(0, v[6].rfind(',') + 1) + "ninety";
    EXPECT_NE(ProbeErrorOf(join(v)).find("probe.csv:7: c_deg"),
              std::string::npos);
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
    const std::string e = ProbeErrorOf(join(v));
    EXPECT_NE(e.find("probe.csv:3: x,y,z"), std::string::npos) << e;
    EXPECT_NE(e.find("machine frame"), std::string::npos) << e;
  }
  EXPECT_NE(ProbeErrorOf("point_id,x,y,z,c_deg\n").find("no probe results"),
            std::string::npos);
  // A facet with too few points is missing, with a warning.
  {
    ProbeImport imp;
    auto v = lines;
    std::vector<std::string> keep{v[0]};
    const auto pts = plan::PlanPoints(config.part);
    int kept = 0;
    for (size_t i = 1; i < v.size(); ++i)
      if (pts[i - 1].feature != test::Fid("X2-4") || kept++ < 2)
        keep.push_back(v[i]);
    imp = ReadProbeResults(config, join(keep), "probe.csv");
    EXPECT_EQ(imp.results.count(test::Fid("X2-4")), 0u);
    EXPECT_EQ(imp.results.count(test::Fid("X2-3")), 1u);
    ASSERT_FALSE(imp.warnings.empty());
    EXPECT_NE(imp.warnings[0].find("X2-4 has 2 points"), std::string::npos);
  }
}

// ---- The probing program's own logs -------------------------------------

// A finished piece whose facets and strips sit delta_mm off nominal along
// their normals, an R-test sphere off its profile position, a stylus whose
// effective radius is not the nominal, and the reference facets grown by
// drift_mm by the end of the run. Contacts are computed along the probe
// moves as the controller executes them (start and end of each move from
// the interpreter's canon), independently of the reader.
struct TrueRun {
  std::map<std::string, double> delta_mm;
  Eigen::Vector3d sphere_offset_mm{0.31, -0.22, 0.17};
  double r_eff_mm = 1.4962;
  double drift_mm = 0.0007;
  InspectionResult truth;
};

TrueRun MakeTrueRun(const Config& config, uint32_t seed) {
  TrueRun run;
  std::mt19937 rng(seed);
  std::normal_distribution<double> dev(0.0, 5e-3);
  for (const NominalFeature& f : TestFeatures(config.part)) {
    const double delta = dev(rng);
    run.delta_mm[f.id] = delta;
    FeatureResult r;
    r.present = true;
    r.d_mm = f.kind == FeatureKind::kStrip
                 ? -(config.part.strip_floor_z_mm + delta)
                 : f.size_mm + delta;
    run.truth.features[f.Key()] = r;
  }
  ComputeResultFigures(config.part, &run.truth);
  return run;
}

// Ball centre (program frame) where the move a -> b at table angle c first
// touches the true surface of `feature` (planned point p for planes).
Eigen::Vector3d TrueContact(const Config& config, const TrueRun& run,
                            const std::string& feature, const std::string& pass,
                            const plan::PlannedPoint* p,
                            const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            double c_rad) {
  const double r = run.r_eff_mm;
  // |q + s (b - a) - centre| = radius, first root.
  const auto sphere_hit =
      [&](const Eigen::Vector3d& q, const Eigen::Vector3d& d,
          const Eigen::Vector3d& centre, double radius, int dims) {
        Eigen::Vector3d qq = q - centre, dd = d;
        if (dims == 2) qq.z() = dd.z() = 0;
        const double A = dd.squaredNorm(), B = 2 * qq.dot(dd),
                     C = qq.squaredNorm() - radius * radius;
        const double disc = B * B - 4 * A * C;
        EXPECT_GE(disc, 0) << feature << ": the move misses the surface";
        return (-B - std::sqrt(std::max(0.0, disc))) / (2 * A);
      };
  if (feature == "SPHERE") {
    const MachineProfile& m = config.machine;
    const Eigen::Vector3d centre =
        MachineToProgram(
            config, Eigen::Vector3d(m.sphere_distance_mm, 0,
                                    m.table_top_z_mm + m.sphere_height_mm)) +
        run.sphere_offset_mm;
    const double s = sphere_hit(a, b - a, centre, m.sphere_radius_mm + r, 3);
    return a + s * (b - a);
  }
  // In W: the surface does not turn with the move.
  const auto to_w = [&](const Eigen::Vector3d& q) {
    return MachineToWorkpiece(config, ProgramToMachine(config, q), c_rad);
  };
  const Eigen::Vector3d aw = to_w(a), dw = to_w(b) - aw;
  double s = 0;
  if (feature == "CYL199") {
    s = sphere_hit(aw, dw, Eigen::Vector3d::Zero(), 99.5 + r, 2);
  } else {
    const Eigen::Vector3d n = p->normal_w;
    double d = n.dot(p->point_w_mm);
    auto it = run.delta_mm.find(feature);
    if (it != run.delta_mm.end()) d += it->second;
    if (pass == "drift") d += run.drift_mm;
    s = (d + r - n.dot(aw)) / n.dot(dw);
  }
  EXPECT_GT(s, 0.0) << feature;
  EXPECT_LT(s, 1.0) << feature;
  return a + s * (b - a);
}

void ExpectTruth(const TrueRun& run, const ProbeImport& imp, double tol_mm) {
  EXPECT_TRUE(imp.qualified);
  EXPECT_NEAR(imp.stylus_radius_mm, run.r_eff_mm, tol_mm);
  for (const auto& [id, f] : run.truth.features)
    EXPECT_NEAR(imp.results.at(id).d_mm, f.d_mm, tol_mm) << id;
  InspectionResult r;
  r.features = imp.results;
  ComputeResultFigures(Config{}.part, &r);
  ASSERT_EQ(r.figures.size(), run.truth.figures.size());
  for (size_t c = 0; c < r.figures.size(); ++c) {
    EXPECT_NEAR(r.figures[c].e_x_mm, run.truth.figures[c].e_x_mm, tol_mm);
    EXPECT_NEAR(r.figures[c].e_y_mm, run.truth.figures[c].e_y_mm, tol_mm);
    EXPECT_NEAR(r.figures[c].e_z_mm, run.truth.figures[c].e_z_mm, tol_mm);
    EXPECT_NEAR(r.figures[c].e_ttp_mm, run.truth.figures[c].e_ttp_mm, tol_mm);
  }
  ASSERT_EQ(imp.drift.size(), 4u);
  for (const ProbeDrift& d : imp.drift) {
    EXPECT_NEAR(d.mean_um, run.drift_mm * 1e3, tol_mm * 1e3 * 2) << d.feature;
    EXPECT_EQ(d.points, 6) << d.feature;
  }
}

// The LinuxCNC log: LinuxCNC's interpreter runs the program; each (LOG,...)
// row it reports (canon LOG, parameters substituted with %lf) is written
// with the probe position the controller would have at the true contact of
// the canon's STRAIGHT_PROBE before it. The file goes back through `ttp
// inspect`'s reader as it is.
TEST(ProbeTest, LinuxCncLogFromRs274ComesBackToTheFigures) {
  if (!gcode::Rs274Available()) GTEST_SKIP() << "rs274 not installed";
  const Config config;
  const auto points = plan::PlanProbePoints(config);
  std::map<int, const plan::PlannedPoint*> by_id;
  for (const auto& p : points) by_id[p.id] = &p;
  const auto rs = gcode::RunRs274(
      plan::WriteProbeProgram(config, points, gcode::Dialect::kLinuxCnc),
      config);
  const TrueRun run = MakeTrueRun(config, 7);
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> moves;
  std::vector<double> c_of_move;
  for (size_t i = 1; i < rs.statements.size(); ++i)
    if (rs.statements[i].kind == gcode::CanonKind::kProbe) {
      moves.emplace_back(rs.statements[i - 1].end_mm, rs.statements[i].end_mm);
      c_of_move.push_back(rs.statements[i].end_c_rad);
    }
  static const std::regex log_re(
      R"re(^\s*\d+\s+N[.\d]+\s*LOG\("(.*)"\)\s*$)re");
  std::istringstream in(rs.canon_text);
  std::string line, log;
  size_t k = 0;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, log_re)) continue;
    const std::string body = m[1];
    if (log.empty()) {
      log = body + "\n";
      continue;
    }
    std::vector<std::string> cells;
    std::istringstream cs(body);
    std::string c;
    while (std::getline(cs, c, ',')) cells.push_back(c);
    ASSERT_EQ(cells.size(), 7u);
    ASSERT_LT(k, moves.size());
    const plan::PlannedPoint* p =
        cells[5] == "SPHERE" ? nullptr : by_id.at(std::stoi(cells[0]));
    const Eigen::Vector3d q =
        TrueContact(config, run, cells[5], cells[6], p, moves[k].first,
                    moves[k].second, c_of_move[k]);
    log += fmt::format("{},{:.6f},{:.6f},{:.6f},{},{},{}\n", cells[0], q.x(),
                       q.y(), q.z(), cells[4], cells[5], cells[6]);
    ++k;
  }
  EXPECT_EQ(k, moves.size());
  const ProbeImport imp = ReadProbeResults(config, log, "ttp-probe-log.csv");
  ExpectTruth(run, imp, 0.02e-3);
  // The same log read with the nominal radius would be 3.8 um off: the
  // qualified radius is the one in use.
  EXPECT_GT(std::abs(run.r_eff_mm - config.process.probe.diameter_mm / 2),
            0.003);
}

// The FANUC program's DPRNT output, formatted as the control prints
// #5061[44] (four decimals), read through the measurement loader (the file
// is recognised by its first line).
TEST(ProbeTest, FanucDprntOutputComesBackToTheFigures) {
  const Config config;
  const auto points = plan::PlanProbePoints(config);
  std::map<int, const plan::PlannedPoint*> by_id;
  for (const auto& p : points) by_id[p.id] = &p;
  const std::string text =
      plan::WriteProbeProgram(config, points, gcode::Dialect::kFanuc);
  const auto canon =
      gcode::ReadProgram(text, gcode::Dialect::kFanuc, config, "probe.nc");
  const TrueRun run = MakeTrueRun(config, 8);
  std::string out = "%\nTTP PROBE LOG O1002 D20261125 T 93015\n";
  int clock = 93016;
  for (size_t i = 1; i + 1 < canon.size(); ++i) {
    if (canon[i].kind != gcode::CanonKind::kProbe) continue;
    const auto& report = canon[i + 1];
    ASSERT_EQ(report.kind, gcode::CanonKind::kReport);
    std::vector<std::string> parts;
    std::istringstream ps(report.text);
    std::string part;
    while (std::getline(ps, part, ',')) parts.push_back(part);
    ASSERT_GE(parts.size(), 3u) << report.text;
    ASSERT_NE(report.text.find("C#5065[33]"), std::string::npos);
    const std::string pass = Lower(parts[0]);
    const plan::PlannedPoint* p =
        parts[2] == "SPHERE" ? nullptr : by_id.at(std::stoi(parts[1]));
    const Eigen::Vector3d q =
        TrueContact(config, run, parts[2], pass, p, canon[i - 1].end_mm,
                    canon[i].end_mm, canon[i].end_c_rad);
    out +=
        fmt::format("{} {} {} X{:10.4f} Y{:10.4f} Z{:10.4f} C{:8.3f} T{:6d}\n",
                    parts[0], parts[1], parts[2], q.x(), q.y(), q.z(),
                    canon[i].end_c_rad / kDeg, clock++);
  }
  out += "%\n";
  const std::filesystem::path file = test::TestDir("probe_log") / "probe.txt";
  std::ofstream(file) << out;
  const Measurement m = LoadMeasurement(config, file.string());
  EXPECT_EQ(m.kind, MeasurementKind::kProbe);
  const ProbeImport imp = ReadProbeResults(config, out, "probe.txt");
  // Four decimals: 0.05 um per touch.
  ExpectTruth(run, imp, 0.2e-3);
  for (const auto& [id, f] : run.truth.features)
    EXPECT_NEAR(m.result.features.at(id).d_mm, f.d_mm, 0.2e-3) << id;
}

// A log whose feature names do not match the point list (another plan) is
// refused, naming the line.
TEST(ProbeTest, LogOfAnotherPlanIsRefused) {
  const std::string log =
      "point_id,x,y,z,c_deg,feature,pass\n"
      "1,10,10,1.5,0,X1-5,measure\n";
  try {
    ReadProbeResults(Config{}, log, "log.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "feature");
    EXPECT_NE(std::string(e.what()).find("log.csv:2"), std::string::npos);
  }
}

}  // namespace
}  // namespace ttp::inspect
