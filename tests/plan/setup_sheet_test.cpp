// The setup sheet's numbers are read back from the printed page (every
// number cell carries a data-key) and held against the config they came
// from, for a config whose values all differ from the defaults: nothing
// the profile holds may be printed from elsewhere. Dial positions are
// checked with test-piece.md's own rule (a W direction phi points along
// machine angle phi - c when c_sense = +1).
#include "ttp/plan/setup_sheet.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "test_dir.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"

namespace ttp::plan {
namespace {

std::map<std::string, double> Cells(const std::string& html) {
  std::map<std::string, double> out;
  const std::regex cell(R"re(data-key="([^"]+)">([-0-9.]+)<)re");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), cell);
       it != std::sregex_iterator(); ++it) {
    EXPECT_FALSE(out.count((*it)[1])) << "key twice: " << (*it)[1];
    out[(*it)[1]] = std::stod((*it)[2]);
  }
  return out;
}

Config Unusual() {
  return ConfigFromJson(nlohmann::json::parse(R"({
    "machine": {"table_top_z_mm": 12.5, "sphere_phi_deg": 30.0,
                "sphere_distance_mm": 170.0, "sphere_height_mm": 90.0,
                "sphere_radius_mm": 12.0, "sphere_stem_diameter_mm": 10.0,
                "c_sense": -1,
                "clamps": [{"phi_deg": 45, "r_inner_mm": 86, "r_outer_mm": 120,
                            "width_mm": 20, "height_mm": 18},
                           {"phi_deg": 225, "r_inner_mm": 86,
                            "r_outer_mm": 120, "width_mm": 20,
                            "height_mm": 18}]},
    "part": {"adapter_height_mm": 35.0},
    "process": {"finishing": {"number": 7, "length_mm": 72.5,
                              "stick_out_mm": 33.0},
                "probe": {"number": 21, "diameter_mm": 2.0}}
  })"),
                        "unusual.json");
}

TEST(SetupSheetTest, NumbersOnThePageAreTheConfigs) {
  const Config config = Unusual();
  const SetupSheet sheet = BuildSetupSheet(config);
  const std::string html = SetupSheetHtml(sheet);
  const auto cells = Cells(html);
  const auto at = [&](const std::string& k) {
    auto it = cells.find(k);
    if (it == cells.end()) {
      ADD_FAILURE() << "no cell " << k;
      return std::nan("");
    }
    return it->second;
  };
  // G54: on the C axis, at the top face: table + adapter + piece.
  EXPECT_EQ(at("g54-x"), 0.0);
  EXPECT_EQ(at("g54-y"), 0.0);
  EXPECT_NEAR(at("g54-z"), 12.5 + 35.0 + 24.0, 1e-3);
  // Tools: T, H, diameters, lengths, stick-out.
  const ProcessSpec& p = config.process;
  for (const ToolSpec* t : p.Tools()) {
    const std::string k = "tool-" + std::to_string(t->number) + "-";
    EXPECT_EQ(at(k + "t"), t->number);
    EXPECT_EQ(at(k + "h"), t->number);
    EXPECT_NEAR(at(k + "diameter"), t->diameter_mm, 1e-3);
    EXPECT_NEAR(at(k + "gauge-length"), t->length_mm, 1e-3);
    EXPECT_NEAR(at(k + "stick-out"), t->stick_out_mm, 1e-3);
  }
  EXPECT_NEAR(at("tool-7-gauge-length"), 72.5, 1e-3);
  EXPECT_NEAR(at("tool-7-stick-out"), 33.0, 1e-3);
  EXPECT_NEAR(at("tool-21-diameter"), 2.0, 1e-3);
  // Adapter and clamps.
  EXPECT_NEAR(at("adapter-height"), 35.0, 1e-3);
  EXPECT_NEAR(at("adapter-diameter"), config.part.adapter_diameter_mm, 1e-3);
  EXPECT_NEAR(at("clamp-2-phi"), 225.0, 0.05);
  EXPECT_NEAR(at("clamp-2-top-z"), 12.5 + 18.0, 0.05);
  EXPECT_EQ(cells.count("clamp-3-phi"), 0u);
  // Sphere at C = 0: 170 mm from the axis at 30 deg, 90 above the table.
  const double phi = 30.0 * M_PI / 180;
  EXPECT_NEAR(at("sphere-m-x"), 170 * std::cos(phi), 1e-3);
  EXPECT_NEAR(at("sphere-m-y"), 170 * std::sin(phi), 1e-3);
  EXPECT_NEAR(at("sphere-m-z"), 12.5 + 90.0, 1e-3);
  EXPECT_NEAR(at("sphere-w-z"), 90.0 - 35.0 - 24.0, 1e-3);
  EXPECT_NEAR(at("sphere-radius"), 12.0, 1e-3);
  // Dial gauge: with c_sense = -1 a W direction phi points along machine
  // angle phi + c, so the facet's normal is on +X at c = -phi.
  int facets = 0, strips = 0;
  for (const NominalFeature& f : TestFeatures(config.part)) {
    const std::string k = "dial-" + f.id + "-";
    if (f.kind == FeatureKind::kFacet) {
      ++facets;
      const double phi_f = std::atan2(f.normal.y(), f.normal.x()) * 180 / M_PI;
      const double c = std::fmod(std::fmod(-phi_f, 360.0) + 360.0, 360.0);
      EXPECT_NEAR(std::remainder(at(k + "c") - c, 360.0), 0.0, 1e-3) << f.id;
      EXPECT_NEAR(at(k + "x"), config.part.facet_final_distance_mm, 1e-3);
      EXPECT_NEAR(at(k + "y"), 0.0, 1e-3);
      EXPECT_NEAR(at(k + "z"), 12.5 + 35 + 24 + (f.z_min_mm + f.z_max_mm) / 2,
                  1e-3);
      EXPECT_NE(html.find(fmt::format("G90 G0 C{:.3f}", at(k + "c"))),
                std::string::npos);
    } else {
      ++strips;
      EXPECT_EQ(at(k + "c"), 0.0);
      EXPECT_NEAR(at(k + "y"), StripY(config.part, f.index), 1e-3);
    }
  }
  EXPECT_EQ(facets, 36);
  EXPECT_EQ(strips, 9);
  // One self-contained printable page.
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("src="), std::string::npos);
  EXPECT_EQ(html.find("http"), std::string::npos);
  EXPECT_NE(html.find("@media print"), std::string::npos);
  // The JSON holds the same numbers.
  const nlohmann::json j = SetupSheetToJson(sheet);
  EXPECT_NEAR(j["g54_m_mm"][2].get<double>(), at("g54-z"), 1e-3);
  EXPECT_EQ(j["tools"][3]["t"].get<int>(), 7);
  EXPECT_EQ(j["dial"].size(), 45u);
}

TEST(SetupSheetTest, NamesAreEscaped) {
  Config config;
  config.machine.name = "mill <A&B>";
  const std::string html = SetupSheetHtml(BuildSetupSheet(config));
  EXPECT_NE(html.find("mill &lt;A&amp;B&gt;"), std::string::npos);
}

// Printed by headless Chromium (no network): the page prints, on a few
// A4 pages.
TEST(BrowserTest, SetupSheetPrintsOnAFewPages) {
  const auto dir = test::TestDir("setup-sheet-print");
  const auto html = dir / "sheet.html";
  const auto pdf = dir / "sheet.pdf";
  WriteFileAtomic(html, SetupSheetHtml(BuildSetupSheet(Config{})));
  const std::string cmd =
      std::string("timeout 120 '") + TTP_CHROMIUM +
      "' --headless --no-sandbox --disable-gpu --no-first-run "
      "--disable-extensions --proxy-server=127.0.0.1:9 "
      "--no-pdf-header-footer --print-to-pdf='" +
      pdf.string() + "' 'file://" + html.string() + "' > '" +
      (dir / "chromium.log").string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(pdf, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  const std::string text = s.str();
  ASSERT_EQ(text.rfind("%PDF", 0), 0u);
  int pages = 0;
  for (size_t at = text.find("/Type /Page"); at != std::string::npos;
       at = text.find("/Type /Page", at + 1))
    pages += text.compare(at, 12, "/Type /Pages") != 0;
  EXPECT_GE(pages, 2);
  EXPECT_LE(pages, 6);
}

}  // namespace
}  // namespace ttp::plan
