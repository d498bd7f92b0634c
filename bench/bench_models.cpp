// Prints: read, fit (auto and each structure) and predict times of the
// thermal error models on the real FL spindle test (train.csv). Never fails.
#include <fmt/format.h>

#include <chrono>
#include <string>

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
  for (const std::string model :
       {"static", "fir", "lag", "arx", "combined", "auto"}) {
    FitOptions o;
    o.model = model;
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
  return 0;
}
