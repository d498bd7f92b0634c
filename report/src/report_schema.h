// Names shared by validation and rendering. Internal to ttp_report.
#pragma once

#include <array>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/geometry/config.h"

namespace ttp::report_internal {

inline const std::array<std::string, 5> kFigureKeys = {"E_X", "E_Y", "E_Z",
                                                       "E_B", "E_TTP"};
inline const std::array<std::string, 7> kRtestKeys = {
    "EX0C", "EY0C", "EZ0T", "ER0T", "EA0C", "EB0C", "EC0C"};

// The PartSpec of the data ("part" over the spec defaults).
PartSpec PartFromReportData(const nlohmann::json& report_data,
                            const std::string& source);

}  // namespace ttp::report_internal
