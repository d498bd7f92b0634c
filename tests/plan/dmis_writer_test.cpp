// The CMM program is checked by the DMIS reader of the inspect module
// (statement table written from DMIS 5, label order, patterns, the stylus
// path against the part's mesh), which is itself checked on real CMM
// programs in tests/inspect/dmis_test.cpp. Here: the written program
// passes, and each defect the issue names makes it fail.
#include "ttp/plan/dmis_writer.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <regex>
#include <sstream>

#include "test_dir.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/inspect/dmis.h"
#include "ttp/inspect/measurement.h"
#include "ttp/sim/twin.h"

namespace ttp::plan {
namespace {

const PartMesh& Finished() {
  static const PartMesh mesh = BuildPartMesh(PartSpec{}, Stage::kFinished);
  return mesh;
}

inspect::DmisProgramCheck Check(const std::string& text,
                                bool check_path = true) {
  inspect::DmisPathOptions o;
  o.check_path = check_path;  // tracing the path is the costly part
  return inspect::CheckDmisProgram(inspect::ParseDmisProgram(text, "p.dmi"),
                                   PartSpec{}, Finished(), o);
}

bool CheckPassed(const inspect::DmisProgramCheck& c, const std::string& name) {
  for (const auto& k : c.checks)
    if (k.name == name) return k.passed;
  ADD_FAILURE() << "no check " << name;
  return false;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}
std::string Join(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

const char* kPath = "moves clear the piece, adapter and table";
const char* kPatterns = "point patterns not degenerate";
const char* kStandard = "DMIS 5 statements and labels";

TEST(DmisWriterTest, ProgramPassesEveryCheck) {
  const PartSpec part;
  const auto points = CmmPoints(part);
  const std::string dmis = WriteDmisProgram(part, points);
  const auto c = Check(dmis);
  for (const auto& k : c.checks) {
    EXPECT_TRUE(k.passed) << k.name;
    for (const auto& f : k.findings)
      ADD_FAILURE() << "line " << f.line << ": " << f.problem;
  }
  EXPECT_EQ(c.probe_points, static_cast<int>(points.size()) + 2);  // + mark
  EXPECT_GE(c.min_clearance_mm, 0.5);
  // One measurement and one output per feature, in the reader's labels.
  int meas = 0, outputs = 0;
  for (const auto& l : Lines(dmis)) {
    meas += l.rfind("MEAS/", 0) == 0;
    outputs += l.rfind("OUTPUT/FA(", 0) == 0;
  }
  // 4 datums + 45 features + 3 by hand + the mark and its opposite.
  EXPECT_EQ(meas, 49 + 3 + 2);
  EXPECT_EQ(outputs, 49 + 2);
  EXPECT_NE(dmis.find("OUTPUT/FA(X1_5)"), std::string::npos);
  EXPECT_NE(dmis.find("D(W)=DATSET/DAT(A),ZDIR,ZORIG,DAT(B),YDIR,DAT(C),"
                      "XORIG,YORIG"),
            std::string::npos);
  // The stylus and the options reach the program.
  DmisOptions o;
  o.stylus_diameter_mm = 2.0;
  o.clearance_height_mm = 35;
  const std::string small = WriteDmisProgram(part, CmmPoints(part, {}, o), o);
  int sensors = 0, clearance_moves = 0;
  for (const auto& st : inspect::ParseDmisProgram(small, "s").statements) {
    if (st.major == "SNSDEF") {
      ++sensors;
      EXPECT_EQ(st.args.back(), "2.0000");
    }
    clearance_moves += st.major == "GOTO" && st.args.back() == "35.0000";
  }
  EXPECT_EQ(sensors, 1);
  EXPECT_GT(clearance_moves, 49);
  EXPECT_TRUE(Check(small).Passed());
}

TEST(DmisWriterTest, PlanesSpanTwoDirections) {
  const PartSpec part;
  // The probing plan's flank and strip points lie on lines: refused.
  try {
    WriteDmisProgram(part, PlanPoints(part));
    ADD_FAILURE() << "collinear flank points accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(e.field() == "FLANK+Y" || e.field() == "FLANK-Y" ||
                e.field()[0] == 'Z')
        << e.what();
  }
  // A program whose flank points were put back on one line fails the
  // pattern check.
  auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  bool in_flank = false;
  for (auto& l : lines) {
    if (l == "MEAS/PLANE,F(FLANK_PY),4") in_flank = true;
    if (l == "ENDMES") in_flank = false;
    if (in_flank && l.find("PTMEAS") != std::string::npos)
      l = std::regex_replace(l, std::regex(",-8\\.0000,"), ",-4.0000,");
  }
  const auto c = Check(Join(lines), false);
  EXPECT_FALSE(CheckPassed(c, kPatterns));
  EXPECT_TRUE(CheckPassed(c, kStandard));
}

// Without the clearance moves the stylus goes straight from strip Z9 into
// segment X1 (the defect of the earlier program).
TEST(DmisWriterTest, MissingClearanceMoveIsFound) {
  const PartSpec part;
  auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  std::vector<std::string> cut;
  bool after_z9 = false;
  for (const auto& l : lines) {
    if (l.rfind("MEAS/PLANE,F(Z9)", 0) == 0) after_z9 = true;
    // Drop the move up at the end of Z9 and the move across at the
    // clearance height before X1-1.
    if (after_z9 && l.rfind("  GOTO/", 0) == 0 &&
        l.find(",20.0000") != std::string::npos)
      continue;
    if (after_z9 && l.rfind("GOTO/", 0) == 0) {
      after_z9 = false;
      continue;
    }
    cut.push_back(l);
  }
  ASSERT_EQ(cut.size() + 2, lines.size());
  const auto c = Check(Join(cut));
  EXPECT_FALSE(CheckPassed(c, kPath));
  EXPECT_TRUE(CheckPassed(c, kStandard));
  EXPECT_LT(c.min_clearance_mm, 0);
}

// The table is a plane under everything: a move along it, 300 km at 0.01
// mm more than the required clearance, is clear exactly (sampled, it took
// minutes and ended as "not shown clear"); a move a metre down through it
// fails by its depth.
TEST(DmisWriterTest, MovesAlongAndThroughTheTable) {
  const PartSpec part;
  const double table_z = -part.height_mm() - part.adapter_height_mm;
  const double ball_r = 2.0, margin = inspect::DmisPathOptions{}.margin_mm;
  const auto with_moves = [&](const std::vector<std::string>& moves) {
    auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
    const auto end = std::find(lines.begin(), lines.end(), "ENDFIL");
    EXPECT_NE(end, lines.end());
    lines.insert(end, moves.begin(), moves.end());
    return Check(Join(lines));
  };
  const std::string z = fmt::format("{:.4f}", table_z + ball_r + margin + 0.01);
  auto c = with_moves(
      {"GOTO/300.0000,0.0000,50.0000", "GOTO/300.0000,0.0000," + z,
       "GOTO/300000.0000,0.0000," + z, "GOTO/300.0000,0.0000,50.0000"});
  EXPECT_TRUE(CheckPassed(c, kPath));
  EXPECT_NEAR(c.min_clearance_mm, margin + 0.01, 1e-9);
  c = with_moves({"GOTO/300.0000,0.0000,50.0000",
                  "GOTO/300.0000,0.0000,-1000.0000",
                  "GOTO/300.0000,0.0000,50.0000"});
  EXPECT_FALSE(CheckPassed(c, kPath));
  EXPECT_NEAR(c.min_clearance_mm, -1000.0 - table_z - ball_r, 1e-9);
}

TEST(DmisWriterTest, DatumUsedBeforeItIsMeasuredIsFound) {
  const PartSpec part;
  auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  // Move "DATDEF/FA(TOP),DAT(A)" before the measurement of TOP.
  auto it = std::find(lines.begin(), lines.end(), "DATDEF/FA(TOP),DAT(A)");
  ASSERT_NE(it, lines.end());
  const std::string datdef = *it;
  lines.erase(it);
  auto top = std::find_if(lines.begin(), lines.end(), [](const std::string& l) {
    return l.rfind("F(TOP)=FEAT", 0) == 0;
  });
  lines.insert(top, datdef);
  const auto c = Check(Join(lines), false);
  EXPECT_FALSE(CheckPassed(c, kStandard));
}

TEST(DmisWriterTest, NoSensorNoFeedsNoAlignmentAreFound) {
  const PartSpec part;
  const auto lines = Lines(WriteDmisProgram(part, CmmPoints(part)));
  const auto without = [&](const std::string& prefix) {
    std::vector<std::string> out;
    for (const auto& l : lines)
      if (l.rfind(prefix, 0) != 0) out.push_back(l);
    return Check(Join(out), false);
  };
  EXPECT_FALSE(without("SNSLCT/").Passed());
  EXPECT_FALSE(CheckPassed(without("FEDRAT/MESVEL"),
                           "sensor, feeds and distances set before measuring"));
  EXPECT_FALSE(CheckPassed(without("D(MAN)=DATSET"),
                           "part aligned from measured datums before moving"));
}

TEST(DmisWriterTest, RefusesWhatCannotRun) {
  const PartSpec part;
  DmisOptions o;
  o.stylus_diameter_mm = 0;
  try {
    WriteDmisProgram(part, CmmPoints(part), o);
    ADD_FAILURE() << "a stylus of 0 mm accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "stylus_diameter_mm");
  }
  // A ball too big to touch the 199 band above the step to the 200
  // cylinder.
  o.stylus_diameter_mm = 9;
  try {
    CmmPoints(part, {}, o);
    ADD_FAILURE() << "9 mm ball accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "stylus_diameter_mm");
  }
  auto points = CmmPoints(part);
  points.erase(std::remove_if(points.begin(), points.end(),
                              [](const PlannedPoint& p) {
                                return p.feature == FeatureId::Cylinder(199);
                              }),
               points.end());
  EXPECT_THROW(WriteDmisProgram(part, points), InputError);
}

// ---------------------------------------------------------------------
// A CMM written here from what the DMIS statements mean runs the program on
// a piece cut by the digital twin with a clamping distortion (its true cut
// geometry), placed on the CMM table off the program's frame. Its output
// file goes through `ttp inspect`'s loader; the figures must be the twin's.
class SimulatedCmm {
 public:
  SimulatedCmm(const PartSpec& part, const FeatureResults& truth,
               const Eigen::Isometry3d& w_to_cmm)
      : operator_pose_(w_to_cmm), part_(part), truth_(truth), pose_(w_to_cmm) {
    for (const NominalFeature& f : TestFeatures(part)) nominal_[f.id] = f;
  }

