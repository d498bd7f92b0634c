#include "ttp/plan/probe_program.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <regex>
#include <sstream>

#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/frames.h"

namespace ttp::plan {
namespace {

using gcode::CanonKind;
using gcode::CanonStatement;
using gcode::Dialect;

constexpr double kDeg = M_PI / 180.0;

// What each probing move must do, computed here from the drawing and the
// profile: the stylus centre at the nominal contact (program frame) and the
// outward normal in the machine frame.
struct Expected {
  std::string feature;
  Eigen::Vector3d contact;
  Eigen::Vector3d normal_m;
};

std::vector<Expected> ExpectedTouches(const Config& config,
                                      const std::vector<PlannedPoint>& points) {
  const double r = config.process.probe.diameter_mm / 2;
  const MachineProfile& m = config.machine;
  std::vector<Expected> out;
  // The sphere turned onto machine +X: centre (d, 0, table + h) in M.
  const Eigen::Vector3d centre = MachineToProgram(
      config, Eigen::Vector3d(m.sphere_distance_mm, 0,
                              m.table_top_z_mm + m.sphere_height_mm));
  for (const Eigen::Vector3d& n :
       {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0),
        Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, 1, 0),
        Eigen::Vector3d(0, -1, 0)})
    out.push_back({"SPHERE", centre + (m.sphere_radius_mm + r) * n, n});
  const auto piece = [&](const PlannedPoint& p) {
    // The table angle that turns the normal onto +X (horizontal) or 0.
    const bool vertical = p.normal_w.z() > 0.999;
    double c = 0;
    if (!vertical) {
      const double phi = std::atan2(p.normal_w.y(), p.normal_w.x());
      c = std::remainder(phi * m.c_sense, 2 * M_PI);
    }
    const Eigen::Vector3d n_m =
        WorkpieceToMachineRotation(c, m.c_sense) * p.normal_w;
    out.push_back(
        {p.feature.ToString(),
         MachineToProgram(config, WorkpieceToMachine(config, p.point_w_mm, c)) +
             r * n_m,
         n_m});
  };
  for (const PlannedPoint& p : points) piece(p);
  for (const PlannedPoint& p : points)
    if (p.feature.kind == FeatureKind::kFacet && p.feature.index == 5) piece(p);
  return out;
}

// Every probing move runs along one machine axis (the normal), C fixed,
// from outside the surface through the expected contact to beyond it.
void CheckProbeMoves(const Config& config,
                     const std::vector<PlannedPoint>& points,
                     const std::vector<CanonStatement>& canon) {
  const std::vector<Expected> expected = ExpectedTouches(config, points);
  size_t next = 0;
  for (size_t i = 1; i < canon.size(); ++i) {
    if (canon[i].kind != CanonKind::kProbe) continue;
    ASSERT_LT(next, expected.size());
    const Expected& e = expected[next++];
    const Eigen::Vector3d a = canon[i - 1].end_mm, b = canon[i].end_mm;
    EXPECT_DOUBLE_EQ(canon[i].end_c_rad, canon[i - 1].end_c_rad)
        << "C moved while probing";
    // The normal is along machine X or Z for the piece: C as planned.
    const Eigen::Vector3d ab = b - a;
    EXPECT_NEAR(ab.normalized().dot(-e.normal_m), 1.0, 1e-12)
        << "touch " << next << " on " << e.feature
        << " does not run along the approach";
    const double s = (e.contact - a).dot(ab) / ab.squaredNorm();
    EXPECT_GT(s, 0.0) << next;
    EXPECT_LT(s, 1.0) << next;
    EXPECT_LT((a + s * ab - e.contact).norm(), 1e-4) << next << e.feature;
    EXPECT_GT((a - e.contact).dot(e.normal_m), 1.0) << "starts off the surface";
  }
  EXPECT_EQ(next, expected.size());
}

