// The reports of the sample runs (samples/: a cloud, dial, DMIS and probe
// measurement, with and without the TALC log, and the comparison of two
// pieces) and of the real thermal log, built by the `ttp report` binary,
// opened in headless Chromium with no network. Every uPlot instance must have
// drawn every data point of its series inside its plot area (the page's draw
// hook counts them from uPlot's own data and scales into data-points), the page
// must log nothing to the console and report no script error, and a screenshot
// is saved to <build>/docs/report.png (copied into docs/report.png for the
// README).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>

#include "run_ttp.h"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

using ttp::test::RunCommand;
using ttp::test::RunResult;

int Finite(const json& column) {
  int n = 0;
  for (const json& v : column)
    n += v.is_number() && std::isfinite(v.get<double>());
  return n;
}

// What each plot must show: the finite values of the series it draws.
std::map<std::string, int> ExpectedPoints(const json& data) {
  std::map<std::string, int> out;
  std::map<int, const json*> meas, sim;
  const json none = json::array();
  const json& figures = data.contains("figures") ? data["figures"] : data;
  const json measured = figures.value("measured", none);
  const json simulated = figures.value("simulated", none);
  const json linear = figures.value("simulated_linear", none);
  for (const json& e : measured) meas[e["cycle"]] = &e;
  for (const json& e : simulated) sim[e["cycle"]] = &e;
  for (const char* key : {"E_X", "E_Y", "E_Z", "E_B", "E_TTP"}) {
    int n = 0;
    for (const auto& [c, e] : meas) n += Finite(json::array({(*e)[key]}));
    for (const auto& [c, e] : sim) n += Finite(json::array({(*e)[key]}));
    for (const json& e : linear) {
      n += Finite(json::array({e[key]}));
    }
    out[key] = n;
  }
  if (!data.contains("log")) return out;
  const json& samples = data["log"]["samples"];
  int temps = 0;
  for (const char* key : {"T_env", "T_ws", "T_mwf", "dT_cool"}) {
    if (samples.contains(key)) temps += Finite(samples[key]);
  }
  out["temperatures"] = temps;
  out["c-speed"] = Finite(samples["c_rpm"]);
  const json& rtests = data["log"]["rtests"];
  out["rtest-linear"] = Finite(rtests["EX0C"]) + Finite(rtests["EY0C"]) +
                        Finite(rtests["EZ0T"]) + Finite(rtests["ER0T"]);
  out["rtest-angular"] =
      Finite(rtests["EA0C"]) + Finite(rtests["EB0C"]) + Finite(rtests["EC0C"]);
  if (!data.contains("diagnosis")) return out;
  const json& r = data["diagnosis"]["residuals"];
  for (const char* which : {"before", "after"}) {
    int n = 0;
    for (const auto& [key, column] : r[which].items()) n += Finite(column);
    out[std::string("residual-") + which] = n;
  }
  return out;
}

// Each test writes in a folder of its own, made by the test itself: ctest
// runs every test in a process of its own, in parallel, so a folder made
// for the whole suite would be emptied by the next test's start.
class BrowserTest : public ::testing::Test {
 public:
  // Chromium headless, no network: a dead proxy, unresolvable hosts, a
  // fresh profile, no background services. stderr carries the console.
  // `profile`: a folder of the calling test's own (ctest runs the tests in
  // parallel).
  static RunResult Chromium(const std::string& args, const fs::path& profile) {
    fs::remove_all(profile);
    return RunCommand(
        std::string("timeout 120 ") + TTP_CHROMIUM +
        " --headless --no-sandbox --disable-gpu"
        " --user-data-dir=" +
        ttp::test::ShellQuoted(profile) +
        " --proxy-server=127.0.0.1:9"
        " --host-resolver-rules='MAP * ~NOTFOUND'"
        " --disable-background-networking --disable-component-update"
        " --disable-sync --no-first-run --disable-extensions"
        " --enable-logging=stderr --v=0"
        " --hide-scrollbars --virtual-time-budget=10000 " +
        args + " 2>&1");
  }
};

// Chromium's output for a page (console lines and the dumped DOM): nothing
// logged, no uncaught error, and the page's script marked itself done
// without marking an error.
void CheckPageRanClean(const std::string& output) {
  std::string console;
  std::istringstream lines(output);
  for (std::string line; std::getline(lines, line);) {
    if (line.find(":CONSOLE") != std::string::npos ||
        line.find("Uncaught") != std::string::npos) {
      console += line + "\n";
    }
  }
  EXPECT_TRUE(console.empty()) << "the page logged:\n" << console;
  EXPECT_NE(output.find("data-plots-done=\"1\""), std::string::npos)
      << "the plotting script did not finish";
  EXPECT_EQ(output.find("data-js-error=\"1\""), std::string::npos);
}

// uPlot instances in a dumped DOM.
size_t UplotInstances(const std::string& dom) {
  size_t n = 0;
  for (size_t p = dom.find("class=\"uplot"); p != std::string::npos;
       p = dom.find("class=\"uplot", p + 1))
    ++n;
  return n;
}

