// The machine's seven C-axis errors at any time of a run, from the R-tests
// and the log's inputs (talc-log.md section 2, test-piece.md section 6).
//
// Estimator: per error, the thesis' ARX(1, 1) in continuous-time form
//   y(t) = c + sum_i g_i * L_tau_i[u_i](t) + sum_i h_i exp(-(t - t0)/tau_i),
// L_tau a first-order lag (the ARX pole) of input u_i (C-axis and spindle
// speed in 1000/min, linear and squared: bearing friction heat grows with
// the square of the speed; T_env, T_ws - their start values, dT_cool). The
// exponential terms are the lags' free initial state: a real log starts
// after pre-machining and a hold, not in steady state. Gains, offset and
// initial states are fitted by linear least squares on the R-tests of the
// run; the inputs and each input's time constant (a grid) are chosen by
// BIC. The model is used
// as a smoother: its prediction plus the R-test residuals, smoothed with a
// Gaussian kernel whose bandwidth (0 = linear interpolation through the
// R-tests) is chosen per error by leave-one-out error, so the estimate
// follows the inputs between R-tests (a straight line cannot bend at the start
// of the warm-up or the cool-down). With compensation on, the target is the
// machine's own error: R-test residual + pred_ (thesis 6.4.2).
#pragma once

#include <Eigen/Core>
#include <array>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/rigid_table.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::thermal {

