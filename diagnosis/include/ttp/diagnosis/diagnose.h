// What the simulation gets wrong (diagnosis.md): residual = measured -
// simulated (figures E_X, E_Y, E_Z, E_TTP per cycle and facet normal
// angles), every cause fitted by weighted least squares together with
// nuisance offsets (the reference cycle's machine state is uncertain, so
// each figure may be off by a constant), chosen by BIC; a cause is named
// only when its BIC beats the nominal model by the evidence threshold.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "ttp/diagnosis/effects.h"
#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"
#include "ttp/inspect/inspect.h"
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
  std::map<std::string, double> facet_angle_rad;  // absolute angle errors
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
MeasuredPiece LoadMeasuredPiece(const Config& config, const std::string& path);

// Residual observations: measured - simulated.
struct Observations {
  std::vector<std::string> labels;  // "E_X@3", "angle X1-3"
  std::vector<FeatureId> facet;     // group 4 (angles): the facet
  std::vector<double> value;        // um (figures) or urad (angles)
  std::vector<double> sigma;        // standard uncertainty, same unit
  std::vector<int> cycle;           // 0 = reference features
  std::vector<int> group;           // 0..3 E_X,E_Y,E_Z,E_TTP; 4 angles
  size_t size() const { return value.size(); }
};

struct DiagnosisOptions {
  // BIC of the best cause must beat the nominal model's by this much
  // (Kass & Raftery: > 10 is very strong evidence).
  double evidence_threshold = 10.0;
  // Lower bounds of the residual uncertainties (um, urad).
  double min_sigma_um = 0.05, min_sigma_urad = 0.3;
  // The estimator's leave-one-R-test-out error includes the R-test's own
  // noise; between R-tests the smoother averages several of them, so its
  // error at a cut time is smaller. Scale applied to that error.
  double estimator_sigma_scale = 0.5;
  // DiagnoseRun refuses (InputError) when even the best model leaves
  // chi2 / degrees of freedom above this: the measurement does not belong
  // to the log (twin battery: at most ~1.2; mismatched samples: ~5.6).
  double max_chi2_per_dof = 3.0;
  std::vector<double> tau_grid_s = {300,  450,  700,  1000,  1500, 2200,
                                    3300, 5000, 7500, 11000, 17000};
};

struct ParamEstimate {
  std::string name;
  double value = 0, uncertainty = 0;  // k = 1
};

struct CandidateResult {
  Cause cause = Cause::kNone;
  std::vector<double> params;                // in CauseParameterNames order
  std::vector<ParamEstimate> report_params;  // with units, uncertainty
  double chi2 = 0, bic = 0, delta_bic = 0;   // delta to the nominal model
  int parameters = 0;                        // incl. nuisance offsets
  double rms_um = 0, rms_urad = 0;  // residual after effect and offsets
};

struct DiagnosisReport {
  std::string cause = "none";
  std::vector<ParamEstimate> params;
  // Residual RMS after fitting the nominal model (nuisance offsets only)
  // and the extension (cause + offsets); raw = measured - simulated.
  double raw_rms_um = 0, raw_rms_urad = 0;
  double baseline_rms_um = 0, extended_rms_um = 0;
  double baseline_rms_urad = 0, extended_rms_urad = 0;
  // Leave one cycle out: residual RMS on held-out cycles (whitened, all
  // observations), baseline vs extension.
  double gain_pct = 0;
  double heldout_baseline_rms = 0, heldout_extended_rms = 0;
  int observations = 0;
  std::vector<CandidateResult> candidates;
  std::string estimator;
};

// Diagnosis on prepared residuals.
DiagnosisReport Diagnose(const Observations& observations,
                         const EffectContext& context, const PartSpec& part,
                         const DiagnosisOptions& options = {});

// Residuals of a measured piece against the simulation of a log.
struct PreparedRun {
  thermal::Simulation simulation;
  EffectContext context;
  Observations observations;
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

// Diagnose on a prepared run, with the estimator's description, refusing a
// measurement the best model cannot explain (options.max_chi2_per_dof):
// InputError naming the measurement.
DiagnosisReport DiagnosePrepared(const PreparedRun& run,
                                 const thermal::TalcLog& log,
                                 const PartSpec& part,
                                 const MeasuredPiece& measured,
                                 const DiagnosisOptions& options = {});
// PrepareRun, then DiagnosePrepared.
DiagnosisReport DiagnoseRun(const thermal::TalcLog& log, const Config& config,
                            const MeasuredPiece& measured,
                            const DiagnosisOptions& options = {});

// Effect of a cause on the observations (same layout), um / urad.
std::vector<double> EffectOnObservations(Cause cause,
                                         const std::vector<double>& params,
                                         const Observations& observations,
                                         const EffectContext& context,
                                         const PartSpec& part);

nlohmann::json DiagnosisToJson(const DiagnosisReport& report);
std::string DiagnosisText(const DiagnosisReport& report);

}  // namespace ttp::diagnosis
