#include "piece_drawing.h"

#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <string>

#include "ttp/geometry/features.h"

namespace ttp::report_internal {
namespace {

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos;
       pos = text.find(what, pos + 1)) {
    ++n;
  }
  return n;
}

TEST(PieceDrawing, DrawsEveryFacetAndStripInItsCycleColour) {
  const PartSpec part;
  const std::string svg = PieceSvg(part);
  EXPECT_EQ(Count(svg, "class=\"facet\""), 36);
  EXPECT_EQ(Count(svg, "class=\"strip\""), 9);
  EXPECT_EQ(Count(svg, "class=\"segment\""), 4);
  for (const NominalFeature& f : TestFeatures(part)) {
    // Each feature's tooltip names it and its cycle; its element carries the
    // cycle's colour.
    const std::string title =
        "<title>" + f.id + " - cycle " + std::to_string(f.cycle) + "</title>";
    const size_t at = svg.find(title);
    ASSERT_NE(at, std::string::npos) << f.id;
    const size_t element = svg.rfind('<', svg.rfind("<title>", at) - 1);
    const std::string tag = svg.substr(element, at - element);
    EXPECT_NE(tag.find(CycleColour(f.cycle)), std::string::npos) << tag;
  }
}

TEST(PieceDrawing, CycleColoursAreDistinct) {
  std::set<std::string> colours;
  for (int cycle = 0; cycle <= 8; ++cycle) colours.insert(CycleColour(cycle));
  EXPECT_EQ(colours.size(), 9u);
}

TEST(PieceDrawing, FollowsThePartSpec) {
  PartSpec part;
  part.segment_centre_deg = {45.0, 135.0, 225.0, 315.0};
  const std::string moved = PieceSvg(part);
  EXPECT_NE(moved, PieceSvg(PartSpec{}));
  // The facet X1-5 normal now points at 45 deg: its chord midpoint lies on
  // the diagonal (x = -svg_y).
  const std::regex facet(
      "x1=\"([-0-9.]+)\" y1=\"([-0-9.]+)\" x2=\"([-0-9.]+)\" "
      "y2=\"([-0-9.]+)\" stroke=\"[^\"]+\"><title>X1-5 ");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(moved, m, facet));
  const double mx = (std::stod(m[1]) + std::stod(m[3])) / 2;
  const double my = -(std::stod(m[2]) + std::stod(m[4])) / 2;
  EXPECT_NEAR(mx, my, 1e-2);
  EXPECT_NEAR(std::hypot(mx, my), part.facet_final_distance_mm, 1e-2);
}

}  // namespace
}  // namespace ttp::report_internal
