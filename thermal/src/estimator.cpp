#include "ttp/thermal/estimator.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "ttp/geometry/error.h"
#include "ttp/geometry/series.h"

namespace ttp::thermal {
namespace {

struct InputSpec {
  const char* name;
  NumericColumn column;
  double scale;  // to the model's unit
  bool relative_to_start;
};
struct InputSpecPower {
  InputSpec spec;
  int power;  // heat from friction grows with speed (1) or its square (2)
};
const InputSpecPower kEstimatorInputs[] = {
    {{"c_rpm/1000", kCRpm, 1e-3, false}, 1},
    {{"(c_rpm/1000)^2", kCRpm, 1e-3, false}, 2},
    {{"spindle_rpm/1000", kSpindleRpm, 1e-3, false}, 1},
    {{"(spindle_rpm/1000)^2", kSpindleRpm, 1e-3, false}, 2},
    {{"T_env-T_env(0)", kTEnv, 1.0, true}, 1},
    {{"T_ws-T_ws(0)", kTWs, 1.0, true}, 1},
    {{"dT_cool", kDTCool, 1.0, false}, 1}};

// A weak prior on the lags' initial states (a pseudo-observation of 0 with
// this weight, in the error's unit): states the R-tests barely see (a lag
// that decays before the first R-test) stay small instead of exploding.
constexpr double kInitialStateRidge = 0.01;
// Below this many R-tests the cross-validation chooses the model's
// structure again in every fold.
constexpr int kReselectBelowRTests = 40;
// Shortest lag of an input that is on only between R-tests (the spindle).
constexpr double kPulsedMinTauS = 1200;

// The smoother's Gaussian kernel of bandwidth h (h = inf: every R-test
// weighs the same).
double KernelWeight(double t, double x, double h) {
  return std::isinf(h) ? 1.0 : std::exp(-0.5 * std::pow((t - x) / h, 2));
}

// Kernel-smoothed (h > 0; h = inf: mean) or linearly interpolated (h = 0)
// residuals at t.
double Smooth(const std::vector<double>& t, const std::vector<double>& r,
              double h, double x) {
  if (t.empty()) return 0.0;
  if (h == 0) return Interpolate(t, r, x);
  double sw = 0, swr = 0;
  for (size_t k = 0; k < t.size(); ++k) {
    const double w = KernelWeight(t[k], x, h);
    sw += w;
    swr += w * r[k];
  }
  return sw > 1e-300 ? swr / sw : 0.0;
}

// The smoother's weights on the R-tests' residuals at x (Smooth is their
// dot product with the residuals).
Eigen::VectorXd SmoothWeights(const std::vector<double>& t, double h,
                              double x) {
  const int n = static_cast<int>(t.size());
  Eigen::VectorXd w = Eigen::VectorXd::Zero(n);
  if (n == 0) return w;
  if (h == 0) {
    if (x <= t.front()) {
      w[0] = 1;
    } else if (x >= t.back()) {
      w[n - 1] = 1;
    } else {
      const int i =
          static_cast<int>(std::upper_bound(t.begin(), t.end(), x) - t.begin());
      const double f = (x - t[i - 1]) / (t[i] - t[i - 1]);
      w[i - 1] = 1 - f;
      w[i] = f;
    }
    return w;
  }
  for (int k = 0; k < n; ++k) w[k] = KernelWeight(t[k], x, h);
  const double sw = w.sum();
  return sw > 1e-300 ? Eigen::VectorXd(w / sw) : Eigen::VectorXd::Zero(n);
}

// The structures a fit on n R-tests may choose: m inputs (offset, gain
// and time constant each, and with a free initial state its amplitude
// too) kept overdetermined by two R-tests for one input and by three for
// two, a free initial state only with three R-tests per parameter (enough
// to see it). One input with two to spare: an 8 h run with R-tests 2 h
// apart and none after the last cut has five, and one lag through them
// follows a machine's heating and cooling where the line between them
// does not (outside battery at 2 h without the closing R-test: 174 of 276
// right with a constant, 229 with the lag; no cause named without one
// either way). Two inputs with three to spare: with two, seven R-tests 2 h
// apart fitted two lags whose gains the cuts' phases did not pin, and the
// twin's battery at 7200 s named a cause in 2 of 48 runs without one (0
// with three).
bool StructureAffordable(int n, int m, bool free_state) {
  const int k_params = 1 + 2 * m + (free_state ? m : 0);
  const int spare = m <= 1 ? 2 : 3;
  return n >= k_params + spare && (!free_state || n >= 3 * k_params);
}

// A standard deviation estimated from m squared errors, used for the
// tails of a normal distribution: the 99.5 % quantile of Student's t with
// m degrees of freedom over the normal one (Cornish-Fisher expansion; 1
// for many evaluations, about 1.4 for six).
double SmallSampleFactor(int m) {
  if (m <= 0) return 1.0;
  const double z = 2.5758, v = std::max(m, 3);
  const double t =
      z + (z * z * z + z) / (4 * v) +
      (5 * std::pow(z, 5) + 16 * z * z * z + 3 * z) / (96 * v * v) +
      (3 * std::pow(z, 7) + 19 * std::pow(z, 5) + 17 * z * z * z - 15 * z) /
          (384 * v * v * v);
  return t / z;
}

// Least squares of the design x against ya. The structure search solves
// thousands of these on a few columns, where the Cholesky factor of the
// normal equations costs a fraction of a column-pivoting QR. They square
// x's condition number, so an ill-conditioned x (nearly collinear lags, a
// decay close to the offset) goes to the QR, as does the chosen
// structure's final fit (Choose).
constexpr int kNormalEquationsMaxColumns = 16;
// Reciprocal condition of x'x below which the QR decides: x's condition
// number above 1e4 would leave the normal equations' coefficients off by
// more than about 1e-8 of their size.
constexpr double kNormalEquationsMinRcond = 1e-8;
Eigen::VectorXd FastLeastSquares(const Eigen::MatrixXd& x,
                                 const Eigen::VectorXd& ya) {
  using Small =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                    kNormalEquationsMaxColumns, kNormalEquationsMaxColumns>;
  using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor,
                                    kNormalEquationsMaxColumns, 1>;
  if (x.cols() <= kNormalEquationsMaxColumns) {
    Small gram(x.cols(), x.cols());
    // (coefficient-wise: a blocked matrix product costs more than it
    // saves on so few columns)
    gram.noalias() = x.transpose().lazyProduct(x);
    const Eigen::LLT<Small> llt(gram);
    if (llt.info() == Eigen::Success &&
        llt.rcond() > kNormalEquationsMinRcond) {
      SmallVector xty(x.cols());
      xty.noalias() = x.transpose().lazyProduct(ya);
      return llt.solve(xty);
    }
  }
  return x.colPivHouseholderQr().solve(ya);
}

// Candidate input subsets of up to max_inputs of n inputs.
void Subsets(int n, int max_size, int first, std::vector<int>& current,
             std::vector<std::vector<int>>& out) {
  out.push_back(current);
  if (static_cast<int>(current.size()) == max_size) return;
  for (int i = first; i < n; ++i) {
    current.push_back(i);
    Subsets(n, max_size, i + 1, current, out);
    current.pop_back();
  }
}

// The median of a non-empty set (the upper one of an even count).
double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Whether the prediction in force jumps at the R-tests (the controller
// re-anchors or updates its model with each measurement) rather than
// changing smoothly: the change of pred_ across each R-test row (from the
// last row before it to the first at or after it), against the changes
// between consecutive rows elsewhere, both in units of the R-tests' noise
// (largest over the seven errors). Re-anchoring: the median jump at the
// R-tests exceeds half the R-test noise and five times the median change
// between other rows.
bool PredictionReanchorsAtRTests(const TalcLog& log,
                                 const std::vector<double>& pred_t,
                                 const std::vector<CAxisErrors>& pred,
                                 const std::array<double, 7>& noise) {
  if (pred_t.size() < 3 || log.rtests.size() < 3) return false;
  auto step = [&](size_t a, size_t b) {
    const auto pa = pred[a].ToMicro(), pb = pred[b].ToMicro();
    double m = 0;
    for (int e = 0; e < 7; ++e)
      m = std::max(m, std::abs(pb[e] - pa[e]) / std::max(noise[e], 1e-9));
    return m;
  };
  std::vector<double> jumps, steps;
  std::vector<bool> at_rtest(pred_t.size(), false);
  for (size_t k = 1; k < log.rtests.size(); ++k) {
    const double t = log.rtests[k].t_end_s;
    const size_t after = static_cast<size_t>(
        std::lower_bound(pred_t.begin(), pred_t.end(), t) - pred_t.begin());
    if (after == 0 || after >= pred_t.size()) continue;
    jumps.push_back(step(after - 1, after));
    at_rtest[after] = true;
  }
  for (size_t i = 1; i < pred_t.size(); ++i)
    if (!at_rtest[i]) steps.push_back(step(i - 1, i));
  if (jumps.size() < 2 || steps.empty()) return false;
  const double jump = Median(jumps), typical = Median(steps);
  return jump > 0.5 && jump > 5 * typical;
}

// The noise of values r at times t (k = 1) from the scatter of each about
// the straight line through its two neighbours (Gasser, Sroka and
// Jennen-Steinmetz's pseudo-residuals: a smooth r cancels, its noise does
// not), as the median absolute pseudo-residual, robust to the few R-tests
// next to a load change or with a gross error. Its relative standard
// deviation, for white noise, is about 1.4 / sqrt(pseudo-residuals) (the
// median's, with neighbouring pseudo-residuals sharing values; by
// simulation). NaN for fewer than three values.
struct NoiseReading {
  double sigma = std::numeric_limits<double>::quiet_NaN();
  double relative_sd = 0;
};
NoiseReading NoiseFromNeighbours(const std::vector<double>& t,
                                 const std::vector<double>& r) {
  std::vector<double> pseudo;
  for (size_t k = 1; k + 1 < r.size(); ++k) {
    const double span = t[k + 1] - t[k - 1];
    if (!(span > 0)) continue;
    const double a = (t[k + 1] - t[k]) / span, b = 1 - a;
    pseudo.push_back(std::abs(r[k] - a * r[k - 1] - b * r[k + 1]) /
                     std::sqrt(1 + a * a + b * b));
  }
  if (pseudo.empty()) return {};
  return {1.4826 * Median(pseudo),
          1.4 / std::sqrt(static_cast<double>(pseudo.size()))};
}

}  // namespace

bool EstimatorOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (tau_grid_s.empty()) return fail("tau_grid_s: empty");
  if (!(min_tau_fraction_of_rtest_spacing >= 0) ||
      !std::isfinite(min_tau_fraction_of_rtest_spacing))
    return fail("min_tau_fraction_of_rtest_spacing: must be >= 0 and finite");
  for (double t : tau_grid_s)
    if (!(t > 0) || !std::isfinite(t))
      return fail("tau_grid_s: every time constant must be > 0 and finite");
  if (max_inputs < 0) return fail("max_inputs: must be >= 0");
  if (!(grid_step_s > 0) || !std::isfinite(grid_step_s))
    return fail("grid_step_s: must be > 0 and finite");
  if (bandwidth_grid_s.empty()) return fail("bandwidth_grid_s: empty");
  for (double h : bandwidth_grid_s)
    if (!(h >= 0)) return fail("bandwidth_grid_s: every bandwidth >= 0");
  if (cv_block_rtests < 1) return fail("cv_block_rtests: must be >= 1");
  if (!(cut_time_error_fraction >= 0))
    return fail("cut_time_error_fraction: must be >= 0");
  if (!(rtest_noise_floor_factor >= 0))
    return fail("rtest_noise_floor_factor: must be >= 0");
  if (!(model_shape_error_fraction >= 0))
    return fail("model_shape_error_fraction: must be >= 0");
  for (double s : rtest_noise_um_or_urad)
    if (!(s >= 0)) return fail("rtest_noise_um_or_urad: every value >= 0");
  if (rtest_noise_from_log_min_rtests != 0 &&
      rtest_noise_from_log_min_rtests < 3)
    return fail("rtest_noise_from_log_min_rtests: 0 (never) or at least 3");
  if (!(rtest_noise_lower_bound_sd >= 0) ||
      !std::isfinite(rtest_noise_lower_bound_sd))
    return fail("rtest_noise_lower_bound_sd: must be >= 0 and finite");
  if (!(rtest_gross_error_z >= 0) || !std::isfinite(rtest_gross_error_z))
    return fail("rtest_gross_error_z: must be >= 0 and finite");
  if (rtest_gross_error_min_rtests < 4)
    return fail("rtest_gross_error_min_rtests: must be >= 4");
  if (!(rtest_gross_error_max_fraction >= 0 &&
        rtest_gross_error_max_fraction < 1))
    return fail("rtest_gross_error_max_fraction: must be in [0, 1)");
  return true;
}

EstimatorOptions EstimatorOptionsFor(const MachineProfile& machine,
                                     EstimatorOptions options) {
  for (int e = 0; e < 4; ++e)
    options.rtest_noise_um_or_urad[e] = machine.rtest_u95_um[e] / 2;
  for (int e = 0; e < 3; ++e)
    options.rtest_noise_um_or_urad[4 + e] = machine.rtest_u95_urad[e] / 2;
  return options;
}

MachineErrorEstimator MachineErrorEstimator::Fit(
    const TalcLog& log, const EstimatorOptions& options) {
  std::vector<int> skipped;
  MachineErrorEstimator est = FitExcluding(log, skipped, options, true);
  if (!(options.rtest_gross_error_z > 0) ||
      static_cast<int>(log.rtests.size()) <
          options.rtest_gross_error_min_rtests)
    return est;
  // (one at least: a log of 12 to 19 R-tests can hold a gross error too)
  const int max_left_out = std::max(
      1, static_cast<int>(std::floor(options.rtest_gross_error_max_fraction *
                                     log.rtests.size())));
  std::vector<LeftOutRTest> left_out;
  while (static_cast<int>(skipped.size()) < max_left_out) {
    // The candidate: the R-test whose cross-validation error lies farthest
    // from the others' (their median; the median absolute deviation from
    // it as the scale, never below the R-test's own noise), for any error.
    // A gross error in the fit shifts every other R-test's error alike:
    // the median follows that shift, zero would not. The refit without it
    // confirms (a clean log costs no refit).
    const int n = static_cast<int>(est.rtest_t_.size());
    if (n < 4 || static_cast<int>(est.cv_error_.size()) != n) break;
    std::array<double, 7> centre{}, scale{};
    for (int e = 0; e < 7; ++e) {
      std::vector<double> a;
      for (int k = 0; k < n; ++k)
        if (std::isfinite(est.cv_error_[k][e]))
          a.push_back(est.cv_error_[k][e]);
      if (a.empty()) continue;
      centre[e] = Median(a);
      for (double& v : a) v = std::abs(v - centre[e]);
      scale[e] = std::max(1.4826 * Median(a), est.RTestNoise(e));
    }
    int candidate = -1;
    double worst = options.rtest_gross_error_z;
    for (int k = 0; k < n; ++k) {
      if (est.rtest_log_index_[k] == 0) continue;  // the reference
      for (int e = 0; e < 7; ++e) {
        if (!(scale[e] > 0)) continue;
        const double z = std::abs(est.cv_error_[k][e] - centre[e]) / scale[e];
        if (std::isfinite(z) && z > worst) {
          worst = z;
          candidate = k;
        }
      }
    }
    if (candidate < 0) break;
    // Confirmed against the estimate without it, with that estimate's
    // budget at the R-test's time and the R-test's own noise.
    std::vector<int> without = skipped;
    without.push_back(est.rtest_log_index_[candidate]);
    MachineErrorEstimator refit = FitExcluding(log, without, options, true);
    const double t = est.rtest_t_[candidate];
    const std::array<double, 7> value = est.rtest_y_[candidate].ToMicro();
    const std::array<double, 7> estimate = refit.MachineErrorsAt(t).ToMicro();
    LeftOutRTest worst_error;
    for (int e = 0; e < 7; ++e) {
      const double d = value[e] - estimate[e];
      const double sigma =
          std::hypot(refit.ErrorSigmaAt(e, t), refit.RTestNoise(e));
      const double z = sigma > 0 ? std::abs(d) / sigma : 0.0;
      if (z > worst_error.z) {
        worst_error.error = e;
        worst_error.deviation_um_or_urad = d;
        worst_error.z = z;
      }
    }
    if (!(worst_error.z > options.rtest_gross_error_z)) break;
    worst_error.line = log.rtests[est.rtest_log_index_[candidate]].line;
    worst_error.t_s = t;
    left_out.push_back(worst_error);
    skipped = std::move(without);
    est = std::move(refit);
  }
  std::sort(left_out.begin(), left_out.end(),
            [](const LeftOutRTest& a, const LeftOutRTest& b) {
              return a.t_s < b.t_s;
            });
  est.left_out_ = std::move(left_out);
  return est;
}

MachineErrorEstimator MachineErrorEstimator::FitWithout(
    const TalcLog& log, int skip, const EstimatorOptions& options) {
  // (a fit for one leave-one-out check needs no budget)
  return FitExcluding(log, std::vector<int>{skip}, options, skip < 0);
}

MachineErrorEstimator MachineErrorEstimator::FitExcluding(
    const TalcLog& log, const std::vector<int>& skipped,
    const EstimatorOptions& options, bool cross_validate) {
  std::string invalid;
  if (!options.IsValid(&invalid))
    throw std::invalid_argument("EstimatorOptions." + invalid);
  MachineErrorEstimator est;
  est.options_ = options;
  est.compensation_ = log.compensation;
  if (log.rtests.size() < 2) {
    throw InputError(log.source, 0, "rtest",
                     "the log needs at least two R-tests to estimate the "
                     "machine's errors");
  }
  // Prediction in force, from every row giving all seven pred_ values.
  for (const auto& row : log.rows) {
    bool all = true;
    for (int i = 0; i < 7; ++i) all &= row.Has(NumericColumn(kPredEX0C + i));
    if (!all) continue;
    std::array<double, 7> micro;
    for (int i = 0; i < 7; ++i) micro[i] = row.values[kPredEX0C + i];
    if (!est.pred_t_.empty() && row.t_s == est.pred_t_.back()) continue;
    est.pred_t_.push_back(row.t_s);
    est.pred_.push_back(CAxisErrors::FromMicro(micro));
  }
  if (log.compensation && est.pred_t_.empty()) {
    throw InputError(log.source, 0, "pred_EX0C",
                     "compensation on but no row gives the pred_ values; "
                     "the machine's own error cannot be recovered");
  }

  // Machine errors at the R-tests (log units for the fit).
  for (int k = 0; k < static_cast<int>(log.rtests.size()); ++k) {
    if (std::find(skipped.begin(), skipped.end(), k) != skipped.end()) continue;
    const RTestRecord& r = log.rtests[k];
    CAxisErrors y = r.measured;
    if (log.compensation) y = y + est.PredictedAt(r.t_ref_s);
    if (!est.rtest_t_.empty() && r.t_ref_s <= est.rtest_t_.back()) {
      throw InputError(log.source, r.line, "dur_s",
                       "R-test refers to a time not after the previous one");
    }
    est.rtest_t_.push_back(r.t_ref_s);
    est.rtest_y_.push_back(y);
    est.rtest_log_index_.push_back(k);
  }

  switch (options.compensation_fit) {
    case EstimatorOptions::CompensationFit::kResidual:
      est.fit_machine_ = !log.compensation;
      break;
    case EstimatorOptions::CompensationFit::kMachine:
      est.fit_machine_ = true;
      break;
    case EstimatorOptions::CompensationFit::kAuto:
      est.fit_machine_ =
          !log.compensation ||
          PredictionReanchorsAtRTests(log, est.pred_t_, est.pred_,
                                      options.rtest_noise_um_or_urad);
      break;
  }

  // Input signals, lag-filtered for every tau on a uniform grid.
  const double t0 = std::min(log.FirstTimeS(), est.rtest_t_.front());
  const double t1 = std::max(log.LastTimeS(), est.rtest_t_.back());
  const double dt = options.grid_step_s;
  const int steps = static_cast<int>(std::ceil((t1 - t0) / dt)) + 1;
  est.grid_t0_ = t0;
  for (const InputSpecPower& sp : kEstimatorInputs) {
    const InputSpec& spec = sp.spec;
    std::vector<double> t, v;
    for (const auto& row : log.rows) {
      if (!row.Has(spec.column)) continue;
      if (!t.empty() && row.t_s == t.back()) continue;
      t.push_back(row.t_s);
      v.push_back(std::pow(row.values[spec.column] * spec.scale, sp.power));
    }
    if (t.size() < 2) continue;
    const double base = spec.relative_to_start ? v.front() : 0.0;
    const auto [mn, mx] = std::minmax_element(v.begin(), v.end());
    if (*mx - *mn < 1e-9) continue;  // constant: carries no information
    Signal s;
    s.name = spec.name;
    s.pulsed = spec.column == kSpindleRpm;
    s.column = spec.column;
    // The input at the middle of each grid step (u[i] for the step ending
    // at grid point i), shared by every lag.
    std::vector<double> u(steps);
    u[0] = Interpolate(t, v, t0) - base;
    for (int i = 1; i < steps; ++i)
      u[i] = Interpolate(t, v, t0 + (i - 0.5) * dt) - base;
    for (double tau : options.tau_grid_s) {
      std::vector<double> f(steps);
      const double a = 1.0 - std::exp(-dt / tau);
      double x = u[0];  // start in steady state
      f[0] = x;
      for (int i = 1; i < steps; ++i) {
        x += a * (u[i] - x);
        f[i] = x;
      }
      s.filtered.push_back(std::move(f));
    }
    est.signals_.push_back(std::move(s));
  }

  for (const CutRecord& cut : log.cuts) est.cut_t_.push_back(cut.t_s);
  est.at_rtests_ = est.Tabulate(est.rtest_t_);
  est.at_cuts_ = est.Tabulate(est.cut_t_);

  // Per error: BIC over input subsets and time constants.
  const int n = static_cast<int>(est.rtest_t_.size());
  est.models_.resize(7);
  est.model_input_index_.resize(7);
  est.model_tau_index_.resize(7);
  est.choice_.resize(7);
  est.coef_map_.resize(7);
  est.hat_.resize(7);
  est.residual_.assign(n, {});
  std::vector<int> all(n);
  for (int k = 0; k < n; ++k) all[k] = k;
  for (int e = 0; e < 7; ++e) {
    // With compensation on the fit targets the R-test residual (machine minus
    // pred_) while pred_ is continuous (it follows the fast dynamics of the
    // inputs, so what is left is smoother), the machine's own error when
    // pred_ jumps at the R-tests (FitBaseAt).
    Eigen::VectorXd y(n);
    for (int k = 0; k < n; ++k) {
      y[k] = (est.rtest_y_[k] - est.FitBaseAt(est.rtest_t_[k])).ToMicro()[e];
    }
    est.SelectModel(e, y, all);
    {
      // The fit is linear in the R-test values: coefficients = map * y.
      const Eigen::MatrixXd x = est.Design(est.choice_[e], all);
      const Eigen::MatrixXd map =
          x.colPivHouseholderQr()
              .solve(Eigen::MatrixXd::Identity(x.rows(), x.rows()))
              .leftCols(n);
      est.coef_map_[e] = map;
      est.hat_[e] = x.topRows(n) * map;
    }
    for (int k = 0; k < n; ++k) {
      est.residual_[k][e] = y[k] - est.ModelAt(e, est.rtest_t_[k]);
    }
    // Residual smoother: the bandwidth with the least leave-one-out error.
    double best = std::numeric_limits<double>::infinity();
    double best_bandwidth = 0;
    for (double h : options.bandwidth_grid_s) {
      est.models_[e].bandwidth_s = h;
      double ss = 0;
      for (int k = 0; k < n; ++k) {
        const double r = est.ResidualAt(e, est.rtest_t_[k], k);
        ss += (r - est.residual_[k][e]) * (r - est.residual_[k][e]);
      }
      if (ss < best - 1e-12) {
        best = ss;
        est.models_[e].loo_rms_um_or_urad = std::sqrt(ss / n);
        best_bandwidth = h;
      }
    }
    est.models_[e].bandwidth_s = best_bandwidth;
  }
  // The R-tests' own noise: the stated one, or the log's where it shows
  // more, read from the model's residuals, which the load's dynamics leave
  // smooth (the values themselves bend at the load changes).
  for (int e = 0; e < 7; ++e) {
    const double stated = options.rtest_noise_um_or_urad[e];
    est.rtest_noise_[e] = stated;
    est.rtest_noise_from_log_[e] = std::numeric_limits<double>::quiet_NaN();
    if (options.rtest_noise_from_log_min_rtests == 0 ||
        n < options.rtest_noise_from_log_min_rtests)
      continue;
    std::vector<double> r(n);
    for (int k = 0; k < n; ++k) r[k] = est.residual_[k][e];
    const NoiseReading from_log = NoiseFromNeighbours(est.rtest_t_, r);
    if (!std::isfinite(from_log.sigma)) continue;
    est.rtest_noise_from_log_[e] = from_log.sigma;
    const double bound =
        from_log.sigma * std::max(0.0, 1 - options.rtest_noise_lower_bound_sd *
                                               from_log.relative_sd);
    est.rtest_noise_[e] = std::max(stated, bound);
  }
  if (cross_validate) est.CrossValidate();
  return est;
}

// Error e's model chosen on the R-tests `rows` (y indexed like rtest_t_):
// inputs, time constants and whether the lags' initial state is free, by
// BIC.
MachineErrorEstimator::Choice MachineErrorEstimator::Choose(
    int e, const std::vector<double>& y, const std::vector<int>& rows,
    int affordable_n) const {
  const int n = static_cast<int>(rows.size());
  const int n_afford = affordable_n > 0 ? affordable_n : n;
  const int n_inputs = static_cast<int>(signals_.size());
  const int n_tau = static_cast<int>(options_.tau_grid_s.size());
  // (the longest time constant of the grid is always tried)
  const double min_tau_s =
      std::min(options_.min_tau_fraction_of_rtest_spacing * MeanRTestSpacingS(),
               *std::max_element(options_.tau_grid_s.begin(),
                                 options_.tau_grid_s.end()));
  std::vector<std::vector<int>> subsets;
  std::vector<int> current;
  Subsets(n_inputs, options_.max_inputs, 0, current, subsets);
  double best_bic = std::numeric_limits<double>::infinity();
  Choice best;
  Eigen::VectorXd yv(n);
  for (int r = 0; r < n; ++r) yv[r] = y[rows[r]];
  for (int state = 0; state < (options_.free_initial_state ? 2 : 1); ++state) {
    const bool free_state = state == 1;
    for (const auto& subset : subsets) {
      const int m = static_cast<int>(subset.size());
      if (free_state && m == 0) continue;
      // One term per physical input (speed or its square, not both: they
      // are nearly collinear at the R-tests and extrapolate wildly).
      bool distinct = true;
      for (int a = 0; a < m; ++a)
        for (int b = a + 1; b < m; ++b)
          distinct &= signals_[subset[a]].column != signals_[subset[b]].column;
      if (!distinct) continue;
      const int k_params = 1 + 2 * m + (free_state ? m : 0);
      if (!StructureAffordable(n_afford, m, free_state)) continue;
      std::vector<int> taus(m, 0);
      while (true) {
        // The spindle turns only during cuts, which no R-test sees: only
        // its slow lags (the heat it leaves) are observable.
        bool observable = true;
        for (int k = 0; k < m; ++k)
          observable &= !(signals_[subset[k]].pulsed &&
                          options_.tau_grid_s[taus[k]] < kPulsedMinTauS) &&
                        options_.tau_grid_s[taus[k]] >= min_tau_s;
        Choice c;
        c.subset = subset;
        c.taus = taus;
        c.free_state = free_state;
        if (!observable) {
          int k = 0;
          while (k < m && ++taus[k] == n_tau) taus[k++] = 0;
          if (k == m) break;
          continue;
        }
        const Eigen::MatrixXd x = Design(c, rows);
        Eigen::VectorXd ya = Eigen::VectorXd::Zero(x.rows());
        ya.head(n) = yv;
        const Eigen::VectorXd beta = FastLeastSquares(x, ya);
        const double rss =
            std::max((yv - x.topRows(n) * beta).squaredNorm(), 1e-12);
        const double bic = n * std::log(rss / n) + k_params * std::log(n);
        bool bounded = true;
        if (bic < best_bic - 1e-9 && beta.allFinite() && !cut_t_.empty()) {
          // No blind extrapolation to the cuts (cut_t_).
          const Eigen::VectorXd at_rtests = x.topRows(n) * beta;
          const double lo = at_rtests.minCoeff(), hi = at_rtests.maxCoeff();
          const double margin =
              std::max(0.5 * (hi - lo), 2.0 * std::sqrt(rss / n));
          for (size_t j = 0; j < cut_t_.size(); ++j) {
            const double v = at_cuts_.RowDot(c, j, beta);
            bounded &= v >= lo - margin && v <= hi + margin;
          }
        }
        if (bic < best_bic - 1e-9 && beta.allFinite() && bounded) {
          best_bic = bic;
          c.beta = beta;
          c.bic = bic;
          c.rms = std::sqrt(rss / n);
          best = c;
        }
        int k = 0;  // next combination of time constants
        while (k < m && ++taus[k] == n_tau) taus[k++] = 0;
        if (k == m) break;
      }
    }
  }
  if (!std::isfinite(best_bic)) {  // too few R-tests: offset only
    best = Choice{};
    best.beta = Eigen::VectorXd::Constant(1, yv.mean());
    best.rms = std::sqrt((yv.array() - yv.mean()).square().mean());
    return best;
  }
  // The chosen structure's coefficients from the QR (FastLeastSquares).
  const Eigen::MatrixXd x = Design(best, rows);
  Eigen::VectorXd ya = Eigen::VectorXd::Zero(x.rows());
  ya.head(n) = yv;
  best.beta = x.colPivHouseholderQr().solve(ya);
  const double rss =
      std::max((yv - x.topRows(n) * best.beta).squaredNorm(), 1e-12);
  const int m = static_cast<int>(best.subset.size());
  best.bic = n * std::log(rss / n) +
             (1 + 2 * m + (best.free_state ? m : 0)) * std::log(n);
  best.rms = std::sqrt(rss / n);
  return best;
}

// Columns at the R-tests `rows`: offset, the lagged inputs, their decays
// from the log's start (free initial state), then one weak-prior row per
// initial state.
Eigen::MatrixXd MachineErrorEstimator::Design(
    const Choice& c, const std::vector<int>& rows) const {
  const int n = static_cast<int>(rows.size());
  const int m = static_cast<int>(c.subset.size());
  const int ridge = c.free_state ? m : 0;
  Eigen::MatrixXd x = Eigen::MatrixXd::Zero(n + ridge, 1 + m + ridge);
  x.col(0).head(n).setOnes();
  for (int a = 0; a < m; ++a) {
    for (int r = 0; r < n; ++r) {
      const size_t k = static_cast<size_t>(rows[r]);
      x(r, 1 + a) = at_rtests_.Input(c.subset[a], c.taus[a], k);
      if (c.free_state) x(r, 1 + m + a) = at_rtests_.Decay(c.taus[a], k);
    }
  }
  for (int k = 0; k < ridge; ++k) x(n + k, 1 + m + k) = kInitialStateRidge;
  return x;
}

MachineErrorEstimator::InputTable MachineErrorEstimator::Tabulate(
    const std::vector<double>& times_s) const {
  InputTable t;
  t.taus = options_.tau_grid_s.size();
  t.times = times_s.size();
  t.inputs.resize(signals_.size() * t.taus * t.times);
  t.decays.resize(t.taus * t.times);
  for (size_t tau = 0; tau < t.taus; ++tau) {
    for (size_t k = 0; k < t.times; ++k) {
      t.decays[t.DecaySlot(tau, k)] =
          std::exp(-(times_s[k] - grid_t0_) / options_.tau_grid_s[tau]);
      for (size_t input = 0; input < signals_.size(); ++input)
        t.inputs[t.InputSlot(input, tau, k)] =
            InputAt(static_cast<int>(input), static_cast<int>(tau), times_s[k]);
    }
  }
  return t;
}

double MachineErrorEstimator::InputTable::RowDot(
    const Choice& c, size_t k, const Eigen::VectorXd& beta) const {
  const int m = static_cast<int>(c.subset.size());
  double v = beta[0];
  for (int a = 0; a < m; ++a) {
    v += beta[1 + a] * Input(c.subset[a], c.taus[a], k);
    if (c.free_state) v += beta[1 + m + a] * Decay(c.taus[a], k);
  }
  return v;
}

Eigen::VectorXd MachineErrorEstimator::Row(const Choice& c, double t) const {
  const int m = static_cast<int>(c.subset.size());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(1 + m + (c.free_state ? m : 0));
  x[0] = 1;
  for (int k = 0; k < m; ++k) {
    x[1 + k] = InputAt(c.subset[k], c.taus[k], t);
    if (c.free_state)
      x[1 + m + k] = std::exp(-(t - grid_t0_) / options_.tau_grid_s[c.taus[k]]);
  }
  return x;
}

void MachineErrorEstimator::SelectModel(int e, const Eigen::VectorXd& y,
                                        const std::vector<int>& rows) {
  const std::vector<double> yv(y.data(), y.data() + y.size());
  const Choice c = Choose(e, yv, rows);
  ErrorModel& model = models_[e];
  model = ErrorModel{};
  model.unit = e < 4 ? "um" : "urad";
  model.offset_um_or_urad = c.beta[0];
  model.bic = c.bic;
  model.rms_residual_um_or_urad = c.rms;
  model.free_initial_state = c.free_state;
  const int m = static_cast<int>(c.subset.size());
  for (int k = 0; k < m; ++k) {
    model.inputs.push_back(signals_[c.subset[k]].name);
    model.tau_s.push_back(options_.tau_grid_s[c.taus[k]]);
    model.gains_um_or_urad_per_input_unit.push_back(c.beta[1 + k]);
    model.initial_state_um_or_urad.push_back(c.free_state ? c.beta[1 + m + k]
                                                          : 0.0);
  }
  model_input_index_[e] = c.subset;
  model_tau_index_[e] = c.taus;
  choice_[e] = c;
}

// Blocked cross-validation: every block of consecutive R-tests is held
// out, the model refitted without it (its structure chosen again when the
// R-tests are few enough for that to be cheap; else its coefficients) and
// evaluated there, residual smoother included.
void MachineErrorEstimator::CrossValidate() {
  const int n = static_cast<int>(rtest_t_.size());
  const int block = CvBlock();
  const bool reselect = n <= kReselectBelowRTests;
  cv_error_.assign(n, {});
  for (auto& row : cv_error_)
    row.fill(std::numeric_limits<double>::quiet_NaN());
  for (int e = 0; e < 7; ++e) {
    std::vector<double> y(n);
    for (int k = 0; k < n; ++k)
      y[k] = (rtest_y_[k] - FitBaseAt(rtest_t_[k])).ToMicro()[e];
    double ss = 0;
    int count = 0;
    for (int b0 = 0; b0 < n; b0 += block) {
      const int b1 = std::min(n, b0 + block);
      std::vector<int> kept;
      for (int k = 0; k < n; ++k)
        if (k < b0 || k >= b1) kept.push_back(k);
      if (kept.size() < 2) continue;
      Choice c = choice_[e];
      // The structure is chosen again on the kept R-tests (its choice is
      // part of what is validated), among the structures the whole log
      // can afford: with the held-out R-tests' count taken off, R-tests
      // 2 h apart (six of them afford one input, five none) would have the
      // folds validate a constant and the smoother across 2 h gaps, not
      // the estimator used (on the outside generator its budget at the
      // cuts was then 2.5 to 6 times the error on EX0C..ER0T).
      if (reselect) {
        c = Choose(e, y, kept, n);
      } else {
        const Eigen::MatrixXd x = Design(c, kept);
        Eigen::VectorXd ya = Eigen::VectorXd::Zero(x.rows());
        for (size_t r = 0; r < kept.size(); ++r) ya[r] = y[kept[r]];
        c.beta = x.colPivHouseholderQr().solve(ya);
      }
      if (!c.beta.allFinite()) continue;
      std::vector<double> tk, rk;
      for (int k : kept) {
        tk.push_back(rtest_t_[k]);
        rk.push_back(y[k] - at_rtests_.RowDot(c, k, c.beta));
      }
      for (int k = b0; k < b1; ++k) {
        const double t = rtest_t_[k];
        const double pred = at_rtests_.RowDot(c, k, c.beta) +
                            Smooth(tk, rk, models_[e].bandwidth_s, t);
        ss += (pred - y[k]) * (pred - y[k]);
        cv_error_[k][e] = y[k] - pred;
        ++count;
      }
    }
    models_[e].cv_rms_um_or_urad =
        count > 0 ? std::sqrt(ss / count) : models_[e].loo_rms_um_or_urad;
    models_[e].cv_evaluations = count;
  }
}

double MachineErrorEstimator::MeanRTestSpacingS() const {
  const size_t n = rtest_t_.size();
  return n > 1 ? (rtest_t_.back() - rtest_t_.front()) / (n - 1) : 0.0;
}

double MachineErrorEstimator::CorrelationTimeS() const {
  return std::max(MeanRTestSpacingS(), options_.grid_step_s);
}

int MachineErrorEstimator::CvBlock() const {
  const int n = static_cast<int>(rtest_t_.size());
  int b = std::max(1, options_.cv_block_rtests);
  while (b > 1 && n < 4 * b) --b;
  return b;
}

double MachineErrorEstimator::NoiseSigmaAt(int e, double t_s) const {
  if (e >= static_cast<int>(coef_map_.size())) return 0.0;
  // estimate(t) = row(t) * map * y + s(t)' (I - hat) y
  const Eigen::VectorXd s =
      SmoothWeights(rtest_t_, models_[e].bandwidth_s, t_s);
  const Eigen::VectorXd w = coef_map_[e].transpose() * Row(choice_[e], t_s) +
                            s - hat_[e].transpose() * s;
  return rtest_noise_[e] * w.norm();
}

double MachineErrorEstimator::ShapeDeviationAt(int e, double t_s) const {
  const auto hi = std::upper_bound(rtest_t_.begin(), rtest_t_.end(), t_s);
  if (hi == rtest_t_.begin() || hi == rtest_t_.end()) return 0.0;
  const double ta = *(hi - 1), tb = *hi;
  if (!(tb > ta)) return 0.0;
  const double f = (t_s - ta) / (tb - ta);
  const double chord = (1 - f) * ModelAt(e, ta) + f * ModelAt(e, tb);
  return std::abs(ModelAt(e, t_s) - chord);
}

double MachineErrorEstimator::ErrorSigmaAt(int e, double t_s) const {
  return std::hypot(
      CrossValidatedSigmaAt(e, t_s),
      options_.model_shape_error_fraction * ShapeDeviationAt(e, t_s));
}

double MachineErrorEstimator::CrossValidatedSigmaAt(int e, double t_s) const {
  const double cv = models_[e].cv_rms_um_or_urad;
  // Only the stated noise comes off the cross-validation error, not the
  // log's when it is larger: noisier R-tests make the estimator's own
  // error grow with them (the structure BIC affords is simpler, the
  // smoother wider, and what they miss is systematic, which the R-tests'
  // scatter hides). On the outside generator with R-test noise x 4 and
  // thesis table 5.4 stated, taking the log's noise off left EX0C's error
  // at the cuts at 1.6 times its budget (RMS z), the table's 1.1.
  const double noise = options_.rtest_noise_um_or_urad[e];
  // cv rests on few held-out R-tests when they are sparse: its error
  // scaled to the tails of Student's t with that many degrees of freedom.
  const double tail = SmallSampleFactor(models_[e].cv_evaluations);
  const double floor =
      std::max(options_.cut_time_error_fraction * cv * tail,
               options_.rtest_noise_floor_factor * NoiseSigmaAt(e, t_s));
  const double s =
      std::max(tail * std::sqrt(std::max(cv * cv - noise * noise, 0.0)), floor);
  const double outside =
      std::max({0.0, rtest_t_.front() - t_s, t_s - rtest_t_.back()});
  const double spacing = std::max(MeanRTestSpacingS(), 1.0);
  // Between R-tests the estimator's error grows with the distance to them
  // like a Brownian bridge (variance x (gap - x) / gap at x into the gap):
  // the cross-validation measured it at the held-out R-tests of a block (x
  // = j spacings into a gap of block + 1), so a cut close to an R-test gets
  // less than a cut in the middle of its gap, never below the fraction the
  // R-tests cannot show. With fewer than four blocks the cross-validation
  // error rests on too few gaps to be scaled: one number per run.
  const int b = CvBlock();
  if (outside > 0 || static_cast<int>(rtest_t_.size()) < 4 * b)
    return s * std::sqrt(1.0 + std::pow(outside / spacing, 2));
  const auto hi = std::upper_bound(rtest_t_.begin(), rtest_t_.end(), t_s);
  if (hi == rtest_t_.begin() || hi == rtest_t_.end()) return s;
  const double ta = *(hi - 1), tb = *hi, gap = tb - ta;
  if (!(gap > 0)) return s;
  double ref = 0;
  for (int j = 1; j <= b; ++j) ref += j * (b + 1.0 - j) / (b + 1.0);
  ref *= spacing / b;
  const double bridge = (t_s - ta) * (tb - t_s) / gap;
  const double excess =
      tail * std::sqrt(std::max(cv * cv - noise * noise, 0.0));
  return std::max(excess * std::sqrt(bridge / ref), floor);
}

double MachineErrorEstimator::InputAt(int input, int tau, double t_s) const {
  return InterpolateUniform(signals_[input].filtered[tau], grid_t0_,
                            options_.grid_step_s, t_s);
}

double MachineErrorEstimator::ModelAt(int e, double t_s) const {
  const ErrorModel& m = models_[e];
  double y = m.offset_um_or_urad;
  for (size_t c = 0; c < m.inputs.size(); ++c) {
    y += m.gains_um_or_urad_per_input_unit[c] *
             InputAt(model_input_index_[e][c], model_tau_index_[e][c], t_s) +
         m.initial_state_um_or_urad[c] *
             std::exp(-(t_s - grid_t0_) / m.tau_s[c]);
  }
  return y;
}

// Residual correction at t, R-test `skip` left out (-1: none).
double MachineErrorEstimator::ResidualAt(int e, double t_s, int skip) const {
  const int n = static_cast<int>(rtest_t_.size());
  std::vector<double> t, r;
  for (int k = 0; k < n; ++k) {
    if (k == skip) continue;
    t.push_back(rtest_t_[k]);
    r.push_back(residual_[k][e]);
  }
  return Smooth(t, r, models_[e].bandwidth_s, t_s);
}

CAxisErrors MachineErrorEstimator::MachineErrorsAt(double t_s) const {
  std::array<double, 7> micro;
  for (int e = 0; e < 7; ++e) {
    micro[e] = ModelAt(e, t_s) + ResidualAt(e, t_s, -1);
  }
  return FitBaseAt(t_s) + CAxisErrors::FromMicro(micro);
}

CAxisErrors MachineErrorEstimator::LinearErrorsAt(double t_s) const {
  return Interpolate(rtest_t_, rtest_y_, t_s);
}

CAxisErrors MachineErrorEstimator::FitBaseAt(double t_s) const {
  return fit_machine_ ? CAxisErrors{} : PredictedAt(t_s);
}

CAxisErrors MachineErrorEstimator::PredictedAt(double t_s) const {
  if (!compensation_ || pred_t_.empty()) return CAxisErrors{};
  return Interpolate(pred_t_, pred_, t_s);
}

std::string MachineErrorEstimator::Describe() const {
  std::string s = fmt::format(
      "ARX(1,1) smoother: per error c + sum g_i * lag_tau_i(u_i) + free "
      "initial states, least squares on {} R-tests, inputs (speeds linear "
      "and squared, temperatures) and tau by BIC, plus R-test residuals "
      "smoothed (Gaussian kernel, bandwidth per error by leave-one-out; 0 = "
      "linear interpolation){}",
      rtest_t_.size(),
      !compensation_ ? ""
      : fit_machine_
          ? "; machine error = R-test residual + pred_, the model fitted to "
            "it (pred_ jumps at the R-tests)"
          : "; machine error = R-test residual + pred_, the model fitted to "
            "the residual (pred_ continuous)");
  for (const std::string& w : Warnings()) s += "; " + w;
  return s;
}

std::vector<std::string> MachineErrorEstimator::Warnings() const {
  std::vector<std::string> out;
  // Two R-tests leave no fold with two to fit: nothing tells the
  // estimator's error between them from the R-tests' own noise.
  if (!cv_error_.empty() &&
      std::any_of(models_.begin(), models_.end(),
                  [](const auto& m) { return m.cv_evaluations == 0; }))
    out.push_back(fmt::format(
        "{} R-tests are too few to cross-validate the estimator (at least "
        "3): its uncertainty between them is the R-tests' noise alone, "
        "which understates it",
        rtest_t_.size()));
  // R-tests noisier than stated: the budget is wider than the stated
  // R-test would give, and the user should know why and what to state.
  // Named when the log's lower bound lies a quarter above the stated noise
  // (seven errors at two standard deviations would name one in about a
  // sixth of the logs as noisy as stated).
  std::string noisier;
  for (int e = 0; e < 7 && e < static_cast<int>(models_.size()); ++e) {
    const double stated = options_.rtest_noise_um_or_urad[e];
    if (!(rtest_noise_[e] > 1.25 * stated)) continue;
    noisier += fmt::format("{}{} {:.2f} {} (stated {:.2f})",
                           noisier.empty() ? "" : ", ", kErrorNames[e],
                           rtest_noise_from_log_[e], models_[e].unit, stated);
  }
  if (!noisier.empty())
    out.push_back(fmt::format(
        "the log's R-tests scatter more than the R-test's stated uncertainty "
        "(machine.rtest_u95_um, rtest_u95_urad: thesis table 5.4 unless the "
        "configuration states the lab's), as noise (k = 1): {}; state the "
        "lab's R-test uncertainty there (U, k = 2) for the error budget to "
        "carry it",
        noisier));
  for (const LeftOutRTest& r : left_out_) {
    out.push_back(fmt::format(
        "R-test of line {} (t_s {:.0f}) left out as a gross error: its {} "
        "lies {:+.2f} {} off the estimate from the other R-tests ({:.1f} "
        "standard deviations, limit {:g})",
        r.line, r.t_s, kErrorNames[r.error], r.deviation_um_or_urad,
        models_[r.error].unit, r.z, options_.rtest_gross_error_z));
  }
  return out;
}

nlohmann::json MachineErrorEstimator::ToJson() const {
  nlohmann::json j;
  j["name"] = "arx_smoother";
  j["description"] = Describe();
  j["rtests"] = rtest_t_.size();
  j["compensation"] = compensation_;
  j["fitted_to"] = fit_machine_ ? "machine_error" : "residual";
  nlohmann::json models = nlohmann::json::object();
  for (int e = 0; e < 7; ++e) {
    const ErrorModel& m = models_[e];
    nlohmann::json terms = nlohmann::json::array();
    for (size_t c = 0; c < m.inputs.size(); ++c) {
      terms.push_back(
          {{"input", m.inputs[c]},
           {"tau_s", m.tau_s[c]},
           {"gain_" + m.unit + "_per_input_unit",
            m.gains_um_or_urad_per_input_unit[c]},
           {"initial_state_" + m.unit, m.initial_state_um_or_urad[c]}});
    }
    models[kErrorNames[e]] = {
        {"unit", m.unit},
        {"offset_" + m.unit, m.offset_um_or_urad},
        {"terms", terms},
        {"bic", m.bic},
        {"rms_residual_" + m.unit, m.rms_residual_um_or_urad},
        // JSON has no infinity: the smoother is named, its bandwidth is a
        // number or null (the mean of the residuals).
        {"residual_smoother", std::isinf(m.bandwidth_s) ? "mean"
                              : m.bandwidth_s == 0      ? "linear"
                                                        : "gaussian"},
        {"residual_bandwidth_s", std::isinf(m.bandwidth_s)
                                     ? nlohmann::json(nullptr)
                                     : nlohmann::json(m.bandwidth_s)},
        {"loo_rms_" + m.unit, m.loo_rms_um_or_urad},
        {"cv_rms_" + m.unit, m.cv_rms_um_or_urad},
        // The R-tests' noise (k = 1) the uncertainty takes, and what the
        // log's R-tests show (null: too few to read it).
        {"rtest_noise_" + m.unit, rtest_noise_[e]},
        {"rtest_noise_from_log_" + m.unit,
         std::isfinite(rtest_noise_from_log_[e])
             ? nlohmann::json(rtest_noise_from_log_[e])
             : nlohmann::json(nullptr)}};
  }
  j["models"] = models;
  nlohmann::json left_out = nlohmann::json::array();
  for (const LeftOutRTest& r : left_out_)
    left_out.push_back({{"line", r.line},
                        {"t_s", r.t_s},
                        {"error", kErrorNames[r.error]},
                        {"deviation", r.deviation_um_or_urad},
                        {"unit", models_[r.error].unit},
                        {"z", r.z}});
  j["rtests_left_out"] = left_out;
  return j;
}

LoadChangeComparison CompareAtLoadChanges(const TalcLog& log,
                                          const EstimatorOptions& options) {
  LoadChangeComparison out;
  double first_load = -1, last_load = -1;
  for (const auto& row : log.rows) {
    if (row.Has(kCRpm) && row.values[kCRpm] > 0) {
      if (first_load < 0) first_load = row.t_s;
      last_load = row.t_s;
    }
  }
  if (first_load >= 0) out.load_change_times_s = {first_load, last_load};
  const int n = static_cast<int>(log.rtests.size());
  std::array<double, 7> sum_arx{}, sum_lin{};
  double all_arx = 0, all_lin = 0;
  int near = 0, interior = 0;
  for (int k = 1; k + 1 < n; ++k) {
    const MachineErrorEstimator est =
        MachineErrorEstimator::FitWithout(log, k, options);
    const double t = log.rtests[k].t_ref_s;
    CAxisErrors truth = log.rtests[k].measured;
    if (log.compensation) truth = truth + est.PredictedAt(t);
    const auto y = truth.ToMicro();
    const auto a = est.MachineErrorsAt(t).ToMicro();
    const auto l = est.LinearErrorsAt(t).ToMicro();
    bool is_near = false;
    for (double c : out.load_change_times_s) {
      is_near |= log.rtests[k - 1].t_ref_s < c && c < log.rtests[k + 1].t_ref_s;
    }
    ++interior;
    for (int e = 0; e < 7; ++e) {
      const double da = (a[e] - y[e]) * (a[e] - y[e]);
      const double dl = (l[e] - y[e]) * (l[e] - y[e]);
      all_arx += da;
      all_lin += dl;
      if (is_near) {
        sum_arx[e] += da;
        sum_lin[e] += dl;
      }
    }
    if (is_near) {
      ++near;
      out.tested_rtest_times_s.push_back(t);
    }
  }
  if (near > 0) {
    double sa = 0, sl = 0;
    for (int e = 0; e < 7; ++e) {
      out.rms_arx[e] = std::sqrt(sum_arx[e] / near);
      out.rms_linear[e] = std::sqrt(sum_lin[e] / near);
      sa += sum_arx[e];
      sl += sum_lin[e];
    }
    out.rms_arx_all = std::sqrt(sa / (7.0 * near));
    out.rms_linear_all = std::sqrt(sl / (7.0 * near));
  }
  if (interior > 0) {
    out.rms_arx_everywhere = std::sqrt(all_arx / (7.0 * interior));
    out.rms_linear_everywhere = std::sqrt(all_lin / (7.0 * interior));
  }
  return out;
}

}  // namespace ttp::thermal