  std::string Run(const std::string& program) {
    std::string out = "FILNAM/'simulated CMM results'\nUNITS/MM,ANGDEC\n";
    Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();  // -> CMM
    bool manual = false;
    Block block;
    std::map<std::string, std::vector<double>> nominal;
    std::map<std::string, std::string> datum_of;
    for (const auto& s : inspect::ParseDmisProgram(program, "p").statements) {
      const auto num = [&](size_t k) { return std::stod(s.args.at(k)); };
      const auto ref = [](const std::string& w) {
        return w.substr(w.find('(') + 1, w.size() - w.find('(') - 2);
      };
      if (s.major == "MODE") manual = s.args[0] == "MAN";
      if (s.major == "SNSDEF") ball_r_ = std::stod(s.args.back()) / 2;
      if (s.major == "FEAT") {
        std::vector<double> v;
        for (const auto& a : s.args)
          if (!a.empty() && (std::isdigit(a[0]) || a[0] == '-'))
            v.push_back(std::stod(a));
        nominal[s.label] = v;
      }
      if (s.major == "MEAS") {
        block = Block{ref(s.args[1]), s.args[0], {}, {}};
        const auto& v = nominal[block.label];
        block.nominal_dir = frame.linear() * Eigen::Vector3d(v[3], v[4], v[5]);
      }
      if (s.major == "PTMEAS") {
        const Eigen::Vector3d p(num(1), num(2), num(3)),
            n(num(4), num(5), num(6));
        // By hand the operator finds the nominal place on the piece itself;
        // automatically the CMM goes where the active frame says.
        const Eigen::Isometry3d to_cmm = manual ? operator_pose_ : frame;
        const Eigen::Vector3d from = to_cmm * Eigen::Vector3d(p + 5.0 * n);
        const Eigen::Vector3d dir = to_cmm.linear() * -n;
        block.points.push_back(Touch(block.label, from, dir));
      }
      if (s.major == "ENDMES") actual_[block.label] = Fit(block);
      if (s.major == "CONST") {  // PLANE, F(MID), MIDPL, FA(a), FA(b)
        const Actual& a = actual_.at(ref(s.args[3]));
        const Actual& b = actual_.at(ref(s.args[4]));
        const auto& v = nominal[ref(s.args[1])];
        const Eigen::Vector3d want =
            frame.linear() * Eigen::Vector3d(v[3], v[4], v[5]);
        Eigen::Vector3d n = Oriented(a.dir, want) + Oriented(b.dir, want);
        actual_[ref(s.args[1])] = {"PLANE", (a.point + b.point) / 2,
                                   n.normalized(), 0};
      }
      if (s.major == "DATDEF") datum_of[ref(s.args[1])] = ref(s.args[0]);
      if (s.major == "DATSET" && s.args[0] != "MCS") {
        // DAT(A),ZDIR,ZORIG,DAT(B),YDIR,DAT(C),XORIG,YORIG
        const Actual& a = actual_.at(datum_of.at(ref(s.args[0])));
        const Actual& b = actual_.at(datum_of.at(ref(s.args[3])));
        const Actual& c = actual_.at(datum_of.at(ref(s.args[5])));
        const Eigen::Vector3d z = a.dir;
        const Eigen::Vector3d y = (b.dir - b.dir.dot(z) * z).normalized();
        Eigen::Matrix3d r;
        r << y.cross(z), y, z;
        frame.linear() = r;
        frame.translation() = c.point - (c.point - a.point).dot(z) * z;
      }
      if (s.major == "OUTPUT") {
        const std::string label = ref(s.args[0]);
        const Actual& a = actual_.at(label);
        const Eigen::Vector3d p = frame.inverse() * a.point;
        const Eigen::Vector3d d = frame.linear().transpose() * a.dir;
        out += fmt::format(
            "FA({}) = FEAT/{},{}CART, $\n  {:.12f},{:.12f},"
            "{:.12f},{:.12f},{:.12f},{:.12f}{}\n",
            label, a.type, a.type == "CIRCLE" ? "OUTER," : "", p.x(), p.y(),
            p.z(), d.x(), d.y(), d.z(),
            a.type == "CIRCLE" ? fmt::format(",{:.12f}", a.diameter) : "");
      }
    }
    return out + "ENDFIL\n";
  }

