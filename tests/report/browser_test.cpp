// The report of the sample run samples/run-a (made outside the
// project), built by the `ttp report` binary, opened in headless Chromium
// with no network. Every uPlot instance must have drawn every data point of
// its series inside its plot area (the page's draw hook counts them from
// uPlot's own data and scales into data-points), the page must log nothing
// to the console and report no script error, and a screenshot is saved to
// <build>/docs/report.png (copied into docs/report.png for the README).
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

std::string Quote(const fs::path& p) { return "'" + p.string() + "'"; }

std::string ReadFile(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

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
  for (const json& e : data["figures"]["measured"]) meas[e["cycle"]] = &e;
  for (const json& e : data["figures"]["simulated"]) sim[e["cycle"]] = &e;
  for (const char* key : {"E_X", "E_Y", "E_Z", "E_B", "E_TTP"}) {
    int n = 0;
    for (const auto& [c, e] : meas) n += Finite(json::array({(*e)[key]}));
    for (const auto& [c, e] : sim) n += Finite(json::array({(*e)[key]}));
    for (const json& e : data["figures"]["simulated_linear"]) {
      n += Finite(json::array({e[key]}));
    }
    out[key] = n;
  }
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
  const json& r = data["diagnosis"]["residuals"];
  for (const char* which : {"before", "after"}) {
    int n = 0;
    for (const auto& [key, column] : r[which].items()) n += Finite(column);
    out[std::string("residual-") + which] = n;
  }
  return out;
}

class BrowserTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(TTP_BINARY_DIR) / "report_browser";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }

  // Chromium headless, no network: a dead proxy, unresolvable hosts, a
  // fresh profile, no background services. stderr carries the console.
  static RunResult Chromium(const std::string& args) {
    const fs::path profile = dir_ / "profile";
    fs::remove_all(profile);
    return RunCommand(
        std::string("timeout 120 ") + TTP_CHROMIUM +
        " --headless --no-sandbox --disable-gpu"
        " --user-data-dir=" +
        Quote(profile) +
        " --proxy-server=127.0.0.1:9"
        " --host-resolver-rules='MAP * ~NOTFOUND'"
        " --disable-background-networking --disable-component-update"
        " --disable-sync --no-first-run --disable-extensions"
        " --enable-logging=stderr --v=0"
        " --hide-scrollbars --virtual-time-budget=10000 " +
        args + " 2>&1");
  }

  static fs::path dir_;
};
fs::path BrowserTest::dir_;

TEST_F(BrowserTest, SampleRunReportDrawsEveryPlotOffline) {
  ASSERT_TRUE(fs::exists(TTP_CHROMIUM))
      << "Chromium not found (" << TTP_CHROMIUM
      << "): install the Debian packages chromium and chromium-driver "
         "(scripts/install-deps.sh)";
  const fs::path sample = fs::path(TTP_DATA_DIR) / "samples" / "run-a";
  const fs::path html = dir_ / "run-a.html", data_path = dir_ / "run-a.json";
  const RunResult report = RunCommand(
      std::string(TTP_BINARY_DIR) + "/app/ttp report --log " +
      Quote(sample / "talc.csv") + " " + Quote(sample / "piece.ply") + " -o " +
      Quote(html) + " --json " + Quote(data_path) + " 2>&1");
  ASSERT_EQ(report.exit_code, 0) << report.output;
  const json data = json::parse(ReadFile(data_path));
  const std::string page = ReadFile(html);

  // Self-contained: nothing is fetched (scripts, styles, images, fonts).
  const std::regex external(
      R"((src|href|srcset|action|poster|data)\s*=\s*["']?\s*(https?:)?//|url\(\s*["']?\s*(https?:)?//|@import|<link\b|<iframe\b|<object\b|<embed\b|\bimport\s*\(|fetch\(|XMLHttpRequest)",
      std::regex::icase);
  std::smatch hit;
  EXPECT_FALSE(std::regex_search(page, hit, external))
      << "external reference: " << hit.str();

  const RunResult dom =
      Chromium("--window-size=1280,1000 --dump-dom " +
               Quote("file://" + fs::absolute(html).string()));
  ASSERT_EQ(dom.exit_code, 0) << dom.output;
  std::string console;
  std::istringstream lines(dom.output);
  for (std::string line; std::getline(lines, line);) {
    if (line.find(":CONSOLE") != std::string::npos ||
        line.find("Uncaught") != std::string::npos) {
      console += line + "\n";
    }
  }
  EXPECT_TRUE(console.empty()) << "the page logged:\n" << console;
  EXPECT_NE(dom.output.find("data-plots-done=\"1\""), std::string::npos)
      << "the plotting script did not finish";
  EXPECT_EQ(dom.output.find("data-js-error=\"1\""), std::string::npos);
  EXPECT_NE(dom.output.find("<div id=\"js-errors\"></div>"), std::string::npos)
      << "script errors shown on the page";

  // Every plot: drawn by uPlot, with all its points inside the plot area.
  const std::map<std::string, int> expected = ExpectedPoints(data);
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
  size_t instances = 0;
  for (size_t p = dom.output.find("class=\"uplot"); p != std::string::npos;
       p = dom.output.find("class=\"uplot", p + 1)) {
    ++instances;
  }
  EXPECT_EQ(instances, expected.size()) << "uPlot instances in the page";
  // What the page shows matches the data.
  EXPECT_NE(dom.output.find("data-verdict=\"" +
                            data["grade"]["verdict"].get<std::string>() + "\""),
            std::string::npos);
  EXPECT_NE(
      dom.output.find("id=\"cause\">" +
                      data["diagnosis"]["cause"].get<std::string>() + "<"),
      std::string::npos);

  // The screenshot for the README.
  const fs::path png = fs::path(TTP_BINARY_DIR) / "docs" / "report.png";
  fs::create_directories(png.parent_path());
  fs::remove(png);
  const RunResult shot =
      Chromium("--window-size=1280,2600 --screenshot=" + Quote(png) + " " +
               Quote("file://" + fs::absolute(html).string()));
  ASSERT_EQ(shot.exit_code, 0) << shot.output;
  ASSERT_TRUE(fs::exists(png)) << shot.output;
  const std::string image = ReadFile(png);
  EXPECT_EQ(image.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_GT(image.size(), 50000u);  // a drawn page, not a blank one
}

}  // namespace
