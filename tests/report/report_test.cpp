#include "ttp/report/report.h"

#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "synthetic_report_data.h"
#include "ttp/geometry/error.h"

namespace ttp {
namespace {

using nlohmann::json;

bool Has(const std::string& text, const std::string& what) {
  return text.find(what) != std::string::npos;
}

// The embedded data document, parsed back from the page.
json EmbeddedData(const std::string& html) {
  const std::string open = "<script type=\"application/json\" id=\"ttp-data\">";
  const size_t start = html.find(open);
  EXPECT_NE(start, std::string::npos);
  const size_t end = html.find("</script>", start);
  return json::parse(
      html.substr(start + open.size(), end - start - open.size()));
}

TEST(RenderReportHtml, HasEverySectionAndPlot) {
  const std::string html = RenderReportHtml(test::SyntheticReportData());
  for (const char* id : {"piece", "figures", "verdict", "log", "diagnosis"}) {
    EXPECT_TRUE(Has(html, std::string("<section id=\"") + id + "\"")) << id;
  }
  for (const char* plot :
       {"E_X", "E_Y", "E_Z", "E_B", "E_TTP", "temperatures", "c-speed",
        "rtest-linear", "rtest-angular", "residual-before", "residual-after"}) {
    EXPECT_TRUE(Has(html, std::string("data-plot=\"") + plot + "\"")) << plot;
  }
  EXPECT_FALSE(Has(html, "Not available"));
  EXPECT_TRUE(Has(html, "<svg class=\"piece\""));
  EXPECT_TRUE(Has(html, "workpiece_expansion"));
  EXPECT_TRUE(Has(html, "tau_wp_s"));
  EXPECT_TRUE(Has(html, "<td>s</td>"));  // the unit of tau_wp_s
  EXPECT_TRUE(Has(html, "log: gap of 12 min"));
  EXPECT_TRUE(Has(html, "ISO 14253-1"));
}

TEST(RenderReportHtml, EmbedsTheDataAndThePlottingLibrary) {
  const json data = test::SyntheticReportData();
  const std::string html = RenderReportHtml(data);
  EXPECT_EQ(EmbeddedData(html), data);
  EXPECT_TRUE(Has(html, "uPlot"));
  EXPECT_GT(html.size(), 50000u);  // uPlot's minified file is ~50 kB
}

TEST(RenderReportHtml, LoadsNothingFromOutside) {
  const std::string html = RenderReportHtml(test::SyntheticReportData());
  // No element or stylesheet that fetches: the page must open offline.
  const std::regex external(
      R"((src|href|srcset|action|poster|data)\s*=\s*["']?\s*(https?:)?//|url\(\s*["']?\s*(https?:)?//|@import|<link\b|<iframe\b|<object\b|<embed\b|\bimport\s*\(|fetch\(|XMLHttpRequest)",
      std::regex::icase);
  std::smatch hit;
  EXPECT_FALSE(std::regex_search(html, hit, external)) << hit.str();
  // The check itself catches a fetched script.
  EXPECT_TRUE(std::regex_search(
      std::string("<script src=\"https://cdn.example/uplot.js\">"), external));
}

TEST(RenderReportHtml, IsDeterministic) {
  EXPECT_EQ(RenderReportHtml(test::SyntheticReportData()),
            RenderReportHtml(test::SyntheticReportData()));
}

TEST(RenderReportHtml, ShowsAbsentSectionsAsNotAvailable) {
  const std::string html = RenderReportHtml(json{{"schema", kReportSchema}});
  for (const char* id : {"piece", "figures", "verdict", "log", "diagnosis"}) {
    EXPECT_TRUE(Has(html, std::string("<section id=\"") + id + "\"")) << id;
  }
  EXPECT_TRUE(Has(html, "Not available: no measured or simulated figures"));
  EXPECT_TRUE(Has(html, "Not available: no measured figures to grade"));
  EXPECT_TRUE(Has(html, "Not available: no TALC log"));
  EXPECT_TRUE(Has(html, "Not available: no diagnosis"));
  EXPECT_FALSE(Has(html, "data-plot="));
  // The piece is always drawn, from the spec defaults.
  EXPECT_TRUE(Has(html, "<svg class=\"piece\""));
}

TEST(RenderReportHtml, VerdictFollowsTheDecisionRule) {
  json data = test::SyntheticReportData();
  data.erase("grade");  // without a grading, the page applies the rule
  for (json& entry : data["figures"]["measured"]) {
    for (const char* key : {"E_X", "E_Y", "E_Z", "E_TTP"}) entry[key] = 1.0;
    entry["E_B"] = 2.0;
  }
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"pass\""));
  data["figures"]["measured"][6]["E_Z"] = -4.5;  // 4.5 +- 0.8 at a 5 um limit
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"undecidable\""));
  data["figures"]["measured"][2]["E_B"] = 30.0;  // 30 +- 8 at 15 um/m
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"fail\""));
  data["limits"]["angular_um_per_m"] = 40.0;
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"undecidable\""));
  data["limits"]["angular_um_per_m"] = 100.0;
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"undecidable\""));
  data["figures"]["measured"][6]["E_Z"] = -1.0;
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"pass\""));
  // A missing value leaves conformance unproven (as `ttp grade`).
  data["figures"]["measured"][4]["E_X"] = nullptr;
  data["figures"]["measured"][4]["U"]["E_X"] = nullptr;
  EXPECT_TRUE(Has(RenderReportHtml(data), "data-verdict=\"undecidable\""));
}

TEST(RenderReportHtml, OverallVerdictComesFromTheGrading) {
  json data = test::SyntheticReportData();
  for (const char* verdict : {"pass", "fail", "undecidable"}) {
    data["grade"]["verdict"] = verdict;
    EXPECT_TRUE(Has(RenderReportHtml(data),
                    std::string("data-verdict=\"") + verdict + "\""));
  }
}

TEST(RenderReportHtml, EscapesTextAndScriptEnds) {
  json data = test::SyntheticReportData();
  data["title"] = "A & B <run>";
  data["diagnosis"]["summary"] = "</script><script>alert(1)</script>";
  const std::string html = RenderReportHtml(data);
  EXPECT_TRUE(Has(html, "A &amp; B &lt;run&gt;"));
  EXPECT_FALSE(Has(html, "</script><script>alert(1)"));
  EXPECT_EQ(EmbeddedData(html), data);
}

TEST(RenderReportHtml, RejectsInvalidData) {
  json data = test::SyntheticReportData();
  data["log"]["cuts"][3]["feature"] = 7;
  try {
    RenderReportHtml(data);
    FAIL() << "accepted a numeric feature name";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "log.cuts[3].feature");
  }
}

}  // namespace
}  // namespace ttp