struct EstimatorOptions {
  std::vector<double> tau_grid_s = {60,   300,  600,  1200,
                                    2400, 4800, 9600, 19200};
  int max_inputs = 2;       // inputs per error model
  // Lags faster than this fraction of the mean R-test spacing are not
  // tried (the grid's longest always is): R-tests taken at the same few
  // phases of every test cycle see such a lag at two or three levels (C
  // running or stopped before them), so its gain rests on those levels
  // alone, and its value at a cut (another phase) is a guess that gain
  // multiplies. 0 tries every time constant.
  double min_tau_fraction_of_rtest_spacing = 0.1;
  double grid_step_s = 10;  // integration step of the lag filters
  // Fit the lags' initial state (one exp(-(t - t0)/tau) term per input)
  // instead of assuming the log starts in steady state.
  bool free_initial_state = true;
  // Blocked cross-validation of the estimator between R-tests: blocks of
  // this many consecutive R-tests are held out, the model refitted without
  // them and evaluated at them.
  int cv_block_rtests = 2;
  // The R-tests' own noise (k = 1, um for EX0C..ER0T, urad for EA0C..EC0C;
  // thesis table 5.4: U95 0.4, 0.5, 0.4, 0.6 um and 2.3, 2.5, 2.6 um/m;
  // EstimatorOptionsFor takes a machine's stated values).
  // The cross-validation error at a held-out R-test holds it; the error
  // between R-tests does not (ErrorSigmaAt).
  std::array<double, 7> rtest_noise_um_or_urad = {0.2,  0.25, 0.2, 0.3,
                                                  1.15, 1.25, 1.3};
  // A lab's R-test may be noisier than the thesis' (diagnosis.md section 4
  // allows up to 1.3 um and 6 urad): with at least this many R-tests the
  // noise is also read from the log, per error, from the scatter of each
  // R-test about the straight line through its two neighbours (the
  // model's residuals, so that the load's dynamics do not count as
  // noise). The larger of the stated value (rtest_noise_um_or_urad) and
  // the log's lower bound (rtest_noise_lower_bound_sd below the estimate)
  // is the noise carried to the cut times (NoiseSigmaAt) and the
  // gross-error screen's, and is named in Warnings() when a quarter above
  // the stated one; the cross-validation error keeps only the stated noise
  // taken off (CrossValidatedSigmaAt says why). Fewer R-tests lie too far apart
  // for the machine to move along a straight line between neighbours. 0 never
  // reads it.
  int rtest_noise_from_log_min_rtests = 30;
  // How many of its standard deviations below the log's noise estimate the
  // bound lies: a log whose R-tests are as noisy as stated keeps the
  // stated values.
  double rtest_noise_lower_bound_sd = 2.0;
  // The error at a cut time that the R-tests cannot show (the machine
  // between R-tests, under the cut's own load), as a fraction of the
  // cross-validation error: a floor of ErrorSigmaAt, calibrated by
  // simulation (docs/DIAGNOSIS.md).
  double cut_time_error_fraction = 0.5;
  // The estimate at a cut time rests on R-tests that carry their own
  // noise: a floor of ErrorSigmaAt is that noise carried through the
  // estimator to the cut time (NoiseSigmaAt), times this factor.
  double rtest_noise_floor_factor = 1.0;
  // Between two R-tests the estimate follows the model's dynamics, which
  // the R-tests pin only at the gap's ends (a first-order lag for a
  // machine that is not one, an input missing): its error there is taken
  // as this fraction of the model's deviation from its chord between the
  // two R-tests (ShapeDeviationAt), added in quadrature. Large where a
  // load change falls inside a gap, zero next to an R-test; calibrated on
  // the estimator's actual errors at the cut times (docs/DIAGNOSIS.md).
  double model_shape_error_fraction = 0.5;
  // With compensation on, what the model is fitted to. The machine's own
  // error (R-test residual + pred_) is a smooth thermal response; the
  // residual (machine - pred_) is smooth only while pred_ is: a controller
  // that re-anchors its model at every R-test (TALC's recursive update,
  // thesis chapter 6) makes pred_ jump there, and the residual between two
  // R-tests then follows the change since the last one, which a fit
  // through the R-tests' residuals cannot see. kAuto fits the machine's
  // error when pred_ jumps at the R-tests (PredictionReanchorsAtRTests)
  // and the residual when pred_ is continuous there (a model of the
  // inputs that follows their fast dynamics, leaving less to fit).
  enum class CompensationFit { kAuto, kResidual, kMachine };
  CompensationFit compensation_fit = CompensationFit::kAuto;
  // Residual smoothing bandwidths tried (s); 0 = linear interpolation
  // through the R-tests, infinity = model only (plus mean residual). The
  // one with the least leave-one-out error is used, per error.
  std::vector<double> bandwidth_grid_s = {
      0,    300,  600,  1200,
      2400, 4800, 9600, std::numeric_limits<double>::infinity()};
  // Gross errors among the R-tests (a chip or coolant on a sphere, a probe
  // that slipped): the R-test whose cross-validation error lies farthest
  // from the others' (in units of their median absolute deviation) is a
  // candidate beyond this many; it is left out when its value of some
  // error lies this many standard deviations off the estimate from the
  // other R-tests (that estimate's budget there plus the R-test's own
  // noise); then the next, and each is named in the results. The first
  // R-test (the reference of every value) is never left out. 0 keeps
  // every R-test.
  double rtest_gross_error_z = 6.0;
  // At most this share of the log's R-tests is left out so (one at least).
  double rtest_gross_error_max_fraction = 0.1;
  // Only a log of this many R-tests is screened: fewer (R-tests an hour or
  // more apart over the 8-hour test) leave the estimate between them too
  // uncertain to tell a gross error from the machine's own dynamics.
  int rtest_gross_error_min_rtests = 12;

  // False with a message naming the field when the options cannot be used.
  bool IsValid(std::string* error) const;
};

// `options` with the R-tests' noise of the machine's configuration: half
// the R-test uncertainty it states (machine.rtest_u95_um, rtest_u95_urad;
// thesis table 5.4 unless the lab states its own). Every command that
// reads a TALC log fits its estimator so.
EstimatorOptions EstimatorOptionsFor(const MachineProfile& machine,
                                     EstimatorOptions options = {});

// An R-test the estimator left out as a gross error (rtest_gross_error_z).
struct LeftOutRTest {
  int line = 0;    // in the log
  double t_s = 0;  // the time its values describe
  int error = 0;   // the error that deviates most (0..6: EX0C..EC0C)
  double deviation_um_or_urad = 0;  // its value - the estimate without it
  double z = 0;  // deviation / (budget there (+) R-test noise)
};

