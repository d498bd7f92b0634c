#include "ttp/diagnosis/diagnose.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>
#include <limits>

#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/inspect/measurement.h"

namespace ttp::diagnosis {
namespace {

constexpr const char* kFigureNames[4] = {"E_X", "E_Y", "E_Z", "E_TTP"};
constexpr int kGroups = 5;  // E_X, E_Y, E_Z, E_TTP, facet angles

double FigureValueMm(const CycleFigures& f, int group) {
  switch (group) {
    case 0:
      return f.e_x_mm;
    case 1:
      return f.e_y_mm;
    case 2:
      return f.e_z_mm;
    default:
      return f.e_ttp_mm;
  }
}
double FigureUncertaintyMm(const CycleFigures& f, int group) {
  switch (group) {
    case 0:
      return f.u_x_mm;
    case 1:
      return f.u_y_mm;
    case 2:
      return f.u_z_mm;
    default:
      return f.u_ttp_mm;
  }
}

struct FitResult {
  std::vector<double> params;   // cause parameters
  std::vector<double> offsets;  // nuisance, per group
  double chi2 = 0;
  Eigen::MatrixXd covariance;  // cause parameters (k = 1)
  bool ok = true;
};

// Weighted linear least squares y ~ X b on the rows in `use`.
bool SolveWeighted(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                   const Eigen::VectorXd& w, Eigen::VectorXd* b,
                   Eigen::MatrixXd* cov, double* chi2) {
  const Eigen::MatrixXd xw = w.asDiagonal() * x;
  const Eigen::VectorXd yw = w.asDiagonal() * y;
  const Eigen::MatrixXd n = xw.transpose() * xw;
  Eigen::LDLT<Eigen::MatrixXd> ldlt(n);
  if (ldlt.info() != Eigen::Success) return false;
  *b = ldlt.solve(xw.transpose() * yw);
  if (cov) *cov = ldlt.solve(Eigen::MatrixXd::Identity(n.rows(), n.cols()));
  *chi2 = (yw - xw * *b).squaredNorm();
  return b->allFinite();
}

class Fitter {
 public:
  Fitter(const Observations& obs, const EffectContext& context,
         const PartSpec& part, const DiagnosisOptions& options,
         std::vector<bool> use)
      : obs_(obs),
        context_(context),
        part_(part),
        options_(options),
        use_(std::move(use)) {
    for (size_t i = 0; i < obs.size(); ++i)
      if (use_[i]) group_used_[obs.group[i]] = true;
    for (int g = 0; g < kGroups; ++g)
      if (group_used_[g]) nuisance_groups_.push_back(g);
    for (size_t i = 0; i < obs.size(); ++i)
      if (use_[i]) rows_.push_back(static_cast<int>(i));
  }

  int NuisanceCount() const {
    return static_cast<int>(nuisance_groups_.size());
  }
  int Rows() const { return static_cast<int>(rows_.size()); }

  Eigen::VectorXd Effect(Cause cause, const std::vector<double>& p) const {
    const auto v = EffectOnObservations(cause, p, obs_, context_, part_);
    return Eigen::Map<const Eigen::VectorXd>(v.data(), v.size());
  }

  // Linear fit: y - base = sum_k p_k column_k + offsets.
  FitResult FitLinear(const std::vector<Eigen::VectorXd>& columns,
                      const Eigen::VectorXd& base) const {
    const int nr = Rows(), nc = static_cast<int>(columns.size()),
              nn = NuisanceCount();
    Eigen::MatrixXd x = Eigen::MatrixXd::Zero(nr, nc + nn);
    Eigen::VectorXd y(nr), w(nr);
    for (int r = 0; r < nr; ++r) {
      const int i = rows_[r];
      for (int c = 0; c < nc; ++c) x(r, c) = columns[c][i];
      for (int g = 0; g < nn; ++g)
        x(r, nc + g) = obs_.group[i] == nuisance_groups_[g] ? 1.0 : 0.0;
      y[r] = obs_.value[i] - base[i];
      w[r] = 1.0 / obs_.sigma[i];
    }
    FitResult fit;
    Eigen::VectorXd b;
    Eigen::MatrixXd cov;
    fit.ok = SolveWeighted(x, y, w, &b, &cov, &fit.chi2);
    if (!fit.ok) {
      fit.chi2 = std::numeric_limits<double>::infinity();
      return fit;
    }
    fit.params.assign(b.data(), b.data() + nc);
    fit.offsets.assign(kGroups, 0.0);
    for (int g = 0; g < nn; ++g) fit.offsets[nuisance_groups_[g]] = b[nc + g];
    fit.covariance = cov.topLeftCorner(nc, nc);
    return fit;
  }

