#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fit_test_util.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/fit.h"

namespace ttp::fit {
namespace {

using namespace testing;  // ttp::fit::testing: NIST cases, tolerances

TEST(FitAxialNist, Cylinder) {
  const auto cases = NistCases("Cylinder");
  ASSERT_EQ(cases.size(), 3u);
  for (const std::string& name : cases) {
    SCOPED_TRACE(name);
    const auto p = ReadNistPoints(NistDir() + "Cylinder/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Cylinder/" + name + ".fit");
    ASSERT_EQ(ref.size(), 7u);
    const CylinderFit fit = FitCylinder(p);
    // The axis point may slide along the axis: it must lie on the
    // reference axis.
    EXPECT_LT(DistanceToLine(fit.point, Vec3(ref, 0), Vec3(ref, 3)), kNistMm);
    EXPECT_LT(AxisAngle(fit.axis, Vec3(ref, 3)), kNistRad);
    EXPECT_NEAR(2 * fit.radius_mm, ref[6], kNistMm);
    EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
    // The reported point is the foot of the centroid.
    EXPECT_NEAR((p.rowwise().mean() - fit.point).dot(fit.axis), 0, 1e-9);
  }
}

TEST(FitAxialNist, Cone) {
  const auto cases = NistCases("Cone");
  ASSERT_EQ(cases.size(), 3u);
  for (const std::string& name : cases) {
    SCOPED_TRACE(name);
    const auto p = ReadNistPoints(NistDir() + "Cone/" + name + ".ds");
    const auto ref = ReadNistFit(NistDir() + "Cone/" + name + ".fit");
    ASSERT_EQ(ref.size(), 8u);
    const ConeFit fit = FitCone(p);
    const Eigen::Vector3d ref_point = Vec3(ref, 0), ref_axis = Vec3(ref, 3);
    EXPECT_LT(DistanceToLine(fit.point, ref_point, ref_axis), kNistMm);
    EXPECT_LT(AxisAngle(fit.axis, ref_axis), kNistRad);
    // Both axes point towards increasing radius.
    EXPECT_GT(fit.axis.dot(ref_axis), 0);
    EXPECT_NEAR(2 * fit.half_angle_rad, ref[7] * M_PI / 180, kNistRad);
    // Orthogonal distance from the reference axis point to the fitted cone.
    const double h = (ref_point - fit.point).dot(fit.axis);
    const double radius =
        fit.radius_at_point_mm + h * std::tan(fit.half_angle_rad);
    EXPECT_NEAR(radius * std::cos(fit.half_angle_rad), ref[6], kNistMm);
    // The apex lies on the axis, radius_at_point / tan(half angle) behind.
    EXPECT_LT(DistanceToLine(fit.apex, ref_point, ref_axis), 1e-5);
    EXPECT_TRUE(fit.summary.converged) << fit.summary.message;
  }
}

// The QIF sample's bore: 18 probe-centre points on two levels, not
// compensated: stored diameter = fitted diameter + probe diameter.
TEST(FitAxialQif, CylinderReproducesStoredResult) {
  const Eigen::Matrix3Xd p = testing::ReadQifPointSet("797");
  ASSERT_EQ(p.cols(), 18);
  const std::string anchor = "<CylinderFeatureMeasurement id=\"796\">";
  const auto axis_point = testing::QifNumbersAfter(anchor, "AxisPoint");
  const auto direction = testing::QifNumbersAfter(anchor, "Direction");
  const auto diameter = testing::QifNumbersAfter(anchor, "Diameter");
  ASSERT_EQ(axis_point.size(), 3u);
  ASSERT_EQ(direction.size(), 3u);
  ASSERT_EQ(diameter.size(), 1u);
  const CylinderFit fit = FitCylinder(p);
  const Eigen::Vector3d ref_point = Vec3(axis_point, 0);
  const Eigen::Vector3d ref_axis = Vec3(direction, 0);
  // Stored to 12 decimals; direction cosines to ~1e-12.
  EXPECT_LT(DistanceToLine(fit.point, ref_point, ref_axis), 1e-8);
  EXPECT_LT(AxisAngle(fit.axis, ref_axis), 1e-8);
  EXPECT_NEAR(2 * (fit.radius_mm + testing::kQifProbeRadiusMm), diameter[0],
              1e-8);
}

Eigen::Matrix3Xd CylinderPoints(std::mt19937_64& rng,
                                const Eigen::Vector3d& point,
                                const Eigen::Vector3d& axis, double radius,
                                double length, double span_rad, int n,
                                double noise_mm) {
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  std::uniform_real_distribution<double> t(0, span_rad), h(0, length);
  std::normal_distribution<double> g(0, noise_mm);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = t(rng);
    p.col(i) = point + h(rng) * axis +
               (radius + g(rng)) * (std::cos(a) * u + std::sin(a) * v);
  }
  return p;
}

// Points on a cone (heights from the apex in [z0, z1], all around), with
// normal noise along the surface normal.
Eigen::Matrix3Xd ConePoints(std::mt19937_64& rng, const Eigen::Vector3d& apex,
                            const Eigen::Vector3d& axis, double half_angle,
                            double z0, double z1, int n, double noise_mm) {
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  std::uniform_real_distribution<double> t(0, 2 * M_PI), h(z0, z1);
  std::normal_distribution<double> g(0, noise_mm);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const double a = t(rng), z = h(rng);
    const Eigen::Vector3d radial = std::cos(a) * u + std::sin(a) * v;
    const Eigen::Vector3d normal =
        std::cos(half_angle) * radial - std::sin(half_angle) * axis;
    p.col(i) =
        apex + z * axis + z * std::tan(half_angle) * radial + g(rng) * normal;
  }
  return p;
}

