// A realistic synthetic report document for the tests: 8 cycles of measured
// and simulated figures, a TALC log of 8.5 h at one row a minute with 96
// R-tests every 5 min and the 45 cuts, and a workpiece-expansion diagnosis.
// Seeded, so every run builds the same document.
#pragma once

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <string>

#include "ttp/geometry/config.h"
#include "ttp/geometry/features.h"
#include "ttp/report/report.h"

namespace ttp::test {

inline nlohmann::json SyntheticReportData(unsigned seed = 2026) {
  using nlohmann::json;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const PartSpec part;
  const double hour_s = 3600.0;
  // Machine state: warm-up (C spinning) for cycles 0..4, cool-down after.
  auto warm = [&](double t_s) {
    const double t_h = t_s / hour_s, on = 4.25;
    return t_h < on ? 1.0 - std::exp(-t_h / 1.2)
                    : (1.0 - std::exp(-on / 1.2)) * std::exp(-(t_h - on) / 1.5);
  };
  json data = {{"schema", kReportSchema},
               {"title", "Thermal test piece - synthetic run"},
               {"run",
                {{"machine", "generic 5-axis, C-axis table"},
                 {"date", "2026-03-02"},
                 {"compensation", "off"}}},
               {"limits", {{"linear_um", 5.0}, {"angular_um_per_m", 15.0}}}};
  json measured = json::array(), simulated = json::array();
  for (int cycle = 1; cycle <= part.cycles(); ++cycle) {
    const double t_s = (cycle + 0.5) * hour_s;
    const double w = warm(t_s) - warm(0.5 * hour_s);
    json sim = {{"cycle", cycle},  {"E_X", 2.0 * w}, {"E_Y", -3.0 * w},
                {"E_Z", -7.5 * w}, {"E_B", 6.0 * w}, {"E_TTP", 3.5 * w}};
    json mea = {{"cycle", cycle}};
    json u = json::object();
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_B", "E_TTP"}) {
      const bool angular = std::string(key) == "E_B";
      // The hidden effect: the piece grows more than the table says.
      const double extra = std::string(key) == "E_TTP" ? 2.0 * w : 0.0;
      mea[key] =
          sim[key].get<double>() + extra + (angular ? 2.0 : 0.3) * noise(rng);
      u[key] = angular ? 8.0 : 0.8;
    }
    mea["U"] = u;
    measured.push_back(mea);
    simulated.push_back(sim);
  }
  data["figures"] = {{"measured", measured}, {"simulated", simulated}};

  json samples = {{"t_s", json::array()},   {"T_env", json::array()},
                  {"T_ws", json::array()},  {"dT_cool", json::array()},
                  {"c_rpm", json::array()}, {"spindle_rpm", json::array()}};
  const double span_s = 8.5 * hour_s;
  for (double t = 0; t <= span_s; t += 60.0) {
    const bool spinning = t < 4.25 * hour_s;
    samples["t_s"].push_back(t);
    samples["T_env"].push_back(20.0 + 0.4 * std::sin(t / 20000.0) +
                               0.02 * noise(rng));
    samples["T_ws"].push_back(20.3 + 1.6 * warm(t) + 0.02 * noise(rng));
    samples["dT_cool"].push_back(0.8 * warm(t) + 0.01 * noise(rng));
    samples["c_rpm"].push_back(spinning ? 1000.0 : 0.0);
    samples["spindle_rpm"].push_back(0.0);
  }
  json rtests = {{"t_s", json::array()}};
  const double gains[7] = {2.0, -3.0, -7.5, 3.5, 4.0, 6.0, -5.0};
  const char* keys[7] = {"EX0C", "EY0C", "EZ0T", "ER0T",
                         "EA0C", "EB0C", "EC0C"};
  for (int i = 0; i < 96; ++i) {
    const double t = 95.0 + i * 300.0;
    rtests["t_s"].push_back(t);
    for (int k = 0; k < 7; ++k) {
      rtests[keys[k]].push_back(gains[k] * warm(t) +
                                (k < 4 ? 0.3 : 1.5) * noise(rng));
    }
  }
  json cuts = json::array();
  for (int cycle = 0; cycle <= part.cycles(); ++cycle) {
    const int index = IndexForCycle(part, cycle);
    double t = (cycle + 0.5) * hour_s;
    for (Segment s : kSegments) {
      cuts.push_back({{"t_s", t}, {"feature", FacetId(s, index)}});
      t += 40.0;
    }
    cuts.push_back({{"t_s", t}, {"feature", StripId(index)}});
  }
  data["log"] = {{"start", "2026-03-02T06:00:00+01:00"},
                 {"samples", samples},
                 {"rtests", rtests},
                 {"cuts", cuts}};
  data["diagnosis"] = {
      {"status", "named"},
      {"cause", "workpiece_expansion"},
      {"summary",
       "The piece grew more than the cast-iron table: its aluminium follows "
       "the working-space temperature with a lag."},
      {"baseline", {{"rms_um", 1.21}, {"rms_urad", 3.4}}},
      {"extended",
       {{"rms_um", 0.34},
        {"rms_urad", 3.3},
        {"params", {{"tau_wp_s", 2650.0}, {"gain", 0.99}}},
        {"uncertainty", {{"tau_wp_s", 310.0}, {"gain", 0.08}}}}},
      {"gain_pct", 68.5},
      {"gain",
       {{"method", "leave one cycle out"},
        {"heldout_baseline_rms_um", 3.1},
        {"heldout_extended_rms_um", 0.98}}},
      {"evidence", "BIC = chi2 + k ln n"},
      {"threshold", 10.0},
      {"candidates",
       {{{"cause", "none"}, {"delta_bic", 0.0}, {"rms_um", 1.21}},
        {{"cause", "workpiece_expansion"},
         {"delta_bic", -41.3},
         {"rms_um", 0.34},
         {"params",
          {{"tau_wp_s", {{"value", 2650.0}, {"uncertainty", 310.0}}},
           {"gain", {{"value", 0.99}, {"uncertainty", 0.08}}}}}},
        {{"cause", "tool_wear"}, {"delta_bic", -12.8}, {"rms_um", 0.71}},
        {{"cause", "clamping_distortion"},
         {"delta_bic", 3.1},
         {"rms_um", 1.18}},
        {{"cause", "c_axis_indexing"}, {"delta_bic", 4.0}, {"rms_um", 1.2}}}}};
  json residuals = {{"cycles", json::array()},
                    {"before", json::object()},
                    {"after", json::object()},
                    {"sigma", json::object()}};
  for (int cycle = 1; cycle <= part.cycles(); ++cycle) {
    residuals["cycles"].push_back(cycle);
    const double w = warm((cycle + 0.5) * hour_s) - warm(0.5 * hour_s);
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_TTP"}) {
      const double extra = std::string(key) == "E_TTP" ? 2.0 * w : 0.0;
      const double r = extra + 0.3 * noise(rng);
      residuals["before"][key].push_back(r);
      residuals["after"][key].push_back(r - extra);
      residuals["sigma"][key].push_back(0.4);
    }
  }
  data["diagnosis"]["residuals"] = residuals;
  data["warnings"] = {"log: gap of 12 min at line 300 (synthetic)"};
  data["grade"] = {{"verdict", "fail"},
                   {"rule", "ISO 14253-1: pass if |value| <= limit - U"}};
  return data;
}

}  // namespace ttp::test