TEST(ProbeProgramTest, OurReaderReadsBothDialectsAndTheMovesHitThePlan) {
  const Config config;
  const auto points = PlanProbePoints(config);
  for (Dialect d : {Dialect::kFanuc, Dialect::kLinuxCnc}) {
    const std::string text = WriteProbeProgram(config, points, d);
    const auto canon = gcode::ReadProgram(text, d, config, "probe");
    CheckProbeMoves(config, points, canon);
  }
}

// Lines of `text` in order.
std::vector<std::string> ProgramLines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string l;
  while (std::getline(in, l)) out.push_back(l);
  return out;
}
size_t FirstLine(const std::vector<std::string>& lines, const std::string& s) {
  for (size_t i = 0; i < lines.size(); ++i)
    if (lines[i].rfind(s, 0) == 0) return i;
  return lines.size();
}
size_t LastLine(const std::vector<std::string>& lines, const std::string& s) {
  for (size_t i = lines.size(); i-- > 0;)
    if (lines[i].rfind(s, 0) == 0) return i;
  return lines.size();
}

// Probe on only with the spindle stopped and oriented and the length offset
// on (with a Z word); off after the last touch; M-codes and variables from
// the profile.
TEST(ProbeProgramTest, ProbeSwitchedOnOrientedAndOffFromTheProfile) {
  Config config;
  config.machine.m_probe_on = 70;
  config.machine.m_probe_off = 71;
  config.machine.fanuc_skip_variables = {5061, 5062, 5063, 5064};
  config.machine.linuxcnc_probe_output = 3;
  const auto points = PlanProbePoints(config);
  for (Dialect d : {Dialect::kFanuc, Dialect::kLinuxCnc}) {
    const bool fanuc = d == Dialect::kFanuc;
    const auto l = ProgramLines(WriteProbeProgram(config, points, d));
    const size_t change = FirstLine(l, "T20 M6");
    const size_t stop = FirstLine(l, "M5");
    const size_t orient = FirstLine(l, "M19");
    const size_t offset = FirstLine(l, "G0 G43 H20 Z");
    const size_t on = FirstLine(l, fanuc ? "M70" : "M64 P3");
    const size_t first = FirstLine(l, fanuc ? "G31 " : "G38.2 ");
    const size_t last = LastLine(l, fanuc ? "G31 " : "G38.2 ");
    const size_t off = LastLine(l, fanuc ? "M71" : "M65 P3");
    ASSERT_LT(first, l.size()) << DialectName(d);
    EXPECT_LT(stop, change);
    EXPECT_LT(change, orient);
    EXPECT_LT(orient, offset);
    EXPECT_LT(offset, on);
    EXPECT_LT(on, first);
    EXPECT_LT(last, off);
    EXPECT_LT(off, FirstLine(l, "M30"));
    EXPECT_LT(FirstLine(l, fanuc ? "G17 G21 G40 G49 G69 G80 G90 G94"
                                 : "G17 G21 G40 G49 G80 G90 G94"),
              first);
    if (fanuc) {
      // C of an XYZBC machine declared as the 4th axis here: #5064.
      EXPECT_NE(l[first + 2].find("C#5064[33]"), std::string::npos)
          << l[first + 2];
      EXPECT_NE(l[first + 2].find("T#3012[60]"), std::string::npos);
    } else {
      EXPECT_NE(l[first + 1].find(",#5061,#5062,#5063,#5066,"),
                std::string::npos)
          << l[first + 1];
    }
  }
}

