// Numeric constants shared by every module (one definition, so that the
// sources of a module can be compiled together: CMAKE_UNITY_BUILD).
#pragma once

#include <limits>

namespace ttp {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDeg = kPi / 180.0;  // one degree in radians
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace ttp
