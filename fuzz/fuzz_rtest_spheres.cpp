// R-test sphere centres (`ttp rtest FILE`): the file read, and every cycle
// solved against the first, as the command does.
#include "fuzz_common.h"
#include "ttp/geometry/rtest.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return ttp::fuzz::Run([&] {
    const auto cycles =
        ttp::ParseSphereMeasurements(ttp::fuzz::Text(data, size), "fuzz.csv");
    const ttp::RTestGeometry geometry;
    for (size_t k = 1; k < cycles.size(); ++k)
      ttp::SolveRTest(geometry, cycles.front().positions, cycles[k].positions);
  });
}