// FANUC: every G31 is followed by the check of its moving axis against the
// nominal contact; a G31 without a skip signal leaves the variable at the
// end of the move, which the check refuses.
TEST(ProbeProgramTest, FanucChecksEveryTouch) {
  const Config config;
  const ProbeOptions options;
  const auto points = PlanProbePoints(config);
  const auto l =
      ProgramLines(WriteProbeProgram(config, points, Dialect::kFanuc));
  const std::vector<Expected> expected = ExpectedTouches(config, points);
  static const std::regex g31(R"(G31 ([XYZ])(-?[0-9.]+) F[0-9.]+)");
  static const std::regex check(
      R"(IF \[ABS\[#(\d+)([-+][0-9.]+)\] GT ([0-9.]+)\] THEN #3000=(\d) \(.*\))");
  size_t n = 0;
  for (size_t i = 0; i + 1 < l.size(); ++i) {
    std::smatch a, b;
    if (!std::regex_match(l[i], a, g31)) continue;
    ASSERT_TRUE(std::regex_match(l[i + 1], b, check)) << l[i + 1];
    ASSERT_LT(n, expected.size());
    const Expected& e = expected[n++];
    const int axis = a[1].str()[0] - 'X';
    EXPECT_EQ(std::stoi(b[1]), config.machine.fanuc_skip_variables[axis]);
    // #var - nominal, the sign folded into the operator.
    const double nominal = -std::stod(b[2]);
    EXPECT_NEAR(nominal, e.contact[axis], 1e-4);
    const double window = std::stod(b[3]);
    // No touch: the skip position is the target.
    EXPECT_GT(std::abs(std::stod(a[2]) - nominal), window);
    // A touch within 0.1 mm of nominal passes.
    EXPECT_LT(0.1, window);
    EXPECT_EQ(std::stoi(b[4]), e.feature == "SPHERE"   ? 2
                               : n > points.size() + 5 ? 3
                                                       : 1);
  }
  EXPECT_EQ(n, expected.size());
}

// LinuxCNC's interpreter accepts the program; its canonical probe moves go
// through the planned contacts; every LOG row reports X, Y, Z and C of the
// probe position (#5061..#5063, #5066 on XYZBC: rs274 trips at the move's
// end), with the point id, feature and pass; the log is opened, headed and
// closed.
TEST(ProbeProgramTest, Rs274AcceptsTheLinuxCncProgramAndItsLog) {
  if (!gcode::Rs274Available()) GTEST_SKIP() << "rs274 not installed";
  const Config config;
  const auto points = PlanProbePoints(config);
  const std::string text =
      WriteProbeProgram(config, points, Dialect::kLinuxCnc);
  const auto rs = gcode::RunRs274(text, config);
  CheckProbeMoves(config, points, rs.statements);
  const auto ours = gcode::ReadProgram(text, Dialect::kLinuxCnc, config, "p");
  const auto diff = gcode::CompareToolpaths(ours, rs.statements);
  EXPECT_TRUE(diff.same) << diff.what;

  static const std::regex call(R"(^\s*\d+\s+N[.\d]+\s*([A-Z_]+)\((.*)\)\s*$)");
  std::istringstream in(rs.canon_text);
  std::string line;
  std::vector<double> probe_end;  // x y z (mm) c (deg) of the last probe
  std::vector<std::string> log;
  bool open = false, closed = false, oriented = false, probe_on = false;
  int rows = 0;
  const std::vector<Expected> expected = ExpectedTouches(config, points);
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_match(line, m, call)) continue;
    const std::string name = m[1], args = m[2];
    if (name == "ORIENT_SPINDLE") oriented = true;
    if (name == "SET_AUX_OUTPUT_BIT" &&
        std::stoi(args) == config.machine.linuxcnc_probe_output)
      probe_on = true;
    if (name == "LOGOPEN") open = true;
    if (name == "LOGCLOSE") closed = true;
    if (name == "STRAIGHT_PROBE") {
      EXPECT_TRUE(oriented && probe_on && open) << line;
      double v[6];
      ASSERT_EQ(std::sscanf(args.c_str(), "%lf, %lf, %lf, %lf, %lf, %lf", &v[0],
                            &v[1], &v[2], &v[3], &v[4], &v[5]),
                6);
      probe_end = {v[0], v[1], v[2], v[5]};
    }
    if (name == "LOG") {
      const std::string body = args.substr(1, args.size() - 2);
      if (log.empty()) {
        EXPECT_EQ(body, "point_id,x,y,z,c_deg,feature,pass");
        log.push_back(body);
        continue;
      }
      ASSERT_EQ(probe_end.size(), 4u) << "LOG before a probe move";
      std::vector<std::string> cells;
      std::istringstream cs(body);
      std::string c;
      while (std::getline(cs, c, ',')) cells.push_back(c);
      ASSERT_EQ(cells.size(), 7u) << body;
      for (int k = 0; k < 4; ++k)
        EXPECT_NEAR(std::stod(cells[1 + k]), probe_end[k], 1e-6) << body;
      ASSERT_LT(static_cast<size_t>(rows), expected.size());
      EXPECT_EQ(cells[5], expected[rows].feature);
      const std::string pass = rows < 5 ? "qualify"
                               : rows < 5 + static_cast<int>(points.size())
                                   ? "measure"
                                   : "drift";
      EXPECT_EQ(cells[6], pass);
      ++rows;
      probe_end.clear();
      log.push_back(body);
    }
  }
  EXPECT_TRUE(open && closed);
  EXPECT_EQ(rows, static_cast<int>(expected.size()));
}

