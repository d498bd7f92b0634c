// Top view of the finished piece (seen from +Z, X right, Y up), drawn from
// the PartSpec so that a user's own geometry is what the report shows.
#include "piece_drawing.h"

#include <fmt/format.h>

#include <cmath>
#include <string>

#include "ttp/geometry/constants.h"
#include "ttp/geometry/features.h"

namespace ttp::report_internal {
namespace {

// SVG y grows downwards; W's y grows upwards.
std::string Pt(double x, double y) {
  return fmt::format("{:.3f},{:.3f}", x, -y);
}

}  // namespace

const char* CycleColour(int cycle) {
  // Cycle 0 (reference) in near-black; cycles 1..8 in a categorical palette
  // (Tableau 10) so neighbouring cycles stay distinguishable.
  static const char* const kColours[9] = {"#222222", "#1f77b4", "#ff7f0e",
                                          "#2ca02c", "#d62728", "#9467bd",
                                          "#8c564b", "#e377c2", "#17becf"};
  return kColours[(cycle >= 0 && cycle <= 8) ? cycle : 0];
}

std::string PieceSvg(const PartSpec& part) {
  const double outer_r = part.ref_cylinders.empty()
                             ? part.blank_diameter_mm / 2
                             : part.ref_cylinders.back().diameter_mm / 2;
  const double floor_r = part.ref_cylinders.empty()
                             ? outer_r
                             : part.ref_cylinders.front().diameter_mm / 2;
  const double half = outer_r + 18.0;
  std::string svg = fmt::format(
      "<svg class=\"piece\" xmlns=\"http://www.w3.org/2000/svg\" "
      "viewBox=\"{:.1f} {:.1f} {:.1f} {:.1f}\" role=\"img\" "
      "aria-label=\"Top view of the test piece\">\n",
      -half, -half, 2 * half, 2 * half);
  // Quadrants left standing by the two notches: clip for the segments.
  const double big = part.big_notch_half_width_mm;
  const double small = part.small_notch_half_width_mm;
  svg += "<defs><clipPath id=\"segments-clip\">";
  for (int sx : {-1, 1}) {
    for (int sy : {-1, 1}) {
      const double x0 = sx > 0 ? small : -half, y0 = sy > 0 ? half : -big;
      svg += fmt::format(
          "<rect x=\"{:.3f}\" y=\"{:.3f}\" width=\"{:.3f}\" "
          "height=\"{:.3f}\"/>",
          x0, -y0, half - small, half - big);
    }
  }
  svg += "</clipPath></defs>\n";
  // Lower reference cylinder (outline) and the big-notch floor.
  svg += fmt::format(
      "<circle cx=\"0\" cy=\"0\" r=\"{:.3f}\" class=\"cyl\"/>\n"
      "<circle cx=\"0\" cy=\"0\" r=\"{:.3f}\" class=\"floor\"/>\n",
      outer_r, floor_r);
  // Strips on the big-notch floor, coloured by the cycle that cuts them.
  for (int k = 1; k <= part.facets_per_segment; ++k) {
    const double y = StripY(part, k);
    const double w = part.strip_width_mm / 2;
    const double y_edge = std::min(std::abs(y) + w, floor_r);
    const double x_max =
        std::sqrt(std::max(0.0, floor_r * floor_r - y_edge * y_edge));
    const int cycle = CycleForIndex(part, k);
    svg += fmt::format(
        "<rect class=\"strip\" x=\"{:.3f}\" y=\"{:.3f}\" width=\"{:.3f}\" "
        "height=\"{:.3f}\" fill=\"{}\"><title>{} - cycle {}</title></rect>\n",
        -x_max, -(y + w), 2 * x_max, 2 * w, CycleColour(cycle), StripId(k),
        cycle);
    svg += fmt::format(
        "<text class=\"lbl small\" x=\"{:.3f}\" y=\"{:.3f}\">{}</text>\n",
        -x_max + 9, -y + 1.2, StripId(k));
  }
  // Small notch across the floor.
  svg += fmt::format(
      "<rect class=\"notch\" x=\"{:.3f}\" y=\"{:.3f}\" width=\"{:.3f}\" "
      "height=\"{:.3f}\"/>\n",
      -small, -outer_r, 2 * small, 2 * outer_r);
  // Segments: top faces (facet wedges, clipped by the notches) then facets.
  const double facet_d = part.facet_final_distance_mm;
  const double half_step = part.facet_step_deg / 2 * kDeg;
  const double corner_r = facet_d / std::cos(half_step);
  svg += "<g clip-path=\"url(#segments-clip)\">\n";
  for (Segment s : kSegments) {
    std::string points = "0,0";
    for (int j = 1; j <= part.facets_per_segment; ++j) {
      const double phi = FacetPhiDeg(part, s, j) * kDeg;
      points += " " + Pt(corner_r * std::cos(phi - half_step),
                         corner_r * std::sin(phi - half_step));
      points += " " + Pt(corner_r * std::cos(phi + half_step),
                         corner_r * std::sin(phi + half_step));
    }
    svg += fmt::format("<polygon class=\"segment\" points=\"{}\"/>\n", points);
    for (int j = 1; j <= part.facets_per_segment; ++j) {
      const double phi = FacetPhiDeg(part, s, j) * kDeg;
      const int cycle = CycleForIndex(part, j);
      svg += fmt::format(
          "<line class=\"facet\" x1=\"{:.3f}\" y1=\"{:.3f}\" x2=\"{:.3f}\" "
          "y2=\"{:.3f}\" stroke=\"{}\"><title>{} - cycle {}</title></line>\n",
          corner_r * std::cos(phi - half_step),
          -corner_r * std::sin(phi - half_step),
          corner_r * std::cos(phi + half_step),
          -corner_r * std::sin(phi + half_step), CycleColour(cycle),
          FacetId(s, j), cycle);
    }
  }
  svg += "</g>\n";
  // Facet index labels outside the rim, segment names inside.
  for (Segment s : kSegments) {
    for (int j = 1; j <= part.facets_per_segment; ++j) {
      const double phi = FacetPhiDeg(part, s, j) * kDeg;
      svg += fmt::format(
          "<text class=\"lbl small\" x=\"{:.3f}\" y=\"{:.3f}\" "
          "fill=\"{}\">{}</text>\n",
          (outer_r + 6) * std::cos(phi), -(outer_r + 6) * std::sin(phi) + 1.2,
          CycleColour(CycleForIndex(part, j)), j);
    }
    const double centre = part.segment_centre_deg[static_cast<int>(s)] * kDeg;
    svg += fmt::format(
        "<text class=\"lbl seg\" x=\"{:.3f}\" y=\"{:.3f}\">{}</text>\n",
        78 * std::cos(centre), -78 * std::sin(centre) + 2.5, SegmentName(s));
  }
  // Engraved mark.
  const double mark = part.mark_phi_deg * kDeg;
  svg += fmt::format(
      "<line class=\"mark\" x1=\"{:.3f}\" y1=\"{:.3f}\" x2=\"{:.3f}\" "
      "y2=\"{:.3f}\"><title>engraved mark</title></line>\n",
      part.mark_r_start_mm * std::cos(mark),
      -part.mark_r_start_mm * std::sin(mark),
      part.mark_r_end_mm * std::cos(mark),
      -part.mark_r_end_mm * std::sin(mark));
  // W axes.
  svg +=
      "<g class=\"axes\"><line x1=\"0\" y1=\"0\" x2=\"30\" y2=\"0\"/>"
      "<line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"-30\"/>"
      "<text class=\"lbl small\" x=\"34\" y=\"1.5\">X</text>"
      "<text class=\"lbl small\" x=\"0\" y=\"-33\">Y</text></g>\n";
  svg += "</svg>\n";
  return svg;
}

}  // namespace ttp::report_internal