TEST(FitCylinder, FarFromOriginShortAndLong) {
  std::mt19937_64 rng(21);
  for (double length : {5.0, 40.0, 400.0}) {
    SCOPED_TRACE(length);
    const Eigen::Vector3d point(6e4, -2e4, 3e4), axis = RandomUnit(rng);
    const auto p =
        CylinderPoints(rng, point, axis, 99.5, length, 2 * M_PI, 200, 0);
    const CylinderFit fit = FitCylinder(p);
    EXPECT_LT(DistanceToLine(fit.point, point, axis), 1e-8);
    EXPECT_LT(AxisAngle(fit.axis, axis), 1e-10);
    EXPECT_NEAR(fit.radius_mm, 99.5, 1e-8);
    EXPECT_NEAR(fit.u.cross(fit.v).dot(fit.axis), 1, 1e-12);
  }
}

TEST(FitCylinder, PartialArcWithNoiseWithinUncertainty) {
  std::mt19937_64 rng(22);
  const Eigen::Vector3d point(1e4, 1e4, 1e4), axis = RandomUnit(rng);
  // A 90 degree strip, 1 um noise.
  const auto p = CylinderPoints(rng, point, axis, 50, 30, M_PI / 2, 300, 1e-3);
  const CylinderFit fit = FitCylinder(p);
  ASSERT_EQ(fit.summary.covariance.rows(), 5);
  const double sigma_r = std::sqrt(fit.summary.covariance(4, 4));
  EXPECT_LT(std::abs(fit.radius_mm - 50), 4 * sigma_r);
  const double sigma_tilt =
      std::sqrt(fit.summary.covariance(2, 2) + fit.summary.covariance(3, 3));
  EXPECT_LT(AxisAngle(fit.axis, axis), 4 * sigma_tilt);
  EXPECT_NEAR(fit.summary.rms_mm, 1e-3, 2e-4);
}

