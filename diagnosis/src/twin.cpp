#include "ttp/diagnosis/twin.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <mutex>
#include <random>
#include <stdexcept>

#include "ttp/diagnosis/diagnose.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/geometry/rigid_table.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/synth.h"
#include "ttp/thermal/simulate.h"

namespace ttp::diagnosis {
namespace {

constexpr double kStepS = 10.0;
constexpr double kRTestDurS = 95.0;
// Thesis table 5.4, expanded uncertainty (k = 2): um and um/m.
constexpr std::array<double, 7> kRTestU95 = {0.4, 0.5, 0.4, 0.6, 2.3, 2.5, 2.6};

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
    const auto l1 = LagFilter(load, kStepS, dyn[e].tau1_s);
    const auto l2 = LagFilter(l1, kStepS, dyn[e].tau2_s);
    const auto le = LagFilter(env_delta, kStepS, dyn[e].tau_env_s);
    for (size_t i = 0; i < load.size(); ++i)
      out[i][e] = dyn[e].load_gain * l2[i] + dyn[e].env_gain * le[i];
  }
  return out;
}

std::string Num(double v) { return fmt::format("{:.4f}", v); }

}  // namespace

FitNoise CloudFitNoise(const PartSpec& part, double point_noise_um,
                       int cloud_points) {
  // The synthetic CMM (inspect/synth.h) puts 45 % of the points on the 36
  // facets and 25 % on the 9 strips; the inspection keeps those inside the
  // edge margins: about 1/100 of the cloud per facet, 1/40 per strip.
  FitNoise n;
  n.facet_points = std::max(10, cloud_points / 100);
  n.strip_points = std::max(10, cloud_points / 40);
  const double s = point_noise_um * 1e-3;
  n.facet = FeatureFitScatter(part, FeatureKind::kFacet, s, n.facet_points);
  n.strip = FeatureFitScatter(part, FeatureKind::kStrip, s, n.strip_points);
  return n;
}