// One error's fitted model. Values are in the error's unit: um for EX0C,
// EY0C, EZ0T, ER0T and urad (= um/m) for EA0C, EB0C, EC0C (`unit`).
struct ErrorModel {
  std::string unit;  // "um" or "urad"
  std::vector<std::string> inputs;
  std::vector<double> tau_s;
  // Per unit of the input (krpm, krpm^2 or K).
  std::vector<double> gains_um_or_urad_per_input_unit;
  bool free_initial_state = false;
  std::vector<double> initial_state_um_or_urad;  // free initial state
  double offset_um_or_urad = 0;
  double bic = 0;
  double rms_residual_um_or_urad = 0;  // at the R-tests
  double bandwidth_s = 0;  // residual smoother chosen by leave-one-out
  double loo_rms_um_or_urad = 0;  // smoother's leave-one-out error
  // Blocked cross-validation: RMS error at held-out R-tests with the model
  // refitted without them (includes the R-test's own noise).
  double cv_rms_um_or_urad = 0;
  int cv_evaluations = 0;  // held-out R-tests it rests on
};

class MachineErrorEstimator {
 public:
  // Fits on the R-tests of the log, gross errors left out
  // (rtest_gross_error_z; left_out_rtests()). Throws InputError if the log
  // has fewer than two R-tests, or compensation on without pred_ values.
  static MachineErrorEstimator Fit(const TalcLog& log,
                                   const EstimatorOptions& options = {});
  // Every R-test but `skip` (for leave-one-out checks; no gross-error
  // screening).
  static MachineErrorEstimator FitWithout(const TalcLog& log, int skip,
                                          const EstimatorOptions& options);

  // The R-tests left out as gross errors, in the log's order.
  const std::vector<LeftOutRTest>& left_out_rtests() const { return left_out_; }
  // One sentence per R-test left out, naming its line, for the results.
  std::vector<std::string> Warnings() const;

  // Standard uncertainty of MachineErrorsAt(t) for error e (um or urad):
  // the blocked cross-validation error with the held-out R-test's own
  // noise taken out, at least cut_time_error_fraction of the
  // cross-validation error, growing linearly with the distance
  // beyond the first or last R-test (extrapolation through the model) in
  // units of the mean R-test spacing.
  double ErrorSigmaAt(int error, double t_s) const;
  // Time over which the estimator's errors stay correlated: the mean
  // R-test spacing (the smoother interpolates over it).
  double CorrelationTimeS() const;
  double MeanRTestSpacingS() const;

  // Machine's own errors at t: ARX prediction + interpolated residuals.
  CAxisErrors MachineErrorsAt(double t_s) const;
  // Straight line between the R-tests around t (the naive estimator).
  CAxisErrors LinearErrorsAt(double t_s) const;
  // Prediction in force at t (linear between rows giving pred_); zero when
  // compensation is off.
  CAxisErrors PredictedAt(double t_s) const;

  // Machine errors measured at the R-tests (residual + pred_), their times.
  const std::vector<double>& rtest_times_s() const { return rtest_t_; }
  const std::vector<CAxisErrors>& rtest_errors() const { return rtest_y_; }
  double FirstRTestS() const { return rtest_t_.front(); }
  double LastRTestS() const { return rtest_t_.back(); }
  const std::vector<ErrorModel>& models() const { return models_; }
  // The R-tests' own noise (k = 1) the budget takes for error e: the
  // stated one, or the log's where its R-tests are noisier
  // (EstimatorOptions::rtest_noise_from_log_min_rtests).
  double RTestNoise(int error) const { return rtest_noise_[error]; }
  bool compensation() const { return compensation_; }
  // With compensation on: whether the model is fitted to the machine's own
  // error (true) or to the R-test residual (EstimatorOptions::
  // compensation_fit); true with compensation off.
  bool fits_machine_error() const { return fit_machine_; }

  std::string Describe() const;  // one line for reports
  nlohmann::json ToJson() const;