// Opens `html` in Chromium and checks that every plot drew every point
// of `expected` (plot name -> points), that nothing was logged to the
// console and that no script error was raised.
void CheckPageDrawsEverything(const fs::path& html,
                              const std::map<std::string, int>& expected,
                              const std::string& verdict,
                              std::string* dom_out) {
  const std::string page = ttp::test::FileBytes(html);

  // Self-contained: nothing is fetched (scripts, styles, images, fonts).
  const std::regex external(
      R"((src|href|srcset|action|poster|data)\s*=\s*["']?\s*(https?:)?//|url\(\s*["']?\s*(https?:)?//|@import|<link\b|<iframe\b|<object\b|<embed\b|\bimport\s*\(|fetch\(|XMLHttpRequest)",
      std::regex::icase);
  std::smatch hit;
  EXPECT_FALSE(std::regex_search(page, hit, external))
      << "external reference: " << hit.str();

  const RunResult dom = BrowserTest::Chromium(
      "--window-size=1280,1000 --dump-dom " +
          ttp::test::ShellQuoted("file://" + fs::absolute(html).string()),
      html.parent_path() / "profile");
  ASSERT_EQ(dom.exit_code, 0) << dom.output;
  *dom_out = dom.output;
  CheckPageRanClean(dom.output);
  EXPECT_NE(dom.output.find("<div id=\"js-errors\"></div>"), std::string::npos)
      << "script errors shown on the page";

  // Every plot: drawn by uPlot, with all its points inside the plot area.
  std::map<std::string, int> drawn;
  const std::regex plot_tag(R"re(<div[^>]*\bdata-plot="([^"]+)"[^>]*>)re");
  const std::regex points_attr(R"re(data-points="(\d+)")re");
  for (auto it =
           std::sregex_iterator(dom.output.begin(), dom.output.end(), plot_tag);
       it != std::sregex_iterator(); ++it) {
    const std::string tag = it->str(0);
    std::smatch m;
    drawn[it->str(1)] =
        std::regex_search(tag, m, points_attr) ? std::stoi(m.str(1)) : -1;
  }
  EXPECT_EQ(drawn.size(), expected.size());
  for (const auto& [plot, n] : expected) {
    ASSERT_TRUE(drawn.count(plot)) << "plot " << plot << " missing";
    EXPECT_GT(n, 0) << "plot " << plot << " has no data";
    EXPECT_EQ(drawn[plot], n) << "plot " << plot;
  }
  EXPECT_EQ(UplotInstances(dom.output), expected.size())
      << "uPlot instances in the page";
  EXPECT_NE(dom.output.find("data-verdict=\"" + verdict + "\""),
            std::string::npos);
}

TEST_F(BrowserTest, SampleRunReportDrawsEveryPlotOffline) {
  ASSERT_TRUE(fs::exists(TTP_CHROMIUM))
      << "Chromium not found (" << TTP_CHROMIUM
      << "): install the Debian packages chromium and chromium-driver "
         "(scripts/install-deps.sh)";
  const fs::path dir = fs::path(TTP_BINARY_DIR) / "report_browser" / "run-a";
  fs::remove_all(dir);
  fs::create_directories(dir);
  // Made from the repository root with relative paths, as the README shows
  // it: the page names no build machine's folder.
  const fs::path html = fs::absolute(dir / "run-a.html");
  const fs::path data_path = fs::absolute(dir / "run-a.json");
  const RunResult report = RunCommand(
      "cd " + ttp::test::ShellQuoted(TTP_DATA_DIR) + " && " +
      std::string(TTP_BINARY_DIR) +
      "/app/ttp report --log samples/run-a/talc.csv samples/run-a/piece.ply"
      " -o " +
      ttp::test::ShellQuoted(html) + " --json " +
      ttp::test::ShellQuoted(data_path) + " 2>&1");
  ASSERT_EQ(report.exit_code, 1) << report.output;  // run-a fails
  const json data = json::parse(ttp::test::FileBytes(data_path));
  std::string dom;
  CheckPageDrawsEverything(html, ExpectedPoints(data),
                           data["grade"]["verdict"].get<std::string>(), &dom);
  EXPECT_NE(dom.find("id=\"cause\">" +
                     data["diagnosis"]["cause"].get<std::string>() + "<"),
            std::string::npos);
  EXPECT_EQ(ttp::test::FileBytes(html).find(TTP_DATA_DIR), std::string::npos)
      << "the page names the build machine's folder";

  // The screenshot for the README.
  const fs::path png = fs::path(TTP_BINARY_DIR) / "docs" / "report.png";
  fs::create_directories(png.parent_path());
  fs::remove(png);
  const RunResult shot = Chromium(
      "--window-size=1280,2600 --screenshot=" + ttp::test::ShellQuoted(png) +
          " " + ttp::test::ShellQuoted("file://" + fs::absolute(html).string()),
      dir / "profile");
  ASSERT_EQ(shot.exit_code, 0) << shot.output;
  ASSERT_TRUE(fs::exists(png)) << shot.output;
  const std::string image = ttp::test::FileBytes(png);
  EXPECT_EQ(image.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_GT(image.size(), 50000u);  // a drawn page, not a blank one
}

// The page of a thermal log (the real spindle data): the comparison of the
// model structures (measured and predicted, residual against the leading
// temperature) and the TALC replay (P99 against the interval, and the
// hourly compensation over time), each output's plots drawn by uPlot,
// nothing logged, no script error.
TEST_F(BrowserTest, ThermalLogPageDrawsTheComparisonAndTheReplay) {
  ASSERT_TRUE(fs::exists(TTP_CHROMIUM)) << "Chromium not found";
  const fs::path dir = fs::path(TTP_BINARY_DIR) / "report_browser" / "thermal";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path html = fs::absolute(dir / "thermal.html");
  const fs::path data_path = fs::absolute(dir / "thermal.json");
  const RunResult report =
      RunCommand("cd " + ttp::test::ShellQuoted(TTP_DATA_DIR) + " && " +
                 std::string(TTP_BINARY_DIR) +
                 "/app/ttp report --log reference/fl-thermal/train.csv -o " +
                 ttp::test::ShellQuoted(html) + " --json " +
                 ttp::test::ShellQuoted(data_path) + " 2>&1");
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const json data = json::parse(ttp::test::FileBytes(data_path));
  const size_t outputs = data["outputs"].size();
  ASSERT_EQ(outputs, 5u);
  ASSERT_EQ(data["replay"]["outputs"].size(), outputs);
  const RunResult dom =
      Chromium("--window-size=1280,1000 --dump-dom " +
                   ttp::test::ShellQuoted("file://" + html.string()),
               dir / "profile");
  ASSERT_EQ(dom.exit_code, 0) << dom.output;
  CheckPageRanClean(dom.output);
  const size_t instances = UplotInstances(dom.output);
  // Per output: measured and predicted, the residual against the leading
  // temperature, the replay over time; and one curve of P99 for all.
  EXPECT_EQ(instances, 3 * outputs + 1);
  EXPECT_NE(dom.output.find("TALC replayed"), std::string::npos);
}

// Every other kind of measurement (dial, DMIS and probe with and without
// the TALC log) and the comparison of two pieces draw as well.
struct PageCase {
  const char* name;
  const char* args;  // after `ttp report`, relative to the repository root
  bool has_log;
};

class BrowserKinds : public ::testing::TestWithParam<PageCase> {};

TEST_P(BrowserKinds, DrawsEveryPlot) {
  ASSERT_TRUE(fs::exists(TTP_CHROMIUM)) << "Chromium not found";
  const PageCase c = GetParam();
  const fs::path dir = fs::path(TTP_BINARY_DIR) / "report_browser" / c.name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path html = fs::absolute(dir / (std::string(c.name) + ".html"));
  const fs::path data_path =
      fs::absolute(dir / (std::string(c.name) + ".json"));
  const RunResult report =
      RunCommand("cd " + ttp::test::ShellQuoted(TTP_DATA_DIR) + " && " +
                 std::string(TTP_BINARY_DIR) + "/app/ttp report " + c.args +
                 " -o " + ttp::test::ShellQuoted(html) + " --json " +
                 ttp::test::ShellQuoted(data_path) + " 2>&1");
  ASSERT_TRUE(report.exit_code == 0 || report.exit_code == 1) << report.output;
  const json data = json::parse(ttp::test::FileBytes(data_path));
  std::string verdict;
  if (data.contains("grade")) {
    verdict = data["grade"]["verdict"];
  } else {  // a comparison: piece A's verdict is shown first
    verdict = data["pieces"][0]["grade"]["verdict"];
  }
  std::map<std::string, int> expected;
  if (data.contains("pieces")) {
    expected =
        ExpectedPoints(json{{"figures",
                             {{"measured", data["pieces"][0]["figures"]},
                              {"simulated", data["pieces"][1]["figures"]}}}});
  } else {
    expected = ExpectedPoints(data);
  }
  EXPECT_EQ(expected.size() > 5, c.has_log);
  std::string dom;
  CheckPageDrawsEverything(html, expected, verdict, &dom);
}

INSTANTIATE_TEST_SUITE_P(
    Pages, BrowserKinds,
    ::testing::Values(
        PageCase{"dial", "--log samples/run-c/talc.csv samples/run-c/dial.csv",
                 true},
        PageCase{"dmis", "--log samples/run-c/talc.csv samples/run-c/piece.dmo",
                 true},
        PageCase{"probe", "samples/run-c/probe.csv", false},
        PageCase{"cloud_no_log", "samples/run-b/piece.xyz", false},
        PageCase{"compare",
                 "--compare samples/run-a/piece.ply samples/run-b/piece.xyz",
                 false}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
