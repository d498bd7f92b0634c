// What the simulation gets wrong (diagnosis.md): residual = measured -
// simulated (figures E_X, E_Y, E_Z, E_TTP per cycle and facet normal
// angles), every cause and pair of causes fitted by generalised least
// squares (whitened with the residuals' covariance) together with nuisance
// offsets (the reference cycle's machine state is uncertain, so each figure
// may be off by a constant), chosen by BIC. A cause is named only when its
// BIC beats the nominal model by the evidence threshold and it leaves a
// residual of the size the error budget predicts; otherwise the outcome is
// `none` or `unexplained` (diagnosis.md section 3).
#pragma once

#include <Eigen/Core>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/diagnosis/effects.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/measurement.h"
#include "ttp/thermal/simulate.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::diagnosis {

// A measured piece as the diagnosis reads it: the measured features, or
// figures and facet angles (as in the samples' truth.json).
struct MeasuredPiece {
  std::string source;
  FeatureResults features;            // the measured ones; empty if only
                                      // figures are given
  std::vector<CycleFigures> figures;  // measured figures per cycle
  std::map<FeatureId, double> facet_angle_rad;  // absolute angle errors
};
// Per-feature results (from any measurement). Where a feature carries its
// fit's scatter (rms_mm, points >= 3), that scatter, not the instrument's
// error limit, gives the variances the causes are judged against; the
// figures are computed from them. Features not present and angles not
// measured (a dial gauge's) are left out.
MeasuredPiece MeasuredPieceFromFeatures(const PartSpec& part,
                                        const FeatureResults& features);
// Any measurement as inspect::LoadMeasurement reads it: its features when
// it has any (MeasuredPieceFromFeatures), else its figures and facet angles
// as given. Throws InputError when it has neither.
MeasuredPiece MeasuredPieceFromInspection(
    const PartSpec& part, const inspect::InspectionResult& result);
// inspect::LoadMeasurement, then MeasuredPieceFromInspection: every
// measurement file `ttp inspect` reads. Throws InputError naming the file
// and field.
MeasuredPiece LoadMeasuredPiece(
    const Config& config, const std::string& path,
    const inspect::MeasurementOptions& options = {});

// Residual observations: measured - simulated, figures in um and facet
// normal angles in urad, each with its covariance (the error budget:
// measurement, form and the estimator's error between R-tests, which is
// common to a cycle's cuts and correlated across cycles).
struct Observations {
  // Figures E_X, E_Y, E_Z, E_TTP (figure_kind 0..3) per cycle, and the
  // ovality E_OV (4: ((X1 + X2) - (Y1 + Y2)) / 4 of the facet distances
  // against the reference facets) where facet distances were measured.
  std::vector<int> figure_cycle, figure_kind;
  std::vector<double> figure_t_s;  // the cycle's cut time
  // figure_sigma_um: each figure's total standard uncertainty, its
  // reference cycle's part included.
  std::vector<double> figure_value_um, figure_sigma_um;
  // Without the reference cycle's common part of an anchored kind (below):
  // the cycle's own measurement and the estimator's error.
  Eigen::MatrixXd figure_covariance_um2;
  // Per figure kind (0..4): the variance of the reference cycle's part of
  // its figures (the reference features' measurement and the estimator's
  // error at the reference cut), um^2. Every figure is a difference to
  // cycle 0, so this part is common to all cycles of the kind: the fits
  // add it to every pair of the kind's observations instead of fitting a
  // free offset. Infinite: not known, and the kind gets a free offset.
  std::vector<double> figure_reference_var_um2 =
      std::vector<double>(5, std::numeric_limits<double>::infinity());
  // Facet normal angles (rotation about Z).
  std::vector<FeatureId> angle_feature;  // the facet (X1-3)
  std::vector<int> angle_cycle;
  std::vector<double> angle_t_s;
  std::vector<double> angle_value_urad, angle_sigma_urad;
  Eigen::MatrixXd angle_covariance_urad2;

  size_t figures() const { return figure_value_um.size(); }
  size_t angles() const { return angle_value_urad.size(); }
  size_t size() const { return figures() + angles(); }
  std::string FigureLabel(size_t i) const;  // "E_X@3"
  std::string AngleLabel(size_t i) const;   // "angle X1-3"
};

