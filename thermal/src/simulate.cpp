#include "ttp/thermal/simulate.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/frames.h"

namespace ttp::thermal {
namespace {

std::vector<double> Linspace(double a, double b, int n) {
  std::vector<double> v(n);
  for (int i = 0; i < n; ++i)
    v[i] = n == 1 ? (a + b) / 2 : a + (b - a) * i / (n - 1);
  return v;
}

}  // namespace

CutGeometry ComputeCutGeometry(const Config& config, const FeatureId& feature,
                               double c_rad, int samples_u, int samples_v) {
  const PartSpec& part = config.part;
  CutGeometry g;
  bool found = false;
  for (const NominalFeature& f : TestFeatures(part)) {
    if (f.Key() == feature) {
      g.feature = f;
      found = true;
    }
  }
  if (!found)
    throw std::invalid_argument("not a test feature: " + feature.ToString());
  g.c_rad = c_rad;
  const Eigen::Matrix3d rot =
      WorkpieceToMachineRotation(c_rad, config.machine.c_sense);
  g.n_w = g.feature.normal;
  g.n_m = rot * g.n_w;
  const NominalFeature& f = g.feature;
  if (f.kind == FeatureKind::kFacet) {
    g.tangent_w = Eigen::Vector3d::UnitZ().cross(g.n_w);
    const double r = config.process.finishing.diameter_mm / 2;
    for (double t : Linspace(f.t_min_mm, f.t_max_mm, samples_u)) {
      for (double z : Linspace(f.z_min_mm, f.z_max_mm, samples_v)) {
        const Eigen::Vector3d p_w =
            f.size_mm * g.n_w + t * g.tangent_w + z * Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d p_m = WorkpieceToMachine(config, p_w, c_rad);
        g.p_w_mm.push_back(p_w);
        g.p_m_mm.push_back(p_m);
        g.q_m_mm.push_back(p_m + r * g.n_m);  // cutter axis beside the facet
        g.uv_mm.emplace_back(t, z);
      }
    }
  } else {
    // Strip: x on both sides of the small notch, y across the cutter width;
    // the tool tip sits on the strip (q = p).
    g.tangent_w = Eigen::Vector3d::UnitX();
    const double gap = part.small_notch_half_width_mm;
    const double y_k = f.point.y();
    const int half = std::max(1, samples_u / 2 + 1);
    std::vector<double> xs = Linspace(f.t_min_mm, -gap, half);
    for (double x : Linspace(gap, f.t_max_mm, half)) xs.push_back(x);
    const double w = part.strip_width_mm / 2;
    for (double x : xs) {
      for (double dy : Linspace(-w, w, std::max(2, samples_v - 1))) {
        const Eigen::Vector3d p_w(x, y_k + dy, f.point.z());
        const Eigen::Vector3d p_m = WorkpieceToMachine(config, p_w, c_rad);
        g.p_w_mm.push_back(p_w);
        g.p_m_mm.push_back(p_m);
        g.q_m_mm.push_back(p_m);
        g.uv_mm.emplace_back(x, dy);
      }
    }
  }
  return g;
}

FeatureResult ShiftsToFeatureResult(const PartSpec& part, const CutGeometry& g,
                                    const std::vector<double>& shifts_mm) {
  const int n = static_cast<int>(shifts_mm.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd s(n);
  for (int i = 0; i < n; ++i) {
    a.row(i) << 1.0, g.uv_mm[i].x(), g.uv_mm[i].y();
    s[i] = shifts_mm[i];
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(s);
  FeatureResult r;
  r.present = true;
  r.points = n;
  r.rms_mm = std::sqrt((s - a * c).squaredNorm() / n);
  if (g.feature.kind == FeatureKind::kFacet) {
    // Surface foot + (a + b t + c z) n: normal n - b t_hat - c z_hat.
    const double norm = std::sqrt(1 + c[1] * c[1] + c[2] * c[2]);
    r.d_mm = (g.feature.size_mm + c[0]) / norm;
    r.angle_rad = std::atan(-c[1]);
    r.tilt_rad = std::atan(-c[2]);
  } else {
    // Floor z = z_floor + a + b x + c (y - y_k); depth at (0, y_k).
    r.d_mm = -(part.strip_floor_z_mm + c[0]);
    r.angle_rad = std::atan(c[1]);
    r.tilt_rad = std::atan(c[2]);
  }
  return r;
}

Simulation SimulatePiece(const TalcLog& log, const Config& config,
                         const SimulationOptions& options) {
  return SimulatePiece(
      log, config,
      MachineErrorEstimator::Fit(
          log, EstimatorOptionsFor(config.machine, options.estimator)),
      options);
}

FeatureResult CutFeatureResult(const PartSpec& part,
                               const CutGeometry& geometry,
                               const CAxisErrors& machine,
                               const CAxisErrors& predicted,
                               double sphere_distance_mm,
                               const std::vector<double>& extra_mm) {
  const CutGeometry& g = geometry;
  std::vector<double> shifts;
  shifts.reserve(g.p_m_mm.size());
  for (size_t i = 0; i < g.p_m_mm.size(); ++i) {
    double s = SurfaceShiftMm(machine, predicted, g.p_m_mm[i], g.q_m_mm[i],
                              g.n_m, sphere_distance_mm);
    if (!extra_mm.empty()) s += extra_mm[i];
    shifts.push_back(s);
  }
  return ShiftsToFeatureResult(part, g, shifts);
}

Simulation SimulatePiece(const TalcLog& log, const Config& config,
                         const MachineErrorEstimator& est,
                         const SimulationOptions& options) {
  Simulation sim;
  sim.estimator_description = est.Describe();
  sim.warnings = est.Warnings();
  sim.estimator_json = est.ToJson();
  if (log.cuts.empty()) {
    throw InputError(log.source, 0, "cut", "the log has no cut rows");
  }
  const double d_half = log.sphere_distance_mm;
  for (const CutRecord& cut : log.cuts) {
    // After the last R-test the estimator extrapolates through its model
    // (with an uncertainty that grows, ErrorSigmaAt); before the first one
    // nothing anchors it.
    if (cut.t_s < est.FirstRTestS()) {
      throw InputError(
          log.source, cut.line, "t_s",
          fmt::format("cut of {} at t_s {} lies before the first R-test "
                      "({:.1f} s): the log does not cover the cut times",
                      cut.feature.ToString(), cut.t_s, est.FirstRTestS()));
    }
    CutGeometry g;
    try {
      g = ComputeCutGeometry(config, cut.feature, cut.c_rad, options.samples_u,
                             options.samples_v);
    } catch (const std::invalid_argument& e) {
      throw InputError(log.source, cut.line, "feature", e.what());
    }
    SimulatedCut sc;
    sc.feature = cut.feature;
    sc.line = cut.line;
    sc.t_s = cut.t_s;
    sc.c_rad = cut.c_rad;
    sc.machine = est.MachineErrorsAt(cut.t_s);
    sc.machine_linear = est.LinearErrorsAt(cut.t_s);
    sc.predicted = est.PredictedAt(cut.t_s);
    std::vector<double> extra;
    if (options.extra_shift_mm) {
      for (size_t i = 0; i < g.p_m_mm.size(); ++i)
        extra.push_back(options.extra_shift_mm(sc, g, static_cast<int>(i)));
    }
    sc.result = CutFeatureResult(config.part, g, sc.machine, sc.predicted,
                                 d_half, extra);
    sc.result_linear = CutFeatureResult(config.part, g, sc.machine_linear,
                                        sc.predicted, d_half, extra);
    sim.results[g.feature.Key()] = sc.result;
    sim.results_linear[g.feature.Key()] = sc.result_linear;
    sim.cuts.push_back(sc);
  }
  // A production log may end before an R-test follows the last cuts.
  std::vector<const SimulatedCut*> past;
  for (const SimulatedCut& sc : sim.cuts)
    if (sc.t_s > est.LastRTestS()) past.push_back(&sc);
  if (!past.empty()) {
    const double beyond_s = past.back()->t_s - est.LastRTestS();
    sim.warnings.push_back(fmt::format(
        "{} cut(s) after the last R-test (t_s {:.0f}), {} at t_s {:.0f} to "
        "{} at t_s {:.0f}: their machine errors are extrapolated through the "
        "estimator's model, up to {:.0f} s ({:.2g} mean R-test spacings) past "
        "it, with an uncertainty that grows with the distance",
        past.size(), est.LastRTestS(), past.front()->feature.ToString(),
        past.front()->t_s, past.back()->feature.ToString(), past.back()->t_s,
        beyond_s, beyond_s / std::max(est.MeanRTestSpacingS(), 1.0)));
  }
  sim.figures = ComputeFigures(config.part, sim.results);
  sim.figures_linear = ComputeFigures(config.part, sim.results_linear);
  return sim;
}

nlohmann::json SimulationToJson(const Simulation& sim,
                                const MachineErrorEstimator& estimator) {
  nlohmann::json j;
  j["estimator"] = sim.estimator_json;
  j["warnings"] = sim.warnings;
  j["figures"] = FiguresToJson(sim.figures)["figures"];
  j["figures_linear_interpolation"] =
      FiguresToJson(sim.figures_linear)["figures"];
  nlohmann::json cuts = nlohmann::json::array();
  for (const SimulatedCut& c : sim.cuts) {
    const auto m = c.machine.ToMicro();
    const auto l = c.machine_linear.ToMicro();
    const auto p = c.predicted.ToMicro();
    nlohmann::json machine, machine_u, linear, pred;
    for (int e = 0; e < 7; ++e) {
      machine[kErrorNames[e]] = m[e];
      machine_u[kErrorNames[e]] = estimator.ErrorSigmaAt(e, c.t_s);
      linear[kErrorNames[e]] = l[e];
      pred[kErrorNames[e]] = p[e];
    }
    cuts.push_back({{"feature", c.feature.ToString()},
                    {"t_s", c.t_s},
                    {"c_deg", c.c_rad * 180 / kPi},
                    {"machine_errors", machine},
                    {"machine_errors_u", machine_u},
                    {"machine_errors_linear", linear},
                    {"predicted_errors", pred},
                    {"d_mm", c.result.d_mm},
                    {"d_linear_mm", c.result_linear.d_mm},
                    {"angle_urad", c.result.angle_rad * 1e6},
                    {"angle_linear_urad", c.result_linear.angle_rad * 1e6}});
  }
  j["cuts"] = cuts;
  return j;
}

std::string SimulationText(const Simulation& sim) {
  std::string s = "estimator: " + sim.estimator_description + "\n";
  for (const std::string& w : sim.warnings) s += "warning: " + w + "\n";
  s += "\n";
  s += "simulated figures per cycle (um, E_B in um/m); [linear] = straight "
       "line between R-tests\n";
  s += fmt::format(
      "{:>5} {:>8} {:>8} {:>8} {:>8} {:>8}   {:>8} {:>8} {:>8} "
      "{:>8} {:>8}\n",
      "cycle", "E_X", "E_Y", "E_Z", "E_B", "E_TTP", "[E_X]", "[E_Y]", "[E_Z]",
      "[E_B]", "[E_TTP]");
  for (size_t i = 0; i < sim.figures.size(); ++i) {
    const CycleFigures& f = sim.figures[i];
    const CycleFigures& l = sim.figures_linear[i];
    s += fmt::format(
        "{:>5} {:8.3f} {:8.3f} {:8.3f} {:8.3f} {:8.3f}   {:8.3f} {:8.3f} "
        "{:8.3f} {:8.3f} {:8.3f}\n",
        f.cycle, f.e_x_mm * 1e3, f.e_y_mm * 1e3, f.e_z_mm * 1e3,
        f.e_b_rad * 1e6, f.e_ttp_mm * 1e3, l.e_x_mm * 1e3, l.e_y_mm * 1e3,
        l.e_z_mm * 1e3, l.e_b_rad * 1e6, l.e_ttp_mm * 1e3);
  }
  s += "\nmachine errors at each cut: estimator / linear (um, um/m)\n";
  s += fmt::format("{:>6} {:>7}", "cut", "t_s");
  for (const char* name : kErrorNames) s += fmt::format(" {:>15}", name);
  s += "\n";
  for (const SimulatedCut& c : sim.cuts) {
    const auto m = c.machine.ToMicro();
    const auto l = c.machine_linear.ToMicro();
    s += fmt::format("{:>6} {:7.0f}", c.feature.ToString(), c.t_s);
    for (int e = 0; e < 7; ++e)
      s += fmt::format(" {:7.2f}/{:<7.2f}", m[e], l[e]);
    s += "\n";
  }
  return s;
}

}  // namespace ttp::thermal
