// `ttp log LOG`: summary of a TALC log. `ttp simulate --log LOG`: the
// simulated piece's figures from the log's machine errors.
#include <fmt/format.h>

#include "command.h"
#include "ttp/thermal/check.h"
#include "ttp/thermal/estimator.h"
#include "ttp/thermal/simulate.h"
#include "ttp/thermal/talc_log.h"

namespace ttp::app {
namespace {

void RegisterThermal(CLI::App& root, GlobalOptions& global) {
  {
    auto* cmd = root.add_subcommand(
        "log", "read a TALC log and summarise it (span, R-tests, cuts, gaps)");
    auto log_path = std::make_shared<std::string>();
    auto json_out = std::make_shared<std::string>();
    cmd->add_option("log", *log_path, "TALC log (CSV)")->required();
    cmd->add_option("--json", *json_out, "also write the summary as JSON");
    cmd->callback([&global, log_path, json_out] {
      // The summary lists the log's warnings itself.
      const thermal::TalcLog log = thermal::ReadTalcLog(*log_path);
      if (!global.quiet || json_out->empty()) {
        TextOut(*json_out) << thermal::LogSummaryText(log);
      }
      if (!json_out->empty())
        WriteJson(*json_out, thermal::LogSummaryJson(log));
    });
  }
  {
    auto* cmd = root.add_subcommand(
        "simulate",
        "simulate the piece from a TALC log: figures E_X..E_TTP per cycle");
    auto log_path = std::make_shared<std::string>();
    auto json_out = std::make_shared<std::string>();
    auto compare = std::make_shared<bool>(false);
    auto interval = std::make_shared<double>(3600.0);
    cmd->add_option("--log", *log_path, "TALC log (CSV)")->required();
    cmd->add_option("--json", *json_out, "also write the result as JSON");
    cmd->add_flag("--compare-interpolation", *compare,
                  "also compare, at the load changes, the dynamic model with "
                  "the straight line between R-tests");
    cmd->add_option("--rtest-interval-s", *interval,
                    "R-test spacing kept for --compare-interpolation "
                    "(default 3600 s, production practice)")
        ->check(FiniteRange(1.0, 86400.0));
    cmd->callback([&global, log_path, json_out, compare, interval] {
      const thermal::TalcLog log = ReadTalcLogWarning(*log_path, global);
      // The simulated figures with the U `ttp check` gives them (the
      // estimator's leave-one-out error).
      const Config config = global.LoadConfig();
      const auto estimator = thermal::MachineErrorEstimator::Fit(
          log, thermal::EstimatorOptionsFor(config.machine));
      thermal::Simulation sim =
          thermal::SimulatePiece(log, config, estimator, {});
      const std::vector<CycleFigures> u =
          thermal::SimulatedFigureUncertainty(log, config, estimator, {});
      for (size_t i = 0; i < sim.figures.size() && i < u.size(); ++i) {
        CycleFigures& f = sim.figures[i];
        f.u_x_mm = u[i].u_x_mm;
        f.u_y_mm = u[i].u_y_mm;
        f.u_z_mm = u[i].u_z_mm;
        f.u_b_rad = u[i].u_b_rad;
        f.u_ttp_mm = u[i].u_ttp_mm;
      }
      std::string text = thermal::SimulationText(sim);
      nlohmann::json j = thermal::SimulationToJson(sim, estimator);
      if (*compare) {
        const auto c = thermal::CompareInterpolation(log, *interval);
        const auto dense = thermal::CompareAtLoadChanges(
            log, thermal::EstimatorOptionsFor(config.machine));
        text += "\n" + thermal::InterpolationText(c);
        text += fmt::format(
            "leave-one-R-test-out on the log's own R-tests, {} R-tests "
            "around the load changes: RMS model {:.3f} vs line {:.3f} "
            "(all seven errors; everywhere {:.3f} vs {:.3f})\n",
            dense.tested_rtest_times_s.size(), dense.rms_arx_all,
            dense.rms_linear_all, dense.rms_arx_everywhere,
            dense.rms_linear_everywhere);
        j["interpolation_at_load_changes"] = thermal::InterpolationToJson(c);
        j["interpolation_at_load_changes"]["leave_one_out"] = {
            {"rtests_near_load_changes", dense.tested_rtest_times_s.size()},
            {"rms_model", dense.rms_arx_all},
            {"rms_line", dense.rms_linear_all},
            {"rms_model_everywhere", dense.rms_arx_everywhere},
            {"rms_line_everywhere", dense.rms_linear_everywhere}};
      }
      if (!global.quiet || json_out->empty()) TextOut(*json_out) << text;
      if (!json_out->empty()) WriteJson(*json_out, j);
    });
  }
}

}  // namespace
TTP_REGISTER_COMMANDS(40, RegisterThermal);
}  // namespace ttp::app
