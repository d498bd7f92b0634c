// Cutting data for EN AW-6082 (AlMgSi1, T6) by tool material, and the
// check that every tool of the process cuts rather than rubs in the
// engagement the programs give it.
//
// | tool material | vc m/min  | fz mm/tooth | h_min mm |
// | ------------- | --------- | ----------- | -------- |
// | HSS           | 100 - 200 | 0.03 - 0.15 | 0.010    |
// | carbide       | 150 - 600 | 0.02 - 0.12 | 0.008    |
//
// (Ranges of the tool makers' tables for wrought Al-Mg-Si alloys; h_min is
// the minimum chip thickness below which the edge ploughs: about half the
// edge radius of a sharp ground edge.) The chip thickness of a side cut of
// radial engagement ae with a cutter of diameter D is
// h_max = fz * 2 sqrt(ae/D (1 - ae/D)) for ae < D/2, else fz.
#pragma once

#include <string>
#include <vector>

#include "ttp/geometry/config.h"

namespace ttp::cam {

struct CuttingDataRow {
  std::string tool_material;  // "HSS" or "carbide"
  double vc_min_m_min, vc_max_m_min;
  double fz_min_mm, fz_max_mm;
  double h_min_mm;  // minimum chip thickness
};
// The table above; nullptr for a material it has no row for.
const CuttingDataRow* CuttingDataFor(const std::string& tool_material);

// One tool's use in a program: its smallest radial engagement ae (mm) and
// the largest axial depth ap (mm).
struct ToolEngagement {
  std::string field;  // "finishing", "roughing"...: process.<field>
  const ToolSpec* tool;
  double ae_mm, ap_mm;
};
std::vector<ToolEngagement> Engagements(const Config& config);

// Cutting speed (m/min), feed per tooth (mm) and largest chip thickness
// (mm) of a tool at an engagement.
double CuttingSpeedMMin(const ToolSpec& tool);
double FeedPerToothMm(const ToolSpec& tool);
double MaxChipThicknessMm(const ToolSpec& tool, double ae_mm);

// Throws InputError(source, 0, "process.<tool>.spindle_rpm" or
// ".feed_mm_min", why) when a cutting tool runs outside its row of the
// table or its chip is thinner than h_min (rubbing). The engraver (a
// pointed tool cutting with its tip) is checked for vc only.
void CheckCuttingData(const Config& config, const std::string& source);

}  // namespace ttp::cam
