#include "ttp/thermal/check.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/format.h"

namespace ttp::thermal {

const char* const kFigureNames[kFigureCount] = {"E_X", "E_Y", "E_Z", "E_B",
                                                "E_TTP"};
const char* const kFigureUnits[kFigureCount] = {"um", "um", "um", "um/m", "um"};

namespace {

// Figure values in um (E_B in um/m).
std::array<double, kFigureCount> Values(const CycleFigures& f) {
  return {f.e_x_mm * 1e3, f.e_y_mm * 1e3, f.e_z_mm * 1e3, f.e_b_rad * 1e6,
          f.e_ttp_mm * 1e3};
}
// Standard uncertainties (k = 1) in um (um/m).
std::array<double, kFigureCount> Sigmas(const CycleFigures& f) {
  return {f.u_x_mm * 1e3, f.u_y_mm * 1e3, f.u_z_mm * 1e3, f.u_b_rad * 1e6,
          f.u_ttp_mm * 1e3};
}

nlohmann::json NumberOrNull(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

// Mean of a log column over rows in [t0, t1]; NaN when no row gives it.
double MeanColumn(const TalcLog& log, NumericColumn c, double t0, double t1) {
  double sum = 0;
  int n = 0;
  for (const LogRow& row : log.rows) {
    if (row.t_s < t0 || row.t_s > t1 || !row.Has(c)) continue;
    sum += row.values[c];
    ++n;
  }
  return n ? sum / n : kNaN;
}

// z with P(Z > z) = p for a standard normal Z (0 < p < 0.5), by bisection
// on the complementary error function.
double NormalUpperQuantile(double p) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (0.5 * std::erfc(mid / std::sqrt(2.0)) > p)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

std::vector<CycleFigures> SimulatedFigureUncertainty(
    const TalcLog& log, const Config& config,
    const MachineErrorEstimator& estimator, const SimulationOptions& options) {
  const Simulation base = SimulatePiece(log, config, estimator, options);
  // Each cycle's cuts (a feature index: the group) at their mean time.
  std::map<int, std::pair<double, int>> group_time;
  for (const CutRecord& c : log.cuts) {
    auto& g = group_time[c.feature.index];
    g.first += c.t_s;
    ++g.second;
  }
  const int cycles = static_cast<int>(base.figures.size());
  std::vector<std::array<double, kFigureCount>> var(cycles);
  for (auto& v : var) v.fill(0.0);
  const double d_half = log.sphere_distance_mm;
  for (const auto& entry : group_time) {
    // (Not a structured binding: the lambda below captures the group.)
    const int group = entry.first;
    const double t_s = entry.second.first / entry.second.second;
    for (int e = 0; e < 7; ++e) {
      // The diagnosis's budget of the estimator at the group's time.
      const double sigma = estimator.ErrorSigmaAt(e, t_s);
      if (!(sigma > 0)) continue;
      std::array<double, 7> micro{};
      micro[e] = sigma;
      const CAxisErrors delta = CAxisErrors::FromMicro(micro);
      SimulationOptions perturbed = options;
      perturbed.extra_shift_mm = [&](const SimulatedCut& cut,
                                     const CutGeometry& g, int i) {
        double extra =
            options.extra_shift_mm ? options.extra_shift_mm(cut, g, i) : 0.0;
        if (cut.feature.index == group) {
          // Machine error + delta: the shift changes by -n . dP_delta(p).
          extra += SurfaceShiftMm(delta, CAxisErrors{}, g.p_m_mm[i],
                                  g.q_m_mm[i], g.n_m, d_half);
        }
        return extra;
      };
      const Simulation sim = SimulatePiece(log, config, estimator, perturbed);
      for (int k = 0; k < cycles; ++k) {
        const auto a = Values(base.figures[k]);
        const auto b = Values(sim.figures[k]);
        for (int f = 0; f < kFigureCount; ++f) {
          var[k][f] += (b[f] - a[f]) * (b[f] - a[f]);
        }
      }
    }
  }
  std::vector<CycleFigures> out(cycles);
  for (int k = 0; k < cycles; ++k) {
    out[k].cycle = base.figures[k].cycle;
    out[k].u_x_mm = std::sqrt(var[k][0]) * 1e-3;
    out[k].u_y_mm = std::sqrt(var[k][1]) * 1e-3;
    out[k].u_z_mm = std::sqrt(var[k][2]) * 1e-3;
    out[k].u_b_rad = std::sqrt(var[k][3]) * 1e-6;
    out[k].u_ttp_mm = std::sqrt(var[k][4]) * 1e-3;
  }
  return out;
}

CheckResult CheckPiece(const TalcLog& log, const Config& config,
                       const std::vector<CycleFigures>& measured,
                       const CheckOptions& options) {
  const MachineErrorEstimator est = MachineErrorEstimator::Fit(
      log, EstimatorOptionsFor(config.machine, options.simulation.estimator));
  const Simulation sim = SimulatePiece(log, config, est, options.simulation);
  return CheckPiece(log, config, est, sim, measured, options);
}

CheckResult CheckPiece(const TalcLog& log, const Config& config,
                       const MachineErrorEstimator& est, const Simulation& sim,
                       const std::vector<CycleFigures>& measured,
                       const CheckOptions& options) {
  const PartSpec& part = config.part;
  CheckResult out;
  out.log_source = log.source;
  out.estimator = sim.estimator_description;
  out.warnings = sim.warnings;
  out.simulated_uncertainty = options.simulated_uncertainty;
  out.piece_alpha_per_k = part.alpha_per_k;
  out.piece_radius_mm = part.facet_final_distance_mm;
  out.table_alpha_per_k = options.table_alpha_per_k;
  out.table_radius_mm = log.sphere_distance_mm;
  std::vector<CycleFigures> u_sim(sim.figures.size());
  if (options.simulated_uncertainty) {
    u_sim = SimulatedFigureUncertainty(log, config, est, options.simulation);
  }

  // Cut times per feature index (a cycle's features share it).
  std::map<int, std::vector<double>> cut_times;
  for (const CutRecord& c : log.cuts) {
    cut_times[c.feature.index].push_back(c.t_s);
  }
  auto span = [&](int index, double* t0, double* t1, double* mean) {
    auto it = cut_times.find(index);
    if (it == cut_times.end()) return false;
    const auto& v = it->second;
    *t0 = *std::min_element(v.begin(), v.end());
    *t1 = *std::max_element(v.begin(), v.end());
    double s = 0;
    for (double t : v) s += t;
    *mean = s / v.size();
    return true;
  };
  double ref0 = 0, ref1 = 0, ref_mean = kNaN;
  const bool have_ref = span(part.reference_index, &ref0, &ref1, &ref_mean);
  const double w = options.temperature_window_s;
  const double ws_ref =
      have_ref ? MeanColumn(log, kTWs, ref0 - w, ref1 + w) : kNaN;
  const double env_ref =
      have_ref ? MeanColumn(log, kTEnv, ref0 - w, ref1 + w) : kNaN;
  const double er_ref = have_ref ? est.MachineErrorsAt(ref_mean).er0t_mm : kNaN;
  const double piece_scale =
      1.0 / (part.alpha_per_k * part.facet_final_distance_mm);  // K per mm

  for (size_t i = 0; i < sim.figures.size(); ++i) {
    const CycleFigures& s = sim.figures[i];
    CycleCheck cc;
    cc.cycle = s.cycle;
    const CycleFigures* m = nullptr;
    for (const CycleFigures& f : measured) {
      if (f.cycle == s.cycle) m = &f;
    }
    const auto sv = Values(s);
    const auto su = Sigmas(u_sim[i]);
    std::array<double, kFigureCount> mv, mu;
    mv.fill(kNaN);
    mu.fill(kNaN);
    if (m) {
      mv = Values(*m);
      mu = Sigmas(*m);
    }
    for (int f = 0; f < kFigureCount; ++f) {
      FigureCheck& fc = cc.figures[f];
      fc.measured = mv[f];
      fc.u_measured = 2 * mu[f];
      fc.simulated = sv[f];
      fc.u_simulated = 2 * su[f];
      fc.available = std::isfinite(mv[f]) && std::isfinite(sv[f]);
      fc.difference = mv[f] - sv[f];
      const double um = std::isfinite(mu[f]) ? mu[f] : 0.0;
      fc.u_combined = 2 * std::sqrt(um * um + su[f] * su[f]);
    }
    // Temperature comparison (thesis 7.10), against the reference cycle.
    TemperatureCheck& tc = cc.temperature;
    tc.piece_measured_k = mv[4] * 1e-3 * piece_scale;
    tc.u_piece_measured_k = 2 * mu[4] * 1e-3 * piece_scale;
    tc.piece_simulated_k = sv[4] * 1e-3 * piece_scale;
    double t0 = 0, t1 = 0, mean = kNaN;
    if (span(IndexForCycle(part, s.cycle), &t0, &t1, &mean) && have_ref) {
      cc.t_s = mean;
      tc.table_rtest_k =
          TemperatureChangeK(est.MachineErrorsAt(mean).er0t_mm - er_ref,
                             options.table_alpha_per_k, log.sphere_distance_mm);
      tc.ws_log_k = MeanColumn(log, kTWs, t0 - w, t1 + w) - ws_ref;
      tc.env_log_k = MeanColumn(log, kTEnv, t0 - w, t1 + w) - env_ref;
    } else {
      cc.t_s = kNaN;
      tc.table_rtest_k = tc.ws_log_k = tc.env_log_k = kNaN;
    }
    out.cycles.push_back(cc);
  }
  for (const CycleFigures& m : measured) {
    const CycleFigures* s = nullptr;
    for (const CycleFigures& f : sim.figures)
      if (f.cycle == m.cycle) s = &f;
    const auto mv = Values(m);
    for (int f = 0; f < kFigureCount; ++f)
      if (std::isfinite(mv[f]) && (!s || !std::isfinite(Values(*s)[f])))
        ++out.not_simulated;
  }
  JudgeRun(options.run_false_alarm, &out);
  return out;
}

void JudgeRun(double run_false_alarm, CheckResult* r) {
  r->compared = r->disagreements = r->beyond_run_limit = 0;
  for (const CycleCheck& cc : r->cycles)
    for (const FigureCheck& fc : cc.figures)
      if (fc.available) ++r->compared;
  // Bonferroni over the figures compared, never below k = 2.
  r->run_false_alarm = run_false_alarm;
  r->run_limit_k = std::max(
      2.0,
      NormalUpperQuantile(run_false_alarm / (2.0 * std::max(r->compared, 1))));
  for (CycleCheck& cc : r->cycles)
    for (FigureCheck& fc : cc.figures) {
      const double d = std::abs(fc.difference);
      fc.agree = !fc.available || d <= fc.u_combined;
      fc.beyond_run_limit =
          fc.available && d > 0.5 * r->run_limit_k * fc.u_combined;
      if (!fc.agree) ++r->disagreements;
      if (fc.beyond_run_limit) ++r->beyond_run_limit;
    }
}

nlohmann::json CheckToJson(const CheckResult& r) {
  nlohmann::json j;
  j["log"] = r.log_source;
  j["estimator"] = r.estimator;
  j["simulated_uncertainty"] = r.simulated_uncertainty
                                   ? "the estimator's error at each cycle's "
                                     "cut time (ErrorSigmaAt), k = 2"
                                   : "none";
  j["compared"] = r.compared;
  j["not_simulated"] = r.not_simulated;
  j["disagreements"] = r.disagreements;
  j["run_limit_k"] = r.run_limit_k;
  j["beyond_run_limit"] = r.beyond_run_limit;
  j["agree"] = r.agree();
  j["units"] = {{"E_X", "um"},   {"E_Y", "um"},   {"E_Z", "um"},
                {"E_B", "um/m"}, {"E_TTP", "um"}, {"dT", "K"}};
  j["temperature_model"] = {{"equation", "dT = E / (alpha R) (thesis 7.10)"},
                            {"piece_alpha_per_k", r.piece_alpha_per_k},
                            {"piece_radius_mm", r.piece_radius_mm},
                            {"table_alpha_per_k", r.table_alpha_per_k},
                            {"table_radius_mm", r.table_radius_mm}};
  nlohmann::json cycles = nlohmann::json::array();
  for (const CycleCheck& c : r.cycles) {
    nlohmann::json cj;
    cj["cycle"] = c.cycle;
    cj["t_s"] = NumberOrNull(c.t_s);
    for (int f = 0; f < kFigureCount; ++f) {
      const FigureCheck& fc = c.figures[f];
      cj[kFigureNames[f]] = {{"measured", NumberOrNull(fc.measured)},
                             {"U_measured", NumberOrNull(fc.u_measured)},
                             {"simulated", NumberOrNull(fc.simulated)},
                             {"U_simulated", NumberOrNull(fc.u_simulated)},
                             {"difference", NumberOrNull(fc.difference)},
                             {"U_combined", NumberOrNull(fc.u_combined)},
                             {"agree", fc.available ? nlohmann::json(fc.agree)
                                                    : nlohmann::json(nullptr)},
                             {"beyond_run_limit",
                              fc.available ? nlohmann::json(fc.beyond_run_limit)
                                           : nlohmann::json(nullptr)}};
    }
    const TemperatureCheck& t = c.temperature;
    cj["temperature"] = {
        {"piece_measured_K", NumberOrNull(t.piece_measured_k)},
        {"U_piece_measured_K", NumberOrNull(t.u_piece_measured_k)},
        {"piece_simulated_K", NumberOrNull(t.piece_simulated_k)},
        {"table_rtest_K", NumberOrNull(t.table_rtest_k)},
        {"T_ws_log_K", NumberOrNull(t.ws_log_k)},
        {"T_env_log_K", NumberOrNull(t.env_log_k)}};
    cycles.push_back(cj);
  }
  j["cycles"] = cycles;
  j["warnings"] = r.warnings;
  return j;
}

std::string CheckTable(const CheckResult& r) {
  std::string s =
      fmt::format("log        {}\nestimator  {}\n", r.log_source, r.estimator);
  for (const std::string& w : r.warnings) s += "warning: " + w + "\n";
  s += fmt::format(
      "measured vs simulated per cycle (um, E_B in um/m); U expanded (k = 2); "
      "ok = |diff| <= U combined; DISAGREE = |diff| > {:.2f} / 2 x U "
      "combined\n",
      r.run_limit_k);
  s += fmt::format("{:>5} {:>6} {:>15} {:>15} {:>8} {:>7}  {}\n", "cycle",
                   "figure", "measured +- U", "simulated +- U", "diff",
                   "U comb", "");
  auto num = [](double v, int width) {
    return fmt::format("{:>{}}", FormatNumber(v, 2), width);
  };
  for (const CycleCheck& c : r.cycles) {
    for (int f = 0; f < kFigureCount; ++f) {
      const FigureCheck& fc = c.figures[f];
      const std::string verdict = !fc.available         ? "missing"
                                  : fc.beyond_run_limit ? "DISAGREE"
                                  : fc.agree            ? "ok"
                                                        : "outside U";
      s += fmt::format("{:>5} {:>6} {} +-{} {} +-{} {} {}  {}\n",
                       f == 0 ? std::to_string(c.cycle) : "", kFigureNames[f],
                       num(fc.measured, 7), num(fc.u_measured, 5),
                       num(fc.simulated, 7), num(fc.u_simulated, 5),
                       num(fc.difference, 8), num(fc.u_combined, 7), verdict);
    }
  }
  s += fmt::format(
      "\ntemperature change vs the reference cycle (K), thesis 7.10: dT = E / "
      "(alpha R)\n  piece: E_TTP, alpha {:.1f} um/(m K), R {:.1f} mm; table: "
      "E_R0T (R-tests), alpha {:.1f} um/(m K), R {:.1f} mm; T_ws, T_env: the "
      "log around the cuts\n",
      r.piece_alpha_per_k * 1e6, r.piece_radius_mm, r.table_alpha_per_k * 1e6,
      r.table_radius_mm);
  s += fmt::format("{:>5} {:>8} {:>17} {:>15} {:>13} {:>8} {:>8}\n", "cycle",
                   "t_s", "piece meas +- U", "piece simulated", "table R-test",
                   "T_ws", "T_env");
  for (const CycleCheck& c : r.cycles) {
    const TemperatureCheck& t = c.temperature;
    s += fmt::format("{:>5} {} {} +-{} {} {} {} {}\n", c.cycle, num(c.t_s, 8),
                     num(t.piece_measured_k, 10), num(t.u_piece_measured_k, 4),
                     num(t.piece_simulated_k, 15), num(t.table_rtest_k, 13),
                     num(t.ws_log_k, 8), num(t.env_log_k, 8));
  }
  s += fmt::format(
      "\n{} of {} figures agree within U; {} beyond the run's limit ({:.2f} "
      "standard uncertainties: a chance of {:g} % that a piece following "
      "the simulation has one){}\n",
      r.compared - r.disagreements, r.compared, r.beyond_run_limit,
      r.run_limit_k, 100 * r.run_false_alarm,
      r.agree() ? ": measured and simulated agree"
                : ": measured and simulated DISAGREE");
  if (r.not_simulated > 0)
    s += fmt::format(
        "{} measured figures have no simulated value: the log does not "
        "cover the cuts of their features, so the run is not compared in "
        "full\n",
        r.not_simulated);
  return s;
}

// ---- Log <-> program consistency ----------------------------------------

ScheduleCheck CheckLogAgainstSchedule(const TalcLog& log,
                                      const std::vector<PlannedCut>& planned,
                                      const ScheduleCheckOptions& options) {
  ScheduleCheck out;
  if (planned.empty()) {
    throw InputError("schedule", 0, "cut", "the program plans no cuts");
  }
  if (log.cuts.empty()) {
    throw InputError(log.source, 0, "cut", "the log has no cut rows");
  }
  std::map<FeatureId, int> order;
  for (int i = 0; i < static_cast<int>(planned.size()); ++i) {
    order[planned[i].feature] = i;
  }
  // Names first, then the offset between program and log time (median of
  // the differences, robust to a single misplaced cut).
  std::vector<double> offsets;
  for (const CutRecord& c : log.cuts) {
    auto it = order.find(c.feature);
    if (it == order.end()) {
      throw InputError(log.source, c.line, "feature",
                       fmt::format("cut '{}' is not a feature of the program's "
                                   "test cycle",
                                   c.feature.ToString()));
    }
    offsets.push_back(c.t_s - planned[it->second].end_s);
  }
  std::vector<double> sorted = offsets;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2,
                   sorted.end());
  out.offset_s = sorted[sorted.size() / 2];

  int previous = -1;
  const CutRecord* previous_cut = nullptr;
  for (const CutRecord& c : log.cuts) {
    const int i = order.at(c.feature);
    const PlannedCut& p = planned[i];
    if (i < previous) {
      throw InputError(
          log.source, c.line, "feature",
          fmt::format("cut {} out of the program's order: the program cuts "
                      "it before {} (line {})",
                      c.feature.ToString(), previous_cut->feature.ToString(),
                      previous_cut->line));
    }
    previous = i;
    previous_cut = &c;
    const double deviation = c.t_s - (p.end_s + out.offset_s);
    if (std::abs(deviation) > options.tolerance_s) {
      throw InputError(
          log.source, c.line, "t_s",
          fmt::format("cut {} ends at t_s {:.0f}, the schedule puts it at "
                      "{:.0f} (program {:.0f} s + offset {:.0f} s): {:+.0f} s, "
                      "more than the tolerance of {:.0f} s",
                      c.feature.ToString(), c.t_s, p.end_s + out.offset_s,
                      p.end_s, out.offset_s, deviation, options.tolerance_s));
    }
    out.max_deviation_s = std::max(out.max_deviation_s, std::abs(deviation));
    const double c_deg = c.c_rad * 180.0 / 3.14159265358979323846;
    // A table angle is an angle: a controller may log -60 deg where the
    // program commands 300 deg (another display range, roll-over).
    if (std::abs(std::remainder(c_deg - p.c_deg, 360.0)) >
        options.angle_tolerance_deg) {
      throw InputError(log.source, c.line, "c_deg",
                       fmt::format("cut {} at table angle {:.3f} deg, the "
                                   "program cuts it at {:.3f} deg",
                                   c.feature.ToString(), c_deg, p.c_deg));
    }
    ++out.matched;
  }

  // Coverage: the log must span the whole program.
  const double first_planned = planned.front().start_s + out.offset_s;
  const double last_planned = planned.back().end_s + out.offset_s;
  if (log.FirstTimeS() > first_planned) {
    throw InputError(
        log.source, log.rows.empty() ? 0 : log.rows.front().line, "t_s",
        fmt::format("the log starts at t_s {:.0f}, after the program's first "
                    "cut ({} starts at {:.0f})",
                    log.FirstTimeS(), planned.front().feature.ToString(),
                    first_planned));
  }
  if (log.LastTimeS() < last_planned) {
    throw InputError(
        log.source, log.rows.empty() ? 0 : log.rows.back().line, "t_s",
        fmt::format("the log ends at t_s {:.0f}, before the program's last "
                    "cut ({} ends at {:.0f})",
                    log.LastTimeS(), planned.back().feature.ToString(),
                    last_planned));
  }
  std::set<FeatureId> logged;
  for (const CutRecord& c : log.cuts) logged.insert(c.feature);
  for (const PlannedCut& p : planned) {
    if (!logged.count(p.feature)) {
      // Name the first logged cut after the planned time.
      int line = log.rows.back().line;
      for (const CutRecord& c : log.cuts) {
        if (c.t_s > p.end_s + out.offset_s) {
          line = c.line;
          break;
        }
      }
      throw InputError(
          log.source, line, "feature",
          fmt::format("the program cuts {} at t_s {:.0f} but the log, which "
                      "covers that time, has no cut row for it",
                      p.feature.ToString(), p.end_s + out.offset_s));
    }
  }
  // Every cut needs an R-test before it: the R-test values are changes
  // since the run's first one, so nothing anchors a machine error before
  // it. After the last R-test the estimator extrapolates (SimulatePiece).
  for (const CutRecord& c : log.cuts) {
    const bool before =
        std::any_of(log.rtests.begin(), log.rtests.end(),
                    [&c](const RTestRecord& r) { return r.t_ref_s <= c.t_s; });
    if (!before) {
      throw InputError(
          log.source, c.line, "rtest",
          fmt::format("cut {} at t_s {:.0f} has no R-test before it: the "
                      "machine error at the cut has no reference",
                      c.feature.ToString(), c.t_s));
    }
  }
  return out;
}

}  // namespace ttp::thermal
