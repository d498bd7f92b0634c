// Prints: read, fit (auto and each structure) and predict times of the
// thermal error models on the real FL spindle test (train.csv). Never fails.
#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <string>
#include <utility>

#include "ttp/models/identify.h"
#include "ttp/models/time_series.h"

#ifndef TTP_DATA_DIR
#define TTP_DATA_DIR "."
#endif

using namespace ttp::models;

namespace {
double Seconds(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a)
      .count();
}
}  // namespace

int main() {
  const std::string path =
      std::string(TTP_DATA_DIR) + "/reference/fl-thermal/train.csv";
  auto t0 = std::chrono::steady_clock::now();
  TimeSeries ts;
  try {
    ts = ReadThermalLog(path);
  } catch (const std::exception& e) {
    fmt::print("bench_models: cannot read {}: {}\n", path, e.what());
    return 0;
  }
  fmt::print("read train.csv ({} rows, {} inputs, {} outputs): {:.1f} ms\n",
             ts.rows(), ts.input_names.size(), ts.output_names.size(),
             1e3 * Seconds(t0));
  for (const std::string model : {"static", "fir", "lag", "arx", "combined",
                                  "joint", "auto", "auto+sel"}) {
    FitOptions o;
    o.model = model == "auto+sel" ? "auto" : model;
    o.auto_selected = model == "auto+sel";
    t0 = std::chrono::steady_clock::now();
    const ThermalModel m = FitThermalModel(ts, {}, o);
    const double fit_s = Seconds(t0);
    t0 = std::chrono::steady_clock::now();
    const Prediction p = Predict(m, ts);
    const double pred_s = Seconds(t0);
    fmt::print(
        "{:<9} fit 5 outputs: {:7.1f} ms   predict {} rows: {:6.2f} ms\n",
        model, 1e3 * fit_s, p.t_s.size(), 1e3 * pred_s);
  }
  // Both chronological splits: RMS (um) of auto and the references on the
  // holdout, and auto's choice per output.
  for (const auto& split : {std::pair<double, double>{54000, 1e300},
                            std::pair<double, double>{36000, 54000}}) {
    const TimeSeries part = HeadOf(ts, split.second);
    const TimeSeries fit = HeadOf(part, split.first);
    fmt::print(
        "\nfit t_s < {:g}, predict to {:g}: RMS um (none / static all "
        "T / lags n,n^2 / joint 3600 / auto)\n",
        split.first, part.t_s.back());
    FitOptions o;
    t0 = std::chrono::steady_clock::now();
    for (size_t j = 0; j < part.output_names.size(); ++j) {
      const int jj = static_cast<int>(j);
      auto rms = [&](const Eigen::VectorXd& p) {
        double s = 0;
        int n = 0;
        for (size_t i = 0; i < part.rows(); ++i)
          if (part.t_s[i] >= split.first &&
              std::isfinite(part.outputs_um(i, jj))) {
            const double r = part.outputs_um(i, jj) - p(i);
            s += r * r, ++n;
          }
        return std::sqrt(s / std::max(1, n));
      };
      OutputModel lag;
      lag.cv_score = 1e300;
      for (double tau : o.taus_s) {
        OutputModel m = FitFixed(fit, jj, SpeedLagRegressors(fit, {tau}),
                                 Structure::kLag, o);
        if (m.cv_score < lag.cv_score) lag = m;
      }
      const OutputModel a = FitAuto(fit, jj, o);
      fmt::print(
          "{}: {:6.2f} {:6.2f} {:6.2f} {:6.2f} {:6.2f}  auto = {}\n",
          part.output_names[j],
          rms(Eigen::VectorXd::Zero(static_cast<Eigen::Index>(part.rows()))),
          rms(PredictOutput(FitFixed(fit, jj, AllTemperatureRegressors(fit),
                                     Structure::kStatic, o),
                            part)),
          rms(PredictOutput(lag, part)),
          rms(PredictOutput(FitOutput(fit, jj, Structure::kJoint, o), part)),
          rms(PredictOutput(a, part)), a.label);
    }
    fmt::print("({:.1f} s)\n", Seconds(t0));
  }
  return 0;
}
