#include "ttp/geometry/fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fit_test_util.h"
#include "ttp/geometry/error.h"

namespace ttp::fit {
namespace {

using namespace testing;  // ttp::fit::testing: NIST cases, tolerances

// --- NIST reference pairs ---------------------------------------------------

TEST(FitNist, EveryCaseListedIsPresent) {
  EXPECT_EQ(NistCases("Line2d").size(), 12u);
  EXPECT_EQ(NistCases("Line3d").size(), 3u);
  EXPECT_EQ(NistCases("Plane").size(), 4u);
  EXPECT_EQ(NistCases("Circle3d").size(), 6u);
  EXPECT_EQ(NistCases("Sphere").size(), 6u);
}

TEST(FitNist, Line2d) {
  for (const std::string& name : NistCases("Line2d")) {
    SCOPED_TRACE(name);
    const Eigen::Matrix3Xd p =
        ReadNistPoints(NistDir() + "Line2d/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Line2d/" + name + ".fit");
    ASSERT_EQ(ref.size(), 6u);
    // The data lie in a plane parallel to a coordinate plane: drop the
    // constant coordinate.
    int constant = -1;
    for (int k = 0; k < 3; ++k) {
      if ((p.row(k).array() == p(k, 0)).all()) constant = k;
    }
    ASSERT_GE(constant, 0);
    const int a = (constant + 1) % 3, b = (constant + 2) % 3;
    Eigen::Matrix2Xd q(2, p.cols());
    q.row(0) = p.row(std::min(a, b));
    q.row(1) = p.row(std::max(a, b));
    const LineFit2D fit = FitLine2D(q);
    Eigen::Vector3d point = Eigen::Vector3d::Zero(),
                    dir = Eigen::Vector3d::Zero();
    point(constant) = p(constant, 0);
    point(std::min(a, b)) = fit.point.x();
    point(std::max(a, b)) = fit.point.y();
    dir(std::min(a, b)) = fit.direction.x();
    dir(std::max(a, b)) = fit.direction.y();
    EXPECT_LT(DistanceToLine(point, Vec3(ref, 0), Vec3(ref, 3)), kNistMm);
    EXPECT_LT((point - Vec3(ref, 0)).norm(), kNistMm);  // both centroids
    EXPECT_LT(AxisAngle(dir, Vec3(ref, 3)), kNistRad);
  }
}

TEST(FitNist, Line3d) {
  for (const std::string& name : NistCases("Line3d")) {
    SCOPED_TRACE(name);
    const auto p = ReadNistPoints(NistDir() + "Line3d/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Line3d/" + name + ".fit");
    ASSERT_EQ(ref.size(), 6u);
    const LineFit3D fit = FitLine3D(p);
    EXPECT_LT((fit.point - Vec3(ref, 0)).norm(), kNistMm);
    EXPECT_LT(AxisAngle(fit.direction, Vec3(ref, 3)), kNistRad);
  }
}

TEST(FitNist, Plane) {
  for (const std::string& name : NistCases("Plane")) {
    SCOPED_TRACE(name);
    const auto p = ReadNistPoints(NistDir() + "Plane/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Plane/" + name + ".fit");
    ASSERT_EQ(ref.size(), 6u);
    const PlaneFit fit = FitPlane(p);
    EXPECT_LT(std::abs((fit.point - Vec3(ref, 0)).dot(Vec3(ref, 3))), kNistMm);
    EXPECT_LT(AxisAngle(fit.normal, Vec3(ref, 3)), kNistRad);
  }
}

TEST(FitNist, Circle3d) {
  for (const std::string& name : NistCases("Circle3d")) {
    SCOPED_TRACE(name);
    const auto p = ReadNistPoints(NistDir() + "Circle3d/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Circle3d/" + name + ".fit");
    ASSERT_EQ(ref.size(), 7u);
    const CircleFit3D fit = FitCircle3D(p);
    EXPECT_LT((fit.centre - Vec3(ref, 0)).norm(), kNistMm);
    EXPECT_LT(AxisAngle(fit.normal, Vec3(ref, 3)), kNistRad);
    EXPECT_NEAR(2 * fit.radius_mm, ref[6], kNistMm);
    EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  }
}

TEST(FitNist, Sphere) {
  for (const std::string& name : NistCases("Sphere")) {
    SCOPED_TRACE(name);
    const auto p = ReadNistPoints(NistDir() + "Sphere/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Sphere/" + name + ".fit");
    ASSERT_EQ(ref.size(), 4u);
    const SphereFit fit = FitSphere(p);
    EXPECT_LT((fit.centre - Vec3(ref, 0)).norm(), kNistMm);
    EXPECT_NEAR(2 * fit.radius_mm, ref[3], kNistMm);
    EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  }
}

// --- QIF sample: stored circle results -------------------------------------

// The three bores of the QIF sample: 219 probe-centre points each (not
// compensated), so the stored diameter is the fitted one plus the probe
// diameter. The stored normal is exactly the nominal -Z and the stored z the
// nominal height: the CMM fitted the circle in the nominal plane.
TEST(FitQif, CirclesReproduceStoredResults) {
  const struct {
    const char* measurement;
    const char* point_set;
  } circles[] = {{"<CircleFeatureMeasurement id=\"28\">", "29"},
                 {"<CircleFeatureMeasurement id=\"261\">", "262"},
                 {"<CircleFeatureMeasurement id=\"509\">", "510"}};
  for (const auto& c : circles) {
    SCOPED_TRACE(c.point_set);
    const Eigen::Matrix3Xd p = testing::ReadQifPointSet(c.point_set);
    ASSERT_EQ(p.cols(), 219);
    const auto location = testing::QifNumbersAfter(c.measurement, "Location");
    const auto diameter = testing::QifNumbersAfter(c.measurement, "Diameter");
    ASSERT_EQ(location.size(), 3u);
    ASSERT_EQ(diameter.size(), 1u);
    const Eigen::Matrix2Xd xy = p.topRows(2);
    const CircleFit2D fit = FitCircle2D(xy);
    // Stored with 12 decimals from points with 11; the CMM's own solver
    // stops a few nm short (observed up to 4e-9 mm), hence 1e-8 mm.
    EXPECT_NEAR(fit.centre.x(), location[0], 1e-8);
    EXPECT_NEAR(fit.centre.y(), location[1], 1e-8);
    EXPECT_NEAR(2 * (fit.radius_mm + testing::kQifProbeRadiusMm), diameter[0],
                1e-8);
    // The free 3D circle (plane first) agrees to the tilt of the data.
    const CircleFit3D fit3 = FitCircle3D(p);
    EXPECT_NEAR(2 * (fit3.radius_mm + testing::kQifProbeRadiusMm), diameter[0],
                1e-3);
    EXPECT_LT(AxisAngle(fit3.normal, Eigen::Vector3d::UnitZ()), 5e-3);
  }
}

// --- synthetic cases --------------------------------------------------------

// Points on a plane through `origin` with normal `normal`, spread over a
// square of side `size_mm`, with Gaussian noise along the normal.
Eigen::Matrix3Xd PlanePoints(std::mt19937_64& rng,
                             const Eigen::Vector3d& origin,
                             const Eigen::Vector3d& normal, double size_mm,
                             int n, double noise_mm) {
  Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
  std::uniform_real_distribution<double> uni(-size_mm / 2, size_mm / 2);
  std::normal_distribution<double> g(0, noise_mm);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    p.col(i) = origin + uni(rng) * u + uni(rng) * v + g(rng) * normal;
  }
  return p;
}

Eigen::Matrix2Xd ArcPoints(std::mt19937_64& rng, const Eigen::Vector2d& centre,
                           double radius, double start_rad, double span_rad,
                           int n, double noise_mm) {
  std::uniform_real_distribution<double> uni(start_rad, start_rad + span_rad);
  std::normal_distribution<double> g(0, noise_mm);
  Eigen::Matrix2Xd p(2, n);
  for (int i = 0; i < n; ++i) {
    const double t = uni(rng);
    p.col(i) =
        centre + (radius + g(rng)) * Eigen::Vector2d(std::cos(t), std::sin(t));
  }
  return p;
}

TEST(FitPlane, FarFromOriginExactPlaneIsRecovered) {
  std::mt19937_64 rng(1);
  const Eigen::Vector3d origin(4.2e4, -8.7e4, 1.3e4);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.1, -0.2, 1).normalized();
  const auto p = PlanePoints(rng, origin, normal, 150, 200, 0);
  const PlaneFit fit = FitPlane(p);
  EXPECT_LT(AxisAngle(fit.normal, normal), 1e-12);
  EXPECT_LT(std::abs((fit.point - origin).dot(normal)), 1e-9);
  EXPECT_LT(fit.summary.rms_mm, 1e-9);
  EXPECT_NEAR(fit.u.norm(), 1, 1e-12);
  EXPECT_NEAR(fit.u.dot(fit.normal), 0, 1e-12);
  EXPECT_NEAR(fit.v.dot(fit.normal), 0, 1e-12);
  EXPECT_EQ(fit.summary.parameter_names.size(), 3u);
  EXPECT_EQ(fit.summary.covariance.rows(), 3);
}

