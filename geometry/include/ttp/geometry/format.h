// One number formatter for text shown to a person (tables, the report):
// fixed point, never "-0.000", "nan" or "1e+02".
#pragma once

#include <string>

namespace ttp {

// `decimals` >= 0: fixed point with that many decimals ("-0.000" -> "0.000").
// decimals < 0: the shortest fixed-point text of up to 6 significant digits
// (15, 2.5, 0.0012). A NaN or infinity is `missing` ("-" by default).
std::string FormatNumber(double v, int decimals,
                         const std::string& missing = "-");

}  // namespace ttp
