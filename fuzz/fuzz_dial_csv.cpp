// Dial gauge readings CSV (feature,reading_um).
#include "fuzz_common.h"
#include "ttp/inspect/dial.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::PartSpec part;
  return ttp::fuzz::Run([&] {
    ttp::inspect::ReadDialReadings(ttp::fuzz::Text(data, size), "fuzz.csv",
                                   part);
  });
}