 private:
  struct Signal {
    std::string name;
    bool pulsed = false;  // on only between R-tests (the spindle)
    int column = 0;       // the log column it comes from
    std::vector<std::vector<double>> filtered;  // [tau][grid index]
  };
  double InputAt(int input, int tau, double t_s) const;
  double ModelAt(int error, double t_s) const;
  double ResidualAt(int error, double t_s, int skip) const;
  struct Choice {
    std::vector<int> subset, taus;  // inputs, tau grid indices
    bool free_state = false;
    Eigen::VectorXd beta;  // offset, gains, initial states
    double bic = 0, rms = 0;
  };
  // The structure of error e by BIC on `rows`, among those that
  // affordable_n R-tests afford (0: rows.size(); a cross-validation fold
  // passes the whole log's count).
  Choice Choose(int e, const std::vector<double>& y,
                const std::vector<int>& rows, int affordable_n = 0) const;
  Eigen::MatrixXd Design(const Choice& c, const std::vector<int>& rows) const;
  Eigen::VectorXd Row(const Choice& c, double t_s) const;
  // Each input through each lag, and each lag's decay from the log's start
  // (free initial state), at fixed times (the R-tests, the cuts): the
  // structure search evaluates them for every candidate.
  struct InputTable {
    size_t taus = 0, times = 0;
    std::vector<double> inputs;  // [(input * taus + tau) * times + k]
    std::vector<double> decays;  // [tau * times + k]
    size_t InputSlot(size_t input, size_t tau, size_t k) const {
      return (input * taus + tau) * times + k;
    }
    size_t DecaySlot(size_t tau, size_t k) const { return tau * times + k; }
    double Input(int input, int tau, size_t k) const {
      return inputs[InputSlot(static_cast<size_t>(input),
                              static_cast<size_t>(tau), k)];
    }
    double Decay(int tau, size_t k) const {
      return decays[DecaySlot(static_cast<size_t>(tau), k)];
    }
    // Row(c, t_k) . beta.
    double RowDot(const Choice& c, size_t k, const Eigen::VectorXd& beta) const;
  };
  InputTable Tabulate(const std::vector<double>& times_s) const;
  void SelectModel(int e, const Eigen::VectorXd& y,
                   const std::vector<int>& rows);
  void CrossValidate();
  // Every R-test of the log but those in `skipped` (log indices); the
  // budget's cross-validation when `cross_validate`.
  static MachineErrorEstimator FitExcluding(const TalcLog& log,
                                            const std::vector<int>& skipped,
                                            const EstimatorOptions& options,
                                            bool cross_validate);

  // What the model's fit takes away from the machine error at t: pred_
  // when it fits the residual, zero when it fits the machine's own error.
  CAxisErrors FitBaseAt(double t_s) const;