TwinRun RunTwin(const Config& config, const TwinOptions& options) {
  if (options.rtest_interval_s < 150 || options.rtest_interval_s > 7200)
    throw std::invalid_argument("rtest interval must be 150..7200 s");
  if (options.point_noise_um < 0 || options.cloud_points < 1000)
    throw std::invalid_argument("point noise >= 0, cloud points >= 1000");
  const PartSpec& part = config.part;
  std::mt19937_64 rng(options.seed);
  auto uniform = [&](double a, double b) {
    return std::uniform_real_distribution<double>(a, b)(rng);
  };
  auto sign = [&] { return uniform(0, 1) < 0.5 ? -1.0 : 1.0; };
  std::normal_distribution<double> gauss(0.0, 1.0);

  // --- schedule (test-piece.md section 3; times as in the sample runs) ---
  const int cycles = part.cycles();
  const double first_cut_s = 320, cycle_s = 3600;
  struct PlannedCut {
    std::string feature;
    double t_s, c_rad;
  };
  std::vector<PlannedCut> cuts;
  std::vector<std::pair<double, double>> cut_windows;
  for (int cycle = 0; cycle <= cycles; ++cycle) {
    const int j = IndexForCycle(part, cycle);
    const double t0 = first_cut_s + cycle * cycle_s;
    const double c_x = FacetPhiDeg(part, Segment::kX1, j) * M_PI / 180;
    const double c_y = c_x - 30 * M_PI / 180;
    cuts.push_back({StripId(j), t0, 0.0});
    cuts.push_back({FacetId(Segment::kX1, j), t0 + 10, c_x});
    cuts.push_back({FacetId(Segment::kX2, j), t0 + 17, c_x});
    cuts.push_back({FacetId(Segment::kY1, j), t0 + 27, c_y});
    cuts.push_back({FacetId(Segment::kY2, j), t0 + 34, c_y});
    cut_windows.push_back({t0 - 30, t0 + 45});
  }
  const double warmup_from_s = cut_windows[0].second;
  const double warmup_to_s = cut_windows[4].first;
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
  const auto ws_lag = LagFilter(load, kStepS, 2400);
  const auto cool_lag = LagFilter(load, kStepS, 300);
  const auto env_ws = LagFilter(env_delta, kStepS, 1800);

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
  auto machine = ErrorHistory(dyn, load, env_delta);
  auto predicted = ErrorHistory(model, load, env_delta);
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

  // --- the hidden effect's parameters ---
  TwinRun run;
  switch (options.effect) {
    case Cause::kNone:
      break;
    case Cause::kWorkpieceExpansion:
      run.effect_params = {uniform(1200, 5400), options.size};
      break;
    case Cause::kToolWear:
      run.effect_params = {options.size};
      break;
    case Cause::kClampingDistortion:
    case Cause::kCAxisIndexing: {
      const double phase = uniform(0, 2 * M_PI);
      run.effect_params = {options.size * std::cos(phase),
                           options.size * std::sin(phase)};
      break;
    }
  }
  std::vector<CutState> states;
  for (const auto& c : cuts)
    states.push_back(MakeCutState(config, c.feature, c.t_s, c.c_rad));
  EffectContext context = MakeEffectContext(config, states);
  context.grid_t0_s = 0;
  context.grid_step_s = kStepS;
  const double dT_scale =
      kTableAlphaPerK * config.machine.sphere_distance_mm * 1e3;  // um/K
  for (int i = 0; i < steps; ++i)
    context.machine_dT_K.push_back(machine[i][3] / dT_scale);
  const EffectDeltas deltas =
      PredictEffect(options.effect, run.effect_params, context);

  // --- the piece cut under the machine errors and the effect ---
  const FitNoise noise =
      CloudFitNoise(part, options.point_noise_um, options.cloud_points);
  for (const auto& c : cuts) {
    const CAxisErrors e_machine = CAxisErrors::FromMicro(at(machine, c.t_s));
    const CAxisErrors e_pred = CAxisErrors::FromMicro(at(predicted, c.t_s));
    const thermal::CutGeometry g =
        thermal::ComputeCutGeometry(config, c.feature, c.c_rad);
    FeatureResult r = thermal::CutFeatureResult(
        part, g, e_machine, e_pred, config.machine.sphere_distance_mm);
    const FeatureDelta& d = deltas.at(c.feature);
    r.d_mm += d.d_mm;
    r.angle_rad += d.angle_rad;
    run.true_results[c.feature] = r;
    FeatureResult m = r;
    const bool facet = g.feature.kind == FeatureKind::kFacet;
    const FitScatter& scatter = facet ? noise.facet : noise.strip;
    const double sd = scatter.d_mm, sa = scatter.angle_rad;
    m.d_mm += sd * gauss(rng);
    m.angle_rad += sa * gauss(rng);
    m.var_d_mm2 = sd * sd;
    m.var_angle_rad2 = sa * sa;
    m.points = facet ? noise.facet_points : noise.strip_points;
    m.rms_mm = options.point_noise_um * 1e-3;  // the fit's residual RMS
    run.measured[c.feature] = m;
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
    cells[ncols - 3] = c.feature;
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
  nlohmann::json params = nlohmann::json::object();
  const auto pnames = CauseParameterNames(options.effect);
  for (size_t k = 0; k < pnames.size(); ++k)
    params[pnames[k]] = run.effect_params[k];
  if (options.effect == Cause::kClampingDistortion)
    params["amplitude_um"] = options.size;
  if (options.effect == Cause::kCAxisIndexing)
    params["amplitude_urad"] = options.size;
  nlohmann::json truth;
  truth["cause"] = CauseName(options.effect);
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
  for (const auto& c : cuts)
    if (c.feature[0] != 'Z')
      angles[c.feature] = run.true_results.at(c.feature).angle_rad * 1e6;
  truth["facet_angle_err_urad"] = angles;
  // The measurement is per-feature results in W: identity pose.
  truth["pose"] = {{"yaw_deg", 0.0},
                   {"tilt_deg", 0.0},
                   {"t_mm", {0.0, 0.0, 0.0}},
                   {"R", {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}},
                   {"convention", "cloud = W @ R.T + t"}};
  nlohmann::json noise_json = {
      {"point_noise_um", options.point_noise_um},
      {"facet_d_um", noise.facet.d_mm * 1e3},
      {"facet_angle_urad", noise.facet.angle_rad * 1e6},
      {"strip_d_um", noise.strip.d_mm * 1e3},
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
  for (const auto& [id, r] : measured) {
    inspect::FeatureDiagnostic d;
    d.id = id;
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
  inspect::SynthOptions o;
  o.points = options.cloud_points;
  o.noise_um = options.point_noise_um;
  o.stray_fraction = options.stray_fraction;
  o.random_pose = true;
  o.sampling = inspect::SynthSampling::kCmm;
  o.seed =
      static_cast<uint32_t>(options.seed ^ (options.seed >> 32)) ^ 0x9e3779b9u;
  inspect::SynthPiece piece = inspect::SynthesizePiece(
      config.part, FinishedMesh(config), run.true_results, o);
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
        out, MeasuredInspectionJson(config.part, run.measured).dump(1) + "\n");
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
  WriteFileAtomic(d / "truth.json", truth.dump(1) + "\n");
  return out.lexically_normal().string();
}

}  // namespace ttp::diagnosis
