#include "ttp/inspect/dmis.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <stdexcept>

#include "feature_ids.h"
#include "test_dir.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/plan/dmis_writer.h"

namespace ttp::inspect {
namespace {

std::string DmisErrorOf(const std::string& text) {
  try {
    ParseDmisOutput(text, "r.dmo");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// The I++ simple part's output file: one inner circle.
TEST(DmisTest, ReadsTheNistSimplePartOutput) {
  const std::string path =
      std::string(TTP_DATA_DIR) + "/reference/cmm-files/output.dms";
  const DmisResults r = ParseDmisOutput(ReadTextFile(path), path);
  ASSERT_EQ(r.features.size(), 1u);
  const DmisFeature& c = r.features[0];
  EXPECT_EQ(c.label, "A_CIRCLE");
  EXPECT_EQ(c.type, "CIRCLE");
  EXPECT_EQ(c.line, 5);  // the statement starts there, continued with $
  EXPECT_DOUBLE_EQ(c.point_mm.x(), 50.0);
  EXPECT_DOUBLE_EQ(c.point_mm.z(), 40.0);
  EXPECT_DOUBLE_EQ(c.direction.z(), 1.0);
  EXPECT_DOUBLE_EQ(c.diameter_mm, 50.0);
}

TEST(DmisTest, HonoursUnitsAndComments) {
  const DmisResults r = ParseDmisOutput(
      "$$ inch file\nUNITS/INCH,ANGDEC\n"
      "FA(P1)=FEAT/PLANE,CART,1,2,3,0,0,2 $$ normal not unit\n",
      "in.dmo");
  ASSERT_EQ(r.features.size(), 1u);
  EXPECT_DOUBLE_EQ(r.features[0].point_mm.y(), 50.8);
  EXPECT_DOUBLE_EQ(r.features[0].direction.z(), 1.0);
}

TEST(DmisTest, BadFilesNameLineAndWord) {
  EXPECT_NE(DmisErrorOf("UNITS/FURLONG\n").find("r.dmo:1: UNITS"),
            std::string::npos);
  EXPECT_NE(
      DmisErrorOf("\nFA(A)=FEAT/PLANE,POL,1,2,3,0,0,1\n").find("r.dmo:2: POL"),
      std::string::npos);
  EXPECT_NE(
      DmisErrorOf("FA(A)=FEAT/PLANE,CART,1,2\n").find("expected 6 values"),
      std::string::npos);
  EXPECT_NE(DmisErrorOf("FA(A)=FEAT/PLANE,CART,1,x,3,0,0,1\n").find("value 2"),
            std::string::npos);
  EXPECT_NE(DmisErrorOf("FA(A)=FEAT/PLANE,CART,1,2,3,0,0,0\n").find("zero"),
            std::string::npos);
  EXPECT_NE(DmisErrorOf("").find("empty"), std::string::npos);
  // A diameter is a size, never negative or zero.
  EXPECT_NE(
      DmisErrorOf("\nFA(C)=FEAT/CIRCLE,OUTER,CART,0,0,60,0,0,1,-199\n")
          .find("r.dmo:2: FA(C) value 7: -199: a diameter must be positive"),
      std::string::npos);
  EXPECT_NE(DmisErrorOf("FA(S)=FEAT/SPHERE,CART,0,0,60,0\n")
                .find("FA(S) value 4: 0: a diameter must be positive"),
            std::string::npos);
  // A program given where its results belong.
  EXPECT_NE(DmisErrorOf("DMISMN/'p',05.0\nF(A)=FEAT/PLANE,CART,0,0,0,0,0,1\n"
                        "MEAS/PLANE,F(A),3\n")
                .find("r.dmo:3: MEAS: this is a DMIS program"),
            std::string::npos);
}

TEST(DmisTest, LabelsMapToFeatureIds) {
  EXPECT_EQ(FeatureIdForDmisLabel("x1_5"), FeatureId::Facet(Segment::kX1, 5));
  EXPECT_EQ(FeatureIdForDmisLabel("Y2-9"), FeatureId::Facet(Segment::kY2, 9));
  EXPECT_EQ(FeatureIdForDmisLabel("STRIP_3"), FeatureId::Strip(3));
  EXPECT_EQ(FeatureIdForDmisLabel("FLANK_PY"), FeatureId::Flank(+1));
  EXPECT_EQ(FeatureIdForDmisLabel("flank-y"), FeatureId::Flank(-1));
  EXPECT_EQ(FeatureIdForDmisLabel("TOP"), FeatureId::Top());
  EXPECT_EQ(FeatureIdForDmisLabel("CYL199"), FeatureId::Cylinder(199));
  EXPECT_EQ(FeatureIdForDmisLabel("A_CIRCLE"), std::nullopt);
  EXPECT_EQ(FeatureIdForDmisLabel("MARK_OPP"), std::nullopt);
  EXPECT_EQ(FeatureIdForDmisLabel("NOTCH_BIG"), std::nullopt);
}

// A CMM report of the whole piece in an arbitrary pose with known plane
// deviations: aligned from the datums, the results come back exactly.
TEST(DmisTest, RecoversDeviationsInAnyPoseFromTheDatums) {
  const PartSpec part;
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> dev(-0.01, 0.01);  // mm
  std::uniform_real_distribution<double> ang(-5e-5, 5e-5);  // rad
  const Eigen::Isometry3d pose =
      Eigen::Translation3d(412.5, -230.25, 81.0) *
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -0.2, 1).normalized());
  std::string text = "UNITS/MM,ANGDEC\n";
  const auto feature = [&](const std::string& label, const char* type,
                           const Eigen::Vector3d& p, const Eigen::Vector3d& n,
                           double sign, const std::string& extra) {
    const Eigen::Vector3d q = pose * p;
    const Eigen::Vector3d m = pose.linear() * n * sign;
    text += fmt::format(
        "FA({})=FEAT/{},CART, $\n  {:.12f},{:.12f},{:.12f},"
        "{:.12f},{:.12f},{:.12f}{}\n",
        label, type, q.x(), q.y(), q.z(), m.x(), m.y(), m.z(), extra);
  };
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  feature("TOP", "PLANE", {30, 40, 0}, z, 1, "");
  feature("FLANK_PY", "PLANE", {20, 53, -5}, {0, -1, 0}, 1, "");
  feature("FLANK_NY", "PLANE", {-10, -53, -7}, {0, 1, 0}, -1, "");
  feature("CYL199", "CIRCLE", {0, 0, -15}, z, 1, ",199.0");
  std::map<std::string, std::pair<double, double>> truth;  // d, angle
  for (const NominalFeature& f : TestFeatures(part)) {
    const double dd = dev(rng), a = ang(rng);
    std::string label = f.id;  // X1-5 is written X1_5, as DMIS needs
    std::replace(label.begin(), label.end(), '-', '_');
    if (f.kind == FeatureKind::kStrip) {
      // Depth d = 12.1 + dd at (0, y_k), slope beta = a.
      const Eigen::Vector3d n(-std::sin(a), 0, std::cos(a));
      const Eigen::Vector3d p(0, f.point.y(), -(12.1 + dd));
      feature(label, "PLANE", p + Eigen::Vector3d(30, 0, 30 * std::tan(a)), n,
              1, "");
      truth[f.id] = {12.1 + dd, a};
    } else {
      const Eigen::Vector3d n =
          Eigen::AngleAxisd(a, z) * f.normal;  // turned about Z
      const Eigen::Vector3d t = z.cross(n);
      const Eigen::Vector3d p = (f.size_mm + dd) * n + 2.0 * t - 6.0 * z;
      feature(label, "PLANE", p, n, 1, "");
      truth[f.id] = {f.size_mm + dd, a};
    }
  }
  const DmisImport got =
      DmisToFeatureResults(ParseDmisOutput(text, "piece.dmo"), part);
  EXPECT_TRUE(got.aligned_from_datums);
  ASSERT_EQ(got.results.size(), truth.size());
  for (const auto& [id, t] : truth) {
    const FeatureResult& r = got.results.at(test::Fid(id));
    EXPECT_NEAR(r.d_mm, t.first, 1e-9) << id;
    EXPECT_NEAR(r.angle_rad, t.second, 1e-10) << id;
    EXPECT_GT(r.var_d_mm2, 0) << id;
  }
}

TEST(DmisTest, WithoutDatumsTheReportedFrameIsW) {
  const PartSpec part;
  const NominalFeature x11 = [&] {
    for (const auto& f : TestFeatures(part))
      if (f.id == "X1-1") return f;
    return NominalFeature{};
  }();
  // X1-1 reported 1 um outside and turned by 20 urad about Z, in W.
  const Eigen::Vector3d n =
      Eigen::AngleAxisd(20e-6, Eigen::Vector3d::UnitZ()) * x11.normal;
  const Eigen::Vector3d p = (x11.size_mm + 0.001) * n;
  const DmisImport got = DmisToFeatureResults(
      ParseDmisOutput(fmt::format("FA(X1_1)=FEAT/PLANE,CART,{:.12f},{:.12f},"
                                  "-6,{:.15f},{:.15f},0\n",
                                  p.x(), p.y(), n.x(), n.y()),
                      "a"),
      part);
  EXPECT_FALSE(got.aligned_from_datums);
  ASSERT_EQ(got.warnings.size(), 1u);
  EXPECT_NEAR(got.results.at(test::Fid("X1-1")).angle_rad, 20e-6, 1e-12);
  EXPECT_NEAR(got.results.at(test::Fid("X1-1")).d_mm, x11.size_mm + 0.001,
              1e-9);
}

// The scatter of a facet's d = n . centroid and angle when the CMM touches
// `points` (on the nominal plane) with independent Gaussian errors of u_mm
// along the normal and fits the plane by orthogonal regression (SVD), as
// simulated here: the oracle of the reader's closed-form variances.
// One simulated plane per trial: its normal (oriented like `normal`) and
// the centroid of its touches.
struct SimulatedPlane {
  Eigen::Vector3d n, centroid;
};
// Each touch's error: u_of_touch(its point) (mm).
std::vector<SimulatedPlane> SimulatedPlaneFits(
    const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal,
    const std::function<double(const Eigen::Vector3d&)>& u_of_touch,
    unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<SimulatedPlane> out;
  for (int k = 0; k < 20000; ++k) {
    Eigen::MatrixXd q(static_cast<Eigen::Index>(points.size()), 3);
    for (size_t i = 0; i < points.size(); ++i)
      q.row(static_cast<Eigen::Index>(i)) =
          (points[i] + u_of_touch(points[i]) * noise(rng) * normal).transpose();
    const Eigen::RowVector3d c = q.colwise().mean();
    const Eigen::MatrixXd centred = q.rowwise() - c;
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(centred, Eigen::ComputeThinV);
    Eigen::Vector3d n = svd.matrixV().col(2);
    if (n.dot(normal) < 0) n = -n;
    out.push_back({n, c.transpose()});
  }
  return out;
}

std::vector<SimulatedPlane> SimulatedPlaneFits(
    const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal,
    double u_mm, unsigned seed) {
  return SimulatedPlaneFits(
      points, normal, [u_mm](const Eigen::Vector3d&) { return u_mm; }, seed);
}

// Population variance of f over the simulated planes.
template <typename F>
double VarianceOver(const std::vector<SimulatedPlane>& planes, F f) {
  double s = 0, ss = 0;
  for (const SimulatedPlane& p : planes) {
    const double v = f(p);
    s += v, ss += v * v;
  }
  const double n = static_cast<double>(planes.size());
  return ss / n - (s / n) * (s / n);
}

struct PlaneScatter {
  double var_d_mm2 = 0, var_angle_rad2 = 0;
};
PlaneScatter SimulatedPlaneScatter(const NominalFeature& f,
                                   const std::vector<Eigen::Vector3d>& points,
                                   double u_mm) {
  const std::vector<SimulatedPlane> planes =
      SimulatedPlaneFits(points, f.normal, u_mm, 20261126);
  const double phi = std::atan2(f.normal.y(), f.normal.x());
  return {
      VarianceOver(planes,
                   [](const SimulatedPlane& p) { return p.n.dot(p.centroid); }),
      VarianceOver(planes, [phi](const SimulatedPlane& p) {
        return std::remainder(std::atan2(p.n.y(), p.n.x()) - phi, 2.0 * M_PI);
      })};
}

const NominalFeature& NominalOf(const std::vector<NominalFeature>& all,
                                const std::string& id) {
  for (const NominalFeature& f : all)
    if (f.id == id) return f;
  throw std::runtime_error("no feature " + id);
}

std::vector<Eigen::Vector3d> TouchesOf(
    const std::vector<plan::PlannedPoint>& points, const std::string& id) {
  std::vector<Eigen::Vector3d> out;
  for (const plan::PlannedPoint& q : points)
    if (q.feature == test::Fid(id)) out.push_back(q.point_w_mm);
  return out;
}

// A DMIS plane's variance is that of the plane through the touches of the
// program `ttp plan cmm` writes (two rows of three on a facet: its tilt
// counts in d through the rows' height), checked against simulated touches;
// for a part whose program cannot be planned, one touch, with a warning.
TEST(DmisTest, APlaneCountsThePlannedTouchesOrOneWhenNoneCanBePlanned) {
  const PartSpec part;
  PartSpec narrow = part;
  narrow.datum_circle_z_max_mm = -15.5;
  const std::string text =
      "FA(X1_1)=FEAT/PLANE,CART,78.7240,57.1963,-6,0.8090170,0.5877853,0\n";
  const DmisImport planned =
      DmisToFeatureResults(ParseDmisOutput(text, "a"), part);
  const DmisImport unplanned =
      DmisToFeatureResults(ParseDmisOutput(text, "a"), narrow);
  const FeatureResult& a = planned.results.at(test::Fid("X1-1"));
  const FeatureResult& b = unplanned.results.at(test::Fid("X1-1"));
  const std::vector<NominalFeature> nominal = TestFeatures(part);
  const NominalFeature& x11 = NominalOf(nominal, "X1-1");
  const double u_mm = (1.2 + x11.point.norm() / 400.0) * 1e-3 / std::sqrt(3.0);
  const PlaneScatter sim = SimulatedPlaneScatter(
      x11, TouchesOf(plan::CmmPoints(part), "X1-1"), u_mm);
  EXPECT_NEAR(a.var_d_mm2 / sim.var_d_mm2, 1.0, 0.04);
  EXPECT_NEAR(a.var_angle_rad2 / sim.var_angle_rad2, 1.0, 0.04);
  // Not the centroid's u^2/6: the tilt's share through the rows' height.
  EXPECT_GT(a.var_d_mm2, 3.0 * u_mm * u_mm / 6.0);
  EXPECT_NEAR(b.var_d_mm2, u_mm * u_mm, 1e-6 * u_mm * u_mm);
  bool said = false;
  for (const std::string& w : unplanned.warnings)
    said = said || w.find("one touch") != std::string::npos;
  EXPECT_TRUE(said);
  for (const std::string& w : planned.warnings)
    EXPECT_EQ(w.find("one touch"), std::string::npos) << w;
}

// W's Z is the top face's normal, fitted from a few touches: its tilt about
// X moves a strip's depth at (0, y_k) by tilt * y_k. The share a strip's
// variance gains with the datums reported (against the same strip in the
// reported frame) is y_k^2 times the variance of that tilt, here simulated:
// the top face's planned touches off by Gaussian errors of u, a plane
// fitted to them by orthogonal regression (SVD), its slope along Y.
TEST(DmisTest, AStripsDepthCarriesTheTopFacesTilt) {
  const PartSpec part;
  const std::vector<NominalFeature> nominal = TestFeatures(part);
  const NominalFeature& z1 = NominalOf(nominal, "Z1");
  const std::string strip = fmt::format(
      "FA(Z1)=FEAT/PLANE,CART,30,{:.6f},-12.1,0,0,1\n", z1.point.y());
  const std::string datums =
      "FA(TOP)=FEAT/PLANE,CART,30,40,0,0,0,1\n"
      "FA(FLANK_PY)=FEAT/PLANE,CART,20,53,-5,0,-1,0\n"
      "FA(FLANK_NY)=FEAT/PLANE,CART,-10,-53,-7,0,1,0\n"
      "FA(CYL199)=FEAT/CIRCLE,CART,0,0,-15,0,0,1,199.0\n";
  const DmisImport with =
      DmisToFeatureResults(ParseDmisOutput(datums + strip, "w.dmo"), part);
  const DmisImport without =
      DmisToFeatureResults(ParseDmisOutput(strip, "r.dmo"), part);
  ASSERT_TRUE(with.aligned_from_datums);
  ASSERT_FALSE(without.aligned_from_datums);
  const double gained = with.results.at(test::Fid("Z1")).var_d_mm2 -
                        without.results.at(test::Fid("Z1")).var_d_mm2;

  std::vector<Eigen::Vector3d> top;
  double reach_mm = 0;
  for (const plan::PlannedPoint& q : plan::CmmPoints(part))
    if (q.feature == FeatureId::Top()) top.push_back(q.point_w_mm);
  ASSERT_GE(top.size(), 3u);
  for (const Eigen::Vector3d& q : top) reach_mm += q.norm() / top.size();
  const double u_mm = (1.2 + reach_mm / 400.0) * 1e-3 / std::sqrt(3.0);
  const double var_tilt = VarianceOver(
      SimulatedPlaneFits(top, Eigen::Vector3d::UnitZ(), u_mm, 7),
      [](const SimulatedPlane& p) { return -p.n.y() / p.n.z(); });  // dz/dy
  const double y = z1.point.y();
  ASSERT_GT(std::abs(y), 20.0);
  EXPECT_NEAR(gained / (y * y * var_tilt), 1.0, 0.05);
}

// The MPE holds for each touch's own length from W's origin: a strip's
// touches reach 80 mm out while its centre lies on the axis. With the
// length term dominant, the depth's variance is that of simulated touches
// each scattered by its own MPE.
TEST(DmisTest, EachTouchHasTheMpeOfItsOwnLength) {
  const PartSpec part;
  const std::vector<NominalFeature> nominal = TestFeatures(part);
  const NominalFeature& z5 = NominalOf(nominal, "Z5");
  DmisImportOptions cmm;
  cmm.cmm_mpe_um = 0.1;
  cmm.cmm_mpe_l_mm = 100.0;
  const DmisImport got = DmisToFeatureResults(
      ParseDmisOutput("FA(Z5)=FEAT/PLANE,CART,20,0,-12.1,0,0,1\n", "s.dmo"),
      part, cmm);
  const std::vector<Eigen::Vector3d> touches =
      TouchesOf(plan::CmmPoints(part), "Z5");
  ASSERT_GE(touches.size(), 3u);
  const auto u_of_touch = [](const Eigen::Vector3d& q) {
    return (0.1 + q.norm() / 100.0) * 1e-3 / std::sqrt(3.0);
  };
  const double y_k = z5.point.y();
  const double var_depth = VarianceOver(
      SimulatedPlaneFits(touches, Eigen::Vector3d::UnitZ(), u_of_touch, 11),
      [y_k](const SimulatedPlane& p) {  // the plane's height at (0, y_k)
        return p.centroid.z() - (p.n.x() * (0.0 - p.centroid.x()) +
                                 p.n.y() * (y_k - p.centroid.y())) /
                                    p.n.z();
      });
  EXPECT_NEAR(got.results.at(test::Fid("Z5")).var_d_mm2 / var_depth, 1.0, 0.04);
}

// A lab's CMM and program: its MPE, its own touch count (the plan's
// pattern taken n / 6 times: twelve touches = every planned touch twice),
// or the point list of the program `ttp plan cmm` wrote with other
// options; each against simulated touches.
TEST(DmisTest, TheLabsMpeAndTouchesSetAPlanesVariance) {
  const PartSpec part;
  const std::string text =
      "FA(X1_1)=FEAT/PLANE,CART,78.7240,57.1963,-6,0.8090170,0.5877853,0\n";
  const DmisResults dmis = ParseDmisOutput(text, "a");
  const std::vector<NominalFeature> nominal = TestFeatures(part);
  const NominalFeature& x11 = NominalOf(nominal, "X1-1");
  const double reach_mm = x11.point.norm();

  DmisImportOptions own;
  own.cmm_mpe_um = 2.0;
  own.cmm_mpe_l_mm = 250.0;
  own.touches_per_plane = 12;
  const DmisImport own_import = DmisToFeatureResults(dmis, part, own);
  const FeatureResult& a = own_import.results.at(test::Fid("X1-1"));
  const double u_mm = (2.0 + reach_mm / 250.0) * 1e-3 / std::sqrt(3.0);
  std::vector<Eigen::Vector3d> twice = TouchesOf(plan::CmmPoints(part), "X1-1");
  ASSERT_EQ(twice.size(), 6u);
  twice.insert(twice.end(), twice.begin(), twice.end());
  const PlaneScatter sim_own = SimulatedPlaneScatter(x11, twice, u_mm);
  EXPECT_NEAR(a.var_d_mm2 / sim_own.var_d_mm2, 1.0, 0.04);
  EXPECT_NEAR(a.var_angle_rad2 / sim_own.var_angle_rad2, 1.0, 0.04);

  // The point list of a program planned with five columns and three rows.
  plan::PlanOptions denser;
  denser.facet_columns = 5;
  denser.facet_rows = 3;
  const std::vector<plan::PlannedPoint> points = plan::CmmPoints(part, denser);
  ASSERT_EQ(TouchesOf(points, "X1-1").size(), 15u);
  const std::filesystem::path csv = test::TestDir() / "cmm_points.csv";
  WriteFileAtomic(csv, plan::PointsToCsv(points));
  DmisImportOptions listed;
  listed.points_csv_path = csv.string();
  const DmisImport listed_import = DmisToFeatureResults(dmis, part, listed);
  const FeatureResult& b = listed_import.results.at(test::Fid("X1-1"));
  const double u0_mm = (1.2 + reach_mm / 400.0) * 1e-3 / std::sqrt(3.0);
  const PlaneScatter sim_listed =
      SimulatedPlaneScatter(x11, TouchesOf(points, "X1-1"), u0_mm);
  EXPECT_NEAR(b.var_d_mm2 / sim_listed.var_d_mm2, 1.0, 0.04);
  EXPECT_NEAR(b.var_angle_rad2 / sim_listed.var_angle_rad2, 1.0, 0.04);

  // Options that cannot describe a CMM program, named as the user gave them.
  for (auto bad :
       {std::function<void(DmisImportOptions&)>(
            [](DmisImportOptions& o) { o.touches_per_plane = 2; }),
        std::function<void(DmisImportOptions&)>(
            [](DmisImportOptions& o) { o.cmm_mpe_um = 0; }),
        std::function<void(DmisImportOptions&)>([&](DmisImportOptions& o) {
          o.touches_per_plane = 9;
          o.points_csv_path = csv.string();
        })}) {
    DmisImportOptions o;
    bad(o);
    std::string why;
    EXPECT_FALSE(o.IsValid(&why));
    EXPECT_EQ(why.rfind("DmisImportOptions.", 0), 0u) << why;
    EXPECT_THROW(DmisToFeatureResults(dmis, part, o), InputError);
  }
}

// Units that do not fit the piece's size, a plane normal reported into the
// piece, readings of 1e300.
TEST(DmisTest, RefusesWhatCannotBeThisPiece) {
  const PartSpec part;
  // 97.301 in inches is 2471 mm: not this piece.
  try {
    DmisToFeatureResults(
        ParseDmisOutput("UNITS/INCH,ANGDEC\nFA(X1_5)=FEAT/PLANE,CART,48.6505,"
                        "84.2660,-6,0.5,0.8660254037844386,0\n",
                        "inch.dmo"),
        part);
    ADD_FAILURE() << "inches on millimetre values accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_EQ(e.field(), "FA(X1_5)");
  }
  // A normal into the piece: the same plane, taken outward, said aloud.
  const std::string out_text =
      "FA(X1_5)=FEAT/PLANE,CART,48.6505,84.2660,-6,0.5,0.8660254037844386,0\n";
  const std::string in_text =
      "FA(X1_5)=FEAT/PLANE,CART,48.6505,84.2660,-6,-0.5,-0.8660254037844386,"
      "0\n";
  const DmisImport a =
      DmisToFeatureResults(ParseDmisOutput(out_text, "o"), part);
  const DmisImport b =
      DmisToFeatureResults(ParseDmisOutput(in_text, "i"), part);
  EXPECT_EQ(a.results.at(test::Fid("X1-5")).d_mm,
            b.results.at(test::Fid("X1-5")).d_mm);
  EXPECT_EQ(a.results.at(test::Fid("X1-5")).angle_rad,
            b.results.at(test::Fid("X1-5")).angle_rad);
  EXPECT_EQ(b.warnings.size(), a.warnings.size() + 1);
  EXPECT_THROW(
      ParseDmisOutput("FA(X1_5)=FEAT/PLANE,CART,1e300,0,-6,1,0,0\n", "h"),
      InputError);
  EXPECT_THROW(
      ParseDmisOutput("FA(X1_5)=FEAT/PLANE,CART,1e400,0,-6,1,0,0\n", "h"),
      InputError);
}

// The half-turn from the mark: the ball sinks into the groove at MARK.
TEST(DmisTest, MarkPointsDecideTheHalfTurn) {
  const PartSpec part;
  const std::string datums =
      "UNITS/MM,ANGDEC\n"
      "FA(TOP)=FEAT/PLANE,CART,30,40,0,0,0,1\n"
      "FA(FLANK_PY)=FEAT/PLANE,CART,20,53,-5,0,-1,0\n"
      "FA(FLANK_NY)=FEAT/PLANE,CART,-10,-53,-7,0,1,0\n"
      "FA(CYL199)=FEAT/CIRCLE,OUTER,CART,0,0,-15,0,0,1,199\n"
      "FA(X1_5)=FEAT/PLANE,CART,48.65,84.266,-6,0.5,0.8660254037844386,0\n";
  const auto load = [&](double mark_z, double opp_z) {
    return DmisToFeatureResults(
        ParseDmisOutput(datums + fmt::format("FA(MARK)=FEAT/POINT,CART,40,"
                                             "69.28,{},0,0,1\n"
                                             "FA(MARK_OPP)=FEAT/POINT,CART,"
                                             "-40,-69.28,{},0,0,1\n",
                                             mark_z, opp_z),
                        "m.dmo"),
        part);
  };
  EXPECT_TRUE(load(-0.0226, 0.0).warnings.empty());
  EXPECT_EQ(load(-0.002, 0.0).warnings.size(), 1u);  // not seen
  try {
    load(0.0, -0.0226);
    ADD_FAILURE() << "a half-turned piece accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "FA(MARK)");
    EXPECT_EQ(e.line(), 7);
  }
}

// The statement checker against real CMM files (NIST I++ test suite: a
// DMIS 4.0 program of the DaimlerChrysler part, a DMIS 3.0 program and its
// output file): an oracle for the checker written by others.
TEST(DmisProgramTest, RealCmmFilesPassTheStandardChecks) {
  for (const char* name : {"IMTS_M_clean.dmi", "simple_in.dms", "output.dms"}) {
    const std::string path =
        std::string(TTP_DATA_DIR) + "/reference/cmm-files/" + name;
    const DmisProgram p = ParseDmisProgram(ReadTextFile(path), path);
    for (const DmisFinding& f : CheckDmisStandard(p))
      ADD_FAILURE() << name << ":" << f.line << ": " << f.check << ": "
                    << f.problem;
  }
  const std::string imts = ReadTextFile(
      std::string(TTP_DATA_DIR) + "/reference/cmm-files/IMTS_M_clean.dmi");
  const DmisProgram p = ParseDmisProgram(imts, "imts");
  EXPECT_EQ(p.statements.size(), 111u);
  // Continuation lines are one statement: the LINE feature of line 86.
  const auto line = std::find_if(
      p.statements.begin(), p.statements.end(), [](const DmisStatement& s) {
        return s.label == "CLIN1" && s.major == "FEAT";
      });
  ASSERT_NE(line, p.statements.end());
  EXPECT_EQ(line->args.size(), 12u);
  EXPECT_EQ(line->label_type, "F");
}

// The same real program with one defect each: every one is found, with
// its line.
TEST(DmisProgramTest, DefectsInARealProgramAreFound) {
  const std::string imts = ReadTextFile(
      std::string(TTP_DATA_DIR) + "/reference/cmm-files/IMTS_M_clean.dmi");
  const auto findings = [&](const std::string& from, const std::string& to) {
    std::string t = imts;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
    return CheckDmisStandard(ParseDmisProgram(t, "m"));
  };
  const auto has = [](const std::vector<DmisFinding>& f, const char* check,
                      const char* text) {
    for (const auto& x : f)
      if (x.check == check && x.problem.find(text) != std::string::npos)
        return true;
    return false;
  };
  // A misspelled major word; a wrong minor word; a missing argument.
  EXPECT_TRUE(has(findings("SNSLCT/S(PROBE6)", "SNSSEL/S(PROBE6)"), "statement",
                  "SNSSEL is not in"));
  EXPECT_TRUE(has(findings("MEAS/PLANE,F(PLN1),4", "MEAS/PLANE,F(PLN1),X"),
                  "statement", "MEAS/PLANE,F(PLN1),X matches none"));
  EXPECT_TRUE(has(findings("F(PLN2)=FEAT/PLANE,CART,0.000,-52.000,15.000,"
                           "0.000,-1.000,0.000",
                           "F(PLN2)=FEAT/PLANE,CART,0.000,-52.000,15.000,"
                           "0.000,-1.000"),
                  "statement", "FEAT/PLANE"));
  // A datum used before its feature is measured.
  EXPECT_TRUE(has(findings("DATDEF/FA(PLN3),DAT(C)", "DATDEF/FA(PLN9),DAT(C)"),
                  "labels", "FA(PLN9) before it is measured"));
  EXPECT_TRUE(has(findings("D(CALN1_a)=DATSET/DAT(CALN1A),ZDIR",
                           "D(CALN1_a)=DATSET/DAT(CALN2A),ZDIR"),
                  "labels", "DAT(CALN2A) before DATDEF"));
  // A line longer than DMIS allows.
  EXPECT_TRUE(has(
      findings("TEXT/OUTFIL,'CYL1 - CYLINDER - '",
               "TEXT/OUTFIL,'CYL1 - CYLINDER - " + std::string(70, 'x') + "'"),
      "structure", "longer than 80"));
  // A MEAS block with fewer points than declared; no ENDFIL.
  EXPECT_TRUE(has(findings("MEAS/CYLNDR,F(CYL2),8", "MEAS/CYLNDR,F(CYL2),9"),
                  "structure", "declares 9 points"));
  EXPECT_TRUE(has(findings("CLOSE/DID(OUTFILE)\nENDFIL", "CLOSE/DID(OUTFILE)"),
                  "structure", "not ENDFIL"));
}

TEST(DmisProgramTest, UnreadableStatementsNameTheLine) {
  try {
    ParseDmisProgram("DMISMN/'x',5.0\nTEXT/OPER,'open\n", "q.dmi");
    ADD_FAILURE() << "unclosed quote accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
  }
  EXPECT_THROW(ParseDmisProgram("DMISMN/'x'\n(A)=FEAT/PLANE\n", "q"),
               InputError);
  EXPECT_THROW(ParseDmisProgram("$$ only a comment\n", "q"), InputError);
}

}  // namespace
}  // namespace ttp::inspect