  bool compensation_ = false;
  bool fit_machine_ = true;
  EstimatorOptions options_;
  double grid_t0_ = 0;
  std::vector<Signal> signals_;
  std::vector<double> pred_t_;
  std::vector<CAxisErrors> pred_;
  std::vector<double> rtest_t_;
  std::vector<CAxisErrors> rtest_y_;
  std::vector<int> rtest_log_index_;  // index into the log's R-tests
  // Per R-test (like rtest_t_): the cross-validation's error there, the
  // model refitted without its block (log units).
  std::vector<std::array<double, 7>> cv_error_;
  std::vector<LeftOutRTest> left_out_;
  // The log's cut times: a candidate model whose prediction there leaves
  // the range it predicts at the R-tests (widened by half of it, at least
  // by twice its residual RMS, on each side) is not used. Inputs that are
  // nearly collinear at the R-tests (the C axis stops for each of them)
  // otherwise fit them with large opposite gains that the cuts' different
  // input state turns into errors of many um.
  std::vector<double> cut_t_;
  InputTable at_rtests_, at_cuts_;
  std::vector<ErrorModel> models_;  // 7
  std::vector<std::vector<int>> model_input_index_, model_tau_index_;
  std::vector<std::array<double, 7>> residual_;  // per R-test, log units
  std::vector<Choice> choice_;  // per error
  // Per error: the fit's map from the R-test values to the model's
  // coefficients (columns: R-tests) and its hat matrix at the R-tests, to
  // carry the R-tests' own noise through the estimator (NoiseSigmaAt).
  std::vector<Eigen::MatrixXd> coef_map_, hat_;
  // The R-tests' own noise carried through the estimator (model fit and
  // residual smoother, both linear in the R-test values) to time t.
  double NoiseSigmaAt(int error, double t_s) const;
  // Per error: the R-tests' noise the budget takes (k = 1): the stated one
  // (rtest_noise_um_or_urad) or, larger, what the log's R-tests show
  // (rtest_noise_from_log_min_rtests); and the log's own estimate (NaN
  // when the R-tests are too few to read it).
  std::array<double, 7> rtest_noise_{}, rtest_noise_from_log_{};
  // R-tests per cross-validation block: cv_block_rtests, fewer when the
  // R-tests are too few for four blocks (sparse R-tests: one per block).
  int CvBlock() const;
  // ErrorSigmaAt without the model's shape term.
  double CrossValidatedSigmaAt(int error, double t_s) const;
  // |model - its chord between the R-tests around t|: how far the
  // estimate between two R-tests rests on the model's dynamics alone.
  double ShapeDeviationAt(int error, double t_s) const;
};

// Leave-one-R-test-out comparison of the ARX smoother and the straight line
// at the R-tests whose neighbours straddle a load change (start of the
// warm-up: first row with c_rpm > 0; start of the cool-down: last one).
struct LoadChangeComparison {
  std::vector<double> load_change_times_s;
  std::vector<double> tested_rtest_times_s;
  // RMS over the tested R-tests, per error (um, um/m) and over all seven.
  std::array<double, 7> rms_arx{}, rms_linear{};
  double rms_arx_all = 0, rms_linear_all = 0;
  // The same over every interior R-test (not only near load changes).
  double rms_arx_everywhere = 0, rms_linear_everywhere = 0;
};
LoadChangeComparison CompareAtLoadChanges(const TalcLog& log,
                                          const EstimatorOptions& options = {});

// Load-change times of a log: start of the warm-up (first row with
// c_rpm > 0) and start of the cool-down (the row after the last one with
// c_rpm > 0). Empty when the C axis never turns.
std::vector<double> LoadChangeTimes(const TalcLog& log);

// The dynamic model against a straight line between R-tests: the R-tests are thinned to one every
// `interval_s` (production practice: every 1-2 h), for every phase of that
// grid; the estimator is fitted on those, and at every held-out R-test
// between the two kept R-tests that
// bracket a load change the machine error of the dynamic model and of the
// straight line between the bracketing R-tests are compared with what that
// R-test measured (itself noisy: the figures include its noise).
struct InterpolationWindow {
  std::string label;  // "warm-up start", "cool-down start"
  double load_change_s = 0;
  double bracket_from_s = 0;  // internal
  double mean_bracket_s = 0;  // time between the bracketing kept R-tests
  int held_out = 0;     // distinct R-tests inside the brackets (reference)
  int evaluations = 0;  // held-out R-tests summed over the phases (RMS base)
  // RMS over the held-out R-tests, per error (um, um/m) and over the four
  // linear errors (um), and the largest |error| of the line and the model
  // over the four linear errors (um).
  std::array<double, 7> rms_model{}, rms_line{};
  double rms_model_um = 0, rms_line_um = 0;
  double max_model_um = 0, max_line_um = 0;
};
struct InterpolationComparison {
  double interval_s = 0;
  int kept_rtests = 0;  // in the first phase
  int phases = 0;       // offsets of the thinning grid tried
  std::vector<InterpolationWindow> windows;
};
InterpolationComparison CompareInterpolation(
    const TalcLog& log, double interval_s,
    const EstimatorOptions& options = {});
nlohmann::json InterpolationToJson(const InterpolationComparison& c);
std::string InterpolationText(const InterpolationComparison& c);

}  // namespace ttp::thermal
