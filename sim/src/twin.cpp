#include "ttp/sim/twin.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>

#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/json_text.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/geometry/rigid_table.h"
#include "ttp/inspect/inspect.h"
#include "ttp/sim/synth.h"
#include "ttp/thermal/simulate.h"

namespace ttp::sim {
namespace {

constexpr double kStepS = 10.0;
constexpr double kRTestDurS = 95.0;
// Thesis table 5.4, expanded uncertainty (k = 2): um and um/m.
constexpr std::array<double, 7> kRTestU95 = {0.4, 0.5, 0.4, 0.6, 2.3, 2.5, 2.6};

// First-order lag of a series sampled every step_s, exact for an input
// held constant over each step (zero-order hold), starting at `initial`.
std::vector<double> Lag(const std::vector<double>& input, double step_s,
                        double tau_s, double initial) {
  std::vector<double> out(input.size());
  const double a = std::exp(-step_s / tau_s);
  double x = initial;
  for (size_t i = 0; i < input.size(); ++i) {
    out[i] = x;
    x = a * x + (1 - a) * input[i];
  }
  return out;
}

struct ErrorDynamics {
  double load_gain = 0, tau1_s = 1, tau2_s = 1;  // second-order load lag
  double env_gain = 0, tau_env_s = 1;            // per K of T_env drift
};

// Seven errors (um, um/m) from the load P (0..1) and the environment.
std::vector<std::array<double, 7>> ErrorHistory(
    const std::array<ErrorDynamics, 7>& dyn, const std::vector<double>& load,
    const std::vector<double>& env_delta) {
  std::vector<std::array<double, 7>> out(load.size());
  for (int e = 0; e < 7; ++e) {
    const auto l1 = Lag(load, kStepS, dyn[e].tau1_s, 0.0);
    const auto l2 = Lag(l1, kStepS, dyn[e].tau2_s, 0.0);
    const auto le = Lag(env_delta, kStepS, dyn[e].tau_env_s, 0.0);
    for (size_t i = 0; i < load.size(); ++i)
      out[i][e] = dyn[e].load_gain * l2[i] + dyn[e].env_gain * le[i];
  }
  return out;
}

std::string Num(double v) { return fmt::format("{:.4f}", v); }

}  // namespace

FitNoise CloudFitNoise(const PartSpec& part, double point_noise_um,
                       int cloud_points) {
  // The synthetic CMM (sim/synth.h) puts 45 % of the points on the 36
  // facets and 25 % on the 9 strips; the inspection keeps those inside the
  // edge margins: about 1/100 of the cloud per facet, 1/40 per strip. A
  // plane through N points spread uniformly over a width w: distance at
  // the points' centroid sigma / sqrt(N), angle sigma / sqrt(N) / (w /
  // sqrt(12)). A facet's distance is the plane's at W's origin, on the top
  // face: its points lie from 1 mm above its foot to 1 mm below the top,
  // and the plane's tilt about the horizontal, as scattered as its angle
  // over that height, carries the centroid's error up to the origin.
  FitNoise n;
  n.facet_points = std::max(10, cloud_points / 100);
  n.strip_points = std::max(10, cloud_points / 40);
  const double s = point_noise_um * 1e-3;
  const double facet_width_mm =
      2 * part.facet_final_distance_mm *
          std::tan(part.facet_step_deg / 2 * M_PI / 180) -
      2.0;
  const double strip_length_mm = 0.9 * part.blank_diameter_mm;
  const double at_centroid_mm = s / std::sqrt(n.facet_points);
  n.facet_angle_rad =
      at_centroid_mm / (std::max(2.0, facet_width_mm) / std::sqrt(12.0));
  const double facet_height_mm = -part.facet_bottom_z_mm - 2.0;
  const double tilt_rad =
      at_centroid_mm / (std::max(2.0, facet_height_mm) / std::sqrt(12.0));
  const double centroid_depth_mm = -part.facet_bottom_z_mm / 2;
  n.facet_d_mm = std::hypot(at_centroid_mm, tilt_rad * centroid_depth_mm);
  n.strip_d_mm = s / std::sqrt(n.strip_points);
  n.strip_angle_rad = n.strip_d_mm / (strip_length_mm / std::sqrt(12.0));
  return n;
}

bool TwinOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (!(rtest_interval_s >= 150 && rtest_interval_s <= 7200))
    return fail("rtest_interval_s: must be 150..7200 s");
  if (!(point_noise_um >= 0)) return fail("point_noise_um: must be >= 0");
  if (cloud_points < 1000) return fail("cloud_points: must be >= 1000");
  if (!(stray_fraction >= 0 && stray_fraction < 0.5))
    return fail("stray_fraction: must be in [0, 0.5)");
  if (!(workpiece_gain >= 0)) return fail("workpiece_gain: must be >= 0");
  if (!(workpiece_tau_s >= 0)) return fail("workpiece_tau_s: must be >= 0");
  if (!(tool_wear_um_per_m >= 0))
    return fail("tool_wear_um_per_m: must be >= 0");
  if (!(clamping_amplitude_um >= 0))
    return fail("clamping_amplitude_um: must be >= 0");
  if (!(c_indexing_amplitude_urad >= 0))
    return fail("c_indexing_amplitude_urad: must be >= 0");
  if (!(two_lobe_amplitude_um >= 0))
    return fail("two_lobe_amplitude_um: must be >= 0");
  if (step_from_cycle < 0) return fail("step_from_cycle: must be >= 0");
  return true;
}

