// Recursive weighted least squares with exponential forgetting, in square-
// root information form (the triangular factor R of the information matrix
// is updated by Givens rotations; R^T R is never formed), which stays
// accurate where the covariance form loses symmetry and definiteness.
//
// Several outputs share the regressors (one factor R, one right-hand side
// per output). After updates k = 1..N with regressors phi_k, values y_k
// (one per output), weights w_k and
// forgetting factors lambda_k applied before update k, Solve() returns the
// minimiser of
//   sum_k (prod_{j>k} lambda_j) w_k (y_k - phi_k' theta)^2 + ridge |theta|^2
// (the ridge is not forgotten: it keeps theta defined when the data do not
// determine every direction yet).
#pragma once

#include <Eigen/Core>

namespace ttp::talc {

class RecursiveLeastSquares {
 public:
  RecursiveLeastSquares() = default;
  RecursiveLeastSquares(int parameters, int outputs, double ridge);

  // Discounts all earlier data by lambda (0 < lambda <= 1), then adds one
  // weighted observation (y: one value per output).
  void Update(const Eigen::Ref<const Eigen::VectorXd>& phi,
              const Eigen::Ref<const Eigen::VectorXd>& y, double weight,
              double lambda);
  // Parameters, one column per output.
  Eigen::MatrixXd Solve() const;
  // Numerical rank of the data factor R (singular values above
  // max(p) * eps * largest).
  int Rank() const;
  int updates() const { return updates_; }
  int parameters() const { return int(z_.rows()); }

 private:
  Eigen::MatrixXd r_;  // upper triangular, p x p
  Eigen::MatrixXd z_;  // R theta = z, one column per output
  double ridge_ = 0.0;
  int updates_ = 0;
};

}  // namespace ttp::talc