namespace ttp::thermal {

std::vector<double> LoadChangeTimes(const TalcLog& log) {
  double first = -1;
  int last = -1;
  for (int i = 0; i < static_cast<int>(log.rows.size()); ++i) {
    const LogRow& row = log.rows[i];
    if (row.Has(kCRpm) && row.values[kCRpm] > 0) {
      if (first < 0) first = row.t_s;
      last = i;
    }
  }
  if (first < 0) return {};
  double cool = log.rows[last].t_s;
  for (size_t i = last + 1; i < log.rows.size(); ++i) {
    if (log.rows[i].Has(kCRpm)) {
      cool = log.rows[i].t_s;
      break;
    }
  }
  return {first, cool};
}

InterpolationComparison CompareInterpolation(const TalcLog& log,
                                             double interval_s,
                                             const EstimatorOptions& options) {
  InterpolationComparison out;
  out.interval_s = interval_s;
  const int n = static_cast<int>(log.rtests.size());
  if (n < 2) {
    throw InputError(log.source, 0, "rtest",
                     "the log needs at least two R-tests");
  }
  // Keep every stride-th R-test (plus the first and the last), for every
  // phase of that grid, so that each load change is seen at every position
  // between two kept R-tests.
  const double spacing =
      (log.rtests.back().t_ref_s - log.rtests.front().t_ref_s) / (n - 1);
  const int stride =
      std::max(1, static_cast<int>(std::lround(interval_s / spacing)));
  const std::vector<double> changes = LoadChangeTimes(log);
  std::vector<InterpolationWindow> windows(changes.size());
  std::vector<std::array<double, 7>> sm(changes.size()), sl(changes.size());
  // An R-test is held out in several phases; it counts once.
  std::vector<std::set<int>> held_out(changes.size());
  for (size_t c = 0; c < changes.size(); ++c) {
    windows[c].label = c == 0 ? "warm-up start" : "cool-down start";
    windows[c].load_change_s = changes[c];
    windows[c].bracket_from_s = 0;
    sm[c].fill(0);
    sl[c].fill(0);
  }
  for (int phase = 0; phase < stride; ++phase) {
    std::vector<bool> kept(n, false);
    for (int k = 0; k < n; ++k) kept[k] = k % stride == phase;
    kept[0] = kept[n - 1] = true;
    TalcLog sparse = log;
    sparse.rtests.clear();
    for (int k = 0; k < n; ++k) {
      if (kept[k]) sparse.rtests.push_back(log.rtests[k]);
    }
    if (phase == 0) out.kept_rtests = static_cast<int>(sparse.rtests.size());
    ++out.phases;
    const MachineErrorEstimator est =
        MachineErrorEstimator::Fit(sparse, options);
    for (size_t c = 0; c < changes.size(); ++c) {
      InterpolationWindow& w = windows[c];
      int a = -1, b = -1;
      for (int k = 0; k < n; ++k) {
        if (!kept[k]) continue;
        if (log.rtests[k].t_ref_s <= changes[c]) a = k;
        if (log.rtests[k].t_ref_s > changes[c] && b < 0) b = k;
      }
      if (a < 0 || b < 0) continue;
      w.bracket_from_s += log.rtests[b].t_ref_s - log.rtests[a].t_ref_s;
      for (int k = a + 1; k < b; ++k) {
        const double t = log.rtests[k].t_ref_s;
        CAxisErrors y = log.rtests[k].measured;
        if (log.compensation) y = y + est.PredictedAt(t);
        const auto yv = y.ToMicro();
        const auto m = est.MachineErrorsAt(t).ToMicro();
        const auto l = est.LinearErrorsAt(t).ToMicro();
        for (int e = 0; e < 7; ++e) {
          sm[c][e] += (m[e] - yv[e]) * (m[e] - yv[e]);
          sl[c][e] += (l[e] - yv[e]) * (l[e] - yv[e]);
          if (e < 4) {
            w.max_model_um = std::max(w.max_model_um, std::abs(m[e] - yv[e]));
            w.max_line_um = std::max(w.max_line_um, std::abs(l[e] - yv[e]));
          }
        }
        ++w.evaluations;
        held_out[c].insert(k);
      }
    }
  }
  for (size_t c = 0; c < changes.size(); ++c) {
    InterpolationWindow& w = windows[c];
    if (w.evaluations == 0) continue;
    w.held_out = static_cast<int>(held_out[c].size());
    w.mean_bracket_s = w.bracket_from_s / out.phases;
    w.bracket_from_s = 0;
    double am = 0, al = 0;
    for (int e = 0; e < 7; ++e) {
      w.rms_model[e] = std::sqrt(sm[c][e] / w.evaluations);
      w.rms_line[e] = std::sqrt(sl[c][e] / w.evaluations);
      if (e < 4) {
        am += sm[c][e];
        al += sl[c][e];
      }
    }
    w.rms_model_um = std::sqrt(am / (4.0 * w.evaluations));
    w.rms_line_um = std::sqrt(al / (4.0 * w.evaluations));
    out.windows.push_back(w);
  }
  return out;
}

nlohmann::json InterpolationToJson(const InterpolationComparison& c) {
  nlohmann::json j;
  j["rtest_interval_s"] = c.interval_s;
  j["kept_rtests"] = c.kept_rtests;
  nlohmann::json windows = nlohmann::json::array();
  for (const InterpolationWindow& w : c.windows) {
    nlohmann::json model, line;
    for (int e = 0; e < 7; ++e) {
      model[kErrorNames[e]] = w.rms_model[e];
      line[kErrorNames[e]] = w.rms_line[e];
    }
    windows.push_back({{"load_change", w.label},
                       {"t_s", w.load_change_s},
                       {"mean_bracket_s", w.mean_bracket_s},
                       {"held_out_rtests", w.held_out},
                       {"held_out_evaluations", w.evaluations},
                       {"rms_model", model},
                       {"rms_line", line},
                       {"rms_model_linear_errors_um", w.rms_model_um},
                       {"rms_line_linear_errors_um", w.rms_line_um},
                       {"max_model_um", w.max_model_um},
                       {"max_line_um", w.max_line_um}});
  }
  j["windows"] = windows;
  return j;
}

std::string InterpolationText(const InterpolationComparison& c) {
  std::string s = fmt::format(
      "machine error at the load changes: dynamic model vs straight line, "
      "R-tests thinned to one every {:.0f} s ({} kept; all {} phases of that "
      "grid), checked against the held-out R-tests between the two kept ones "
      "that bracket each load change\n",
      c.interval_s, c.kept_rtests, c.phases);
  for (const InterpolationWindow& w : c.windows) {
    s += fmt::format(
        "  {} at t_s {:.0f} (kept R-tests {:.0f} s apart around it on "
        "average, {} held-out R-tests, {} evaluations over the phases)\n",
        w.label, w.load_change_s, w.mean_bracket_s, w.held_out, w.evaluations);
    s += "     error   model    line   (RMS, um or um/m)\n";
    for (int e = 0; e < 7; ++e) {
      s += fmt::format("    {:>6} {:7.3f} {:7.3f}\n", kErrorNames[e],
                       w.rms_model[e], w.rms_line[e]);
    }
    s += fmt::format(
        "    EX..ER  {:7.3f} {:7.3f}   largest {:.2f} vs {:.2f} um\n",
        w.rms_model_um, w.rms_line_um, w.max_model_um, w.max_line_um);
  }
  return s;
}

}  // namespace ttp::thermal