TEST(FitPlane, ThreePointsFitExactly) {
  Eigen::Matrix3Xd p(3, 3);
  p << 0, 10, 0,  //
      0, 0, 10,   //
      5, 5, 5;
  const PlaneFit fit = FitPlane(p);
  EXPECT_LT(AxisAngle(fit.normal, Eigen::Vector3d::UnitZ()), 1e-14);
  EXPECT_NEAR(fit.point.z(), 5, 1e-12);
  EXPECT_LT(fit.summary.max_abs_mm, 1e-12);
}

// The fewest points that fix a shape (geometry: 3 a plane, 2 a 3D line,
// 3 a circle in the plane or in space, 4 a sphere) leave no residual
// degree of freedom; one point more leaves some. The count is the fit's
// own, not a table of the caller's.
TEST(FitSummary, TheFewestPointsThatFixAShapeLeaveNoDegreeOfFreedom) {
  const auto on_circle = [](int n, double z_tilt) {
    Eigen::Matrix3Xd p(3, n);
    for (int k = 0; k < n; ++k) {
      const double a = 2 * M_PI * k / n + 0.3;
      p.col(k) << 100 + 20 * std::cos(a), -50 + 20 * std::sin(a),
          7 + z_tilt * std::cos(a);
    }
    return p;
  };
  const auto on_sphere = [](int n) {
    Eigen::Matrix3Xd p(3, n);
    const double d[5][3] = {
        {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {-0.6, -0.64, -0.48}, {0, -1, 0}};
    for (int k = 0; k < n; ++k)
      p.col(k) = Eigen::Vector3d(5, 6, 7) +
                 12.5 * Eigen::Vector3d(d[k][0], d[k][1], d[k][2]);
    return p;
  };
  for (int more : {0, 1}) {
    Eigen::Matrix3Xd line(3, 2 + more);
    for (int k = 0; k < 2 + more; ++k)
      line.col(k) << 1 + 3 * k, 2 - k, 4 + 2 * k;
    EXPECT_EQ(FitLine3D(line).summary.DegreesOfFreedom() > 0, more > 0);
    EXPECT_EQ(FitPlane(on_circle(3 + more, 2.0)).summary.DegreesOfFreedom() > 0,
              more > 0);
    EXPECT_EQ(
        FitCircle3D(on_circle(3 + more, 2.0)).summary.DegreesOfFreedom() > 0,
        more > 0);
    const Eigen::Matrix3Xd flat = on_circle(3 + more, 0.0);
    EXPECT_EQ(FitCircle2D(flat.topRows<2>()).summary.DegreesOfFreedom() > 0,
              more > 0);
    EXPECT_EQ(FitSphere(on_sphere(4 + more)).summary.DegreesOfFreedom() > 0,
              more > 0);
  }
  EXPECT_EQ(FitSphere(on_sphere(4)).summary.DegreesOfFreedom(), 0);
  EXPECT_EQ(FitLine3D(on_circle(3, 0.0)).summary.DegreesOfFreedom(), 2);
}

TEST(FitPlane, ResidualStatisticsMatchNoise) {
  std::mt19937_64 rng(2);
  const auto p = PlanePoints(rng, Eigen::Vector3d(1, 2, 3),
                             Eigen::Vector3d::UnitZ(), 100, 5000, 1e-3);
  const PlaneFit fit = FitPlane(p);
  EXPECT_NEAR(fit.summary.rms_mm, 1e-3, 5e-5);
  EXPECT_GT(fit.summary.max_abs_mm, 3e-3);
  EXPECT_EQ(fit.summary.points, 5000);
}

// Covariance scaled by the residual variance must match the scatter of the
// estimates over seeded repetitions.
TEST(FitPlane, CovarianceMatchesEmpiricalScatter) {
  std::mt19937_64 rng(3);
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, 0.1, 1).normalized();
  const Eigen::Vector3d origin(1e4, 2e4, -3e4);
  const int trials = 400;
  // Reference frame from a noise-free fit with the same sampling pattern.
  double sum_offset_sq = 0, sum_tilt_sq = 0, predicted_offset = 0,
         predicted_tilt = 0;
  for (int t = 0; t < trials; ++t) {
    const auto p = PlanePoints(rng, origin, normal, 80, 30, 2e-3);
    const PlaneFit fit = FitPlane(p);
    const double offset = (fit.point - origin).dot(normal);
    const double tilt = AxisAngle(fit.normal, normal);  // |tilt| in 2D
    sum_offset_sq += offset * offset;
    sum_tilt_sq += tilt * tilt;
    predicted_offset += fit.summary.covariance(0, 0);
    predicted_tilt +=
        fit.summary.covariance(1, 1) + fit.summary.covariance(2, 2);
  }
  EXPECT_NEAR(std::sqrt(sum_offset_sq / predicted_offset), 1.0, 0.2);
  EXPECT_NEAR(std::sqrt(sum_tilt_sq / predicted_tilt), 1.0, 0.2);
}