// Clouds larger than the seeds are ranked on (2000 points): a disc-like
// short cylinder (its largest scatter across the axis), a long one and a
// 90 degree strip, far from the origin, with 1 um noise; the winner is
// refined on every point, so the result is the whole cloud's, within its
// own uncertainty of the generator's cylinder.
TEST(FitCylinder, LargeCloudsFarFromOrigin) {
  std::mt19937_64 rng(27);
  struct Case {
    double length_mm, span_rad;
  };
  for (const Case c :
       {Case{5.0, 2 * M_PI}, Case{400.0, 2 * M_PI}, Case{30.0, M_PI / 2}}) {
    SCOPED_TRACE(c.length_mm);
    const Eigen::Vector3d point(6e4, -2e4, 3e4), axis = RandomUnit(rng);
    const auto p = CylinderPoints(rng, point, axis, 99.5, c.length_mm,
                                  c.span_rad, 10000, 1e-3);
    const CylinderFit fit = FitCylinder(p);
    ASSERT_EQ(fit.summary.status, FitStatus::kConverged) << fit.summary.message;
    ASSERT_EQ(fit.summary.covariance.rows(), 5);
    const auto sigma = [&](int k) {
      return std::sqrt(fit.summary.covariance(k, k));
    };
    EXPECT_LT(std::abs(fit.radius_mm - 99.5), 4 * sigma(4));
    EXPECT_LT(AxisAngle(fit.axis, axis), 4 * std::hypot(sigma(2), sigma(3)));
    EXPECT_LT(DistanceToLine(fit.point, point, axis),
              4 * std::hypot(sigma(0), sigma(1)) +
                  AxisAngle(fit.axis, axis) * c.length_mm);
    EXPECT_NEAR(fit.summary.rms_mm, 1e-3, 2e-5);
  }
}

TEST(FitCylinder, CovarianceMatchesEmpiricalScatter) {
  std::mt19937_64 rng(23);
  const Eigen::Vector3d point(-3e4, 5e3, 2e4);
  const Eigen::Vector3d axis = Eigen::Vector3d(0.1, 0.2, 1).normalized();
  const int trials = 200;
  double sq_r = 0, pred_r = 0, sq_tilt = 0, pred_tilt = 0;
  for (int t = 0; t < trials; ++t) {
    const auto p = CylinderPoints(rng, point, axis, 20, 25, 2 * M_PI, 40, 2e-3);
    const CylinderFit fit = FitCylinder(p);
    ASSERT_EQ(fit.summary.covariance.rows(), 5)
        << "trial " << t << ": " << fit.summary.message;
    const double e_r = fit.radius_mm - 20, e_t = AxisAngle(fit.axis, axis);
    sq_r += e_r * e_r;
    sq_tilt += e_t * e_t;
    pred_r += fit.summary.covariance(4, 4);
    pred_tilt += fit.summary.covariance(2, 2) + fit.summary.covariance(3, 3);
  }
  EXPECT_NEAR(std::sqrt(sq_r / pred_r), 1.0, 0.2);
  EXPECT_NEAR(std::sqrt(sq_tilt / pred_tilt), 1.0, 0.2);
}

TEST(FitCylinder, RobustLossRejectsOutliers) {
  std::mt19937_64 rng(24);
  const Eigen::Vector3d point(0, 0, 0), axis = Eigen::Vector3d::UnitZ();
  auto p = CylinderPoints(rng, point, axis, 15, 20, 2 * M_PI, 400, 1e-3);
  for (int i = 0; i < 20; ++i) {
    p.col(i * 20).head<2>() *= 1.03;  // 5 % stray points outside
  }
  FitOptions robust;
  robust.loss = FitOptions::Loss::kHuber;
  robust.loss_scale_mm = 3e-3;
  const CylinderFit plain = FitCylinder(p);
  const CylinderFit fit = FitCylinder(p, robust);
  EXPECT_GT(std::abs(plain.radius_mm - 15), 0.01);
  EXPECT_NEAR(fit.radius_mm, 15, 5e-4);
  EXPECT_LT(DistanceToLine(fit.point, point, axis), 5e-4);
}

TEST(FitCylinder, DegenerateInputThrows) {
  Eigen::Matrix3Xd collinear(3, 6);
  for (int i = 0; i < 6; ++i) collinear.col(i) = Eigen::Vector3d(i, 2 * i, 0);
  EXPECT_THROW(FitCylinder(collinear), InputError);
  EXPECT_THROW(FitCylinder(Eigen::Matrix3Xd::Random(3, 4)), InputError);
}

