#include "ttp/talc/rls.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

namespace ttp::talc {

RecursiveLeastSquares::RecursiveLeastSquares(int parameters, int outputs,
                                             double ridge)
    : r_(Eigen::MatrixXd::Zero(parameters, parameters)),
      z_(Eigen::MatrixXd::Zero(parameters, outputs)),
      ridge_(ridge) {}

void RecursiveLeastSquares::Update(const Eigen::Ref<const Eigen::VectorXd>& phi,
                                   const Eigen::Ref<const Eigen::VectorXd>& y,
                                   double weight, double lambda) {
  const int p = int(r_.rows());
  const int m = int(z_.cols());
  if (lambda != 1.0) {
    const double s = std::sqrt(lambda);
    r_ *= s;
    z_ *= s;
  }
  const double sw = std::sqrt(weight);
  // The new row [sw*phi | sw*y] is rotated into [R | z] column by column.
  Eigen::VectorXd row = sw * phi;
  Eigen::VectorXd yr = sw * y;
  for (int j = 0; j < p; ++j) {
    const double a = r_(j, j), b = row(j);
    if (b == 0.0) continue;
    const double h = std::hypot(a, b);
    const double c = a / h, s = b / h;
    r_(j, j) = h;
    row(j) = 0.0;
    for (int k = j + 1; k < p; ++k) {
      const double rk = r_(j, k), xk = row(k);
      r_(j, k) = c * rk + s * xk;
      row(k) = -s * rk + c * xk;
    }
    for (int o = 0; o < m; ++o) {
      const double zj = z_(j, o), yo = yr(o);
      z_(j, o) = c * zj + s * yo;
      yr(o) = -s * zj + c * yo;
    }
  }
  ++updates_;
}

Eigen::MatrixXd RecursiveLeastSquares::Solve() const {
  const int p = int(r_.rows());
  const int m = int(z_.cols());
  if (ridge_ <= 0.0) return r_.triangularView<Eigen::Upper>().solve(z_);
  // min |R theta - z|^2 + ridge |theta|^2 as one stacked QR.
  Eigen::MatrixXd a(2 * p, p);
  a << r_, std::sqrt(ridge_) * Eigen::MatrixXd::Identity(p, p);
  Eigen::MatrixXd b(2 * p, m);
  b << z_, Eigen::MatrixXd::Zero(p, m);
  return a.householderQr().solve(b);
}

int RecursiveLeastSquares::Rank() const {
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(r_);
  const auto& s = svd.singularValues();
  if (s.size() == 0 || s(0) == 0.0) return 0;
  const double tol =
      double(r_.rows()) * std::numeric_limits<double>::epsilon() * s(0);
  int rank = 0;
  for (int i = 0; i < s.size(); ++i)
    if (s(i) > tol) ++rank;
  return rank;
}

}  // namespace ttp::talc