 private:
  struct Block {
    std::string label, type;
    Eigen::Vector3d nominal_dir;
    std::vector<Eigen::Vector3d> points;  // CMM frame
  };
  struct Actual {
    std::string type;
    Eigen::Vector3d point, dir;
    double diameter = 0;
  };
  static Eigen::Vector3d Oriented(const Eigen::Vector3d& n,
                                  const Eigen::Vector3d& like) {
    return n.dot(like) >= 0 ? n : Eigen::Vector3d(-n);
  }

  // Where a probe travelling from `from` along `dir` (CMM frame) first
  // touches the true piece: the nearest surface along the ray whose hit
  // lies inside that surface's edges. Ball-compensated, as the CMM reports
  // (flat surfaces: the contact point; the engraved groove: the ball rests
  // on its edges).
  Eigen::Vector3d Touch(const std::string& label, const Eigen::Vector3d& from,
                        const Eigen::Vector3d& dir) {
    const Eigen::Vector3d o = pose_.inverse() * from;
    const Eigen::Vector3d d = pose_.linear().transpose() * dir;
    double best_t = 1e300;
    std::string best_id;
    const auto consider = [&](const std::string& id, double t, bool inside) {
      if (t > 0 && inside && t < best_t) best_t = t, best_id = id;
    };
    const auto plane_t = [&](const Eigen::Vector3d& n, double c) {
      const double nd = n.dot(d);
      return std::abs(nd) < 1e-12 ? -1.0 : (c - n.dot(o)) / nd;
    };
    const double facet_corner = part_.facet_final_distance_mm /
                                std::cos(part_.facet_step_deg / 2 * M_PI / 180);
    {  // top face of the segments
      const double t = plane_t(Eigen::Vector3d::UnitZ(), 0);
      const Eigen::Vector3d h = o + t * d;
      consider("TOP", t,
               std::abs(h.y()) > part_.big_notch_half_width_mm &&
                   h.head<2>().norm() < part_.facet_final_distance_mm);
    }
    for (int side : {1, -1}) {
      const double t = plane_t(Eigen::Vector3d::UnitY(),
                               side * part_.big_notch_half_width_mm);
      const Eigen::Vector3d h = o + t * d;
      consider(side > 0 ? "FLANK+Y" : "FLANK-Y", t,
               h.z() < 0 && h.z() > part_.big_notch_floor_z_mm &&
                   std::abs(h.x()) > part_.small_notch_half_width_mm &&
                   h.head<2>().norm() < facet_corner);
    }
    {  // the 199 cylinder
      const RefCylinder& c = part_.ref_cylinders.front();
      const double r = c.diameter_mm / 2;
      const Eigen::Vector2d o2 = o.head<2>(), d2 = d.head<2>();
      const double a = d2.squaredNorm(), b = 2 * o2.dot(d2),
                   cc = o2.squaredNorm() - r * r;
      if (a > 1e-12 && b * b - 4 * a * cc >= 0) {
        const double t = (-b - std::sqrt(b * b - 4 * a * cc)) / (2 * a);
        const double z = o.z() + t * d.z();
        consider("CYL199", t, z > c.z_bottom_mm && z < c.z_top_mm);
      }
    }
    for (const auto& [id, f] : nominal_) {
      const FeatureResult& r = truth_.at(f.Key());
      if (f.kind == FeatureKind::kStrip) {  // z = -d + tan(beta) x
        const double t =
            plane_t(Eigen::Vector3d(-std::tan(r.angle_rad), 0, 1), -r.d_mm);
        const Eigen::Vector3d h = o + t * d;
        consider(id, t,
                 std::abs(h.y() - f.point.y()) < part_.strip_width_mm / 2 &&
                     std::abs(h.x()) > part_.small_notch_half_width_mm &&
                     std::abs(h.x()) < f.t_max_mm);
      } else {
        const double phi = std::atan2(f.normal.y(), f.normal.x()) + r.angle_rad;
        const Eigen::Vector3d n(std::cos(phi) * std::cos(r.tilt_rad),
                                std::sin(phi) * std::cos(r.tilt_rad),
                                std::sin(r.tilt_rad));
        const double t = plane_t(n, r.d_mm);
        const Eigen::Vector3d h = o + t * d;
        const double tang = Eigen::Vector3d::UnitZ().cross(f.normal).dot(h);
        consider(id, t,
                 tang > f.t_min_mm && tang < f.t_max_mm && h.z() > f.z_min_mm &&
                     h.z() < f.z_max_mm);
      }
    }
    if (best_id.empty()) {
      ADD_FAILURE() << label << ": the probe found nothing";
      return from;
    }
    Eigen::Vector3d hit = o + best_t * d;
    // The engraved groove: the ball rests on its two edges.
    if (best_id == "TOP") {
      const double mphi = part_.mark_phi_deg * M_PI / 180;
      const Eigen::Vector2d along(std::cos(mphi), std::sin(mphi));
      const double s = along.dot(hit.head<2>());
      const double e = std::abs(along.x() * hit.y() - along.y() * hit.x());
      const double half = part_.mark_width_mm / 2;
      if (s > part_.mark_r_start_mm && s < part_.mark_r_end_mm && e < half)
        hit.z() =
            std::sqrt(ball_r_ * ball_r_ - (half - e) * (half - e)) - ball_r_;
    }
    if (check_labels_) {
      std::string want = label;
      if (want == "TOP_M" || want == "MARK" || want == "MARK_OPP") want = "TOP";
      if (want == "FLANK_M" || want == "FLANK_NY") want = "FLANK-Y";
      if (want == "FLANK_PY") want = "FLANK+Y";
      if (want == "CYL_M") want = "CYL199";
      std::replace(want.begin(), want.end(), '_', '-');
      EXPECT_EQ(best_id, want)
          << "a point of " << label << " touches " << best_id;
    }
    touched_[best_id]++;
    return pose_ * hit;
  }