  FitResult Fit(Cause cause) const {
    const size_t n = obs_.size();
    const int np = static_cast<int>(CauseParameterNames(cause).size());
    if (cause == Cause::kWorkpieceExpansion) return FitWorkpiece();
    std::vector<Eigen::VectorXd> columns;
    for (int k = 0; k < np; ++k) {
      std::vector<double> p(np, 0.0);
      p[k] = 1.0;
      columns.push_back(Effect(cause, p));
    }
    FitResult fit = FitLinear(columns, Eigen::VectorXd::Zero(n));
    if (cause == Cause::kToolWear && fit.ok && fit.params[0] < 0) {
      // A cutter does not grow: the constrained optimum is no wear.
      FitResult zero = FitLinear({}, Eigen::VectorXd::Zero(n));
      zero.params = {0.0};
      zero.covariance = fit.covariance;
      return zero;
    }
    return fit;
  }

  // Nonlinear in tau_wp_s: a grid for the start, then Ceres on
  // (log tau, gain, offsets); gain and offsets enter linearly.
  FitResult FitWorkpiece() const {
    FitResult best;
    best.chi2 = std::numeric_limits<double>::infinity();
    double best_tau = options_.tau_grid_s.front();
    for (double tau : options_.tau_grid_s) {
      const Eigen::VectorXd base = Effect(Cause::kWorkpieceExpansion, {tau, 0});
      const Eigen::VectorXd one = Effect(Cause::kWorkpieceExpansion, {tau, 1});
      FitResult f = FitLinear({one - base}, base);
      if (f.ok && f.chi2 < best.chi2) {
        best = f;
        best_tau = tau;
      }
    }
    if (!std::isfinite(best.chi2)) return best;
    const int nn = NuisanceCount();
    std::vector<double> x = {std::log(best_tau), best.params[0]};
    for (int g : nuisance_groups_) x.push_back(best.offsets[g]);
    auto residuals = [this, nn](const double* p, double* out) {
      const Eigen::VectorXd e =
          Effect(Cause::kWorkpieceExpansion, {std::exp(p[0]), p[1]});
      for (int r = 0; r < Rows(); ++r) {
        const int i = rows_[r];
        double offset = 0;
        for (int g = 0; g < nn; ++g)
          if (obs_.group[i] == nuisance_groups_[g]) offset = p[2 + g];
        out[r] = (obs_.value[i] - e[i] - offset) / obs_.sigma[i];
      }
    };
    struct Cost {
      decltype(residuals) f;
      bool operator()(double const* const* p, double* out) const {
        f(p[0], out);
        return true;
      }
    };
    auto* cost =
        new ceres::DynamicNumericDiffCostFunction<Cost>(new Cost{residuals});
    cost->AddParameterBlock(static_cast<int>(x.size()));
    cost->SetNumResiduals(Rows());
    ceres::Problem problem;
    problem.AddResidualBlock(cost, nullptr, x.data());
    problem.SetParameterLowerBound(x.data(), 0, std::log(60.0));
    problem.SetParameterUpperBound(x.data(), 0, std::log(40000.0));
    ceres::Solver::Options so;
    so.max_num_iterations = 50;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    // Covariance from the Jacobian at the solution.
    Eigen::MatrixXd jac(Rows(), x.size());
    std::vector<double> r0(Rows()), r1(Rows());
    residuals(x.data(), r0.data());
    double chi2 = 0;
    for (double v : r0) chi2 += v * v;
    for (size_t k = 0; k < x.size(); ++k) {
      std::vector<double> xp = x;
      const double h = 1e-6 * std::max(1.0, std::abs(x[k]));
      xp[k] += h;
      residuals(xp.data(), r1.data());
      for (int r = 0; r < Rows(); ++r) jac(r, k) = (r1[r] - r0[r]) / h;
    }
    FitResult fit;
    fit.chi2 = chi2;
    fit.params = {std::exp(x[0]), x[1]};
    fit.offsets.assign(kGroups, 0.0);
    for (int g = 0; g < nn; ++g) fit.offsets[nuisance_groups_[g]] = x[2 + g];
    const Eigen::MatrixXd info = jac.transpose() * jac;
    Eigen::MatrixXd cov =
        info.completeOrthogonalDecomposition().pseudoInverse();
    fit.covariance = cov.topLeftCorner(2, 2);
    // tau's uncertainty from log tau's.
    fit.covariance(0, 0) *= fit.params[0] * fit.params[0];
    fit.covariance(0, 1) *= fit.params[0];
    fit.covariance(1, 0) *= fit.params[0];
    if (chi2 > best.chi2) {  // keep the grid's answer if Ceres did worse
      best.params = {best_tau, best.params[0]};
      best.covariance = fit.covariance;
      return best;
    }
    return fit;
  }

