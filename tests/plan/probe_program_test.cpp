#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ttp/gcode/reader.h"
#include "ttp/gcode/rs274.h"
#include "ttp/gcode/writer.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/frames.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

using gcode::CanonKind;
using gcode::CanonStatement;
using gcode::Dialect;

// Each probing move runs along one machine axis, through the stylus centre
// at contact (planned point + stylus radius along the normal, in program
// coordinates at the table angle of the move), starting off the surface.
void CheckProbeMoves(const Config& config,
                     const std::vector<PlannedPoint>& points,
                     const std::vector<CanonStatement>& canon) {
  const double r = config.process.probe.diameter_mm / 2;
  size_t next = 0;
  for (size_t i = 1; i < canon.size(); ++i) {
    if (canon[i].kind != CanonKind::kProbe) continue;
    ASSERT_LT(next, points.size());
    const PlannedPoint& p = points[next++];
    const Eigen::Vector3d a = canon[i - 1].end_mm, b = canon[i].end_mm;
    const double c = canon[i].end_c_rad;
    EXPECT_DOUBLE_EQ(c, canon[i - 1].end_c_rad) << "C moved while probing";
    int moving = 0;
    for (int k = 0; k < 3; ++k) moving += std::abs(a[k] - b[k]) > 1e-9;
    EXPECT_EQ(moving, 1) << "point " << p.id;
    const Eigen::Vector3d n_m =
        WorkpieceToMachineRotation(c, config.machine.c_sense) * p.normal_w;
    const Eigen::Vector3d contact =
        MachineToProgram(config, WorkpieceToMachine(config, p.point_w_mm, c)) +
        r * n_m;
    // contact lies on segment a-b, a outside the surface, b inside.
    const Eigen::Vector3d ab = b - a;
    const double s = (contact - a).dot(ab) / ab.squaredNorm();
    EXPECT_GT(s, 0.0) << "point " << p.id;
    EXPECT_LT(s, 1.0) << "point " << p.id;
    EXPECT_LT((a + s * ab - contact).norm(), 1e-3) << "point " << p.id;
    EXPECT_GT((a - contact).dot(n_m), 1.0) << "starts off the surface";
  }
  EXPECT_EQ(next, points.size());
}

TEST(ProbeProgramTest, OneLinearAxisPerPointThroughTheContact) {
  const Config config;
  const auto points = PlanPoints(config.part);
  const auto program = BuildProbeProgram(config, points);
  for (Dialect d : {Dialect::kFanuc, Dialect::kLinuxCnc}) {
    const std::string text = gcode::WriteProgram(program, d, config);
    const auto canon = gcode::ReadProgram(text, d, config, "probe");
    CheckProbeMoves(config, points, canon);
  }
}

TEST(ProbeProgramTest, ReportsEverySkipPosition) {
  const Config config;
  const auto points = PlanPoints(config.part);
  const std::string fanuc = gcode::WriteProgram(
      BuildProbeProgram(config, points), Dialect::kFanuc, config);
  EXPECT_NE(fanuc.find("G31 X"), std::string::npos);
  EXPECT_NE(fanuc.find("DPRNT[PROBE*1*X#5061[44]"), std::string::npos);
  EXPECT_NE(fanuc.find("POPEN"), std::string::npos);
  const std::string lcnc = gcode::WriteProgram(
      BuildProbeProgram(config, points), Dialect::kLinuxCnc, config);
  EXPECT_EQ(lcnc.find("G31"), std::string::npos);
  EXPECT_NE(lcnc.find("G38.2"), std::string::npos);
  EXPECT_NE(lcnc.find(fmt::format("(print,probe,{},#5061", points.back().id)),
            std::string::npos);
}

TEST(ProbeProgramTest, Rs274AcceptsTheLinuxCncProgram) {
  if (!gcode::Rs274Available()) GTEST_SKIP() << "rs274 not installed";
  const Config config;
  const auto points = PlanPoints(config.part);
  const std::string text = gcode::WriteProgram(
      BuildProbeProgram(config, points), Dialect::kLinuxCnc, config);
  auto rs = gcode::RunRs274(text, config);
  auto ours = gcode::ReadProgram(text, Dialect::kLinuxCnc, config, "p");
  // rs274 substitutes #5061..#5063 and #5066 (C on XYZBC) in the report:
  // without a probe it
  // "trips" at the end of the move, which the report must then show.
  int reports = 0;
  for (size_t i = 1; i < rs.statements.size(); ++i) {
    auto& s = rs.statements[i];
    if (s.kind != CanonKind::kReport || s.text.rfind("probe,", 0) != 0)
      continue;
    ++reports;
    double id, x, y, z, c;
    ASSERT_EQ(std::sscanf(s.text.c_str(), "probe,%lf,%lf,%lf,%lf,%lf", &id, &x,
                          &y, &z, &c),
              5)
        << s.text;
    EXPECT_NEAR(x, s.end_mm.x(), 1e-5);
    EXPECT_NEAR(y, s.end_mm.y(), 1e-5);
    EXPECT_NEAR(z, s.end_mm.z(), 1e-5);
    // #5066 is C on LinuxCNC's XYZBC machine (#5064 would be A: 0).
    EXPECT_NEAR(c, s.end_c_rad * 180.0 / M_PI, 1e-4) << s.text;
    s.text = "probe";
  }
  EXPECT_EQ(reports, static_cast<int>(points.size()));
  for (auto& s : ours)
    if (s.kind == CanonKind::kReport && s.text.rfind("probe,", 0) == 0)
      s.text = "probe";
  const auto diff = gcode::CompareToolpaths(ours, rs.statements);
  EXPECT_TRUE(diff.same) << diff.what;
  CheckProbeMoves(config, points, rs.statements);
}

TEST(ProbeProgramTest, BadOptionsNameTheField) {
  ProbeOptions o;
  o.overtravel_mm = 0;
  try {
    BuildProbeProgram(Config{}, {}, o);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("overtravel_mm"), std::string::npos);
  }
}

}  // namespace
}  // namespace ttp::plan
