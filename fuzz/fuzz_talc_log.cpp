// The TALC log (talc-log.md).
#include "fuzz_common.h"
#include "ttp/thermal/talc_log.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return ttp::fuzz::Run([&] {
    const auto log =
        ttp::thermal::ParseTalcLog(ttp::fuzz::Text(data, size), "fuzz.csv");
    ttp::thermal::LogSummaryJson(log);
    ttp::thermal::LogSummaryText(log);
  });
}