struct DiagnosisOptions {
  // BIC of the chosen model must beat the nominal model's (and, for a pair
  // of causes, the best single cause's) by this much. Calibrated by
  // simulation (docs/DIAGNOSIS.md): at most 1 % of runs without a cause
  // get one named.
  double evidence_threshold = 12.0;
  // The same for a cause seen only in the facet angles (c_axis_indexing,
  // alone or added to another cause): their budget is the fits' own
  // scatter, which the estimator's heavy-tailed error between R-tests
  // hardly touches, so its evidence over runs without a cause stays
  // chi2-like (docs/DIAGNOSIS.md: calibration).
  double angle_evidence_threshold = 6.0;
  // Goodness of fit: the chosen model (or the nominal one) must leave
  // chi2 / degrees of freedom below this, else the residual holds
  // structure no known cause explains (`unexplained`).
  double max_chi2_per_dof = 2.0;
  // The same per figure kind (and for the angles): its whitened chi2, as a
  // standard normal deviate, must stay below this.
  double local_z = 4.5;
  // A step in one figure kind from some cycle on, fitted along with the
  // chosen model, must not lower chi2 by more than this.
  double step_chi2 = 40.0;
  // A drift of one figure kind over the cycles (linear in the cycle),
  // fitted along with the chosen model, must not lower chi2 by more than
  // this (one parameter; calibrated on runs without a cause) while
  // drifting by more than `trend_min_um` over the cycles measured (less is
  // within the R-tests' expanded uncertainty, thesis table 5.4, and the
  // figures' model error on real pieces).
  double trend_chi2 = 15.0;
  double trend_min_um = 1.0;
  // A named cause must beat the best such step (as an alternative to the
  // cause, two parameters: height and first cycle) by this much in BIC.
  double step_rival_margin = 6.0;
  // A name must hold on what the cause's fit did not see and against the
  // shapes the physics excludes (NamedCauseHolds in diagnose.cpp): the
  // chosen model, selected again without each cycle, must predict the
  // held-out cycles better than the nominal model by more than this (%),
  // and no candidate whose fitted parameters are physically implausible
  // (negative wear, a time constant at its bound), unless it holds the
  // named causes, may beat it in BIC by more than
  // `implausible_rival_margin` (the residual then has a shape no known
  // cause gives).
  double min_heldout_gain_pct = 0.0;
  double implausible_rival_margin = 2.0;
  // A workpiece expansion whose time constant's standard uncertainty (from
  // the profile's curvature in log tau) exceeds this fraction of it is no
  // result: the lag that defines the cause is not shown by the data (two
  // standard deviations from no lag at 0.5).
  double max_tau_relative_uncertainty = 0.5;
  // The figures are differences to the reference cycle: its error is
  // common to every cycle of a figure kind, with a variance the budget
  // knows (the reference features' measurement, the estimator at the
  // reference cut). True: that common part enters the covariance and the
  // figures carry no free offset, so a drift that starts at the reference
  // cycle (an effect's mean, another machine's errors) counts in full.
  // False: a free offset per figure kind absorbs it (the facet angles
  // always get one: their datum was cut in pre-machining, before the log).
  bool anchor_reference_cycle = true;
  // Lower bounds of the residual uncertainties (um, urad).
  double min_sigma_um = 0.02, min_sigma_urad = 0.3;
  // Scale on the estimator's blocked cross-validation error (which holds
  // the held-out R-test's own noise and a gap twice the spacing).
  double estimator_sigma_scale = 1.0;
  // Form error of a fitted feature as a fraction of its fit's residual RMS.
  double form_fraction = 0.1;
  // C-axis indexing: harmonics 1..K per turn, K chosen by evidence.
  int max_c_harmonics = 4;
  // Two causes at once are tried.
  bool pairs = true;
  // `refused` when the measured E_X/E_Y follow the simulated ones with a
  // slope this far from 1 (and more than 5 standard deviations) while the
  // nominal model does not fit: the log describes another run.
  double mismatch_slope_limit = 0.4;
  // `refused` also when the residual is unexplained and E_X, E_Y or E_Z
  // (which follow the machine's location errors the log's R-tests measure,
  // and which no catalogue cause changes much) keep a chi2 deviate beyond
  // this after the best model.
  double refuse_z = 7.0;
  // `refused` instead of named when E_X, E_Y and E_Z pooled keep a chi2
  // deviate beyond this after the named cause (calibrated on runs without
  // a cause: docs/DIAGNOSIS.md).
  double named_machine_z = 3.0;
  // `refused` whatever the outcome when E_X, E_Y and E_Z pooled keep a
  // chi2 deviate beyond this after the best model: above every run with
  // its own log in the calibration and the batteries (docs/DIAGNOSIS.md).
  double refuse_machine_pooled_z = 3.5;
  // The three rules above refuse only when E_X, E_Y and E_Z pooled stay
  // beyond this with the best drift or step of one figure kind fitted
  // along: another run's log misplaces the machine errors in every kind
  // the R-tests measure, while an effect on one feature type (the strips
  // drifting: E_Z alone) is explained by that one term and is
  // `unexplained`, not a mismatch. One standard deviation: a residual
  // the budget describes after that term.
  double refuse_after_one_kind_z = 1.0;
  // The three rules above refuse also only when a machine of another run
  // under this run's loads explains what E_X, E_Y and E_Z keep: each of
  // them following the table's temperature change directly and through a
  // lag (one of other_machine_tau_s) and drifting in time (the room, its
  // own start state), with gains of its own, leaves a pooled deviate of at
  // most this. What another run's log leaves is smooth in time; an effect
  // on the piece that moves each cycle its own way is `unexplained`, not a
  // mismatch (docs/DIAGNOSIS.md).
  double refuse_other_machine_z = 2.5;
  // The lags tried for another run's machine, s.
  std::vector<double> other_machine_tau_s = {600, 1800, 5400};
  std::vector<double> tau_grid_s = {300,  450,  700,  1000,  1500, 2200,
                                    3300, 5000, 7500, 11000, 17000};
  // Relative standard uncertainty of the path length the wear is referred
  // to (reported with `wear_um_per_m`, not used in the decision): the
  // length a finishing cutter "has cut" is a model (a strip's chord under
  // the floor, with or without the small notch, the overruns); two
  // independent counts of it (the twin's cut simulation, the outside
  // generator's chords) give wears 1.5 and 3.5 % off the diagnosis's.
  double wear_path_relative_uncertainty = 0.03;

