// The thermal test log of the models (thermal-log.md).
#include "fuzz_common.h"
#include "ttp/models/time_series.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return ttp::fuzz::Run([&] {
    ttp::models::ParseThermalLog({reinterpret_cast<const char*>(data), size},
                                 "fuzz.csv");
  });
}
