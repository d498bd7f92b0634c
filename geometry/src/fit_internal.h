// Shared machinery of the fits (not part of the public API): centring, the
// scatter eigen decomposition, algebraic seeds and the Ceres driver that
// fills a FitSummary.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "ttp/geometry/error.h"
#include "ttp/geometry/fit.h"

namespace ttp::fit::internal {

// Eigenvalues ascending, eigenvectors as columns, of the centred scatter.
template <int D>
struct Scatter {
  Eigen::Matrix<double, D, 1> centroid;
  Eigen::Matrix<double, D, 1> eigenvalues;
  Eigen::Matrix<double, D, D> eigenvectors;
};

template <int D>
Scatter<D> ComputeScatter(const Eigen::Matrix<double, D, Eigen::Dynamic>& p) {
  Scatter<D> s;
  s.centroid = p.rowwise().mean();
  const Eigen::Matrix<double, D, Eigen::Dynamic> c = p.colwise() - s.centroid;
  const Eigen::Matrix<double, D, D> scatter = c * c.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, D, D>> eig(scatter);
  s.eigenvalues = eig.eigenvalues().cwiseMax(0.0);
  s.eigenvectors = eig.eigenvectors();
  return s;
}

// Throws InputError("fit", 0, shape, ...) unless the points are finite and
// at least `minimum` in number.
void RequirePoints(const char* shape, long count, long minimum,
                   bool all_finite);

// Relative eigenvalue below which the spread along an axis is treated as
// zero: the scatter's eigenvalues carry rounding of ~1e-16 of the largest,
// so this means an extent ratio of ~1e-7 (10 nm across 100 mm).
constexpr double kDegenerateRatio = 1e-14;

// Whether points spread at all: the largest scatter eigenvalue against
// the rounding of coordinates `distance_mm` from the origin (1e-12 of it
// per point). Points closer together than that coincide in double.
inline bool Spread(double largest_eigenvalue, long n, double distance_mm) {
  const double rounding = 1e-12 * std::max(1.0, distance_mm);
  return largest_eigenvalue > static_cast<double>(n) * rounding * rounding;
}

// Two unit vectors completing `w` to a right-handed orthonormal frame.
void CompleteFrame(const Eigen::Vector3d& w, Eigen::Vector3d* u,
                   Eigen::Vector3d* v);

// Algebraic (Kasa) circle/sphere seed on centred points: centre and radius.
template <int D>
bool AlgebraicSphere(const Eigen::Matrix<double, D, Eigen::Dynamic>& centred,
                     Eigen::Matrix<double, D, 1>* centre, double* radius) {
  const long n = centred.cols();
  const double scale = std::sqrt(centred.squaredNorm() / n);
  if (!(scale > 0)) return false;
  Eigen::MatrixXd a(n, D + 1);
  Eigen::VectorXd b(n);
  for (long i = 0; i < n; ++i) {
    const Eigen::Matrix<double, D, 1> q = centred.col(i) / scale;
    a.row(i).head(D) = 2.0 * q.transpose();
    a(i, D) = 1.0;
    b(i) = q.squaredNorm();
  }
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
  if (!x.allFinite()) return false;
  const Eigen::Matrix<double, D, 1> c = x.head(D);
  const double r2 = x(D) + c.squaredNorm();
  if (!(r2 > 0)) return false;
  *centre = c * scale;
  *radius = std::sqrt(r2) * scale;
  return true;
}

std::unique_ptr<ceres::LossFunction> MakeLoss(const FitOptions& options);

// One residual functor per point; each has
//   template <class T> bool operator()(const T* params, T* residuals) const
// and `static constexpr int kResiduals`.
struct SolveResult {
  FitSummary summary;
  double cost = 0;  // Ceres final cost (robustified)
};

// Status from Ceres' summary: converged, stopped at the iteration limit, or
// not usable.
void SetStatusFromCeres(const ceres::Solver::Summary& summary, FitSummary* s);

// Whether the (robustified) Jacobian at the solution determines every
// parameter: Ceres' own test for a dense covariance, (sigma_min /
// sigma_max)^2 >= 1e-14. Otherwise marks `s` degenerate, naming the
// parameter the weakest direction moves most. Checked before
// ceres::Covariance, which would log the rank deficiency to stderr.
// Ceres reports through glog (e.g. "Terminating: ..." from its minimizer
// even when Solver::Options::logging_type is SILENT). The fits report
// through FitSummary instead: raise glog's threshold to FATAL once, before
// the first solve. The project uses glog for nothing else.
void SilenceCeresLogging();

bool CheckRank(const Eigen::MatrixXd& jacobian,
               const std::vector<std::string>& names, FitSummary* s);

// The residuals of functors [first, first + count) as one Ceres residual
// block, differentiated with Ceres' Jets exactly as AutoDiffCostFunction
// differentiates one functor (the same values, in the same rows). Ceres
// spends far more per residual block (allocation, bookkeeping, a virtual
// call and a scratch copy) than a circle's or a plane's residual costs, and
// the fits take up to 10^5 points; blocks of many points make the same
// problem several times faster. A robust loss applies to a block's squared
// norm, so robust fits keep one point per block.
template <class Functor, int P>
class BatchedAutoDiffCost final : public ceres::CostFunction {
 public:
  static constexpr int kResiduals = Functor::kResiduals;
  BatchedAutoDiffCost(const Functor* first, int count)
      : first_(first), count_(count) {
    set_num_residuals(count * kResiduals);
    mutable_parameter_block_sizes()->push_back(P);
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* p = parameters[0];
    if (jacobians == nullptr || jacobians[0] == nullptr) {
      for (int i = 0; i < count_; ++i)
        if (!first_[i](p, residuals + kResiduals * i)) return false;
      return true;
    }
    using Jet = ceres::Jet<double, P>;
    std::array<Jet, P> x;
    for (int k = 0; k < P; ++k) x[k] = Jet(p[k], k);
    Jet r[kResiduals];
    double* jacobian = jacobians[0];  // row-major, residuals x P
    for (int i = 0; i < count_; ++i) {
      if (!first_[i](x.data(), r)) return false;
      for (int a = 0; a < kResiduals; ++a) {
        const int row = kResiduals * i + a;
        residuals[row] = r[a].a;
        for (int k = 0; k < P; ++k) jacobian[row * P + k] = r[a].v[k];
      }
    }
    return true;
  }