TEST(FitCone, FarFromOriginRecoversApexAndAngle) {
  std::mt19937_64 rng(25);
  for (double half_angle_deg : {5.0, 30.0, 60.0}) {
    SCOPED_TRACE(half_angle_deg);
    const double half_angle = half_angle_deg * M_PI / 180;
    const Eigen::Vector3d apex(-4e4, 8e4, 1e4), axis = RandomUnit(rng);
    const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
    std::uniform_real_distribution<double> t(0, 2 * M_PI), h(20, 60);
    Eigen::Matrix3Xd p(3, 150);
    for (int i = 0; i < 150; ++i) {
      const double a = t(rng), z = h(rng);
      p.col(i) = apex + z * axis +
                 z * std::tan(half_angle) * (std::cos(a) * u + std::sin(a) * v);
    }
    const ConeFit fit = FitCone(p);
    EXPECT_LT((fit.apex - apex).norm(), 1e-7);
    EXPECT_GT(fit.axis.dot(axis), 1 - 1e-12);
    EXPECT_NEAR(fit.half_angle_rad, half_angle, 1e-10);
    EXPECT_EQ(fit.summary.covariance.rows(), 6);
  }
}

// A cone of 10000 points (more than the seeds are ranked on), far from
// the origin, with 1 um noise.
TEST(FitCone, LargeCloudFarFromOrigin) {
  std::mt19937_64 rng(28);
  const double half_angle = 0.4;
  const Eigen::Vector3d apex(-4e4, 8e4, 1e4), axis = RandomUnit(rng);
  const auto p = ConePoints(rng, apex, axis, half_angle, 20, 60, 10000, 1e-3);
  const ConeFit fit = FitCone(p);
  ASSERT_EQ(fit.summary.status, FitStatus::kConverged) << fit.summary.message;
  ASSERT_EQ(fit.summary.covariance.rows(), 6);
  EXPECT_LT(std::abs(fit.half_angle_rad - half_angle),
            4 * std::sqrt(fit.summary.covariance(5, 5)));
  EXPECT_GT(fit.axis.dot(axis), std::cos(1e-5));
  EXPECT_LT((fit.apex - apex).norm(), 1e-3);
  EXPECT_NEAR(fit.summary.rms_mm, 1e-3, 2e-5);
}

TEST(FitCone, NoisyConeWithinUncertaintyAndRobust) {
  std::mt19937_64 rng(26);
  const double half_angle = 0.3;
  const Eigen::Vector3d apex(100, 200, 300), axis = RandomUnit(rng);
  Eigen::Matrix3Xd p =
      ConePoints(rng, apex, axis, half_angle, 10, 40, 400, 1e-3);
  const ConeFit fit = FitCone(p);
  const double sigma = std::sqrt(fit.summary.covariance(5, 5));
  EXPECT_LT(std::abs(fit.half_angle_rad - half_angle), 4 * sigma);
  EXPECT_NEAR(fit.summary.rms_mm, 1e-3, 2e-4);
  // 5 % outliers 0.2 mm off the surface, along its normal (along the
  // generatrix from the apex they would stay on the cone).
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d d = p.col(i * 20) - apex;
    const Eigen::Vector3d radial = (d - d.dot(axis) * axis).normalized();
    p.col(i * 20) +=
        0.2 * (std::cos(half_angle) * radial - std::sin(half_angle) * axis);
  }
  EXPECT_GT((FitCone(p).apex - apex).norm(), 5e-3);  // the plain fit is pulled
  FitOptions robust;
  robust.loss = FitOptions::Loss::kCauchy;
  robust.loss_scale_mm = 3e-3;
  const ConeFit rob = FitCone(p, robust);
  EXPECT_NEAR(rob.half_angle_rad, half_angle, 1e-4);
  EXPECT_LT((rob.apex - apex).norm(), 5e-3);
}