 private:
  const Observations& obs_;
  const EffectContext& context_;
  const PartSpec& part_;
  const DiagnosisOptions& options_;
  std::vector<bool> use_;
  bool group_used_[kGroups] = {false, false, false, false, false};
  std::vector<int> nuisance_groups_;
  std::vector<int> rows_;
};

std::vector<ParamEstimate> ReportParams(Cause cause, const FitResult& fit) {
  std::vector<ParamEstimate> out;
  const auto names = CauseParameterNames(cause);
  auto sd = [&](int k) {
    return k < fit.covariance.rows()
               ? std::sqrt(std::max(0.0, fit.covariance(k, k)))
               : 0.0;
  };
  if (cause == Cause::kClampingDistortion || cause == Cause::kCAxisIndexing) {
    // Amplitude and phase of a cos + b sin = A cos(x - phase).
    const double a = fit.params[0], b = fit.params[1];
    const double amp = std::hypot(a, b);
    const double phase = std::atan2(b, a);
    const double s = std::max(sd(0), sd(1));
    const std::string unit =
        cause == Cause::kClampingDistortion ? "_um" : "_urad";
    out.push_back({"amplitude" + unit, amp, s});
    out.push_back({"phase_deg", phase * 180 / M_PI,
                   amp > 0 ? s / amp * 180 / M_PI : 180.0});
    for (int k = 0; k < 2; ++k) out.push_back({names[k], fit.params[k], sd(k)});
    return out;
  }
  for (size_t k = 0; k < names.size(); ++k)
    out.push_back({names[k], fit.params[k], sd(static_cast<int>(k))});
  return out;
}

// What a fitted model predicts for the observations: the cause's effect
// plus the nuisance offset of each observation's group.
std::vector<double> ModelPrediction(Cause cause, const FitResult& fit,
                                    const Observations& obs,
                                    const EffectContext& context,
                                    const PartSpec& part) {
  if (!fit.ok) return std::vector<double>(obs.size(), 0.0);
  std::vector<double> out =
      EffectOnObservations(cause, fit.params, obs, context, part);
  if (!fit.offsets.empty())
    for (size_t i = 0; i < obs.size(); ++i) out[i] += fit.offsets[obs.group[i]];
  return out;
}

double Rms(const std::vector<double>& v) {
  if (v.empty()) return 0;
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / v.size());
}

}  // namespace

std::vector<double> EffectOnObservations(Cause cause,
                                         const std::vector<double>& params,
                                         const Observations& obs,
                                         const EffectContext& context,
                                         const PartSpec& part) {
  std::vector<double> out(obs.size(), 0.0);
  if (cause == Cause::kNone) return out;
  const EffectDeltas deltas = PredictEffect(cause, params, context);
  FeatureResults results;
  for (const auto& [id, d] : deltas) {
    FeatureResult r;
    r.present = true;
    r.d_mm = d.d_mm;
    r.angle_rad = d.angle_rad;
    results[id] = r;
  }
  const std::vector<CycleFigures> figures = ComputeFigures(part, results);
  for (size_t i = 0; i < obs.size(); ++i) {
    if (obs.group[i] < 4) {
      const int c = obs.cycle[i];
      if (c >= 1 && c <= static_cast<int>(figures.size())) {
        const double v = FigureValueMm(figures[c - 1], obs.group[i]) * 1e3;
        out[i] = std::isfinite(v) ? v : 0.0;
      }
    } else {
      auto it = deltas.find(obs.facet[i].ToString());
      if (it != deltas.end()) out[i] = it->second.angle_rad * 1e6;
    }
  }
  return out;
}