TEST(FitPlane, HuberRejectsFivePercentOutliers) {
  std::mt19937_64 rng(4);
  auto p = PlanePoints(rng, Eigen::Vector3d(0, 0, 20), Eigen::Vector3d::UnitZ(),
                       100, 400, 1e-3);
  for (int i = 0; i < 20; ++i) p(2, i * 20) += 0.5;  // 5 % stray points
  const PlaneFit plain = FitPlane(p);
  FitOptions robust;
  robust.loss = FitOptions::Loss::kHuber;
  robust.loss_scale_mm = 3e-3;
  const PlaneFit fit = FitPlane(p, robust);
  EXPECT_GT(std::abs(plain.point.z() - 20), 0.02);  // plain fit is pulled
  EXPECT_LT(std::abs(fit.point.z() - 20), 1e-3);
  EXPECT_LT(AxisAngle(fit.normal, Eigen::Vector3d::UnitZ()), 2e-5);
  robust.loss = FitOptions::Loss::kCauchy;
  const PlaneFit cauchy = FitPlane(p, robust);
  EXPECT_LT(std::abs(cauchy.point.z() - 20), 3e-4);
}

TEST(FitPlane, DegenerateInputThrows) {
  Eigen::Matrix3Xd collinear(3, 4);
  collinear << 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3;
  EXPECT_THROW(FitPlane(collinear), InputError);
  EXPECT_THROW(FitPlane(Eigen::Matrix3Xd(3, 2)), InputError);
  Eigen::Matrix3Xd nan = Eigen::Matrix3Xd::Random(3, 5);
  nan(1, 2) = std::nan("");
  EXPECT_THROW(FitPlane(nan), InputError);
}