 public:
  bool check_labels_ = true;
  double ball_r_ = 2.0;
  // The operator's idea of where the piece lies (the manual points).
  Eigen::Isometry3d operator_pose_;
  std::map<std::string, int> touched_;

 private:
  Actual Fit(const Block& block) const {
    const auto& pts = block.points;
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (const auto& p : pts) m += p;
    m /= static_cast<double>(pts.size());
    if (block.type == "POINT")
      return {"POINT", pts.front(), block.nominal_dir, 0};
    if (block.type == "CIRCLE") {  // in the plane across the nominal axis
      const Eigen::Vector3d ax = block.nominal_dir.normalized();
      const Eigen::Vector3d u = ax.unitOrthogonal(), v = ax.cross(u);
      Eigen::MatrixXd a(pts.size(), 3);
      Eigen::VectorXd b(pts.size());
      for (size_t i = 0; i < pts.size(); ++i) {
        const double x = u.dot(pts[i] - m), y = v.dot(pts[i] - m);
        a.row(i) << x, y, 1;
        b(i) = x * x + y * y;
      }
      const Eigen::Vector3d k = a.colPivHouseholderQr().solve(b);
      const double cx = k(0) / 2, cy = k(1) / 2;
      return {"CIRCLE", m + cx * u + cy * v, ax,
              2 * std::sqrt(k(2) + cx * cx + cy * cy)};
    }
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& p : pts) cov += (p - m) * (p - m).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
    return {"PLANE", m, Oriented(es.eigenvectors().col(0), block.nominal_dir),
            0};
  }