DiagnosisReport Diagnose(const Observations& obs, const EffectContext& context,
                         const PartSpec& part,
                         const DiagnosisOptions& options) {
  DiagnosisReport report;
  const int n = static_cast<int>(obs.size());
  report.observations = n;
  if (n == 0)
    throw InputError("measurement", 0, "",
                     "no residual observations (no figures or angles)");
  std::vector<double> raw_um, raw_urad;
  for (int i = 0; i < n; ++i)
    (obs.group[i] < 4 ? raw_um : raw_urad).push_back(obs.value[i]);
  report.raw_rms_um = Rms(raw_um);
  report.raw_rms_urad = Rms(raw_urad);

  const Fitter fitter(obs, context, part, options, std::vector<bool>(n, true));
  double none_bic = 0;
  for (Cause cause : kAllCauses) {
    const FitResult fit = fitter.Fit(cause);
    CandidateResult c;
    c.cause = cause;
    c.params = fit.params;
    c.parameters = static_cast<int>(fit.params.size()) + fitter.NuisanceCount();
    c.chi2 = fit.chi2;
    c.bic = fit.chi2 + c.parameters * std::log(static_cast<double>(n));
    if (cause == Cause::kNone) none_bic = c.bic;
    c.delta_bic = c.bic - none_bic;
    if (fit.ok && cause != Cause::kNone)
      c.report_params = ReportParams(cause, fit);
    const auto effect = ModelPrediction(cause, fit, obs, context, part);
    std::vector<double> um, urad;
    for (int i = 0; i < n; ++i)
      (obs.group[i] < 4 ? um : urad).push_back(obs.value[i] - effect[i]);
    c.rms_um = Rms(um);
    c.rms_urad = Rms(urad);
    report.candidates.push_back(c);
  }
  int best = 0;
  for (int k = 1; k < static_cast<int>(report.candidates.size()); ++k)
    if (report.candidates[k].bic < report.candidates[best].bic) best = k;
  if (-report.candidates[best].delta_bic < options.evidence_threshold) best = 0;
  const CandidateResult& chosen = report.candidates[best];
  report.baseline_rms_um = report.candidates[0].rms_um;
  report.baseline_rms_urad = report.candidates[0].rms_urad;
  report.cause = CauseName(chosen.cause);
  report.params = chosen.report_params;
  report.extended_rms_um = chosen.rms_um;
  report.extended_rms_urad = chosen.rms_urad;

  // Gain on held-out cycles: fit without cycle k, predict cycle k.
  if (chosen.cause != Cause::kNone) {
    std::vector<double> held_base, held_ext;
    for (int k = 1; k <= part.cycles(); ++k) {
      std::vector<bool> use(n);
      bool any = false;
      for (int i = 0; i < n; ++i) {
        use[i] = obs.cycle[i] != k;
        any = any || !use[i];
      }
      if (!any) continue;
      const Fitter loo(obs, context, part, options, use);
      const FitResult fit = loo.Fit(chosen.cause);
      const FitResult nominal = loo.Fit(Cause::kNone);
      if (!fit.ok || !nominal.ok) continue;
      const auto effect =
          ModelPrediction(chosen.cause, fit, obs, context, part);
      const auto base =
          ModelPrediction(Cause::kNone, nominal, obs, context, part);
      for (int i = 0; i < n; ++i) {
        if (use[i]) continue;
        held_base.push_back((obs.value[i] - base[i]) / obs.sigma[i]);
        held_ext.push_back((obs.value[i] - effect[i]) / obs.sigma[i]);
      }
    }
    report.heldout_baseline_rms = Rms(held_base);
    report.heldout_extended_rms = Rms(held_ext);
    if (report.heldout_baseline_rms > 0)
      report.gain_pct = 100.0 * (1.0 - report.heldout_extended_rms /
                                           report.heldout_baseline_rms);
  }
  return report;
}

