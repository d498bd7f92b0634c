// `ttp thermal fit|predict|compare`: thermal error models identified from a
// thermal log (thermal-log.md), causal prediction from the inputs alone, and
// every structure side by side on a chronological holdout (docs/THERMAL.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "command.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/json_text.h"
#include "ttp/models/compare.h"
#include "ttp/models/identify.h"
#include "ttp/models/time_series.h"
#include "ttp/thermal/talc_log.h"
#include "ttp/thermal/time_series.h"

namespace ttp::app {
namespace {

std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

models::TimeSeries ReadLog(const std::string& path) {
  return thermal::ReadThermalOrTalcLog(path);
}

void AddFitOptions(CLI::App* cmd, models::FitOptions* o) {
  cmd->add_option("--criterion", o->criterion,
                  "selection criterion: cv (chronological cross-validation "
                  "with the MDL factor, default) or mdl (in-sample MDL-like, "
                  "thesis eq. 4.23)");
  cmd->add_option("--temperature-lag-s", o->temperature_lag_s,
                  "joint: the lag each temperature passes through "
                  "besides its direct path (default 3600 s; select tries "
                  "every time constant)");
  cmd->add_flag("--auto-selected", o->auto_selected,
                "select: also the forward-selected structures among the "
                "candidates (scored by nested CV; slow)");
  cmd->add_option("--max-terms", o->max_terms,
                  "most regressors per output (default 8)");
  cmd->add_option("--weight-half-life-s", o->weight_half_life_s,
                  "WLSE: halve a sample's weight per this age (default 0: "
                  "ordinary least squares)");
  cmd->add_flag("!--keep-jumps", o->repair_jumps,
                "do not shift a temperature sensor that jumps inside the "
                "fitted span back by its step (default: shift it, in the "
                "fit and in later predictions; either way it is warned "
                "about)");
}

// An invalid option is named as the user wrote it: the command's flag for
// the field (max_terms: --max-terms), the options' field name otherwise.
void CheckFitOptions(const models::FitOptions& o, const CLI::App* cmd) {
  std::string error;
  if (o.IsValid(&error)) return;
  std::string flag = "--" + error.substr(0, error.find(':'));
  std::replace(flag.begin(), flag.end(), '_', '-');
  throw InputError(cmd->get_option_no_throw(flag) != nullptr ? flag : "options",
                   0, "", error);
}

void Warn(const GlobalOptions& global, const std::vector<std::string>& w) {
  if (global.quiet) return;
  for (const auto& line : w)
    std::fprintf(stderr, "warning: %s\n", line.c_str());
}

std::string PredictionCsv(const models::Prediction& p) {
  std::string s = "t_s";
  for (const auto& name : p.outputs) s += "," + name;
  s += "\n";
  for (Eigen::Index i = 0; i < p.values_um.rows(); ++i) {
    s += fmt::format("{:g}", p.t_s[i]);
    for (Eigen::Index k = 0; k < p.values_um.cols(); ++k)
      s += fmt::format(",{:.4f}", p.values_um(i, k));
    s += "\n";
  }
  return s;
}

void RegisterThermalModels(CLI::App& root, GlobalOptions& global) {
  auto* group = root.add_subcommand(
      "thermal",
      "thermal error models from a thermal log: fit, predict, compare");
  group->require_subcommand(1);
  {
    auto* cmd = group->add_subcommand(
        "fit",
        "identify a model per output by chronological cross-validation "
        "(auto: the ridge of the joint model on every input; select: the "
        "structure; static..combined: inputs, lags and orders too)");
    auto log = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    auto outputs = std::make_shared<std::string>();
    auto json_out = std::make_shared<std::string>();
    auto o = std::make_shared<models::FitOptions>();
    cmd->add_option("log", *log, "thermal log (thermal-log.md) or TALC log")
        ->required();
    cmd->add_option("-o,--output", *out, "model file (JSON) to write")
        ->required();
    cmd->add_option("--outputs", *outputs,
                    "outputs to model, comma separated (default: every d_)");
    cmd->add_option(
        "--model", o->model,
        "auto (default: joint, the method validated on the real data), "
        "select (chosen per output by chronological CV), static, fir, lag, "
        "arx, combined or joint");
    cmd->add_option("--json", *json_out, "also write a fit summary as JSON");
    AddFitOptions(cmd, o.get());
    cmd->callback([&global, cmd, log, out, outputs, json_out, o] {
      CheckFitOptions(*o, cmd);
      const models::TimeSeries ts = ReadLog(*log);
      Warn(global, ts.warnings);
      const std::vector<std::string> wanted = SplitList(*outputs);
      if (!outputs->empty() && wanted.empty())
        throw InputError("thermal fit", 0, "--outputs",
                         "names no column (give d_ columns, comma separated)");
      const models::ThermalModel model =
          models::FitThermalModel(ts, wanted, *o);
      Warn(global, model.fit_warnings);
      const nlohmann::json j = models::ModelToJson(model);
      std::string text;
      nlohmann::json summary = {{"log", *log}, {"model_file", *out}};
      for (const auto& m : model.outputs) {
        text += fmt::format(
            "{}: {} with {} regressors, CV RMS {:.3f} um, fit "
            "RMS {:.3f} um\n",
            m.output,
            m.label.empty() ? std::string(models::StructureName(m.structure))
                            : m.label,
            m.regressors.size(), m.cv_rms_um, m.fit_rms_um);
        std::vector<std::string> names;
        for (const auto& r : m.regressors) names.push_back(r.Name());
        summary["outputs"][m.output] = {
            {"structure", models::StructureName(m.structure)},
            {"candidate", m.label},
            {"selection", m.selection_log},
            {"regressors", names},
            {"cv_rms_um", m.cv_rms_um},
            {"fit_rms_um", m.fit_rms_um}};
      }
      summary["warnings"] = ts.warnings;
      for (const auto& w : model.fit_warnings) summary["warnings"].push_back(w);
      summary["fitted_jumps"] = j.at("fitted_jumps");
      OutputBatch outputs;  // the model and its summary, or neither
      outputs.Add(*out, JsonText(j, 2) + "\n");
      if (!json_out->empty())
        outputs.Add(*json_out, JsonText(summary, 2) + "\n");
      outputs.Commit();
      if (!global.quiet) WriteText("-", text);
    });
  }
  {
    auto* cmd = group->add_subcommand(
        "predict",
        "causal prediction of every modelled output from the "
        "inputs alone, at every row of the log");
    auto model_path = std::make_shared<std::string>();
    auto log = std::make_shared<std::string>();
    auto out = std::make_shared<std::string>();
    cmd->add_option("--model", *model_path, "model file from `thermal fit`")
        ->required();
    cmd->add_option("log", *log, "thermal log (outputs, if any, are ignored)")
        ->required();
    cmd->add_option("-o,--output", *out, "prediction CSV to write")->required();
    auto json_out = std::make_shared<std::string>();
    auto po = std::make_shared<models::PredictOptions>();
    cmd->add_option("--json", *json_out,
                    "also write a summary: per output the CV RMS of the fit, "
                    "inputs outside the fitted range, sensor jumps");
    cmd->add_flag("!--keep-jumps", po->repair_jumps,
                  "do not shift a jumping temperature sensor back by its "
                  "step (default: shift it; either way it is warned about)");
    cmd->callback([&global, model_path, log, out, json_out, po] {
      const nlohmann::json j = ReadJsonFile(*model_path);
      const models::ThermalModel model = models::ModelFromJson(j, *model_path);
      const models::TimeSeries ts = ReadLog(*log);
      const models::Prediction p = models::Predict(model, ts, *po);
      Warn(global, p.warnings);
      OutputBatch outputs;  // the prediction and its summary, or neither
      outputs.Add(*out, PredictionCsv(p));
      if (!json_out->empty())
        outputs.Add(*json_out, JsonText(PredictionSummaryJson(p), 2) + "\n");
      outputs.Commit();
      if (!global.quiet)
        std::fprintf(stderr, "%zu rows predicted (%s) -> %s\n", p.t_s.size(),
                     p.continued ? "continuing the fitted log"
                                 : "filters from the first row",
                     out->c_str());
    });
  }
  {
    auto* cmd = group->add_subcommand(
        "compare",
        "every structure side by side on a chronological holdout, "
        "and what the best and the simplest get wrong");
    auto log = std::make_shared<std::string>();
    auto from = std::make_shared<double>(0);
    auto json_out = std::make_shared<std::string>();
    auto o = std::make_shared<models::FitOptions>();
    cmd->add_option("log", *log, "thermal log with outputs")->required();
    cmd->add_option("--holdout-from", *from,
                    "fit on t_s below this (s), predict the rest")
        ->required();
    auto until =
        std::make_shared<double>(std::numeric_limits<double>::infinity());
    cmd->add_option("--holdout-until", *until,
                    "predict only the rows with t_s below this (s; default: "
                    "to the end of the log)");
    cmd->add_option("--json", *json_out, "also write the comparison as JSON");
    AddFitOptions(cmd, o.get());
    cmd->callback([&global, cmd, log, from, until, json_out, o] {
      CheckFitOptions(*o, cmd);
      if (!std::isfinite(*from))
        throw InputError("thermal compare", 0, "--holdout-from",
                         "must be a finite time (s)");
      if (!(*until > *from))
        throw InputError("thermal compare", 0, "--holdout-until",
                         "must be after --holdout-from");
      const models::TimeSeries ts = models::HeadOf(ReadLog(*log), *until);
      const models::CompareResult r = models::CompareModels(ts, *from, *o);
      if (!global.quiet || json_out->empty())
        WriteText("-", models::CompareText(r));
      if (!json_out->empty()) WriteJson(*json_out, models::CompareToJson(r));
    });
  }
}

}  // namespace
TTP_REGISTER_COMMANDS(45, RegisterThermalModels);
}  // namespace ttp::app
