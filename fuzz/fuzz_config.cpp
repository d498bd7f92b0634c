// Config files, TOML or JSON (the first byte chooses).
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "fuzz_common.h"
#include "ttp/geometry/config.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const bool json = size > 0 && data[0] == '{';
  static const std::string stem = (std::filesystem::temp_directory_path() /
                                   ("ttp-fuzz-" + std::to_string(::getpid())))
                                      .string();
  const std::filesystem::path path = stem + (json ? ".json" : ".toml");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data),
              static_cast<std::streamsize>(size));
  }
  return ttp::fuzz::Run([&] { ttp::LoadConfig(path); });
}
