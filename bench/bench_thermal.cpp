// Prints: TALC log parse speed, leave-one-R-test-out error of the ARX
// smoother vs the straight line near the load changes, and the simulated
// figures against the sample runs' truth. Never fails.
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/geometry/file_io.h"
#include "ttp/thermal/check.h"
#include "ttp/thermal/estimator.h"
#include "ttp/thermal/simulate.h"
#include "ttp/thermal/talc_log.h"

#ifndef TTP_DATA_DIR
#define TTP_DATA_DIR "."
#endif

using namespace ttp;
using namespace ttp::thermal;

int main() {
  // Parse speed: one day of a row a minute plus an R-test every 5 min.
  {
    std::string day =
        "# talc-log: 1\n# start: 2026-03-02T06:00:00+01:00\n# compensation: "
        "off\nt_s,event,T_env,T_ws,c_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,"
        "dur_s\n";
    for (int i = 0; i < 1440; ++i) {
      day += fmt::format("{},sample,20.{:04d},21.0,{},,,,,,,,\n", i * 60.0,
                         i % 9973, (i / 90) % 2 ? 1200 : 0);
      if (i % 5 == 4) {
        day += fmt::format("{},rtest,,,,0.1,0.2,0.3,0.4,0.5,0.6,0.7,95\n",
                           i * 60.0 + 30);
      }
    }
    const auto a = std::chrono::steady_clock::now();
    const TalcLog log = ParseTalcLog(day, "day");
    const auto b = std::chrono::steady_clock::now();
    fmt::print(
        "parse {} rows (one day, a row a minute, R-test every 5 min): "
        "{:.1f} ms\n",
        log.rows.size(),
        std::chrono::duration<double, std::milli>(b - a).count());
  }
  // Parse speed: seven days of a row a minute plus an R-test every hour.
  std::string text =
      "# talc-log: 1\n# start: 2026-03-02T06:00:00+01:00\n# compensation: "
      "off\nt_s,event,T_env,T_ws,c_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,"
      "dur_s\n";
  const int days = 7;
  for (int i = 0; i < days * 1440; ++i) {
    text += fmt::format("{},sample,20.{:04d},21.0,{},,,,,,,,\n", i * 60.0,
                        i % 9973, (i / 90) % 2 ? 1200 : 0);
    if (i % 60 == 59) {
      text += fmt::format("{},rtest,,,,0.1,0.2,0.3,0.4,0.5,0.6,0.7,95\n",
                          i * 60.0 + 30);
    }
  }
  auto t0 = std::chrono::steady_clock::now();
  const TalcLog big = ParseTalcLog(text, "synthetic");
  auto t1 = std::chrono::steady_clock::now();
  fmt::print("parse {} rows ({} days, a row a minute): {:.1f} ms\n",
             big.rows.size(), days,
             std::chrono::duration<double, std::milli>(t1 - t0).count());
  t0 = std::chrono::steady_clock::now();
  const MachineErrorEstimator est = MachineErrorEstimator::Fit(big);
  t1 = std::chrono::steady_clock::now();
  fmt::print("fit estimator on it: {:.1f} ms\n",
             std::chrono::duration<double, std::milli>(t1 - t0).count());

  for (const char* run : {"run-a", "run-b"}) {
    const std::string dir = std::string(TTP_DATA_DIR) + "/samples/" + run;
    const TalcLog log = ReadTalcLog(dir + "/talc.csv");
    t0 = std::chrono::steady_clock::now();
    const LoadChangeComparison cmp = CompareAtLoadChanges(log);
    t1 = std::chrono::steady_clock::now();
    fmt::print(
        "\n{}: leave-one-R-test-out at {} R-tests around the load changes "
        "({:.1f} ms)\n",
        run, cmp.tested_rtest_times_s.size(),
        std::chrono::duration<double, std::milli>(t1 - t0).count());
    for (int e = 0; e < 7; ++e) {
      fmt::print("  {}  ARX {:6.3f}  linear {:6.3f}\n", kErrorNames[e],
                 cmp.rms_arx[e], cmp.rms_linear[e]);
    }
    fmt::print(
        "  all   ARX {:6.3f}  linear {:6.3f}  (everywhere: {:.3f} vs "
        "{:.3f})\n",
        cmp.rms_arx_all, cmp.rms_linear_all, cmp.rms_arx_everywhere,
        cmp.rms_linear_everywhere);
    t0 = std::chrono::steady_clock::now();
    const InterpolationComparison thin = CompareInterpolation(log, 3600);
    t1 = std::chrono::steady_clock::now();
    fmt::print(
        "  R-tests thinned to one an hour ({} phases, {:.0f} ms): RMS over "
        "EX0C..ER0T at the held-out R-tests, dynamic model vs straight line\n",
        thin.phases,
        std::chrono::duration<double, std::milli>(t1 - t0).count());
    for (const auto& w : thin.windows) {
      fmt::print(
          "    {:<16} model {:.2f} um  line {:.2f} um  (largest {:.2f} "
          "vs {:.2f} um, {} R-tests)\n",
          w.label, w.rms_model_um, w.rms_line_um, w.max_model_um, w.max_line_um,
          w.held_out);
    }
    Config config;
    t0 = std::chrono::steady_clock::now();
    const Simulation sim = SimulatePiece(log, config);
    t1 = std::chrono::steady_clock::now();
    fmt::print("  simulate the piece (fit + 45 cuts): {:.1f} ms\n",
               std::chrono::duration<double, std::milli>(t1 - t0).count());
    const nlohmann::json truth =
        nlohmann::json::parse(ReadTextFile(dir + "/truth.json"));
    fmt::print("  simulated - truth per cycle (um, um/m), ARX | linear\n");
    const char* names[] = {"E_X", "E_Y", "E_Z", "E_B", "E_TTP"};
    std::array<double, 5> ss{}, ss_lin{};
    for (size_t i = 0; i < sim.figures.size(); ++i) {
      const auto& f = sim.figures[i];
      const auto& l = sim.figures_linear[i];
      const double v[5] = {f.e_x_mm * 1e3, f.e_y_mm * 1e3, f.e_z_mm * 1e3,
                           f.e_b_rad * 1e6, f.e_ttp_mm * 1e3};
      const double w[5] = {l.e_x_mm * 1e3, l.e_y_mm * 1e3, l.e_z_mm * 1e3,
                           l.e_b_rad * 1e6, l.e_ttp_mm * 1e3};
      std::string line = fmt::format("  {}", f.cycle);
      for (int k = 0; k < 5; ++k) {
        const double t = truth["figures"][i][names[k]].get<double>();
        ss[k] += (v[k] - t) * (v[k] - t);
        ss_lin[k] += (w[k] - t) * (w[k] - t);
        line +=
            fmt::format(" {}={:+6.2f}|{:+6.2f}", names[k], v[k] - t, w[k] - t);
      }
      fmt::print("{}\n", line);
    }
    std::string line = "  RMS";
    for (int k = 0; k < 5; ++k) {
      line += fmt::format(" {}={:5.2f}|{:5.2f}", names[k],
                          std::sqrt(ss[k] / sim.figures.size()),
                          std::sqrt(ss_lin[k] / sim.figures.size()));
    }
    fmt::print("{}\n", line);
    double angle_ss = 0;
    int angle_n = 0;
    for (const auto& [id, value] : truth["facet_angle_err_urad"].items()) {
      const double a = sim.results.at(FeatureId::Parse(id).value()).angle_rad * 1e6;
      angle_ss += (a - value.get<double>()) * (a - value.get<double>());
      ++angle_n;
    }
    fmt::print("  facet angle RMS vs truth: {:.3f} urad over {} facets\n",
               std::sqrt(angle_ss / angle_n), angle_n);
    // ttp check with the truth figures (U = 0) as the measurement: how often
    // the simulated U covers the true figure.
    std::vector<CycleFigures> truth_figures;
    for (size_t i = 0; i < truth["figures"].size(); ++i) {
      const auto& t = truth["figures"][i];
      CycleFigures f;
      f.cycle = t["cycle"].get<int>();
      f.e_x_mm = t["E_X"].get<double>() * 1e-3;
      f.e_y_mm = t["E_Y"].get<double>() * 1e-3;
      f.e_z_mm = t["E_Z"].get<double>() * 1e-3;
      f.e_b_rad = t["E_B"].get<double>() * 1e-6;
      f.e_ttp_mm = t["E_TTP"].get<double>() * 1e-3;
      truth_figures.push_back(f);
    }
    t0 = std::chrono::steady_clock::now();
    const CheckResult check = CheckPiece(log, config, truth_figures);
    t1 = std::chrono::steady_clock::now();
    fmt::print(
        "  check (fit, simulation, U propagation): {:.1f} ms; true figures "
        "inside the simulated U (k = 2): {} of {} (hidden effect: {})\n",
        std::chrono::duration<double, std::milli>(t1 - t0).count(),
        check.compared - check.disagreements, check.compared,
        truth["cause"].get<std::string>());
  }
  return 0;
}