TEST(FitOptions, ValidateNamesTheField) {
  FitOptions o;
  o.loss_scale_mm = 0;
  try {
    o.Validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "FitOptions.loss_scale_mm");
  }
  o = FitOptions();
  o.max_iterations = 0;
  try {
    o.Validate();
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "FitOptions.max_iterations");
  }
  EXPECT_THROW(FitCircle2D(Eigen::Matrix2Xd::Random(2, 10), o), InputError);
  std::string error;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error.rfind("FitOptions.max_iterations:", 0), 0u) << error;
  EXPECT_TRUE(FitOptions().IsValid(&error));
}

// Near-degenerate inputs far from the origin: points on a line (for a
// plane, a circle), on one point (for a line). Each is refused (an
// InputError naming the shape) or comes back not usable; never a result
// that looks fine.
TEST(FitDegenerate, NearlyCollinearOrCoincidentFarFromOrigin) {
  std::mt19937_64 rng(45);
  std::uniform_real_distribution<double> t(-10, 10);
  std::normal_distribution<double> jitter(0, 1e-10);
  const Eigen::Vector3d origin(2e4, -3e4, 1e4), dir = RandomUnit(rng);
  Eigen::Matrix3Xd line(3, 50), point(3, 50);
  for (int i = 0; i < 50; ++i) {
    line.col(i) = origin + t(rng) * dir +
                  Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng));
    point.col(i) = origin + Eigen::Vector3d(jitter(rng), 0, 0) * 1e-3;
  }
  auto refused = [](auto&& fit) {
    try {
      return !fit().summary.Usable();
    } catch (const InputError&) {
      return true;
    }
  };
  EXPECT_TRUE(refused([&] { return FitPlane(line); }));
  EXPECT_TRUE(refused([&] { return FitCircle3D(line); }));
  EXPECT_TRUE(refused([&] { return FitSphere(line); }));
  EXPECT_TRUE(refused([&] { return FitCylinder(line); }));
  EXPECT_TRUE(refused([&] { return FitCone(line); }));
  const Eigen::Matrix2Xd line2 = line.topRows<2>();
  EXPECT_TRUE(refused([&] { return FitCircle2D(line2); }));
  EXPECT_TRUE(refused([&] { return FitLine3D(point); }));
}