namespace {
// The noise the cause models are judged against: the fit's own scatter
// (rms / sqrt(points) for the distance, over the spread of the points
// across the feature for the angle), not the instrument's error limit,
// which is common to the cycles and cancels in the figures' differences
// (and the per-figure offsets of every model absorb what is left).
void UseFitScatter(const PartSpec& part, FeatureKind kind, FeatureResult* r) {
  if (!r->present || !(r->rms_mm > 0) || r->points < 3) return;
  const FitScatter s = FeatureFitScatter(part, kind, r->rms_mm, r->points);
  r->var_d_mm2 = s.d_mm * s.d_mm;
  r->var_angle_rad2 = s.angle_rad * s.angle_rad;
}
}  // namespace

MeasuredPiece MeasuredPieceFromFeatures(const PartSpec& part,
                                        const FeatureResults& features) {
  MeasuredPiece m;
  for (const auto& [id, r] : features) {
    if (!r.present) continue;
    FeatureResult& f = m.features[id] = r;
    FeatureKind kind;
    Segment s;
    int j;
    if (!ParseFeatureId(id, &kind, &s, &j)) continue;
    UseFitScatter(part, kind, &f);
    if (kind == FeatureKind::kFacet && std::isfinite(r.angle_rad))
      m.facet_angle_rad[id] = r.angle_rad;
  }
  m.figures = ComputeFigures(part, m.features);
  return m;
}

MeasuredPiece MeasuredPieceFromInspection(
    const PartSpec& part, const inspect::InspectionResult& result) {
  MeasuredPiece m;
  const bool any_feature =
      std::any_of(result.features.begin(), result.features.end(),
                  [](const auto& f) { return f.second.present; });
  if (any_feature) {
    m = MeasuredPieceFromFeatures(part, result.features);
  } else {
    m.figures = result.figures;
    m.facet_angle_rad = result.facet_angle_rad;
  }
  m.source = result.source;
  if (m.figures.empty() && m.facet_angle_rad.empty())
    throw InputError(result.source.empty() ? "measurement" : result.source, 0,
                     "figures",
                     "the measurement has neither feature results nor "
                     "figures");
  return m;
}

MeasuredPiece LoadMeasuredPiece(const Config& config, const std::string& path) {
  return MeasuredPieceFromInspection(
      config.part, inspect::LoadMeasurement(config, path).result);
}

PreparedRun PrepareRun(const thermal::TalcLog& log, const Config& config,
                       const MeasuredPiece& measured,
                       const DiagnosisOptions& options) {
  const auto estimator = thermal::MachineErrorEstimator::Fit(log);
  return PrepareRun(log, config, estimator,
                    thermal::SimulatePiece(log, config, estimator, {}),
                    measured, options);
}

