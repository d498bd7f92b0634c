// Probe results (CSV point_id,x,y,z,c_deg[,feature,pass] or the FANUC
// probing log) against the default plan.
#include "fuzz_common.h"
#include "ttp/inspect/probe.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::Config config;
  return ttp::fuzz::Run([&] {
    ttp::inspect::ReadProbeResults(config, ttp::fuzz::Text(data, size),
                                   "fuzz.csv");
  });
}
