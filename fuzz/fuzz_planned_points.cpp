// A plan's point list (`ttp plan probe --points-csv`, `ttp plan cmm`'s
// cmm_points.csv), which --probe-points and --cmm-points read back.
#include "fuzz_common.h"
#include "ttp/plan/plan.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return ttp::fuzz::Run([&] {
    ttp::plan::PointsFromCsv(ttp::fuzz::Text(data, size), "fuzz.csv");
  });
}
