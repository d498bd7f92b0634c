// DMIS output: statements, then the features in W.
#include "fuzz_common.h"
#include "ttp/inspect/dmis.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::PartSpec part;
  return ttp::fuzz::Run([&] {
    const auto dmis =
        ttp::inspect::ParseDmisOutput(ttp::fuzz::Text(data, size), "fuzz.dmo");
    ttp::inspect::DmisToFeatureResults(dmis, part);
  });
}