std::string TwinOptions::ExpectedOutcome() const {
  if (step_um != 0 || two_lobe_amplitude_um > 0) return "unexplained";
  std::vector<std::string> names;
  if (c_indexing_amplitude_urad > 0) names.push_back("c_axis_indexing");
  if (clamping_amplitude_um > 0) names.push_back("clamping_distortion");
  if (tool_wear_um_per_m > 0) names.push_back("tool_wear");
  if (workpiece_gain > 0) names.push_back("workpiece_expansion");
  if (names.empty()) return "none";
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : "+") + n;
  return s;
}

const EffectRange* FindEffect(const std::string& name) {
  static constexpr EffectRange kEffects[] = {
      {"workpiece_expansion", 10.0, "gain"},
      {"tool_wear", 1000.0, "um/m"},
      {"clamping_distortion", 100.0, "um"},
      {"c_axis_indexing", 1e4, "urad"}};
  for (const EffectRange& e : kEffects)
    if (name == e.name) return &e;
  return nullptr;
}

void SetEffect(TwinOptions* o, const std::string& name, double size) {
  if (name == "none") return;
  const EffectRange* effect = FindEffect(name);
  if (effect == nullptr)
    throw std::invalid_argument(
        "unknown effect '" + name +
        "' (none, workpiece_expansion, tool_wear, clamping_distortion, "
        "c_axis_indexing)");
  if (!(size >= 0 && size <= effect->max_size))
    throw std::invalid_argument(
        fmt::format("size {:g} of {} is outside "
                    "0..{:g} ({})",
                    size, name, effect->max_size, effect->unit));
  if (name == "workpiece_expansion")
    o->workpiece_gain = size;
  else if (name == "tool_wear")
    o->tool_wear_um_per_m = size;
  else if (name == "clamping_distortion")
    o->clamping_amplitude_um = size;
  else
    o->c_indexing_amplitude_urad = size;
}