PreparedRun PrepareRun(const thermal::TalcLog& log, const Config& config,
                       const thermal::MachineErrorEstimator& estimator,
                       thermal::Simulation simulation,
                       const MeasuredPiece& measured,
                       const DiagnosisOptions& options) {
  PreparedRun run;
  run.simulation = std::move(simulation);
  const PartSpec& part = config.part;

  std::vector<CutState> states;
  for (const auto& cut : run.simulation.cuts)
    states.push_back(MakeCutState(config, cut.feature, cut.t_s, cut.c_rad));
  run.context = MakeEffectContext(config, states);
  // Machine temperature history from the estimated E_R0T.
  const double t_end = log.LastTimeS();
  run.context.grid_t0_s = 0;
  run.context.grid_step_s = 10;
  const double first = estimator.FirstRTestS();
  const double last = estimator.LastRTestS();
  for (double t = 0; t <= t_end + 10; t += 10) {
    const double tc = std::clamp(t, first, last);
    // The R-test sphere radius of this log, as the check takes it.
    run.context.machine_dT_K.push_back(
        TemperatureChangeK(estimator.MachineErrorsAt(tc).er0t_mm,
                           kTableAlphaPerK, log.sphere_distance_mm));
  }

  // Uncertainty of the simulated figures: the estimator's leave-one-out
  // error of the error each figure follows (a figure is a difference of two
  // cut times), combined with the measurement's own.
  auto loo = [&](const char* name) {
    for (size_t k = 0; k < 7; ++k)
      if (std::string(kErrorNames[k]) == name)
        return estimator.models()[k].loo_rms *
               options.estimator_sigma_scale;  // um or um/m
    return 0.0;
  };
  const double est_um[4] = {
      loo("EX0C"), loo("EY0C"), loo("EZ0T"),
      loo("ER0T") * part.facet_final_distance_mm / log.sphere_distance_mm};
  const double est_urad = loo("EC0C");

  // Every measured feature must have been cut in the log: otherwise the
  // log does not cover the measured piece (or belongs to another piece).
  std::vector<std::string> uncut;
  auto check_cut = [&](const std::string& id) {
    auto it = run.simulation.results.find(id);
    if (it == run.simulation.results.end() || !it->second.present)
      if (std::find(uncut.begin(), uncut.end(), id) == uncut.end())
        uncut.push_back(id);
  };
  for (const auto& [id, r] : measured.features)
    if (r.present) check_cut(id);
  for (const auto& [id, a] : measured.facet_angle_rad) check_cut(id);
  if (!uncut.empty()) {
    std::string list;
    for (size_t k = 0; k < uncut.size() && k < 6; ++k)
      list += (k ? ", " : "") + uncut[k];
    if (uncut.size() > 6) list += fmt::format(" and {} more", uncut.size() - 6);
    throw InputError(
        log.source, 0, "cut",
        fmt::format("the log has no cut of {} that the measurement {} holds: "
                    "the log does not cover the piece's cut times, or log "
                    "and measurement do not belong together",
                    list, measured.source.empty() ? "" : measured.source));
  }

  Observations& obs = run.observations;
  for (const CycleFigures& m : measured.figures) {
    if (m.cycle < 1 ||
        m.cycle > static_cast<int>(run.simulation.figures.size()))
      continue;
    const CycleFigures& s = run.simulation.figures[m.cycle - 1];
    for (int g = 0; g < 4; ++g) {
      const double mv = FigureValueMm(m, g), sv = FigureValueMm(s, g);
      if (std::isfinite(mv) && !std::isfinite(sv))
        throw InputError(
            log.source, 0, "cut",
            fmt::format("the measurement {} has {} of cycle {} but the log "
                        "lacks a cut it needs: the log does not cover the "
                        "piece's cut times",
                        measured.source, kFigureNames[g], m.cycle));
      if (!std::isfinite(mv) || !std::isfinite(sv)) continue;
      obs.labels.push_back(fmt::format("{}@{}", kFigureNames[g], m.cycle));
      obs.value.push_back((mv - sv) * 1e3);
      const double u_meas = FigureUncertaintyMm(m, g) * 1e3;
      obs.sigma.push_back(
          std::max(options.min_sigma_um, std::hypot(u_meas, est_um[g])));
      obs.cycle.push_back(m.cycle);
      obs.group.push_back(g);
    }
  }
  for (const auto& [id, angle] : measured.facet_angle_rad) {
    auto it = run.simulation.results.find(id);
    if (it == run.simulation.results.end() || !it->second.present) continue;
    const std::optional<FeatureId> facet = FeatureId::Parse(id);
    if (!facet || !facet->IsTestFeature()) continue;
    obs.labels.push_back("angle " + id);
    obs.facet.resize(obs.labels.size() - 1);
    obs.facet.push_back(*facet);
    obs.value.push_back((angle - it->second.angle_rad) * 1e6);
    double u_meas = 0;
    auto mf = measured.features.find(id);
    if (mf != measured.features.end())
      u_meas = std::sqrt(mf->second.var_angle_rad2) * 1e6;
    obs.sigma.push_back(
        std::max(options.min_sigma_urad, std::hypot(u_meas, est_urad)));
    obs.cycle.push_back(CycleForIndex(part, facet->index));
    obs.group.push_back(4);
  }
  return run;
}

DiagnosisReport DiagnoseRun(const thermal::TalcLog& log, const Config& config,
                            const MeasuredPiece& measured,
                            const DiagnosisOptions& options) {
  return DiagnosePrepared(PrepareRun(log, config, measured, options), log,
                          config.part, measured, options);
}

