// Shared by the libFuzzer targets: every parser either returns or throws
// ttp::InputError (the input's fault). Any other exception, a crash or a
// sanitizer report is a bug: the exception escapes and libFuzzer saves the
// input (fuzz/README.md turns it into a regression test).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "ttp/geometry/error.h"

namespace ttp::fuzz {

inline std::string Text(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

template <typename F>
int Run(F&& parse) {
  try {
    parse();
  } catch (const InputError&) {
    // Bad input, reported as such: the expected outcome.
  }
  return 0;
}

}  // namespace ttp::fuzz
