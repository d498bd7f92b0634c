// `ttp rtest`: the seven C-axis errors from R-test sphere centres (thesis
// 5.2-5.4), and the resolution column of thesis table 5.4.
#include <fmt/format.h>

#include <cmath>
#include <iostream>

#include "command.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/rtest.h"

namespace ttp::app {
namespace {

struct RTestArgs {
  std::string spheres;
  std::string json_out;
  double distance_mm = NAN, height_mm = NAN, phi0_deg = 0;
  bool resolution = false;
  double axis_resolution_um = 1.0;
  double d_m = 0.32;
};

const char* kUnits[7] = {"um", "um", "um", "um", "um/m", "um/m", "um/m"};

void PrintResolution(const RTestArgs& a, const RTestGeometry& base) {
  RTestGeometry g = base;
  g.sphere_distance_mm = a.d_m * 1e3 / 2;
  g.sphere_height_mm = 0;
  const std::vector<double> angles = {0, M_PI / 2, M_PI, 3 * M_PI / 2};
  const auto res = CAxisErrors::FromVector(
                       RTestResolution(g, angles, a.axis_resolution_um * 1e-3))
                       .ToMicro();
  nlohmann::json j = {{"axis_resolution_um", a.axis_resolution_um},
                      {"d_m", a.d_m},
                      {"angles_deg", {0, 90, 180, 270}}};
  TextOut(a.json_out) << fmt::format(
      "R-test resolution, axis resolution {} um, d = {} m, C at 0/90/180/270 "
      "deg:\n",
      a.axis_resolution_um, a.d_m);
  for (int i = 0; i < 7; ++i) {
    TextOut(a.json_out) << fmt::format("  {:<5} {:>8.4f} {}\n", kErrorNames[i],
                                       res[i], kUnits[i]);
    j["resolution"][kErrorNames[i]] = res[i];
  }
  if (!a.json_out.empty()) WriteJson(a.json_out, j);
}

void Evaluate(const RTestArgs& a, const RTestGeometry& g) {
  const std::vector<SphereCycle> cycles =
      ParseSphereMeasurements(ReadTextFile(a.spheres), a.spheres);
  for (const SphereCycle& c : cycles)
    CheckSpheresFollowGeometry(g, c, a.spheres);
  const std::vector<SphereMeasurement>& reference = cycles.front().positions;
  nlohmann::json out = {{"reference_cycle", cycles.front().cycle},
                        {"sphere_distance_mm", g.sphere_distance_mm},
                        {"sphere_height_mm", g.sphere_height_mm},
                        {"cycles", nlohmann::json::array()}};
  TextOut(a.json_out) << fmt::format("{:>6}", "cycle");
  for (int i = 0; i < 7; ++i) {
    TextOut(a.json_out) << fmt::format(
        " {:>9}", std::string(kErrorNames[i]) + "[" + kUnits[i] + "]");
  }
  TextOut(a.json_out) << fmt::format(" {:>9}\n", "rms[um]");
  for (size_t k = 1; k < cycles.size(); ++k) {
    const RTestSolution s = SolveRTest(g, reference, cycles[k].positions);
    const auto e = s.errors.ToMicro();
    nlohmann::json row = {{"cycle", cycles[k].cycle},
                          {"rms_residual_um", s.rms_residual_mm * 1e3}};
    TextOut(a.json_out) << fmt::format("{:>6}", cycles[k].cycle);
    for (int i = 0; i < 7; ++i) {
      row[kErrorNames[i]] = e[i];
      TextOut(a.json_out) << fmt::format(" {:>9.3f}", e[i]);
    }
    TextOut(a.json_out) << fmt::format(" {:>9.3f}\n", s.rms_residual_mm * 1e3);
    out["cycles"].push_back(row);
  }
  if (!a.json_out.empty()) WriteJson(a.json_out, out);
}

void RegisterRtest(CLI::App& root, GlobalOptions& global) {
  auto args = std::make_shared<RTestArgs>();
  auto* cmd = root.add_subcommand(
      "rtest",
      "seven C-axis errors from R-test sphere centres (CSV: "
      "cycle,c_deg,x,y,z in mm, machine frame; first cycle = reference)");
  cmd->add_option("SPHERES", args->spheres, "sphere centre CSV");
  cmd->add_option("--json", args->json_out, "write results as JSON");
  cmd->add_option("--distance-mm", args->distance_mm,
                  "sphere distance from the C axis, d/2 (default: machine)")
      ->check(FiniteRange(1.0, 10000.0));
  cmd->add_option("--height-mm", args->height_mm,
                  "sphere centre above the table (default: machine)")
      ->check(FiniteRange(-10000.0, 10000.0));
  cmd->add_option("--phi0-deg", args->phi0_deg,
                  "sphere direction on the table at C = 0")
      ->check(FiniteRange(-360.0, 360.0));
  cmd->add_flag("--resolution", args->resolution,
                "print the resolution of each error (thesis table 5.4)");
  cmd->add_option("--axis-resolution-um", args->axis_resolution_um,
                  "axis resolution for --resolution")
      ->check(FiniteRange(1e-6, 1000.0));
  cmd->add_option("--d-m", args->d_m,
                  "sphere circle diameter d for "
                  "--resolution")
      ->check(FiniteRange(0.002, 20.0));
  cmd->callback([&global, args] {
    const Config config = global.LoadConfig();
    RTestGeometry g;
    g.sphere_distance_mm = std::isnan(args->distance_mm)
                               ? config.machine.sphere_distance_mm
                               : args->distance_mm;
    g.sphere_height_mm = std::isnan(args->height_mm)
                             ? config.machine.sphere_height_mm
                             : args->height_mm;
    g.sphere_phi0_deg = args->phi0_deg;
    g.c_sense = config.machine.c_sense;
    if (args->resolution) {
      PrintResolution(*args, g);
    } else if (args->spheres.empty()) {
      throw InputError("rtest", 0, "SPHERES",
                       "give a sphere CSV or --resolution");
    } else {
      Evaluate(*args, g);
    }
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(60, RegisterRtest);
}  // namespace ttp::app