DiagnosisReport DiagnosePrepared(const PreparedRun& run,
                                 const thermal::TalcLog& log,
                                 const PartSpec& part,
                                 const MeasuredPiece& measured,
                                 const DiagnosisOptions& options) {
  DiagnosisReport report =
      Diagnose(run.observations, run.context, part, options);
  report.estimator = run.simulation.estimator_description;
  // Even the best model must leave residuals of the size of their
  // uncertainties; far beyond, the measured piece is not the one this log
  // cut (or something beyond every known cause happened): no diagnosis.
  double best = std::numeric_limits<double>::infinity();
  int dof = 1;
  for (const CandidateResult& c : report.candidates)
    if (c.chi2 < best) {
      best = c.chi2;
      dof = std::max(1, report.observations - c.parameters);
    }
  if (best / dof > options.max_chi2_per_dof)
    throw InputError(
        measured.source, 0, "",
        fmt::format("the measured piece does not match the simulation from "
                    "{}: chi2 per degree of freedom {:.1f} even with the best "
                    "cause (limit {:.1f}; RMS {:.2f} um): the measurement and "
                    "the log do not belong together, or an effect beyond the "
                    "known causes is present",
                    log.source, best / dof, options.max_chi2_per_dof,
                    report.baseline_rms_um));
  return report;
}

nlohmann::json DiagnosisToJson(const DiagnosisReport& r) {
  nlohmann::json params = nlohmann::json::object();
  nlohmann::json uncertainty = nlohmann::json::object();
  for (const auto& p : r.params) {
    params[p.name] = p.value;
    uncertainty[p.name] = p.uncertainty;
  }
  nlohmann::json candidates = nlohmann::json::array();
  for (const auto& c : r.candidates) {
    nlohmann::json cp = nlohmann::json::object();
    for (const auto& p : c.report_params)
      cp[p.name] = {{"value", p.value}, {"uncertainty", p.uncertainty}};
    candidates.push_back({{"cause", CauseName(c.cause)},
                          {"bic", c.bic},
                          {"delta_bic", c.delta_bic},
                          {"chi2", c.chi2},
                          {"parameters", c.parameters},
                          {"rms_um", c.rms_um},
                          {"rms_urad", c.rms_urad},
                          {"params", cp}});
  }
  return {{"cause", r.cause},
          {"baseline",
           {{"rms_um", r.baseline_rms_um}, {"rms_urad", r.baseline_rms_urad}}},
          {"extended",
           {{"rms_um", r.extended_rms_um},
            {"rms_urad", r.extended_rms_urad},
            {"params", params},
            {"uncertainty", uncertainty}}},
          {"gain_pct", r.gain_pct},
          {"gain",
           {{"method",
             "leave one cycle out: fit without cycle k, predict cycle k; "
             "RMS of residual/sigma over all held-out observations"},
            {"heldout_baseline_rms", r.heldout_baseline_rms},
            {"heldout_extended_rms", r.heldout_extended_rms}}},
          {"evidence",
           "BIC = chi2 + k ln n on residuals / uncertainty (figures E_X, "
           "E_Y, E_Z, E_TTP and facet angles; nuisance offset per figure); "
           "a cause is named when its BIC is lower than the nominal "
           "model's by the threshold"},
          {"observations", r.observations},
          {"estimator", r.estimator},
          {"candidates", candidates}};
}

std::string DiagnosisText(const DiagnosisReport& r) {
  std::string s = fmt::format("cause: {}\n", r.cause);
  for (const auto& p : r.params)
    s += fmt::format("  {} = {:.4g} +- {:.2g}\n", p.name, p.value,
                     p.uncertainty);
  s += fmt::format(
      "residual RMS (figures, um): measured - simulated {:.3f}, nominal "
      "model {:.3f}, extended {:.3f}\n"
      "residual RMS (facet angles, urad): measured - simulated {:.3f}, "
      "nominal model {:.3f}, extended {:.3f}\n"
      "gain on held-out cycles: {:.1f} %\n"
      "(models: nominal simulation + a fitted offset per figure; "
      "{} observations)\n\n",
      r.raw_rms_um, r.baseline_rms_um, r.extended_rms_um, r.raw_rms_urad,
      r.baseline_rms_urad, r.extended_rms_urad, r.gain_pct, r.observations);
  s += "candidate               k      chi2    delta BIC   rms_um  rms_urad\n";
  for (const auto& c : r.candidates)
    s += fmt::format("{:<22} {:>3} {:>9.1f} {:>12.1f} {:>8.3f} {:>9.3f}\n",
                     CauseName(c.cause), c.parameters, c.chi2, c.delta_bic,
                     c.rms_um, c.rms_urad);
  return s;
}

}  // namespace ttp::diagnosis
