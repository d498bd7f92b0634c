// A thermal model file (`ttp thermal fit -o`), read back and used to
// predict a small log, as `ttp thermal predict --model` does.
#include "fuzz_common.h"
#include "ttp/geometry/json_text.h"
#include "ttp/models/identify.h"
#include "ttp/models/time_series.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::models::TimeSeries log = ttp::models::ParseThermalLog(
      "# thermal-log: 1\n# start: 2024-01-01T00:00:00+00:00\n"
      "t_s,n_spindle,T_a,T_b,d_x\n"
      "0,0,20.0,20.1,0\n15,1000,20.1,20.1,0.5\n30,2000,20.3,20.2,1\n"
      "45,2000,20.6,20.2,1.2\n60,0,20.7,20.3,1.1\n75,0,20.6,20.3,0.9\n",
      "fuzz-log.csv");
  return ttp::fuzz::Run([&] {
    const nlohmann::json j =
        ttp::ParseJsonText(ttp::fuzz::Text(data, size), "fuzz.json");
    const ttp::models::ThermalModel model =
        ttp::models::ModelFromJson(j, "fuzz.json");
    ttp::models::Predict(model, log);
  });
}
