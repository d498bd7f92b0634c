#include "ttp/cam/cutting_data.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "ttp/geometry/error.h"

namespace ttp::cam {
namespace {

const CuttingDataRow kRows[] = {
    {"HSS", 100.0, 200.0, 0.03, 0.15, 0.010},
    {"carbide", 150.0, 600.0, 0.02, 0.12, 0.008},
};

}  // namespace

const CuttingDataRow* CuttingDataFor(const std::string& tool_material) {
  for (const CuttingDataRow& row : kRows)
    if (row.tool_material == tool_material) return &row;
  return nullptr;
}

std::vector<ToolEngagement> Engagements(const Config& c) {
  const PartSpec& p = c.part;
  const ProcessSpec& pr = c.process;
  // Roughing: its thinnest side cut is the finish pass of the big notch
  // walls (the allowance), or the facets' cut from the rim.
  const double rough_ae =
      std::min(pr.finish_allowance_mm > 0 ? pr.finish_allowance_mm
                                          : pr.roughing.diameter_mm,
               p.rim_diameter_mm / 2 - p.facet_pre_distance_mm);
  return {
      {"roughing", &pr.roughing, rough_ae, pr.roughing_step_down_mm},
      {"engraver", &pr.engraver, pr.engraver.diameter_mm, p.mark_depth_mm},
      {"notch", &pr.notch, pr.notch.diameter_mm, pr.roughing_step_down_mm},
      // Facets: the 0.1 mm left by pre-machining, over the facet height.
      {"finishing", &pr.finishing,
       p.facet_pre_distance_mm - p.facet_final_distance_mm,
       -p.facet_bottom_z_mm},
  };
}

double CuttingSpeedMMin(const ToolSpec& t) {
  return M_PI * t.diameter_mm * t.spindle_rpm / 1000.0;
}

double FeedPerToothMm(const ToolSpec& t) {
  return t.feed_mm_min / (t.flutes * t.spindle_rpm);
}

double MaxChipThicknessMm(const ToolSpec& t, double ae_mm) {
  const double fz = FeedPerToothMm(t);
  const double k = ae_mm / t.diameter_mm;
  if (k >= 0.5) return fz;
  return fz * 2 * std::sqrt(k * (1 - k));
}

void CheckCuttingData(const Config& c, const std::string& source) {
  for (const ToolEngagement& e : Engagements(c)) {
    const ToolSpec& t = *e.tool;
    const std::string f = "process." + e.field + ".";
    const CuttingDataRow* row = CuttingDataFor(t.material);
    if (!row)
      throw InputError(source, 0, f + "material",
                       fmt::format("no cutting data for tool material '{}' "
                                   "(HSS or carbide)",
                                   t.material));
    const double vc = CuttingSpeedMMin(t);
    if (vc < row->vc_min_m_min - 1e-9 || vc > row->vc_max_m_min + 1e-9)
      throw InputError(
          source, 0, f + "spindle_rpm",
          fmt::format("cutting speed {:.0f} m/min outside {:.0f}..{:.0f} m/min "
                      "for {} in EN AW-6082",
                      vc, row->vc_min_m_min, row->vc_max_m_min, t.material));
    if (t.tip_angle_deg > 0) continue;  // pointed tool: no side chip
    const double fz = FeedPerToothMm(t);
    if (fz < row->fz_min_mm - 1e-12 || fz > row->fz_max_mm + 1e-12)
      throw InputError(
          source, 0, f + "feed_mm_min",
          fmt::format("{:.4f} mm per tooth outside {}..{} mm for {}", fz,
                      row->fz_min_mm, row->fz_max_mm, t.material));
    const double h = MaxChipThicknessMm(t, e.ae_mm);
    if (h < row->h_min_mm)
      throw InputError(
          source, 0, f + "feed_mm_min",
          fmt::format("chip {:.4f} mm at ae {:.2f} mm is below the minimum "
                      "chip thickness {} mm: the edge rubs",
                      h, e.ae_mm, row->h_min_mm));
  }
}

}  // namespace ttp::cam