// A sphere through points on a plane far from the origin: its centre runs
// off along the normal; the status says the points do not determine it.
TEST(FitSphere, PlaneIsDegenerate) {
  std::mt19937_64 rng(44);
  std::uniform_real_distribution<double> x(-20, 20);
  std::normal_distribution<double> g(0, 1e-3);
  Eigen::Matrix3Xd p(3, 200);
  for (int i = 0; i < 200; ++i)
    p.col(i) = Eigen::Vector3d(4e3 + x(rng), -6e3 + x(rng), 250 + g(rng));
  const SphereFit fit = FitSphere(p);
  EXPECT_FALSE(fit.summary.Usable())
      << fit.summary.message << " r = " << fit.radius_mm;
}

TEST(FitCircle2D, FarFromOriginFullCircle) {
  std::mt19937_64 rng(5);
  const Eigen::Vector2d centre(5.3e4, -9.1e4);
  const auto p = ArcPoints(rng, centre, 99.5, 0, 2 * M_PI, 100, 0);
  const CircleFit2D fit = FitCircle2D(p);
  EXPECT_LT((fit.centre - centre).norm(), 1e-9);
  EXPECT_NEAR(fit.radius_mm, 99.5, 1e-9);
  EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
}

TEST(FitCircle2D, ShortArcWithNoiseIsWithinItsUncertainty) {
  std::mt19937_64 rng(6);
  const Eigen::Vector2d centre(1.2e4, 3.4e4);
  // 15 degree arc of a 100 mm circle, 1 um noise.
  const auto p = ArcPoints(rng, centre, 100, 0.3, 15 * M_PI / 180, 60, 1e-3);
  const CircleFit2D fit = FitCircle2D(p);
  ASSERT_EQ(fit.summary.covariance.rows(), 3);
  const double sigma_r = std::sqrt(fit.summary.covariance(2, 2));
  EXPECT_GT(sigma_r, 1e-4);  // a short arc leaves the radius uncertain
  EXPECT_LT(std::abs(fit.radius_mm - 100), 4 * sigma_r);
  EXPECT_LT(std::abs(fit.centre.x() - centre.x()),
            4 * std::sqrt(fit.summary.covariance(0, 0)));
  EXPECT_NEAR(fit.summary.rms_mm, 1e-3, 3e-4);
}

TEST(FitCircle2D, ThreePointsDefineTheCircle) {
  Eigen::Matrix2Xd p(2, 3);
  p << 10, 0, -10,  //
      0, 10, 0;
  const CircleFit2D fit = FitCircle2D(p);
  EXPECT_LT(fit.centre.norm(), 1e-12);
  EXPECT_NEAR(fit.radius_mm, 10, 1e-12);
}

TEST(FitCircle2D, CovarianceMatchesEmpiricalScatter) {
  std::mt19937_64 rng(7);
  const Eigen::Vector2d centre(-2e4, 7e4);
  const int trials = 300;
  Eigen::Vector3d sum_sq = Eigen::Vector3d::Zero(), predicted = sum_sq;
  for (int t = 0; t < trials; ++t) {
    const auto p = ArcPoints(rng, centre, 50, 1.0, 2.0, 25, 2e-3);
    const CircleFit2D fit = FitCircle2D(p);
    const Eigen::Vector3d e(fit.centre.x() - centre.x(),
                            fit.centre.y() - centre.y(), fit.radius_mm - 50);
    sum_sq += e.cwiseProduct(e);
    predicted += fit.summary.covariance.diagonal();
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(std::sqrt(sum_sq(k) / predicted(k)), 1.0, 0.2) << k;
  }
}

TEST(FitCircle2D, RobustLossRejectsOutliers) {
  std::mt19937_64 rng(8);
  auto p = ArcPoints(rng, Eigen::Vector2d(3, 4), 25, 0, 2 * M_PI, 200, 1e-3);
  for (int i = 0; i < 10; ++i) p.col(i * 20) *= 1.02;  // 5 % stray points
  FitOptions robust;
  robust.loss = FitOptions::Loss::kHuber;
  robust.loss_scale_mm = 3e-3;
  const CircleFit2D plain = FitCircle2D(p);
  const CircleFit2D fit = FitCircle2D(p, robust);
  EXPECT_GT(std::abs(plain.radius_mm - 25), 0.01);
  EXPECT_NEAR(fit.radius_mm, 25, 5e-4);
  EXPECT_LT((fit.centre - Eigen::Vector2d(3, 4)).norm(), 5e-4);
}