TwinRun RunTwin(const Config& config, const TwinOptions& options) {
  std::string invalid;
  if (!options.IsValid(&invalid))
    throw std::invalid_argument("TwinOptions." + invalid);
  const PartSpec& part = config.part;
  std::mt19937_64 rng(options.seed);
  auto uniform = [&](double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(rng);
  };
  auto sign = [&] { return uniform(0, 1) < 0.5 ? -1.0 : 1.0; };
  std::normal_distribution<double> gauss(0.0, 1.0);

  // --- schedule (test-piece.md section 3; the first cut and the cuts'
  // offsets as in the sample runs, the cycle period and the warm-up from the
  // configuration, as in the programs) ---
  const int cycles = part.cycles();
  const double first_cut_s = 320, cycle_s = config.process.cycle_period_s;
  struct PlannedCut {
    FeatureId feature;
    double t_s, c_rad;
  };
  std::vector<PlannedCut> cuts;
  std::vector<std::pair<double, double>> cut_windows;
  for (int cycle = 0; cycle <= cycles; ++cycle) {
    const int j = IndexForCycle(part, cycle);
    const double t0 = first_cut_s + cycle * cycle_s;
    // The table angles the programs cut at (the X facets' normals on
    // machine +X, the Y facets' on +Y), in the machine's C sense.
    const int sense = config.machine.c_sense;
    const double c_x = TableAngleFor(
        FacetPhiDeg(part, Segment::kX1, j) * M_PI / 180, 0.0, sense);
    const double c_y = TableAngleFor(
        FacetPhiDeg(part, Segment::kY1, j) * M_PI / 180, M_PI / 2, sense);
    cuts.push_back({FeatureId::Strip(j), t0, 0.0});
    cuts.push_back({FeatureId::Facet(Segment::kX1, j), t0 + 10, c_x});
    cuts.push_back({FeatureId::Facet(Segment::kX2, j), t0 + 17, c_x});
    cuts.push_back({FeatureId::Facet(Segment::kY1, j), t0 + 27, c_y});
    cuts.push_back({FeatureId::Facet(Segment::kY2, j), t0 + 34, c_y});
    cut_windows.push_back({t0 - 30, t0 + 45});
  }
  const double warmup_from_s = cut_windows[0].second;
  const double warmup_to_s = cut_windows[config.process.warmup_cycles].first;
  const double t_final_s = cuts.back().t_s + 280;

  std::vector<double> rtest_end;
  auto overlaps_cut = [&](double a, double b) {
    for (const auto& w : cut_windows)
      if (a < w.second && b > w.first) return true;
    return false;
  };
  rtest_end.push_back(kRTestDurS);
  for (double t = 245; t <= t_final_s; t += options.rtest_interval_s)
    if (!overlaps_cut(t - kRTestDurS, t)) rtest_end.push_back(t);
  if (rtest_end.back() < cuts.back().t_s) rtest_end.push_back(t_final_s - 5);

  // --- load and environment on the time grid ---
  const int steps = static_cast<int>(std::ceil(t_final_s / kStepS)) + 1;
  std::vector<double> t(steps), c_rpm(steps, 0), spindle(steps, 0), load(steps);
  std::vector<double> env(steps), env_delta(steps);
  const double env_period_s = uniform(8, 24) * 3600;
  const double env_phase = uniform(0, 2 * M_PI);
  const double env_amp_k = uniform(0.1, 0.5);
  const double env_drift_k_per_h = uniform(-0.05, 0.05);
  const double env0 = uniform(19, 22);
  double walk = 0;
  for (int i = 0; i < steps; ++i) {
    t[i] = i * kStepS;
    bool measuring = false;
    for (double r : rtest_end)
      if (t[i] > r - kRTestDurS && t[i] <= r) measuring = true;
    bool cutting = false;
    for (const auto& w : cut_windows)
      if (t[i] >= w.first && t[i] <= w.second) cutting = true;
    if (t[i] >= warmup_from_s && t[i] < warmup_to_s && !measuring && !cutting)
      c_rpm[i] = config.machine.c_max_rpm;
    if (cutting) spindle[i] = config.process.finishing.spindle_rpm;
    // Heat input grows with the square of the speed (bearing friction).
    load[i] = std::pow(c_rpm[i] / config.machine.c_max_rpm, 2);
    walk += 0.002 * gauss(rng);
    env[i] = env0 +
             env_amp_k * (std::sin(2 * M_PI * t[i] / env_period_s + env_phase) -
                          std::sin(env_phase)) +
             env_drift_k_per_h * t[i] / 3600 + walk;
    env_delta[i] = env[i] - env0;
  }
  // Before the log: pre-machining at a drawn load, then a hold; the lags
  // enter the log in that state, not at rest.
  const int pre_steps = static_cast<int>(uniform(2400, 5400) / kStepS) +
                        static_cast<int>(uniform(1200, 3600) / kStepS);
  const int pre_load_steps = pre_steps / 2;
  const double pre_load = uniform(0.2, 0.8);
  std::vector<double> load_ext(pre_steps, 0.0), env_ext(pre_steps, 0.0);
  for (int i = 0; i < pre_load_steps; ++i) load_ext[i] = pre_load;
  load_ext.insert(load_ext.end(), load.begin(), load.end());
  env_ext.insert(env_ext.end(), env_delta.begin(), env_delta.end());
  auto drop_pre = [&](std::vector<double> v) {
    v.erase(v.begin(), v.begin() + pre_steps);
    return v;
  };
  const auto ws_lag = drop_pre(Lag(load_ext, kStepS, 2400, 0.0));
  const auto cool_lag = drop_pre(Lag(load_ext, kStepS, 300, 0.0));
  const auto env_ws = Lag(env_delta, kStepS, 1800, 0.0);

  // --- machine: the seven errors' dynamics (um, um/m) ---
  const std::array<std::pair<double, double>, 7> load_range = {
      {{1, 3}, {2, 5}, {8, 14}, {4, 8}, {3, 8}, {0.5, 2}, {3, 8}}};
  std::array<ErrorDynamics, 7> dyn, model;
  for (int e = 0; e < 7; ++e) {
    dyn[e].load_gain = uniform(load_range[e].first, load_range[e].second) *
                       (e == 2   ? -1.0
                        : e == 3 ? 1.0
                                 : sign());
    dyn[e].tau1_s = uniform(600, 2400);
    dyn[e].tau2_s = uniform(1800, 10800);
    dyn[e].env_gain = uniform(0.5, 2.0) * sign();
    dyn[e].tau_env_s = uniform(1800, 7200);
    // The compensation's model: same structure, 10-30 % off.
    model[e] = dyn[e];
    model[e].load_gain *= 1 + uniform(0.1, 0.3) * sign();
    model[e].tau1_s *= 1 + uniform(0.1, 0.3) * sign();
    model[e].tau2_s *= 1 + uniform(0.1, 0.3) * sign();
    model[e].env_gain *= 1 + uniform(0.1, 0.3) * sign();
  }
  auto machine = ErrorHistory(dyn, load_ext, env_ext);
  auto predicted = ErrorHistory(model, load_ext, env_ext);
  machine.erase(machine.begin(), machine.begin() + pre_steps);
  predicted.erase(predicted.begin(), predicted.begin() + pre_steps);
  // Changes relative to the first R-test's reference time.
  const int ref = static_cast<int>((kRTestDurS / 2) / kStepS);
  const auto machine_ref = machine[ref], predicted_ref = predicted[ref];
  for (int i = 0; i < steps; ++i)
    for (int e = 0; e < 7; ++e) {
      machine[i][e] -= machine_ref[e];
      predicted[i][e] -= predicted_ref[e];
      if (!options.compensation) predicted[i][e] = 0;
    }
  auto at = [&](const std::vector<std::array<double, 7>>& h, double ts) {
    const double x = std::clamp(ts / kStepS, 0.0, steps - 1.0);
    const int i = std::min(static_cast<int>(x), steps - 2);
    const double f = x - i;
    std::array<double, 7> v;
    for (int e = 0; e < 7; ++e) v[e] = h[i][e] * (1 - f) + h[i + 1][e] * f;
    return v;
  };

  // --- the hidden effects, from their physics, per material point ---
  TwinRun run;
  nlohmann::json params = nlohmann::json::object();
  // Table temperature change from the machine's radial growth (E_R0T at
  // the R-test sphere radius over the cast-iron table's expansion).
  const double table_alpha_per_k = 11e-6;
  std::vector<double> table_dT(steps), piece_dT(steps);
  for (int i = 0; i < steps; ++i)
    table_dT[i] = machine[i][3] * 1e-3 /
                  (table_alpha_per_k * config.machine.sphere_distance_mm);
  // Piece + adapter as one lumped thermal mass: C dT/dt = hA (g T_table -
  // T), time constant C / hA, integrated with 1 s Euler steps.
  const double wp_tau_s = options.workpiece_tau_s > 0 ? options.workpiece_tau_s
                                                      : uniform(1200, 5400);
  if (options.workpiece_gain > 0) {
    double temp = options.workpiece_gain * table_dT[0];
    piece_dT[0] = temp;
    for (int i = 1; i < steps; ++i) {
      for (int sub = 0; sub < static_cast<int>(kStepS); ++sub) {
        const double f = (sub + 0.5) / kStepS;
        const double source = options.workpiece_gain *
                              (table_dT[i - 1] * (1 - f) + table_dT[i] * f);
        temp += (source - temp) / wp_tau_s;
      }
      piece_dT[i] = temp;
    }
    params["workpiece_gain"] = options.workpiece_gain;
    params["workpiece_tau_s"] = wp_tau_s;
  }
  auto at_scalar = [&](const std::vector<double>& v, double ts) {
    const double x = std::clamp(ts / kStepS, 0.0, steps - 1.0);
    const int i = std::min(static_cast<int>(x), steps - 2);
    const double f = x - i;
    return v[i] * (1 - f) + v[i + 1] * f;
  };
  // Three clamping bolts, the first at a drawn angle; the deformation is
  // largest at the bottom of the piece (bolts) and falls off upwards.
  const double bolt_rad = uniform(0, 2 * M_PI / 3);
  const double clamp_falloff = uniform(0.2, 0.5);  // over the piece height
  if (options.clamping_amplitude_um > 0) {
    params["clamping_amplitude_um"] = options.clamping_amplitude_um;
    params["clamping_bolt_deg"] = bolt_rad * 180 / M_PI;
  }
  const double lobe2_rad = uniform(0, M_PI);
  if (options.two_lobe_amplitude_um > 0)
    params["two_lobe_amplitude_um"] = options.two_lobe_amplitude_um;
  // C stop error: encoder eccentricity (once per turn), worm wheel
  // runout (twice), bearing (four times), amplitudes shared at random.
  const int kHarmonic[3] = {1, 2, 4};
  double c_amp[3], c_phase[3];
  {
    const double w[3] = {uniform(0.5, 1.0), uniform(0.0, 0.7),
                         uniform(0.0, 0.5)};
    const double sum = w[0] + w[1] + w[2];
    for (int k = 0; k < 3; ++k) {
      c_amp[k] = options.c_indexing_amplitude_urad * w[k] / sum;
      c_phase[k] = uniform(0, 2 * M_PI);
    }
  }
  if (options.c_indexing_amplitude_urad > 0) {
    params["c_indexing_amplitude_urad"] = options.c_indexing_amplitude_urad;
    params["c_harmonics"] = {{"1", c_amp[0]}, {"2", c_amp[1]}, {"4", c_amp[2]}};
  }
  const int step_cycle = options.step_from_cycle > 0
                             ? options.step_from_cycle
                             : static_cast<int>(uniform(3, 8));
  if (options.step_um != 0) {
    params["step_um"] = options.step_um;
    params["step_from_cycle"] = step_cycle;
  }
  if (options.tool_wear_um_per_m > 0)
    params["tool_wear_um_per_m"] = options.tool_wear_um_per_m;
  const double table_z_w =
      -(part.adapter_height_mm + part.height_mm());  // table surface in W
  double cut_length_m = 0;  // of the finishing cutter, before this cut
  // --- the piece cut under the machine errors and the effects ---
  const FitNoise noise =
      CloudFitNoise(part, options.point_noise_um, options.cloud_points);
  for (const auto& c : cuts) {
    CAxisErrors e_machine = CAxisErrors::FromMicro(at(machine, c.t_s));
    const CAxisErrors e_pred = CAxisErrors::FromMicro(at(predicted, c.t_s));
    // The table stops off the commanded angle: a C positioning error.
    double dc_urad = 0;
    for (int k = 0; k < 3; ++k)
      dc_urad += c_amp[k] * std::cos(kHarmonic[k] * c.c_rad + c_phase[k]);
    e_machine.ec0c_rad += dc_urad * 1e-6;
    const thermal::CutGeometry g =
        thermal::ComputeCutGeometry(config, c.feature, c.c_rad);
    const bool facet = g.feature.kind == FeatureKind::kFacet;
    const int cycle = CycleForIndex(part, c.feature.index);
    const double dT_piece = at_scalar(piece_dT, c.t_s);
    const double dT_table = at_scalar(table_dT, c.t_s);
    double u_min = std::numeric_limits<double>::infinity(), u_max = -u_min;
    for (const auto& uv : g.uv_mm) {
      u_min = std::min(u_min, uv.x());
      u_max = std::max(u_max, uv.x());
    }
    const double overrun_mm = 1.0;
    std::vector<double> extra(g.p_w_mm.size(), 0.0);
    for (size_t i = 0; i < g.p_w_mm.size(); ++i) {
      const Eigen::Vector3d& p = g.p_w_mm[i];
      const Eigen::Vector3d& n = g.n_w;
      const double height = p.z() - table_z_w;
      const double phi = std::atan2(p.y(), p.x());
      const Eigen::Vector3d radial(p.x(), p.y(), 0.0);
      double s = 0;
      // A material point displaced by delta while cut returns by delta
      // when the cause goes away: the surface ends at -delta . n.
      if (options.workpiece_gain > 0) {
        // The rigid-table model lets the piece ride the table's radial
        // growth; the piece grows with its own temperature instead.
        const Eigen::Vector3d delta =
            radial *
                (part.alpha_per_k * dT_piece - table_alpha_per_k * dT_table) +
            Eigen::Vector3d::UnitZ() * height * part.alpha_per_k * dT_piece;
        s -= delta.dot(n);
      }
      if (options.clamping_amplitude_um > 0) {
        const double falloff = 1 - clamp_falloff *
                                       (height - part.adapter_height_mm) /
                                       part.height_mm();
        const double u_mm = 1e-3 * options.clamping_amplitude_um * falloff *
                            std::cos(3 * (phi - bolt_rad));
        s -= u_mm * radial.normalized().dot(n);
      }
      if (options.two_lobe_amplitude_um > 0) {
        const double u_mm = 1e-3 * options.two_lobe_amplitude_um *
                            std::cos(2 * (phi - lobe2_rad));
        s -= u_mm * radial.normalized().dot(n);
      }
      if (facet && options.tool_wear_um_per_m > 0) {
        // The flank has lost radius in proportion to the path cut so far:
        // a thinner cutter leaves the surface further out.
        const double along_m =
            cut_length_m + (overrun_mm + g.uv_mm[i].x() - u_min) * 1e-3;
        s += 1e-3 * options.tool_wear_um_per_m * along_m;
      }
      if (facet && options.step_um != 0 && cycle >= step_cycle)
        s += 1e-3 * options.step_um;
      extra[i] = s;
    }
    cut_length_m += (u_max - u_min + 2 * overrun_mm) * 1e-3;
    FeatureResult r = thermal::CutFeatureResult(
        part, g, e_machine, e_pred, config.machine.sphere_distance_mm, extra);
    run.true_results[g.feature.Key()] = r;
    FeatureResult m = r;
    const double sd = facet ? noise.facet_d_mm : noise.strip_d_mm;
    const double sa = facet ? noise.facet_angle_rad : noise.strip_angle_rad;
    m.d_mm += sd * gauss(rng);
    m.angle_rad += sa * gauss(rng);
    m.var_d_mm2 = sd * sd;
    m.var_angle_rad2 = sa * sa;
    m.points = facet ? noise.facet_points : noise.strip_points;
    m.rms_mm = options.point_noise_um * 1e-3;  // the fit's residual RMS
    run.measured[g.feature.Key()] = m;
  }

  // --- the TALC log ---
  const char* const names[7] = {"EX0C", "EY0C", "EZ0T", "ER0T",
                                "EA0C", "EB0C", "EC0C"};
  std::string log = "# talc-log: 1\n# machine: ttp digital twin\n";
  log += "# start: 2026-03-02T06:00:00+01:00\n";
  log += fmt::format("# sphere_distance_mm: {}\n# sphere_height_mm: {}\n",
                     config.machine.sphere_distance_mm,
                     config.machine.sphere_height_mm);
  log +=
      fmt::format("# compensation: {}\n", options.compensation ? "on" : "off");
  log += fmt::format("# twin_seed: {}\n", options.seed);
  log += "t_s,event,T_env,T_ws,dT_cool,c_rpm,spindle_rpm,mwf";
  for (auto* n : names) log += fmt::format(",{}", n);
  if (options.compensation)
    for (auto* n : names) log += fmt::format(",pred_{}", n);
  log += ",feature,c_deg,dur_s\n";
  const int ncols = 8 + 7 + (options.compensation ? 7 : 0) + 3;
  struct Row {
    double t_s;
    int order;
    std::vector<std::string> cells;
  };
  std::vector<Row> rows;
  auto blank = [&] { return std::vector<std::string>(ncols); };
  for (double ts = 0; ts <= t_final_s; ts += 60) {
    const int i = static_cast<int>(ts / kStepS);
    auto cells = blank();
    cells[0] = Num(ts);
    cells[1] = "sample";
    cells[2] = Num(env[i] + 0.01 * gauss(rng));
    cells[3] = Num(env[i] + 0.9 + 0.8 * ws_lag[i] + 0.7 * env_ws[i] -
                   0.7 * env_delta[i] + 0.01 * gauss(rng));
    cells[4] = Num(0.25 * cool_lag[i] + 0.01 * gauss(rng));
    cells[5] = fmt::format("{:.0f}", c_rpm[i]);
    cells[6] = fmt::format("{:.0f}", spindle[i]);
    cells[7] = "0";
    if (options.compensation) {
      const auto p = at(predicted, ts);
      for (int e = 0; e < 7; ++e) cells[15 + e] = Num(p[e]);
    }
    cells[ncols - 2] = "0";
    rows.push_back({ts, 0, cells});
  }
  for (double te : rtest_end) {
    const double t_ref = te - kRTestDurS / 2;
    const auto m = at(machine, t_ref);
    const auto p = at(predicted, t_ref);
    auto cells = blank();
    cells[0] = Num(te);
    cells[1] = "rtest";
    for (int e = 0; e < 7; ++e)
      cells[8 + e] = Num(m[e] - p[e] + kRTestU95[e] / 2 * gauss(rng));
    cells[ncols - 1] = Num(kRTestDurS);
    rows.push_back({te, 1, cells});
  }
  for (const auto& c : cuts) {
    auto cells = blank();
    cells[0] = Num(c.t_s);
    cells[1] = "cut";
    cells[6] = fmt::format("{:.0f}", config.process.finishing.spindle_rpm);
    cells[ncols - 3] = c.feature.ToString();
    cells[ncols - 2] = Num(c.c_rad * 180 / M_PI);
    rows.push_back({c.t_s, 2, cells});
  }
  std::stable_sort(rows.begin(), rows.end(), [](const Row& a, const Row& b) {
    return a.t_s < b.t_s || (a.t_s == b.t_s && a.order < b.order);
  });
  for (const Row& r : rows) {
    for (int k = 0; k < ncols; ++k) log += (k ? "," : "") + r.cells[k];
    log += "\n";
  }
  run.log_text = std::move(log);

  // --- truth, shaped like the samples' truth.json ---
  nlohmann::json truth;
  truth["cause"] = options.ExpectedOutcome();
  truth["params"] = params;
  truth["noise_um"] = options.point_noise_um;
  truth["cloud_points"] = options.cloud_points;
  truth["seed"] = options.seed;
  truth["compensation"] = options.compensation ? "on" : "off";
  nlohmann::json figures = nlohmann::json::array();
  for (const CycleFigures& f : ComputeFigures(part, run.true_results))
    figures.push_back({{"cycle", f.cycle},
                       {"E_X", f.e_x_mm * 1e3},
                       {"E_Y", f.e_y_mm * 1e3},
                       {"E_Z", f.e_z_mm * 1e3},
                       {"E_B", f.e_b_rad * 1e6},
                       {"E_TTP", f.e_ttp_mm * 1e3}});
  truth["figures"] = figures;
  nlohmann::json angles = nlohmann::json::object();
  for (const auto& [id, r] : run.true_results)
    if (id.kind == FeatureKind::kFacet)
      angles[id.ToString()] = r.angle_rad * 1e6;
  truth["facet_angle_err_urad"] = angles;
  // The measurement is per-feature results in W: identity pose.
  truth["pose"] = {{"yaw_deg", 0.0},
                   {"tilt_deg", 0.0},
                   {"t_mm", {0.0, 0.0, 0.0}},
                   {"R", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}},
                   {"convention", "cloud = W @ R.T + t"}};
  nlohmann::json noise_json = {
      {"point_noise_um", options.point_noise_um},
      {"facet_d_um", noise.facet_d_mm * 1e3},
      {"facet_angle_urad", noise.facet_angle_rad * 1e6},
      {"strip_d_um", noise.strip_d_mm * 1e3},
      {"rtest_u95", kRTestU95}};
  truth["noise"] = noise_json;
  run.truth = truth;
  return run;
}

