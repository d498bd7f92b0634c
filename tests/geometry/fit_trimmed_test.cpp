#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "fit_test_util.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/fit.h"

namespace ttp::fit {
namespace {

using testing::RandomUnit;

// The tilt covariance re-expressed in the caller's axes equals the one a
// direct least-squares fit of w = a + b s + c t in those axes gives
// ((A^T A)^-1 sigma^2, written out here), up to the small difference of
// the orthogonal Hessian (lambda - lambda_min).
TEST(OrientPlane, CovarianceInTheGivenAxes) {
  std::mt19937_64 rng(51);
  const Eigen::Vector3d normal = RandomUnit(rng);
  const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  std::uniform_real_distribution<double> x(-30, 30), y(-5, 5);
  std::normal_distribution<double> g(0, 2e-3);
  const int n = 500;
  Eigen::Matrix3Xd p(3, n);
  const Eigen::Vector3d origin(-2e3, 7e3, 4e2);
  for (int i = 0; i < n; ++i)
    p.col(i) = origin + x(rng) * e1 + y(rng) * e2 + g(rng) * normal;
  // Axes turned by 30 degrees from e1, the normal asked the other way.
  const Eigen::Vector3d hint_u =
      std::cos(0.5236) * e1 + std::sin(0.5236) * e2 + 0.1 * normal;
  const PlaneFit fit = OrientPlane(FitPlane(p), -normal, hint_u);
  EXPECT_LT((fit.normal + normal).norm(), 1e-4);
  EXPECT_NEAR(fit.u.dot(fit.normal), 0, 1e-15);
  EXPECT_GT(fit.u.dot(hint_u), 0.99);
  // Independent: the linear model in the fitted axes about the centroid.
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  double ss = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d d = p.col(i) - fit.point;
    const Eigen::Vector3d a(1.0, d.dot(fit.u), d.dot(fit.v));
    ata += a * a.transpose();
    ss += std::pow(d.dot(fit.normal), 2);
  }
  const Eigen::Matrix3d want = ata.inverse() * (ss / (n - 3));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(fit.summary.covariance(r, c), want(r, c),
                  1e-6 * std::sqrt(want(r, r) * want(c, c)))
          << r << "," << c;
}

// 2 % strays 0.1-1 mm off a noisy plane far from the origin: rejected, the
// plane is the clean one; the inliers are the points that were not moved.
TEST(FitPlaneTrimmed, RejectsStraysKeepsThePlane) {
  std::mt19937_64 rng(52);
  const Eigen::Vector3d normal = RandomUnit(rng);
  const Eigen::Vector3d e1 = normal.unitOrthogonal(), e2 = normal.cross(e1);
  std::uniform_real_distribution<double> x(-20, 20), off(0.1, 1.0);
  std::normal_distribution<double> g(0, 5e-4);
  const int n = 2000;
  Eigen::Matrix3Xd p(3, n);
  const Eigen::Vector3d origin(9e3, -1e3, 3e3);
  std::vector<Eigen::Index> all;
  for (int i = 0; i < n; ++i) {
    p.col(i) = origin + x(rng) * e1 + x(rng) * e2 + g(rng) * normal;
    if (i % 50 == 7) p.col(i) += off(rng) * normal;
    all.push_back(i);
  }
  const PlaneFit plain = FitPlane(p);
  RejectionOptions ro;
  ro.floor_mm = 0.003;
  const TrimmedPlane t = FitPlaneTrimmed(p, all, normal, e1, ro);
  EXPECT_EQ(t.rejected, n / 50);
  for (Eigen::Index i : t.inliers) EXPECT_NE(i % 50, 7);
  EXPECT_TRUE(t.plane.summary.Usable());
  EXPECT_NEAR(t.plane.summary.rms_mm, 5e-4, 1e-4);
  EXPECT_GT(plain.summary.rms_mm, 3 * t.plane.summary.rms_mm);
  EXPECT_NEAR((t.plane.point - origin).dot(normal), 0, 1e-4);
}

TEST(FitPlaneTrimmed, TooFewPointsIsAStatusNotAnException) {
  Eigen::Matrix3Xd p = Eigen::Matrix3Xd::Random(3, 10);
  const TrimmedPlane t = FitPlaneTrimmed(p, {1, 2}, Eigen::Vector3d::UnitZ(),
                                         Eigen::Vector3d::UnitX(), {});
  EXPECT_EQ(t.plane.summary.status, FitStatus::kDegenerate);
  RejectionOptions bad;
  bad.k_sigma = -1;
  std::string error;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_EQ(error.rfind("RejectionOptions.k_sigma:", 0), 0u);
  EXPECT_THROW(FitPlaneTrimmed(p, {1, 2, 3}, Eigen::Vector3d::UnitZ(),
                               Eigen::Vector3d::UnitX(), bad),
               InputError);
}

// A ring of 199 mm far from the origin, with a second surface (an inner
// floor at radius 60) and strays: the shrinking bands find the ring.
TEST(FitCircle2DTrimmed, BandsThenStraysFindTheRing) {
  std::mt19937_64 rng(53);
  const Eigen::Vector2d centre(-3.5e3, 1.2e3);
  std::uniform_real_distribution<double> t(0, 2 * M_PI), u(0, 1);
  std::normal_distribution<double> g(0, 1e-3);
  const int n = 3000;
  Eigen::Matrix2Xd p(2, n);
  for (int i = 0; i < n; ++i) {
    const double a = t(rng);
    double r = 99.5 + g(rng);
    if (i % 10 == 0) r = 60 * std::sqrt(u(rng));  // interior points
    if (i % 97 == 1) r += 0.05;                   // strays near the ring
    p.col(i) = centre + r * Eigen::Vector2d(std::cos(a), std::sin(a));
  }
  RejectionOptions ro;
  ro.max_rounds = 6;
  const TrimmedCircle c = FitCircle2DTrimmed(p, {5.0, 1.0, 0.3}, ro);
  ASSERT_TRUE(c.circle.summary.Usable()) << c.circle.summary.message;
  EXPECT_NEAR(c.circle.radius_mm, 99.5, 2e-4);
  EXPECT_LT((c.circle.centre - centre).norm(), 2e-4);
  for (Eigen::Index i : c.inliers) EXPECT_NE(i % 10, 0);
}

}  // namespace
}  // namespace ttp::fit
