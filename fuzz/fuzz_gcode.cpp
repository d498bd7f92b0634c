// G-code programs, both dialects (the first byte chooses): read, check,
// convert and execute into canonical statements with the time model; the
// dialect also recognised from the text (--dialect auto).
#include "fuzz_common.h"
#include "ttp/gcode/reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::Config config;
  if (size == 0) return 0;
  const auto dialect = data[0] % 2 ? ttp::gcode::Dialect::kFanuc
                                   : ttp::gcode::Dialect::kLinuxCnc;
  const std::string text = ttp::fuzz::Text(data + 1, size - 1);
  ttp::fuzz::Run([&] { ttp::gcode::ResolveDialect(text, "fuzz.nc"); });
  return ttp::fuzz::Run(
      [&] { ttp::gcode::ReadProgram(text, dialect, config, "fuzz.nc"); });
}