nlohmann::json MeasuredInspectionJson(const PartSpec& part,
                                      const FeatureResults& measured) {
  inspect::InspectionResult result;
  result.source = "ttp twin";
  result.features = measured;
  result.figures = ComputeFigures(part, measured);
  for (const FeatureId& id : IdsInNameOrder(measured)) {
    const FeatureResult& r = measured.at(id);
    inspect::FeatureDiagnostic d;
    d.id = id.ToString();
    d.candidates = d.used = r.points;
    d.status = r.present ? "ok" : "missing";
    result.diagnostics.push_back(d);
    result.points_total += r.points;
  }
  result.points_assigned = result.points_total;
  return inspect::InspectionToJson(result);
}

namespace {
// The finished part's tagged mesh takes a while to build: one per part.
const PartMesh& FinishedMesh(const Config& config) {
  static std::mutex mutex;
  static std::map<std::string, std::unique_ptr<PartMesh>> cache;
  const std::string key = ConfigToJson(config)["part"].dump();
  std::lock_guard<std::mutex> lock(mutex);
  auto& slot = cache[key];
  if (!slot)
    slot = std::make_unique<PartMesh>(
        BuildPartMesh(config.part, Stage::kFinished));
  return *slot;
}
}  // namespace

inspect::PointCloud TwinCloud(const Config& config, const TwinRun& run,
                              const TwinOptions& options) {
  SynthOptions o;
  o.points = options.cloud_points;
  o.noise_um = options.point_noise_um;
  o.stray_fraction = options.stray_fraction;
  o.random_pose = true;
  o.sampling = SynthSampling::kCmm;
  o.seed =
      static_cast<uint32_t>(options.seed ^ (options.seed >> 32)) ^ 0x9e3779b9u;
  SynthPiece piece =
      SynthesizePiece(config.part, FinishedMesh(config), run.true_results, o);
  piece.cloud.source = fmt::format("ttp twin, seed {}", options.seed);
  return std::move(piece.cloud);
}