// Points that fit a shape perfectly well but do not determine it: a
// cylinder through a plane (radius and axis position run off together), a
// cone on a cylinder (half angle 0: no apex) and on a plane (90 degrees).
// Far from the origin, with noise: the status says so instead of a result.
Eigen::Matrix3Xd NoisyPlane(std::mt19937_64& rng, int n) {
  const Eigen::Vector3d origin(3e3, -2e3, 5e2), normal = RandomUnit(rng);
  const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
  std::uniform_real_distribution<double> x(-20, 20);
  std::normal_distribution<double> g(0, 1e-3);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i)
    p.col(i) = origin + x(rng) * u + x(rng) * v + g(rng) * normal;
  return p;
}

TEST(FitCylinder, PlaneIsDegenerateNotAResult) {
  std::mt19937_64 rng(41);
  const CylinderFit fit = FitCylinder(NoisyPlane(rng, 200));
  EXPECT_EQ(fit.summary.status, FitStatus::kDegenerate)
      << fit.summary.message << " r = " << fit.radius_mm;
  EXPECT_FALSE(fit.summary.Usable());
  EXPECT_NE(fit.summary.message.find("do not determine"), std::string::npos);
  EXPECT_EQ(fit.summary.covariance.size(), 0);
}

TEST(FitCone, CylinderAndPlaneAreDegenerate) {
  std::mt19937_64 rng(42);
  // Exact cylinder of radius 5 about a far, tilted axis.
  const Eigen::Vector3d q(-7e3, 2e3, 1e3), axis = RandomUnit(rng);
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  std::uniform_real_distribution<double> t(0, 2 * M_PI), h(-15, 15);
  Eigen::Matrix3Xd cyl(3, 60);
  for (int i = 0; i < 60; ++i) {
    const double a = t(rng);
    cyl.col(i) = q + h(rng) * axis + 5 * (std::cos(a) * u + std::sin(a) * v);
  }
  const ConeFit on_cylinder = FitCone(cyl);
  EXPECT_FALSE(on_cylinder.summary.Usable())
      << "half angle " << on_cylinder.half_angle_rad << " apex "
      << on_cylinder.apex.transpose();
  const ConeFit on_plane = FitCone(NoisyPlane(rng, 200));
  EXPECT_EQ(on_plane.summary.status, FitStatus::kDegenerate)
      << on_plane.summary.message << " half angle " << on_plane.half_angle_rad;
  // A slender but real cone (0.5 degrees) is still a cone.
  Eigen::Matrix3Xd slim(3, 60);
  const double tan_half = std::tan(0.5 * M_PI / 180);
  for (int i = 0; i < 60; ++i) {
    const double a = t(rng), z = 100 + h(rng);
    slim.col(i) =
        q + z * axis + z * tan_half * (std::cos(a) * u + std::sin(a) * v);
  }
  const ConeFit fit = FitCone(slim);
  EXPECT_TRUE(fit.summary.Usable()) << fit.summary.message;
  EXPECT_LT((fit.apex - q).norm(), 1e-5);
}

TEST(FitCylinder, IterationLimitIsReportedNotHidden) {
  std::mt19937_64 rng(43);
  const Eigen::Vector3d q(100, 200, 300), axis = RandomUnit(rng);
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  std::uniform_real_distribution<double> t(0, M_PI / 3), h(-15, 15);
  std::normal_distribution<double> g(0, 1e-3);
  Eigen::Matrix3Xd p(3, 80);
  for (int i = 0; i < 80; ++i) {
    const double a = t(rng);
    p.col(i) =
        q + h(rng) * axis + (8 + g(rng)) * (std::cos(a) * u + std::sin(a) * v);
  }
  FitOptions one;
  one.max_iterations = 1;
  const CylinderFit fit = FitCylinder(p, one);
  EXPECT_EQ(fit.summary.status, FitStatus::kNoConvergence)
      << fit.summary.termination << ": " << fit.summary.message;
  EXPECT_FALSE(fit.summary.Usable());
  EXPECT_EQ(FitCylinder(p).summary.status, FitStatus::kConverged);
}

}  // namespace
}  // namespace ttp::fit
