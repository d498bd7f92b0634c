#include "ttp/geometry/format.h"

#include <fmt/format.h>

#include <cmath>

namespace ttp {

std::string FormatNumber(double v, int decimals, const std::string& missing) {
  if (!std::isfinite(v)) return missing;
  std::string s;
  if (decimals >= 0) {
    s = fmt::format("{:.{}f}", v, decimals);
  } else {
    // Enough decimals for 6 significant digits, then trailing zeros off.
    const int magnitude =
        v == 0 ? 0 : static_cast<int>(std::floor(std::log10(std::abs(v))));
    const int d = std::max(0, std::min(12, 5 - magnitude));
    s = fmt::format("{:.{}f}", v, d);
    if (s.find('.') != std::string::npos) {
      s.erase(s.find_last_not_of('0') + 1);
      if (s.back() == '.') s.pop_back();
    }
  }
  if (s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos)
    s.erase(0, 1);
  return s;
}

}  // namespace ttp