TwinMeasurement TwinMeasurementFromName(const std::string& name) {
  if (name == "ply" || name == "cloud") return TwinMeasurement::kPly;
  if (name == "xyz") return TwinMeasurement::kXyz;
  if (name == "json") return TwinMeasurement::kJson;
  throw std::invalid_argument("unknown measurement '" + name +
                              "' (cloud, ply, xyz or json)");
}

std::string WriteTwin(const Config& config, const TwinRun& run,
                      const TwinOptions& options, const std::string& dir,
                      TwinMeasurement measurement) {
  std::filesystem::create_directories(dir);
  const std::filesystem::path d(dir);
  WriteFileAtomic(d / "talc.csv", run.log_text);
  nlohmann::json truth = run.truth;
  std::filesystem::path out;
  if (measurement == TwinMeasurement::kJson) {
    out = d / "measured.json";
    WriteFileAtomic(
        out,
        JsonText(MeasuredInspectionJson(config.part, run.measured), 1) + "\n");
    truth["measurement"] = "per-feature results with cloud-fit noise";
  } else {
    const inspect::PointCloud cloud = TwinCloud(config, run, options);
    out =
        d / (measurement == TwinMeasurement::kPly ? "piece.ply" : "piece.xyz");
    inspect::WritePointCloud(out, cloud,
                             measurement == TwinMeasurement::kPly
                                 ? inspect::CloudFormat::kPlyBinary
                                 : inspect::CloudFormat::kXyz);
    truth["measurement"] =
        "CMM cloud of the true cut geometry, random pose (mm)";
    truth.erase("pose");
  }
  WriteFileAtomic(d / "truth.json", JsonText(truth, 1) + "\n");
  return out.lexically_normal().string();
}

