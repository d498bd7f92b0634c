// A twin-like synthetic TALC log for the thermal tests: the seven errors
// follow a first-order lag (tau 1500 s, not on the estimator's grid) of the
// C-axis speed, which runs at 1200/min from the warm-up start to the
// cool-down start; R-tests with fixed-seed noise; the 45 cuts of the test
// cycle on the hour. Truth(t) gives the noise-free errors.
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/rigid_table.h"

namespace ttp::thermal::test {

struct SyntheticRun {
  double warmup_s = 420, cooldown_s = 4 * 3600 + 420, end_s = 8.6 * 3600;
  double tau_s = 1500;
  double rtest_interval_s = 300, rtest_noise_um = 0.05;
  std::array<double, 7> gain = {0.5, -1.5, -8.0, 3.0, -3.0, 1.0, -2.0};
  double scale = 1.0;  // multiplies every gain
  unsigned seed = 7;

  // Lagged C-axis speed (1000/min) at t.
  double Load(double t) const {
    auto rise = [&](double dt) { return 1.2 * (1 - std::exp(-dt / tau_s)); };
    if (t <= warmup_s) return 0;
    if (t <= cooldown_s) return rise(t - warmup_s);
    return rise(cooldown_s - warmup_s) * std::exp(-(t - cooldown_s) / tau_s);
  }
  std::array<double, 7> TruthMicro(double t) const {
    std::array<double, 7> e;
    for (int i = 0; i < 7; ++i) e[i] = scale * gain[i] * Load(t);
    return e;
  }
  CAxisErrors Truth(double t) const {
    return CAxisErrors::FromMicro(TruthMicro(t));
  }

  std::string Text(const Config& config) const {
    struct Row {
      double t;
      std::string text;
    };
    std::vector<Row> rows;
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, rtest_noise_um);
    for (double t = 0; t <= end_s; t += 60) {
      const double env = 20 + 0.3 * std::sin(t / 5000.0);
      const int rpm = t > warmup_s && t <= cooldown_s ? 1200 : 0;
      rows.push_back({t, fmt::format("{},sample,{:.4f},{:.4f},{},,,,,,,,,,", t,
                                     env, env + 0.5, rpm)});
    }
    for (double t = 95; t <= end_s; t += rtest_interval_s) {
      const auto e = TruthMicro(t - 47.5);
      std::string r = fmt::format("{},rtest,,,", t);
      for (int i = 0; i < 7; ++i)
        r += fmt::format(",{:.5f}", e[i] + noise(rng));
      rows.push_back({t, r + ",,,95"});
    }
    const PartSpec& part = config.part;
    for (int cycle = 0; cycle <= part.cycles(); ++cycle) {
      const int j =
          cycle == 0 ? part.reference_index : IndexForCycle(part, cycle);
      const double t0 = 300 + 3600.0 * cycle;
      const double x = 60 + 6.0 * (j - part.reference_index);
      const double y = 30 + 6.0 * (j - part.reference_index);
      const std::pair<std::string, double> cuts[] = {
          {StripId(j), 0},
          {FacetId(Segment::kX1, j), x},
          {FacetId(Segment::kX2, j), x},
          {FacetId(Segment::kY1, j), y},
          {FacetId(Segment::kY2, j), y}};
      const double dt[] = {20, 30, 37, 47, 54};
      for (int k = 0; k < 5; ++k) {
        rows.push_back(
            {t0 + dt[k], fmt::format("{},cut,,,,,,,,,,,{},{},", t0 + dt[k],
                                     cuts[k].first, cuts[k].second)});
      }
    }
    std::stable_sort(rows.begin(), rows.end(),
                     [](const Row& a, const Row& b) { return a.t < b.t; });
    std::string text =
        "# talc-log: 1\n# start: 2026-03-02T06:00:00+01:00\n"
        "# compensation: off\n"
        "t_s,event,T_env,T_ws,c_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,"
        "feature,c_deg,dur_s\n";
    for (const Row& r : rows) text += r.text + "\n";
    return text;
  }
};

}  // namespace ttp::thermal::test