TEST(FitCircle2D, DegenerateInputThrows) {
  Eigen::Matrix2Xd collinear(2, 5);
  collinear << 0, 1, 2, 3, 4, 0, 2, 4, 6, 8;
  EXPECT_THROW(FitCircle2D(collinear), InputError);
  EXPECT_THROW(FitCircle2D(Eigen::Matrix2Xd::Random(2, 2)), InputError);
}

TEST(FitLine, FarFromOriginAndRobust) {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g(0, 1e-3);
  std::uniform_real_distribution<double> t(-50, 50);
  const Eigen::Vector3d a(3e4, 6e4, -1e4), d = RandomUnit(rng);
  Eigen::Matrix3Xd p(3, 300);
  for (int i = 0; i < 300; ++i) {
    p.col(i) = a + t(rng) * d + Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  const LineFit3D fit = FitLine3D(p);
  EXPECT_LT(DistanceToLine(fit.point, a, d), 5e-4);
  EXPECT_LT(AxisAngle(fit.direction, d), 5e-5);
  for (int i = 0; i < 15; ++i) p.col(i * 20) += 0.3 * d.unitOrthogonal();
  FitOptions robust;
  robust.loss = FitOptions::Loss::kHuber;
  robust.loss_scale_mm = 3e-3;
  const LineFit3D plain = FitLine3D(p);
  const LineFit3D rob = FitLine3D(p, robust);
  EXPECT_GT(DistanceToLine(plain.point, a, d), 5e-3);
  EXPECT_LT(DistanceToLine(rob.point, a, d), 5e-4);
  EXPECT_LT(AxisAngle(rob.direction, d), 5e-5);

  Eigen::Matrix2Xd q(2, 4);
  q << 1e5, 1e5 + 1, 1e5 + 2, 1e5 + 3, 0, 1, 2, 3;
  const LineFit2D l2 = FitLine2D(q);
  EXPECT_NEAR(std::abs(l2.direction.dot(Eigen::Vector2d(1, 1).normalized())), 1,
              1e-15);
  EXPECT_THROW(FitLine2D(Eigen::Matrix2Xd::Zero(2, 3)), InputError);
}

TEST(FitSphere, NearlyFlatCapFarFromOrigin) {
  std::mt19937_64 rng(10);
  const Eigen::Vector3d centre(2e4, -5e4, 9e4);
  std::uniform_real_distribution<double> phi(0, 2 * M_PI), cz(std::cos(0.1), 1);
  Eigen::Matrix3Xd p(3, 50);
  for (int i = 0; i < 50; ++i) {
    const double c = cz(rng), s = std::sqrt(1 - c * c), f = phi(rng);
    p.col(i) =
        centre + 12.5 * Eigen::Vector3d(s * std::cos(f), s * std::sin(f), c);
  }
  const SphereFit fit = FitSphere(p);
  EXPECT_LT((fit.centre - centre).norm(), 1e-8);
  EXPECT_NEAR(fit.radius_mm, 12.5, 1e-8);
  Eigen::Matrix3Xd flat = p;
  flat.row(2).setConstant(3);
  EXPECT_THROW(FitSphere(flat), InputError);
}

TEST(FitCircle3D, TiltedCircleFarFromOrigin) {
  std::mt19937_64 rng(11);
  const Eigen::Vector3d centre(-7e4, 1e4, 4e4), n = RandomUnit(rng);
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  Eigen::Matrix3Xd p(3, 7);
  for (int i = 0; i < 7; ++i) {
    const double t = 0.4 * i;
    p.col(i) = centre + 30 * (std::cos(t) * u + std::sin(t) * v);
  }
  const CircleFit3D fit = FitCircle3D(p);
  EXPECT_LT((fit.centre - centre).norm(), 1e-8);
  EXPECT_LT(AxisAngle(fit.normal, n), 1e-11);
  EXPECT_NEAR(fit.radius_mm, 30, 1e-9);
  EXPECT_EQ(fit.summary.covariance.rows(), 6);
}

}  // namespace
}  // namespace ttp::fit
