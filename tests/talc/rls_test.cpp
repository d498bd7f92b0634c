// The recursive solution against a batch least-squares solution of the same
// weighted, forgotten data (normal equations solved directly).
#include "ttp/talc/rls.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

namespace ttp::talc {
namespace {

TEST(Rls, EqualsBatchWeightedLeastSquaresWithForgetting) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  std::uniform_real_distribution<double> uw(0.2, 3.0), ul(0.9, 1.0);
  const int p = 5, m = 2, n = 80;
  const double ridge = 1e-3;
  Eigen::MatrixXd phi(n, p), y(n, m);
  Eigen::VectorXd w(n), lambda(n);
  for (int k = 0; k < n; ++k) {
    for (int j = 0; j < p; ++j) phi(k, j) = j == 0 ? 1.0 : g(rng) * (j + 1);
    for (int o = 0; o < m; ++o) y(k, o) = g(rng) * 5;
    w(k) = uw(rng);
    lambda(k) = ul(rng);
  }
  RecursiveLeastSquares rls(p, m, ridge);
  for (int k = 0; k < n; ++k) {
    rls.Update(phi.row(k).transpose(), y.row(k).transpose(), w(k), lambda(k));
    if (k < 3 || k % 20 != 19) continue;
    // Batch: effective weight of row i after k updates.
    Eigen::MatrixXd a = ridge * Eigen::MatrixXd::Identity(p, p);
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(p, m);
    for (int i = 0; i <= k; ++i) {
      double f = w(i);
      for (int j = i + 1; j <= k; ++j) f *= lambda(j);
      a += f * phi.row(i).transpose() * phi.row(i);
      b += f * phi.row(i).transpose() * y.row(i);
    }
    const Eigen::MatrixXd expected = a.ldlt().solve(b);
    const Eigen::MatrixXd got = rls.Solve();
    EXPECT_LT((got - expected).norm(), 1e-9 * (1 + expected.norm())) << k;
  }
  EXPECT_EQ(rls.Rank(), p);
  EXPECT_EQ(rls.updates(), n);
}

TEST(Rls, RankCountsTheDirectionsTheDataDetermine) {
  RecursiveLeastSquares rls(3, 1, 0.0);
  Eigen::VectorXd y(1);
  y << 1.0;
  for (int k = 0; k < 10; ++k) {
    Eigen::Vector3d phi(1.0, double(k), 2.0 * k);  // third = 2 x second
    rls.Update(phi, y, 1.0, 1.0);
  }
  EXPECT_EQ(rls.Rank(), 2);
}

TEST(Rls, StaysAccurateOnBadlyScaledColumnsWhereNormalEquationsDegrade) {
  // Columns of very different scale and nearly collinear: the exact
  // parameters are recovered from noise-free data.
  const int n = 200, p = 3;
  Eigen::MatrixXd phi(n, p);
  Eigen::Vector3d truth(2.0, -3.0, 0.5);
  RecursiveLeastSquares rls(p, 1, 0.0);
  for (int k = 0; k < n; ++k) {
    const double x = k / double(n);
    phi.row(k) << 1.0, 1e3 * x, 1e3 * x + 1e-3 * std::sin(40 * x);
    Eigen::VectorXd y(1);
    y << phi.row(k).dot(truth);
    rls.Update(phi.row(k).transpose(), y, 1.0, 0.999);
  }
  EXPECT_LT((rls.Solve().col(0) - truth).norm(), 1e-5);
}

}  // namespace
}  // namespace ttp::talc
