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
  EXPECT_TRUE(Has(html, "Not available: no grade of the measured figures"));
  EXPECT_TRUE(Has(html, "Not available: no TALC log"));
  EXPECT_TRUE(Has(html, "Not available: no diagnosis"));
  EXPECT_FALSE(Has(html, "data-plot="));
  // The piece is always drawn, from the spec defaults.
  EXPECT_TRUE(Has(html, "<svg class=\"piece\""));
}

// The page decides nothing: each cell shows the verdict the grade gave it
// and the figures not decided are listed with their reason.
TEST(RenderReportHtml, VerdictTableIsTheGivenGrade) {
  json data = test::SyntheticReportData();
  data["grade"]["values"] = {{{"cycle", 1},
                              {"figure", "E_X"},
                              {"unit", "um"},
                              {"value", 4.5},
                              {"u_expanded", 0.8},
                              {"limit", 5.0},
                              {"verdict", "fail"}},  // not what the rule says
                             {{"cycle", 1},
                              {"figure", "E_B"},
                              {"unit", "um/m"},
                              {"value", -0.0001},
                              {"u_expanded", 16.0},
                              {"limit", 15.0},
                              {"verdict", "not_decidable"}}};
  data["grade"]["figures"] = {{{"figure", "E_B"},
                               {"unit", "um/m"},
                               {"limit", 15.0},
                               {"decided", false},
                               {"verdict", nullptr},
                               {"reason", "U up to 16.0 um/m"},
                               {"max_u_expanded", 16.0}}};
  const std::string html = RenderReportHtml(data);
  EXPECT_TRUE(Has(html, "<td class=\"fail\">4.50 &plusmn; 0.80</td>"));
  // No "-0.00".
  EXPECT_TRUE(
      Has(html, "<td class=\"not_decidable\">0.00 &plusmn; 16.00</td>"));
  EXPECT_TRUE(Has(html, "<b>E_B</b>: U up to 16.0 um/m"));
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
