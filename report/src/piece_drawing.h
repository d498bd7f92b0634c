// SVG drawing of the finished piece seen from +Z, built from the PartSpec:
// segments, facets and strips, each test feature coloured by the cycle
// that cuts it. Internal to ttp_report.
#pragma once

#include <string>

#include "ttp/geometry/config.h"

namespace ttp::report_internal {

// Colour of test cycle 0..8 (shared by the drawing and the plots).
const char* CycleColour(int cycle);

std::string PieceSvg(const PartSpec& part);

}  // namespace ttp::report_internal
