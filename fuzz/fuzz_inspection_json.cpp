// An inspection JSON (per-feature results or figures) through
// LoadMeasurement, which reads files: the input goes to a file first.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "fuzz_common.h"
#include "ttp/inspect/measurement.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::Config config;
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() /
      ("ttp-fuzz-" + std::to_string(::getpid()) + ".json");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data),
              static_cast<std::streamsize>(size));
  }
  return ttp::fuzz::Run([&] { ttp::inspect::LoadMeasurement(config, path); });
}