  const PartSpec& part_;
  const FeatureResults& truth_;
  Eigen::Isometry3d pose_;
  std::map<std::string, NominalFeature> nominal_;
  std::map<std::string, Actual> actual_;
};

// The twin's run both CMM tests measure (default config, a clamping
// distortion of 4 um), run once.
const sim::TwinRun& ClampedRun() {
  static const sim::TwinRun run = [] {
    sim::TwinOptions twin;
    sim::SetEffect(&twin, "clamping_distortion", 4.0);
    twin.seed = 5;
    return sim::RunTwin(Config{}, twin);
  }();
  return run;
}

TEST(DmisWriterTest, ResultsOfTheProgramComeBackToTheTwinsFigures) {
  const Config config;
  const sim::TwinRun& run = ClampedRun();
  // On the CMM table: turned 0.4 deg, tilted 0.05 deg, anywhere.
  const Eigen::Isometry3d pose =
      Eigen::Translation3d(412.0, 233.5, 81.25) *
      Eigen::AngleAxisd(0.4 * M_PI / 180, Eigen::Vector3d::UnitZ()) *
      Eigen::AngleAxisd(0.05 * M_PI / 180, Eigen::Vector3d::UnitX());
  SimulatedCmm cmm(config.part, run.true_results, pose);
  const std::string results =
      cmm.Run(WriteDmisProgram(config.part, CmmPoints(config.part)));
  const auto path = test::TestDir("dmis-roundtrip") / "ttp_cmm_results.dmo";
  WriteFileAtomic(path, results);
  const inspect::Measurement got = inspect::LoadMeasurement(config, path);
  EXPECT_EQ(got.kind, inspect::MeasurementKind::kDmis);

  inspect::InspectionResult truth;
  truth.features = run.true_results;
  inspect::ComputeResultFigures(config.part, &truth);
  ASSERT_EQ(got.result.figures.size(), truth.figures.size());
  double largest_um = 0;
  for (size_t i = 0; i < truth.figures.size(); ++i) {
    const CycleFigures& a = got.result.figures[i];
    const CycleFigures& b = truth.figures[i];
    EXPECT_NEAR(a.e_x_mm, b.e_x_mm, 1e-6) << "cycle " << b.cycle;
    EXPECT_NEAR(a.e_y_mm, b.e_y_mm, 1e-6) << "cycle " << b.cycle;
    EXPECT_NEAR(a.e_z_mm, b.e_z_mm, 1e-6) << "cycle " << b.cycle;
    EXPECT_NEAR(a.e_b_rad, b.e_b_rad, 1e-8) << "cycle " << b.cycle;
    EXPECT_NEAR(a.e_ttp_mm, b.e_ttp_mm, 1e-6) << "cycle " << b.cycle;
    largest_um = std::max(
        {largest_um, std::abs(b.e_x_mm) * 1e3, std::abs(b.e_ttp_mm) * 1e3});
  }
  EXPECT_GT(largest_um, 0.5) << "the twin's piece shows no effect";
  for (const auto& [id, r] : run.true_results) {
    EXPECT_NEAR(got.result.features.at(id).d_mm, r.d_mm, 1e-6) << id;
    EXPECT_NEAR(got.result.features.at(id).angle_rad, r.angle_rad, 1e-8) << id;
  }
  EXPECT_EQ(got.result.warnings.size(), 0u)
      << (got.result.warnings.empty() ? "" : got.result.warnings[0]);
  EXPECT_EQ(cmm.touched_.size(), 49u);  // every feature, none twice
}

// The piece put on the CMM turned by 180 deg: the datums are symmetric, the
// program runs through and measures X2 as X1; the mark's points refuse the
// results.
TEST(DmisWriterTest, APieceTurnedByHalfATurnIsRefused) {
  const Config config;
  const sim::TwinRun& run = ClampedRun();
  const Eigen::Isometry3d pose =
      Eigen::Translation3d(412.0, 233.5, 81.25) *
      Eigen::AngleAxisd(M_PI + 0.004, Eigen::Vector3d::UnitZ());
  SimulatedCmm cmm(config.part, run.true_results, pose);
  cmm.operator_pose_ = pose * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ());
  cmm.check_labels_ = false;
  const std::string results =
      cmm.Run(WriteDmisProgram(config.part, CmmPoints(config.part)));
  const auto path = test::TestDir("dmis-halfturn") / "turned.dmo";
  WriteFileAtomic(path, results);
  try {
    inspect::LoadMeasurement(config, path);
    ADD_FAILURE() << "a piece turned by 180 deg was graded";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "FA(MARK)");
    EXPECT_NE(std::string(e.what()).find("turned by 180 deg"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace ttp::plan
