#include "ttp/diagnosis/explain.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>


namespace ttp::diagnosis {
namespace {

std::string ParamText(const ParamEstimate& p) {
  return fmt::format("{} = {:.3g} +- {:.2g}", p.name, p.value, p.uncertainty);
}

// The cause and its evidence against the others, best candidate first; for
// a diagnosis that names nothing for a reason (refused, unexplained), the
// status, why and where the structure lives.
std::string Summary(const DiagnosisReport& d, double threshold) {
  std::vector<const CandidateResult*> ranked;
  for (const auto& c : d.candidates) {
    if (!c.causes.empty()) ranked.push_back(&c);
  }
  std::sort(ranked.begin(), ranked.end(), [](const auto* a, const auto* b) {
    return a->delta_bic < b->delta_bic;
  });
  if (d.status == DiagnosisStatus::kRefused ||
      d.status == DiagnosisStatus::kUnexplained) {
    std::string s = fmt::format("{}: {}.", StatusName(d.status), d.reason);
    for (const auto& l : d.structure)
      s += fmt::format(" {}: {:.3g} {} (chi2 per observation {:.1f}).",
                       l.where, l.rms, l.unit, l.chi2_per_observation);
    return s;
  }
  if (d.cause == "none") {
    std::string s = fmt::format(
        "No cause beyond noise: no extension of the model beats the nominal "
        "model by the evidence threshold (delta BIC < -{:g}).",
        threshold);
    if (!ranked.empty()) {
      s += fmt::format(" Best candidate: {} (delta BIC {:.1f}).",
                       ranked[0]->name, ranked[0]->delta_bic);
    }
    return s;
  }
  std::string s;
  for (const auto* c : ranked) {
    if (c->name != d.cause) continue;
    s = fmt::format(
        "{}: its BIC is lower than the nominal model's by {:.1f} (delta "
        "BIC {:+.1f}; this model is named below -{:g})",
        d.cause, -c->delta_bic, c->delta_bic,
        d.evidence_threshold > 0 ? d.evidence_threshold : threshold);
  }
  for (const auto* c : ranked) {
    if (c->name == d.cause) continue;
    s += fmt::format("; the next best candidate, {}, has delta BIC {:+.1f}",
                     c->name, c->delta_bic);
    break;
  }
  s += ". Fitted: ";
  for (size_t i = 0; i < d.params.size(); ++i) {
    s += (i ? ", " : "") + ParamText(d.params[i]);
  }
  // An angle cause is judged on the facet angles (urad), which it turns;
  // the figures (distances) it hardly changes.
  const bool angle_only = d.cause == "c_axis_indexing";
  const bool turns_facets =
      d.cause.find("c_axis_indexing") != std::string::npos ||
      d.cause.find("clamping_distortion") != std::string::npos;
  if (angle_only) {
    s += fmt::format(
        ". Residual RMS of the facet angles {:.2f} urad -> {:.2f} urad; on "
        "held-out cycles {:.2f} urad -> {:.2f} urad: the extension removes "
        "{:.0f} % of the angle residual.",
        d.baseline_rms_urad, d.extended_rms_urad, d.heldout_baseline_rms_urad,
        d.heldout_extended_rms_urad, d.gain_pct);
    return s;
  }
  s += fmt::format(
      ". Residual RMS of the figures {:.2f} um -> {:.2f} um",
      d.baseline_rms_um, d.extended_rms_um);
  if (turns_facets)
    s += fmt::format(", of the facet angles {:.2f} urad -> {:.2f} urad",
                     d.baseline_rms_urad, d.extended_rms_urad);
  s += fmt::format(
      "; on held-out cycles the extension removes {:.0f} % of the residual.",
      d.gain_pct);
  return s;
}

// Before: the observations (measured - simulated); after: what the
// diagnosis left of them (its figure_after_um: minus the chosen effect and
// the nuisance offsets).
ResidualTable Residuals(const PreparedRun& run, const DiagnosisReport& d,
                        const PartSpec& part) {
  const Observations& obs = run.observations;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  ResidualTable t;
  for (int c = 1; c <= part.cycles(); ++c) t.cycles.push_back(c);
  for (int g = 0; g < 4; ++g) {
    t.before_um[g].assign(part.cycles(), nan);
    t.after_um[g].assign(part.cycles(), nan);
    t.sigma_um[g].assign(part.cycles(), nan);
  }
  for (size_t i = 0; i < obs.figures(); ++i) {
    const int g = obs.figure_kind[i], c = obs.figure_cycle[i];
    if (g < 0 || g > 3 || c < 1 || c > part.cycles()) continue;
    t.before_um[g][c - 1] = obs.figure_value_um[i];
    if (i < d.figure_after_um.size())
      t.after_um[g][c - 1] = d.figure_after_um[i];
    t.sigma_um[g][c - 1] = obs.figure_sigma_um[i];
  }
  return t;
}

}  // namespace

DiagnosisExplanation ExplainDiagnosis(const PreparedRun& run,
                                      const DiagnosisReport& report,
                                      const PartSpec& part,
                                      double evidence_threshold) {
  return {Summary(report, evidence_threshold), Residuals(run, report, part)};
}

}  // namespace ttp::diagnosis