// A ball that cannot reach a feature is refused before anything is
// written, naming the stylus; the datum circle's touches move up its band
// so that the default 3 mm ball clears the 200 mm cylinder's shoulder.
TEST(ProbeProgramTest, BallMustReachEveryFeature) {
  Config config;
  const auto points = PlanProbePoints(config);
  const double r = config.process.probe.diameter_mm / 2;
  for (const PlannedPoint& p : points) {
    if (p.feature != FeatureId::Cylinder(199)) continue;
    EXPECT_GE(p.point_w_mm.z(), config.part.datum_circle_z_min_mm);
    EXPECT_LE(p.point_w_mm.z(), config.part.datum_circle_z_max_mm);
    // The ball centre is off the 200 mm band (radius 100, z <= -16).
    const double rho = 99.5 + r;
    const double dz = p.point_w_mm.z() - (-16.0);
    EXPECT_GE(std::hypot(rho - 100.0, dz) - r, 0.2 - 1e-9);
  }
  // In the middle of the band the 3 mm ball hits the shoulder first.
  const auto plain = PlanPoints(config.part);
  try {
    CheckBallReach(config, plain);
    FAIL() << "CYL199 at mid-band is not reachable with a 3 mm ball";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "process.probe.diameter_mm");
    EXPECT_NE(e.problem().find("CYL199"), std::string::npos) << e.what();
    EXPECT_NE(e.problem().find("CYL200"), std::string::npos) << e.what();
  }
  // An 8 mm ball: no height in the 2 mm datum band clears the shoulder.
  config.process.probe.diameter_mm = 8.0;
  try {
    PlanProbePoints(config);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "process.probe.diameter_mm");
    EXPECT_NE(e.problem().find("datum band"), std::string::npos) << e.what();
  }
  // Facet touches too close to the 199 shoulder below them.
  config.process.probe.diameter_mm = 3.0;
  PlanOptions low;
  low.edge_margin_mm = 0;
  low.facet_rows = 10;
  try {
    PlanProbePoints(config, low);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "process.probe.diameter_mm");
    EXPECT_NE(e.problem().find("shoulder of CYL199"), std::string::npos)
        << e.what();
  }
  // A wide stylus between the flanks: the outer strips are out of reach.
  config.part.datum_circle_z_min_mm = -16.0;
  config.process.probe.diameter_mm = 13.0;
  std::vector<PlannedPoint> strips;
  for (const PlannedPoint& p : plain)
    if (p.feature == FeatureId::Strip(1)) strips.push_back(p);
  try {
    CheckBallReach(config, strips);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(e.problem().find("flank"), std::string::npos) << e.what();
  }
}

TEST(ProbeProgramTest, BadOptionsNameTheField) {
  ProbeOptions o;
  o.overtravel_mm = 0;
  std::string error;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("ProbeOptions.overtravel_mm"), std::string::npos);
  o = ProbeOptions();
  o.touch_window_mm = 2.5;  // wider than the overtravel: a miss would pass
  try {
    WriteProbeProgram(Config{}, {}, Dialect::kFanuc, o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "touch_window_mm");
  }
  o = ProbeOptions();
  o.log_file = "probe log.csv";
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("log_file"), std::string::npos);
}

}  // namespace
}  // namespace ttp::plan