 private:
  const Functor* first_;
  int count_;
};

// Points per residual block of a fit without a robust loss.
constexpr int kPointsPerBlock = 256;

template <int P, class Functor>
SolveResult Solve(const std::vector<Functor>& functors,
                  std::array<double, P>* params, const FitOptions& options,
                  std::vector<std::string> names, bool want_covariance) {
  constexpr int R = Functor::kResiduals;
  std::unique_ptr<ceres::LossFunction> loss = MakeLoss(options);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const int per_block = loss ? 1 : kPointsPerBlock;
  const int n_functors = static_cast<int>(functors.size());
  for (int first = 0; first < n_functors; first += per_block) {
    const int count = std::min(per_block, n_functors - first);
    problem.AddResidualBlock(
        new BatchedAutoDiffCost<Functor, P>(functors.data() + first, count),
        loss.get(), params->data());
  }
  SilenceCeresLogging();
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-16;
  solver_options.gradient_tolerance = 1e-18;
  solver_options.parameter_tolerance = 1e-15;
  // At the optimum (a re-framing pass starts there) the model's predicted
  // decrease of a step rounds to zero or below, which Ceres counts as an
  // invalid step; after max_num_consecutive_invalid_steps of them (default
  // 5) it reports FAILURE and keeps the start, a good solution reported as
  // unusable depending on the last bits of rounding (one compiler's build
  // did, another's not). With room to shrink the trust region to its
  // minimum radius Ceres reports convergence there instead.
  solver_options.max_num_consecutive_invalid_steps = 100;
  solver_options.num_threads = 1;  // same input -> same output
  // The library never writes to stdout/stderr: the status says it all.
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary ceres_summary;
  ceres::Solve(solver_options, &problem, &ceres_summary);

  SolveResult out;
  out.cost = ceres_summary.final_cost;
  FitSummary& s = out.summary;
  s.points = static_cast<int>(functors.size());
  SetStatusFromCeres(ceres_summary, &s);
  s.parameter_names = std::move(names);

  // Plain (non-robust) residual statistics; weights of the robust loss for
  // the variance estimate (IRLS weights rho'(s), all 1 without a loss).
  double sum_sq = 0, weighted_sq = 0, weight_sum = 0, max_abs = 0;
  for (const Functor& f : functors) {
    double r[R];
    f(params->data(), r);
    double sq = 0;
    for (int k = 0; k < R; ++k) sq += r[k] * r[k];
    double w = 1;
    if (loss) {
      double rho[3];
      loss->Evaluate(sq, rho);
      w = rho[1];
    }
    sum_sq += sq;
    weighted_sq += w * sq;
    weight_sum += w * R;
    max_abs = std::max(max_abs, std::sqrt(sq));
  }
  const double n_residuals = static_cast<double>(functors.size()) * R;
  s.rms_mm = std::sqrt(sum_sq / n_residuals);
  s.max_abs_mm = max_abs;
  if (!s.solution_usable) return out;
  // The rank test runs on every solve, wanted covariance or not: a fit
  // whose parameters the points do not pin down is not a result.
  ceres::CRSMatrix crs;
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.num_threads = 1;
  double cost = 0;
  if (!problem.Evaluate(evaluate_options, &cost, nullptr, nullptr, &crs)) {
    s.status = FitStatus::kFailed;
    s.converged = false;
    s.message = "the Jacobian could not be evaluated at the solution";
    return out;
  }
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Zero(crs.num_rows, P);
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int k = crs.rows[row]; k < crs.rows[row + 1]; ++k)
      jacobian(row, crs.cols[k]) = crs.values[k];
  }
  if (!CheckRank(jacobian, s.parameter_names, &s)) return out;
  if (want_covariance) {
    const double dof = weight_sum - P;
    const double variance = dof > 0 ? weighted_sq / dof : 0.0;
    ceres::Covariance::Options cov_options;
    cov_options.algorithm_type = ceres::DENSE_SVD;
    cov_options.num_threads = 1;
    ceres::Covariance covariance(cov_options);
    std::vector<std::pair<const double*, const double*>> blocks = {
        {params->data(), params->data()}};
    Eigen::Matrix<double, P, P, Eigen::RowMajor> c;
    if (covariance.Compute(blocks, &problem) &&
        covariance.GetCovarianceBlock(params->data(), params->data(),
                                      c.data())) {
      s.covariance = c * variance;
    } else {
      s.status = FitStatus::kDegenerate;
      s.converged = false;
      s.message = "the covariance could not be computed (rank deficient)";
    }
  }
  return out;
}

}  // namespace ttp::fit::internal