  // False with a message naming the field when the options cannot be used.
  bool IsValid(std::string* error) const;
};

// Every diagnosis ends in exactly one of these (diagnosis.md section 3).
enum class DiagnosisStatus { kNamed, kNone, kUnexplained, kRefused };
const char* StatusName(DiagnosisStatus status);

struct ParamEstimate {
  std::string name;
  double value = 0, uncertainty = 0;  // k = 1
};

struct CandidateResult {
  std::string name;          // "tool_wear", "clamping_distortion+tool_wear"
  Cause cause = Cause::kNone;  // the first (or only) cause
  std::vector<Cause> causes;   // empty for none
  std::vector<std::vector<double>> params;   // per cause
  std::vector<ParamEstimate> report_params;  // with units, uncertainty
  double chi2 = 0, bic = 0, delta_bic = 0;   // delta to the nominal model
  int parameters = 0;                        // incl. nuisance offsets
  double rms_um = 0, rms_urad = 0;  // residual after effect and offsets
  // Why the candidate cannot be named although it fits (e.g. a time
  // constant at its bound or undetermined); empty when it can.
  std::string note;
};

// Where unexplained structure lives: one figure kind, cycle or the facet
// angles, with its RMS after the best model and its share of chi2.
struct StructureLocation {
  std::string where;  // "E_TTP", "cycle 6", "facet angles", ...
  double rms = 0;     // in `unit`
  std::string unit;   // "um" or "urad"
  double chi2_per_observation = 0;
};