const char* InstrumentName(Instrument instrument) {
  switch (instrument) {
    case Instrument::kCloudFit:
      return "cloud";
    case Instrument::kProbe:
      return "probe";
    case Instrument::kDial:
      return "dial";
    case Instrument::kDmis:
      return "dmis";
  }
  return "?";
}

FeatureResults MeasureWith(const PartSpec& part, const FeatureResults& truth,
                           Instrument instrument, double point_noise_um,
                           std::uint64_t seed) {
  std::mt19937_64 rng(seed ^ 0x5bd1e995ULL);
  std::normal_distribution<double> gauss(0.0, 1.0);
  FitNoise cloud = CloudFitNoise(part, point_noise_um, 20000);
  FeatureResults out;
  for (const FeatureId& id : IdsInNameOrder(truth)) {
    const FeatureResult& r = truth.at(id);
    const bool facet = id.kind != FeatureKind::kStrip;
    FeatureResult m = r;
    double sd = 0, sa = 0;
    int points = 0;
    switch (instrument) {
      case Instrument::kCloudFit:
        sd = facet ? cloud.facet_d_mm : cloud.strip_d_mm;
        sa = facet ? cloud.facet_angle_rad : cloud.strip_angle_rad;
        points = facet ? cloud.facet_points : cloud.strip_points;
        break;
      case Instrument::kProbe: {
        // Four touches per facet 3 mm apart in width, repeatability
        // 0.3 um: a plane through them.
        const double rep_mm = 0.3e-3;
        points = 4;
        sd = rep_mm / 2;
        sa = rep_mm / (3.0 * std::sqrt(5.0) / 2);
        break;
      }
      case Instrument::kDial:
        // A dial gauge reads distances (0.5 um) and no angle.
        sd = 0.5e-3;
        points = 0;
        break;
      case Instrument::kDmis:
        // The CMM's own fit, reported with its stated uncertainty.
        sd = 0.25e-3;
        sa = facet ? 20e-6 : 3e-6;
        points = 0;
        break;
    }
    m.d_mm += sd * gauss(rng);
    m.var_d_mm2 = sd * sd;
    if (instrument == Instrument::kDial) {
      m.angle_rad = std::numeric_limits<double>::quiet_NaN();
      m.var_angle_rad2 = std::numeric_limits<double>::quiet_NaN();
    } else {
      m.angle_rad += sa * gauss(rng);
      m.var_angle_rad2 = sa * sa;
    }
    m.points = points;
    m.rms_mm = instrument == Instrument::kCloudFit ? point_noise_um * 1e-3 : 0;
    out[id] = m;
  }
  return out;
}

}  // namespace ttp::sim