struct DiagnosisReport {
  DiagnosisStatus status = DiagnosisStatus::kNone;
  std::string cause = "none";  // empty when refused
  std::string reason;          // one sentence: why this status
  std::vector<ParamEstimate> params;
  // Residual RMS after fitting the nominal model (nuisance offsets only)
  // and the extension (cause + offsets); raw = measured - simulated.
  double raw_rms_um = 0, raw_rms_urad = 0;
  double baseline_rms_um = 0, extended_rms_um = 0;
  double baseline_rms_urad = 0, extended_rms_urad = 0;
  double chi2_per_dof = 0;  // of the chosen model
  // The figures carry the reference cycle's common error in their
  // covariance (Observations::figure_reference_var_um2) instead of a free
  // offset per kind.
  bool figures_anchored = false;
  // The decision's statistics: the strongest evidence for any cause (BIC of
  // the nominal model minus the cause's), the largest per-kind chi2 deviate
  // and the largest chi2 a step in one figure kind explains after the
  // chosen model.
  double best_evidence = 0, structure_z = 0, step_chi2 = 0;
  // The largest chi2 a drift of one figure kind over the cycles explains
  // after the chosen model, and that drift over the cycles measured (um).
  double trend_chi2 = 0, trend_um = 0;
  // The evidence threshold the chosen model was held to against the
  // nominal one (DiagnosisOptions::evidence_threshold, or
  // angle_evidence_threshold for a cause seen only in the facet angles).
  double evidence_threshold = 0;
  // The largest per-kind deviate over E_X, E_Y, E_Z (the figures that
  // follow the machine's location errors), after the best model or the
  // nominal one, whichever leaves E_X, E_Y and E_Z pooled closer to the
  // log (machine_pooled_z, machine_kind_z: the same model).
  double machine_z = 0;
  // The same over E_X, E_Y and E_Z pooled (one chi2 deviate).
  double machine_pooled_z = 0;
  // Each of E_X, E_Y, E_Z alone (-inf where fewer than three observations).
  std::vector<double> machine_kind_z;
  // The pooled deviate with the best drift or step of one figure kind
  // fitted along with the best model, or after any candidate's fit (its
  // parameters a result or not), whichever is least: an effect on one
  // feature type (the strips drifting, one set of facets moved) or of a
  // cause's shape leaves little here, another run's machine errors (in
  // every kind the R-tests measure) stay.
  double machine_pooled_z_one_kind = 0;
  // The pooled deviate with another run's machine fitted along with the
  // best model or the nominal one (the least over both and the lags
  // tried): E_X, E_Y and E_Z each following this run's table temperature
  // directly and through a lag, and drifting in time, with gains of their
  // own (DiagnosisOptions::refuse_other_machine_z). A mismatched log
  // leaves little here; structure that moves each cycle its own way stays.
  double machine_pooled_z_other_machine = 0;
  // Held-out cycles (the whole selection repeated without each cycle):
  // RMS of the held-out residuals, nominal vs the fold's chosen model.
  double heldout_baseline_rms_um = 0, heldout_extended_rms_um = 0;
  double heldout_baseline_rms_urad = 0, heldout_extended_rms_urad = 0;
  double gain_pct = 0;  // on figures (um); on angles for angle-only causes
  int observations = 0;
  std::vector<CandidateResult> candidates;
  // Where the residual after the chosen model lives, largest chi2 per
  // observation first (for `unexplained`: where the structure is).
  std::vector<StructureLocation> structure;
  // Figures after the chosen model (measured - simulated - effect -
  // offsets), in Observations' figure order, um.
  std::vector<double> figure_after_um;
  std::string estimator;
  // What the result rests on that the user should know (R-tests the
  // estimator left out as gross errors), one sentence each.
  std::vector<std::string> warnings;
  // Unexplained runs: the slope of the measured E_X, E_Y over the
  // simulated ones (1 when the log describes the piece's run; NaN when not
  // computed).
  double simulation_slope = std::numeric_limits<double>::quiet_NaN();
  double simulation_slope_sd = 0;
};

// Diagnosis on prepared residuals (named, none or unexplained).
DiagnosisReport Diagnose(const Observations& observations,
                         const EffectContext& context, const PartSpec& part,
                         const DiagnosisOptions& options = {});

// Residuals of a measured piece against the simulation of a log.
struct PreparedRun {
  thermal::Simulation simulation;
  EffectContext context;
  Observations observations;
  // Set when the measurement and the log cannot belong together (a
  // measured feature the log never cut): the diagnosis is `refused`.
  std::string refusal;
};
PreparedRun PrepareRun(const thermal::TalcLog& log, const Config& config,
                       const MeasuredPiece& measured,
                       const DiagnosisOptions& options = {});
// The same on an estimator and simulation the caller already has (fitted
// and simulated from `log`), as `ttp run` shares them with its check.
PreparedRun PrepareRun(const thermal::TalcLog& log, const Config& config,
                       const thermal::MachineErrorEstimator& estimator,
                       thermal::Simulation simulation,
                       const MeasuredPiece& measured,
                       const DiagnosisOptions& options = {});
// A diagnosis with the prepared run it was made on (what a report draws).
struct PreparedDiagnosis {
  PreparedRun run;
  DiagnosisReport report;
};

// Diagnose on a prepared run, with the estimator's description: `refused`
// when the run carries a refusal or the measured figures follow another
// run's (DiagnosisOptions::mismatch_slope_limit).
DiagnosisReport DiagnosePrepared(const PreparedRun& run,
                                 const thermal::TalcLog& log,
                                 const PartSpec& part,
                                 const MeasuredPiece& measured,
                                 const DiagnosisOptions& options = {});
// PrepareRun, then DiagnosePrepared.
DiagnosisReport DiagnoseRun(const thermal::TalcLog& log, const Config& config,
                            const MeasuredPiece& measured,
                            const DiagnosisOptions& options = {});

// Effect of a cause on the observations (same layout).
struct ObservationEffect {
  std::vector<double> figure_um, angle_urad;
};
// The figures (and the ovality) and facet angles that per-feature deltas
// give on the observations.
ObservationEffect DeltasOnObservations(const EffectDeltas& deltas,
                                       const Observations& obs,
                                       const PartSpec& part);
ObservationEffect EffectOnObservations(Cause cause,
                                       const std::vector<double>& params,
                                       const Observations& observations,
                                       const EffectContext& context,
                                       const PartSpec& part);

nlohmann::json DiagnosisToJson(const DiagnosisReport& report);
std::string DiagnosisText(const DiagnosisReport& report);

}  // namespace ttp::diagnosis
