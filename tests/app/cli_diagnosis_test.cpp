// `ttp diagnose` and `ttp twin` end to end through the program: the sample
// runs made outside the project, a twin round trip, and bad input.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "run_ttp.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;

const fs::path kSamples = fs::path(TTP_DATA_DIR) / "samples";

// Every key of diagnosis.md section 2, parameters with units in the names.
void ExpectReportKeys(const nlohmann::json& d) {
  ASSERT_TRUE(d.contains("cause")) << d.dump();
  EXPECT_TRUE(d["cause"].is_string());
  EXPECT_TRUE(d["baseline"]["rms_um"].is_number());
  EXPECT_TRUE(d["extended"]["rms_um"].is_number());
  EXPECT_TRUE(d["extended"]["params"].is_object());
  EXPECT_TRUE(d["gain_pct"].is_number());
  ASSERT_TRUE(d["candidates"].is_array());
  EXPECT_EQ(d["candidates"].size(), 11u);  // none, 4 causes, 6 pairs
  ASSERT_TRUE(d.contains("status"));
  for (const auto& c : d["candidates"]) {
    EXPECT_TRUE(c["cause"].is_string());
    EXPECT_TRUE(c["delta_bic"].is_number());
    EXPECT_TRUE(c["bic"].is_number());
  }
  const std::regex unit(".*_(s|um|urad|deg|K_per_K|um_per_m)$");
  for (const auto& [name, v] : d["extended"]["params"].items()) {
    if (name == "harmonics") continue;  // a count
    EXPECT_TRUE(std::regex_match(name, unit)) << name;
    EXPECT_TRUE(v.is_number());
    EXPECT_TRUE(d["extended"]["uncertainty"][name].is_number()) << name;
  }
  if (d["cause"] == "none") {
    EXPECT_TRUE(d["extended"]["params"].empty());
    EXPECT_EQ(d["gain_pct"], 0.0);
  }
}

// A sample's cloud inspected into dir/m.json.
void InspectSample(const std::string& run, const std::string& cloud,
                   const fs::path& dir) {
  const auto inspected =
      test::RunTtp("inspect " + (kSamples / run / cloud).string() + " --json " +
                   (dir / "m.json").string());
  ASSERT_EQ(inspected.exit_code, 0) << inspected.output;
}

nlohmann::json InspectAndDiagnose(const std::string& run,
                                  const std::string& cloud,
                                  const fs::path& dir) {
  const fs::path in = kSamples / run;
  InspectSample(run, cloud, dir);
  const auto r = test::RunTtp("diagnose --log " + (in / "talc.csv").string() +
                              " " + (dir / "m.json").string() + " --json " +
                              (dir / "d.json").string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("cause: "), std::string::npos) << r.output;
  return test::ReadJson(dir / "d.json");
}

TEST(CliDiagnosis, SampleRunANamesWorkpieceExpansionWithItsParameters) {
  const fs::path dir = test::TestDir("diag_a");
  const nlohmann::json d = InspectAndDiagnose("run-a", "piece.ply", dir);
  ExpectReportKeys(d);
  const nlohmann::json truth = test::ReadJson(kSamples / "run-a/truth.json");
  ASSERT_EQ(d["cause"], truth["cause"]);
  const auto& p = d["extended"]["params"];
  const auto& u = d["extended"]["uncertainty"];
  // Within the expanded uncertainty (k = 2) of the truth.
  EXPECT_NEAR(p["tau_wp_s"].get<double>(), truth["params"]["tau_wp_s"],
              2 * u["tau_wp_s"].get<double>());
  EXPECT_NEAR(p["gain_K_per_K"].get<double>(), truth["params"]["gain"],
              2 * u["gain_K_per_K"].get<double>());
  EXPECT_LT(d["extended"]["rms_um"], d["baseline"]["rms_um"]);
  EXPECT_GT(d["gain_pct"], 20.0);
}

// Sample run-a with a gross error written into one R-test (EX0C 3 um off,
// fifteen times its noise: a chip on a sphere): the estimator leaves that
// R-test out and says so, naming its line, in the text and the JSON, and
// the diagnosis stays what the sample's truth says. The clean log leaves
// nothing out.
TEST(CliDiagnosis, SampleRunAWithAGrossErrorInOneRTest) {
  const fs::path dir = test::TestDir("diag_gross");
  const nlohmann::json clean = InspectAndDiagnose("run-a", "piece.ply", dir);
  ASSERT_TRUE(clean["warnings"].is_array());
  EXPECT_TRUE(clean["warnings"].empty()) << clean["warnings"].dump();
  std::ifstream in(kSamples / "run-a/talc.csv");
  std::ofstream out(dir / "talc.csv");
  std::string line;
  int line_no = 0, rtests = 0, gross_line = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find(",rtest,") != std::string::npos && ++rtests == 50) {
      // t_s,event,T_env,T_ws,dT_cool,c_rpm,spindle_rpm,mwf,EX0C,...
      std::vector<std::string> cells;
      std::stringstream ss(line);
      for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
      ASSERT_GT(cells.size(), 8u);
      cells[8] = std::to_string(std::stod(cells[8]) + 3.0);
      line.clear();
      for (size_t k = 0; k < cells.size(); ++k)
        line += (k ? "," : "") + cells[k];
      line += ",";  // the row's last cell (phase) is empty
      gross_line = line_no;
    }
    out << line << "\n";
  }
  out.close();
  ASSERT_GT(gross_line, 0);
  const auto r = test::RunTtp("diagnose --log " + (dir / "talc.csv").string() +
                              " " + (dir / "m.json").string() + " --json " +
                              (dir / "gross.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string named = fmt::format("R-test of line {} ", gross_line);
  EXPECT_NE(r.output.find("warning: " + named), std::string::npos) << r.output;
  const nlohmann::json d = test::ReadJson(dir / "gross.json");
  ASSERT_EQ(d["warnings"].size(), 1u) << d["warnings"].dump();
  EXPECT_NE(d["warnings"][0].get<std::string>().find(named + "(t_s"),
            std::string::npos);
  EXPECT_NE(d["warnings"][0].get<std::string>().find("EX0C"),
            std::string::npos);
  EXPECT_EQ(d["cause"], test::ReadJson(kSamples / "run-a/truth.json")["cause"]);
  // The HTML report's diagnosis says it too.
  const auto report = test::RunTtp(
      "report --log " + (dir / "talc.csv").string() + " " +
      (dir / "m.json").string() + " -o " + (dir / "report.html").string());
  // (exit 1: the sample piece fails its tolerances, a judged outcome)
  ASSERT_TRUE(report.exit_code == 0 || report.exit_code == 1) << report.output;
  std::ifstream html_file(dir / "report.html");
  std::stringstream html;
  html << html_file.rdbuf();
  const std::string page = html.str();
  const size_t list = page.find("id=\"diagnosis-warnings\"");
  ASSERT_NE(list, std::string::npos);
  EXPECT_NE(page.find(named, list), std::string::npos);
}

// Sample run-a's log as production writes it: R-tests every 30 min, the
// last of them more than an hour before the last cuts, none after them. Their
// machine errors are extrapolated through the estimator's model (the log covers
// the cut times; nothing in it is another run's), so the diagnosis is still the
// sample's truth, with a warning that names the cuts extrapolated; the
// check says it too.
TEST(CliDiagnosis, SampleRunAWithoutAClosingRTest) {
  const fs::path dir = test::TestDir("diag_open");
  ASSERT_NO_FATAL_FAILURE(InspectSample("run-a", "piece.ply", dir));
  std::vector<std::string> lines;
  {
    std::ifstream in(kSamples / "run-a/talc.csv");
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  double last_cut_s = 0;
  for (const std::string& l : lines)
    if (l.find(",cut,") != std::string::npos)
      last_cut_s = std::max(last_cut_s, std::stod(l));
  std::ofstream out(dir / "talc.csv");
  double kept_s = -1e9;
  int dropped_after = 0;
  for (const std::string& l : lines) {
    if (l.find(",rtest,") != std::string::npos) {
      const double t = std::stod(l);
      if (t > last_cut_s - 3600) {
        dropped_after += t > last_cut_s;
        continue;
      }
      if (t - kept_s < 1800) continue;
      kept_s = t;
    }
    out << l << "\n";
  }
  out.close();
  ASSERT_GT(dropped_after, 0);
  ASSERT_LT(kept_s, last_cut_s - 3600);
  const std::string args =
      (dir / "talc.csv").string() + " " + (dir / "m.json").string();
  const auto r = test::RunTtp("diagnose --log " + args + " --json " +
                              (dir / "d.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json d = test::ReadJson(dir / "d.json");
  const nlohmann::json truth = test::ReadJson(kSamples / "run-a/truth.json");
  EXPECT_EQ(d["status"], "named") << r.output;
  ASSERT_EQ(d["cause"], truth["cause"]) << r.output;
  EXPECT_NEAR(d["extended"]["params"]["gain_K_per_K"].get<double>(),
              truth["params"]["gain"],
              2 * d["extended"]["uncertainty"]["gain_K_per_K"].get<double>());
  ASSERT_EQ(d["warnings"].size(), 1u) << d["warnings"].dump();
  const std::string w = d["warnings"][0];
  EXPECT_NE(w.find("after the last R-test"), std::string::npos) << w;
  EXPECT_NE(w.find("extrapolated"), std::string::npos) << w;
  EXPECT_NE(r.output.find("warning: "), std::string::npos) << r.output;
  const auto c = test::RunTtp("check --log " + args + " --json " +
                              (dir / "c.json").string());
  ASSERT_TRUE(c.exit_code == 0 || c.exit_code == 1) << c.output;
  EXPECT_NE(c.output.find("after the last R-test"), std::string::npos)
      << c.output;
  EXPECT_EQ(test::ReadJson(dir / "c.json")["warnings"].size(), 1u);
}

// Sample run-a's inspection with one facet's distance 8 um off (a CMM
// glitch, a misread gauge): the piece still belongs to its log. The
// diagnosis says `unexplained` and where: the figures of that facet's
// cycle (X1-3: cycle 3; Y1-9: cycle 8), or, for a facet of the reference
// cycle (X1-5), the kinds every cycle is a difference to it in; never that
// log and measurement do not belong together.
TEST(CliDiagnosis, SampleRunAWithAGrossErrorInOneFacet) {
  const fs::path dir = test::TestDir("diag_gross_facet");
  ASSERT_NO_FATAL_FAILURE(InspectSample("run-a", "piece.ply", dir));
  const nlohmann::json clean = test::ReadJson(dir / "m.json");
  for (const auto& [facet, cycle] : std::vector<std::pair<std::string, int>>{
           {"X1-3", 3}, {"Y1-9", 8}, {"X1-5", 0}}) {
    SCOPED_TRACE(facet);
    nlohmann::json bad = clean;
    ASSERT_TRUE(bad["facets"].contains(facet));
    bad["facets"][facet]["distance_mm"] =
        bad["facets"][facet]["distance_mm"].get<double>() + 0.008;
    const fs::path bad_path = dir / (facet + ".json");
    std::ofstream(bad_path) << bad.dump();
    const auto r = test::RunTtp(
        "diagnose --log " + (kSamples / "run-a/talc.csv").string() + " " +
        bad_path.string() + " --json " + (dir / "d.json").string());
    EXPECT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json d = test::ReadJson(dir / "d.json");
    EXPECT_EQ(d["status"], "unexplained") << d["reason"];
    if (cycle == 0) continue;
    bool located = false;
    for (const auto& u : d["unexplained"])
      located |= u["where"] == fmt::format("figures of cycle {}", cycle);
    EXPECT_TRUE(located) << d["unexplained"].dump();
  }
}

// Sample run-a's inspection mirrored (every facet distance and strip
// depth with its deviation's sign reversed, as a reading convention of the
// wrong sign gives): refused, and the refusal says the figures follow the
// simulated ones mirrored. The piece as measured gets no such hint.
TEST(CliDiagnosis, SampleRunAMirroredIsRefusedWithASignHint) {
  const fs::path dir = test::TestDir("diag_mirrored");
  const nlohmann::json d = InspectAndDiagnose("run-a", "piece.ply", dir);
  EXPECT_EQ(d["reason"].get<std::string>().find("wrong sign"),
            std::string::npos);
  nlohmann::json m = test::ReadJson(dir / "m.json");
  const double facet_mm = 97.3, strip_mm = 12.1;  // test-piece.md nominal
  for (auto& [name, f] : m["facets"].items())
    f["distance_mm"] = 2 * facet_mm - f["distance_mm"].get<double>();
  for (auto& [name, z] : m["strips"].items())
    z["depth_mm"] = 2 * strip_mm - z["depth_mm"].get<double>();
  m.erase("figures");
  std::ofstream(dir / "mirrored.json") << m.dump();
  const auto r =
      test::RunTtp("diagnose --log " + (kSamples / "run-a/talc.csv").string() +
                   " " + (dir / "mirrored.json").string() + " --json " +
                   (dir / "mirrored_d.json").string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const nlohmann::json mirrored = test::ReadJson(dir / "mirrored_d.json");
  EXPECT_EQ(mirrored["status"], "refused");
  EXPECT_NE(mirrored["reason"].get<std::string>().find("wrong sign"),
            std::string::npos)
      << mirrored["reason"];
}

// A sample's log with its R-tests thinned to production spacing: the
// reference R-test, then the first one at least `spacing_s` after the last
// kept (the first of them `first_after_s` after the reference when given:
// another phase of the test cycle), and the first after the last cut (the
// log closes with one). Written to `out`; returns the R-tests kept.
int ThinnedLog(const fs::path& log, double spacing_s, double first_after_s,
               const fs::path& out) {
  std::vector<std::string> lines;
  {
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  double last_cut_s = 0;
  for (const std::string& l : lines)
    if (l.find(",cut,") != std::string::npos)
      last_cut_s = std::max(last_cut_s, std::stod(l));
  std::ofstream o(out);
  int kept = 0;
  bool closed = false;
  double due_s = -1e300;
  for (const std::string& l : lines) {
    if (l.find(",rtest,") != std::string::npos) {
      const double t = std::stod(l);
      const bool closing = t > last_cut_s && !closed;
      if (kept > 0 && t < due_s && !closing) continue;
      closed = closed || t > last_cut_s;
      due_s = t + (kept == 0 && first_after_s > 0 ? first_after_s : spacing_s);
      ++kept;
    }
    o << l << "\n";
  }
  return kept;
}

// The samples (made outside the project, R-tests every 5 min) with their
// R-tests 30 min to 2 h apart, at two phases of the test cycle: the hidden
// expansion is still named and the piece without an effect is still
// `none`; each piece next to the other's log is refused. The gain's stated
// uncertainty holds the estimator's error between R-tests in the
// expansion's regressor: measured over the six logs, the gain lies within
// 3.8 of it from the truth, RMS 2.0 (with the fit's covariance alone 5.0
// and 3.0); the limits below are those figures rounded up.
TEST(CliDiagnosis, SamplesAtProductionSpacings) {
  const fs::path dir = test::TestDir("diag_spacings");
  const fs::path a = dir / "a", b = dir / "b";
  fs::create_directories(a);
  fs::create_directories(b);
  ASSERT_NO_FATAL_FAILURE(InspectSample("run-a", "piece.ply", a));
  ASSERT_NO_FATAL_FAILURE(InspectSample("run-b", "piece.xyz", b));
  const nlohmann::json truth_a = test::ReadJson(kSamples / "run-a/truth.json");
  const double gain = truth_a["params"]["gain"];
  double worst_z = 0, sum_z2 = 0;
  int logs = 0;
  for (double spacing_s : {1800.0, 3600.0, 7200.0}) {
    for (double phase_s : {0.0, 1500.0}) {
      const std::string tag = fmt::format("{:.0f}_{:.0f}", spacing_s, phase_s);
      SCOPED_TRACE(tag);
      const fs::path log_a = dir / ("a_" + tag + ".csv");
      const fs::path log_b = dir / ("b_" + tag + ".csv");
      const int kept =
          ThinnedLog(kSamples / "run-a/talc.csv", spacing_s, phase_s, log_a);
      ASSERT_LE(kept, 8 * 3600 / spacing_s + 3);
      ASSERT_GE(kept, 5);
      ThinnedLog(kSamples / "run-b/talc.csv", spacing_s, phase_s, log_b);
      const auto ra = test::RunTtp("diagnose --log " + log_a.string() + " " +
                                   (a / "m.json").string() + " --json " +
                                   (a / "d.json").string());
      ASSERT_EQ(ra.exit_code, 0) << ra.output;
      const nlohmann::json da = test::ReadJson(a / "d.json");
      EXPECT_EQ(da["status"], "named") << ra.output;
      ASSERT_EQ(da["cause"], truth_a["cause"]) << ra.output;
      const double z =
          std::abs(da["extended"]["params"]["gain_K_per_K"].get<double>() -
                   gain) /
          da["extended"]["uncertainty"]["gain_K_per_K"].get<double>();
      worst_z = std::max(worst_z, z);
      sum_z2 += z * z;
      ++logs;
      const auto rb = test::RunTtp("diagnose --log " + log_b.string() + " " +
                                   (b / "m.json").string() + " --json " +
                                   (b / "d.json").string());
      ASSERT_EQ(rb.exit_code, 0) << rb.output;
      EXPECT_EQ(test::ReadJson(b / "d.json")["status"], "none") << rb.output;
      if (phase_s == 0) {
        const auto swapped_a = test::RunTtp("diagnose --log " + log_b.string() +
                                            " " + (a / "m.json").string());
        EXPECT_EQ(swapped_a.exit_code, 1) << swapped_a.output;
        EXPECT_NE(swapped_a.output.find("status: refused"), std::string::npos)
            << swapped_a.output;
        const auto swapped_b = test::RunTtp("diagnose --log " + log_a.string() +
                                            " " + (b / "m.json").string());
        EXPECT_EQ(swapped_b.exit_code, 1) << swapped_b.output;
        EXPECT_NE(swapped_b.output.find("status: refused"), std::string::npos)
            << swapped_b.output;
      }
    }
  }
  ASSERT_EQ(logs, 6);
  EXPECT_LT(worst_z, 4.0);
  EXPECT_LT(std::sqrt(sum_z2 / logs), 2.5);
  RecordProperty("worst_gain_z", fmt::format("{:.2f}", worst_z));
}

TEST(CliDiagnosis, SampleRunBNamesNone) {
  const fs::path dir = test::TestDir("diag_b");
  const nlohmann::json d = InspectAndDiagnose("run-b", "piece.xyz", dir);
  ExpectReportKeys(d);
  EXPECT_EQ(d["cause"], test::ReadJson(kSamples / "run-b/truth.json")["cause"]);
  EXPECT_EQ(d["cause"], "none");
}

// A cloud and its inspection JSON (`ttp inspect --json`) are judged alike:
// the JSON carries each fitted feature's own scatter (`U_scatter_*`), which
// the diagnosis's budget takes for it, so every candidate's chi2 is the
// same by either route. Without those fields (an inspection of another
// program) the features' rms and points give it for points spread evenly
// over each feature, a facet's d taken at W's origin above its points:
// close to the fit's own for this cloud (with rms / sqrt(points) alone the
// nominal model's chi2 was more than 5 % larger).
TEST(CliDiagnosis, ACloudAndItsInspectionJsonGiveOneBudget) {
  const fs::path dir = test::TestDir("diag_routes");
  const fs::path in = kSamples / "run-a";
  InspectSample("run-a", "piece.ply", dir);
  const auto by_json = test::RunTtp(
      "diagnose --log " + (in / "talc.csv").string() + " " +
      (dir / "m.json").string() + " --json " + (dir / "j.json").string());
  ASSERT_EQ(by_json.exit_code, 0) << by_json.output;
  const auto by_cloud = test::RunTtp(
      "diagnose --log " + (in / "talc.csv").string() + " " +
      (in / "piece.ply").string() + " --json " + (dir / "c.json").string());
  ASSERT_EQ(by_cloud.exit_code, 0) << by_cloud.output;
  const nlohmann::json j = test::ReadJson(dir / "j.json");
  const nlohmann::json c = test::ReadJson(dir / "c.json");
  ASSERT_EQ(j["candidates"].size(), c["candidates"].size());
  for (size_t i = 0; i < j["candidates"].size(); ++i) {
    const double a = j["candidates"][i]["chi2"].get<double>();
    const double b = c["candidates"][i]["chi2"].get<double>();
    EXPECT_NEAR(a, b, 1e-6 * std::max(1.0, b)) << j["candidates"][i]["cause"];
  }
  EXPECT_EQ(j["status"], c["status"]);
  // The facets' scatter is in the JSON, and more than rms / sqrt(points).
  nlohmann::json m = test::ReadJson(dir / "m.json");
  const auto& f = m["facets"]["X1-5"];
  ASSERT_TRUE(f.contains("U_scatter_distance_um")) << f.dump();
  EXPECT_GT(f["U_scatter_distance_um"].get<double>(),
            1.8 * 2 * f["rms_um"].get<double>() /
                std::sqrt(f["points"].get<double>()));
  // Read without them.
  for (auto& [id, v] : m["facets"].items()) {
    v.erase("U_scatter_distance_um");
    v.erase("U_scatter_angle_urad");
  }
  for (auto& [id, v] : m["strips"].items()) {
    v.erase("U_scatter_depth_um");
    v.erase("U_scatter_beta_urad");
  }
  {
    std::ofstream out(dir / "m-bare.json");
    out << m.dump(1);
  }
  const auto bare = test::RunTtp(
      "diagnose --log " + (in / "talc.csv").string() + " " +
      (dir / "m-bare.json").string() + " --json " + (dir / "b.json").string());
  ASSERT_EQ(bare.exit_code, 0) << bare.output;
  const nlohmann::json b = test::ReadJson(dir / "b.json");
  EXPECT_NEAR(b["candidates"][0]["chi2"].get<double>() /
                  c["candidates"][0]["chi2"].get<double>(),
              1.0, 0.02);
  EXPECT_EQ(b["status"], c["status"]);
}

TEST(CliDiagnosis, TwinRoundTripThroughACloud) {
  const fs::path dir = test::TestDir("diag_twin");
  const auto t = test::RunTtp(
      "twin --effect clamping_distortion --size 2 "
      "--seed 12 --compensation on -o " +
      dir.string());
  ASSERT_EQ(t.exit_code, 0) << t.output;
  ASSERT_TRUE(fs::exists(dir / "piece.ply"));  // a cloud by default
  const nlohmann::json truth = test::ReadJson(dir / "truth.json");
  // The cloud straight into diagnose (inspected on the way).
  const auto r = test::RunTtp("diagnose --log " + (dir / "talc.csv").string() +
                              " " + (dir / "piece.ply").string() + " --json " +
                              (dir / "d.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const nlohmann::json d = test::ReadJson(dir / "d.json");
  ExpectReportKeys(d);
  EXPECT_EQ(d["cause"], truth["cause"]);
  // The twin's lobes fall off with height above the bolts: the fitted
  // amplitude is the one at the facets, below the bolts' own.
  const double fitted = d["extended"]["params"]["amplitude_um"].get<double>();
  const double bolts = truth["params"]["clamping_amplitude_um"].get<double>();
  EXPECT_GT(fitted, 0.4 * bolts);
  EXPECT_LT(fitted, 1.1 * bolts);
  // Same input, same output.
  const auto again = test::RunTtp(
      "twin --effect clamping_distortion --size 2 "
      "--seed 12 --compensation on -o " +
      (dir / "again").string());
  ASSERT_EQ(again.exit_code, 0);
  std::ifstream a(dir / "piece.ply", std::ios::binary),
      b(dir / "again/piece.ply", std::ios::binary);
  std::stringstream sa, sb;
  sa << a.rdbuf();
  sb << b.rdbuf();
  EXPECT_EQ(sa.str(), sb.str());
}

TEST(CliDiagnosis, TwinJsonAndXyzMeasurements) {
  const fs::path dir = test::TestDir("diag_twin2");
  const auto t = test::RunTtp(
      "twin --effect tool_wear --size 3 --seed 5 --measurement json -o " +
      dir.string());
  ASSERT_EQ(t.exit_code, 0) << t.output;
  const auto r = test::RunTtp("diagnose --log " + (dir / "talc.csv").string() +
                              " " + (dir / "measured.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("cause: tool_wear"), std::string::npos) << r.output;
  const auto x = test::RunTtp("twin --seed 5 --measurement xyz -o " +
                              (dir / "xyz").string());
  ASSERT_EQ(x.exit_code, 0) << x.output;
  EXPECT_TRUE(fs::exists(dir / "xyz/piece.xyz"));
  const auto help = test::RunTtp("twin --help");
  EXPECT_NE(help.output.find("--measurement"), std::string::npos);
  const auto bad = test::RunTtp("twin --measurement stl -o " + dir.string());
  EXPECT_NE(bad.exit_code, 0);
}

// The twin's cutter wears along its own path (each pass's sampled span plus
// the overrun, counted by the cut simulation), not the diagnosis's count
// of the length cut; at the sample's 20 um/m (run-c) the two must still
// agree on the shape: every seed named tool_wear, the wear within 5 % (the
// two counts differ by about 3 %) and within 2.5 of its stated
// uncertainty, which holds the path's (3 %). One length for every strip
// had left 5 of these 8 `unexplained`.
TEST(CliDiagnosis, TwinWearAtTheSampleSizeIsNamed) {
  const fs::path dir = test::TestDir("diag_twin_wear");
  for (int seed = 1; seed <= 8; ++seed) {
    SCOPED_TRACE(seed);
    const fs::path run = dir / std::to_string(seed);
    const auto t = test::RunTtp("twin --effect tool_wear --size 20 --seed " +
                                std::to_string(seed) +
                                " --measurement json -o " + run.string());
    ASSERT_EQ(t.exit_code, 0) << t.output;
    const auto r =
        test::RunTtp("diagnose --log " + (run / "talc.csv").string() + " " +
                     (run / "measured.json").string() + " --json " +
                     (run / "d.json").string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    const nlohmann::json d = test::ReadJson(run / "d.json");
    ASSERT_EQ(d["cause"], "tool_wear") << r.output;
    const double wear = d["extended"]["params"]["wear_um_per_m"];
    EXPECT_NEAR(wear, 20.0, 1.0);
    EXPECT_LT(
        std::abs(wear - 20.0),
        2.5 * d["extended"]["uncertainty"]["wear_um_per_m"].get<double>());
  }
}

// How the piece was measured reaches the reader from `diagnose` and
// `report` as from `inspect`: run-c's probe results are read against the
// plan given with --probe-points (here one of two columns per facet, not
// the plan they were taken with: refused naming the probe file), and a
// CMM program option that cannot be is refused naming the option.
TEST(CliDiagnosis, TheMeasurementOptionsReachTheReader) {
  const fs::path dir = test::TestDir("diag_options");
  const std::string c = (kSamples / "run-c").string();
  const std::string log = " --log " + c + "/talc.csv ";
  auto r = test::RunTtp("diagnose" + log + c + "/probe.csv");
  EXPECT_NE(r.exit_code, 2) << r.output;
  const std::string plan = (dir / "two_columns.csv").string();
  ASSERT_EQ(test::RunTtp("plan probe --facet-columns 2 -o " +
                         (dir / "p.nc").string() + " --points-csv " + plan)
                .exit_code,
            0);
  for (const std::string& command : {"diagnose" + log, "report" + log}) {
    const std::string out =
        command[0] == 'r' ? " -o " + (dir / "r.html").string() : "";
    r = test::RunTtp(command + c + "/probe.csv --probe-points " + plan + out);
    EXPECT_EQ(r.exit_code, 2) << command << r.output;
    EXPECT_NE(r.output.find("probe.csv:"), std::string::npos) << r.output;
    r = test::RunTtp(command + c + "/piece.dmo --cmm-touches 2" + out);
    EXPECT_EQ(r.exit_code, 2) << command << r.output;
    EXPECT_NE(r.output.find("--cmm-touches"), std::string::npos) << r.output;
  }
}

// An effect far beyond any machine's is refused before anything is made:
// its piece would leave every plausible range (a 1e300 gain wrote a NaN
// point and blamed the twin's own cloud).
TEST(CliDiagnosis, TwinAndRunRefuseAnEffectSizeBeyondItsRange) {
  const fs::path dir = test::TestDir("twin_size");
  auto r = test::RunTtp("twin --effect tool_wear --size 5000 --seed 1 -o " +
                        (dir / "t").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--size"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0..1000"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "t" / "talc.csv"));
  r = test::RunTtp("run --effect workpiece_expansion --size 1e300 -o " +
                   (dir / "r").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("0..10 (gain)"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir / "r" / "report.html"));
  // An effect the twin does not know is named as the effect, before its size.
  r = test::RunTtp("twin --effect thermal_bend -o " + (dir / "u").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--effect: unknown effect 'thermal_bend'"),
            std::string::npos)
      << r.output;
}

TEST(CliDiagnosis, BadInputExitsTwoNamingTheFile) {
  const fs::path dir = test::TestDir("diag_bad");
  const std::string a = (kSamples / "run-a").string();
  ASSERT_EQ(test::RunTtp("inspect " + a + "/piece.ply --json " +
                         (dir / "a.json").string())
                .exit_code,
            0);
  const std::string measured = (dir / "a.json").string();
  // A dial sheet with the reference facet alone holds nothing to compare:
  // bad input naming the file.
  {
    std::ofstream(dir / "one_row.csv") << "feature,reading_um\nX1-1,1.0\n";
    const std::string one = (dir / "one_row.csv").string();
    const auto d = test::RunTtp("diagnose --log " + a + "/talc.csv " + one);
    EXPECT_EQ(d.exit_code, 2) << d.output;
    EXPECT_NE(d.output.find(one + ": no figure or facet angle"),
              std::string::npos)
        << d.output;
  }
  // A missing log.
  const std::string missing = (dir / "no_such_log.csv").string();
  auto r = test::RunTtp("diagnose --log " + missing + " " + measured);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find(missing), std::string::npos) << r.output;
  // A log that stops after cycle 4: it does not cover the later cuts.
  {
    std::ifstream in(a + "/talc.csv");
    std::ofstream out(dir / "short.csv");
    std::string line;
    while (std::getline(in, line)) {
      if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) &&
          std::stod(line) > 16000)
        break;
      out << line << "\n";
    }
  }
  const std::string short_log = (dir / "short.csv").string();
  // Refused (exit 1): the log and the measurement cannot belong together.
  r = test::RunTtp("diagnose --log " + short_log + " " + measured);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("status: refused"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(short_log), std::string::npos) << r.output;
  // Caught by the schedule check (the log ends before the last cut) ...
  EXPECT_NE(r.output.find("before the program's last cut"), std::string::npos)
      << r.output;
  // ... and, without it, by the diagnosis (the log has no cut of them).
  r = test::RunTtp("diagnose --no-schedule-check --log " + short_log + " " +
                   measured);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("cover"), std::string::npos) << r.output;
  // A log with its first R-test alone: read, but it cannot give the
  // machine's error at the cuts: refused (as with none), not bad input.
  {
    std::ifstream in(a + "/talc.csv");
    std::ofstream out(dir / "one_rtest.csv");
    std::string line;
    bool seen = false;
    while (std::getline(in, line)) {
      if (line.find(",rtest,") != std::string::npos) {
        if (seen) continue;
        seen = true;
      }
      out << line << "\n";
    }
  }
  r = test::RunTtp("diagnose --log " + (dir / "one_rtest.csv").string() + " " +
                   measured);
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("status: refused"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("two R-tests"), std::string::npos) << r.output;
  // Run-a's piece against run-b's log: no cause is named (refused when the
  // E_X/E_Y slope test tells them apart, else unexplained).
  r = test::RunTtp("diagnose --log " + (kSamples / "run-b/talc.csv").string() +
                   " " + measured);
  EXPECT_TRUE(r.output.find("status: refused") != std::string::npos ||
              r.output.find("status: unexplained") != std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("status: named"), std::string::npos) << r.output;
  // A measurement that is not JSON of a piece.
  { std::ofstream(dir / "junk.json") << "{\"hello\": 1}"; }
  r = test::RunTtp("diagnose --log " + a + "/talc.csv " +
                   (dir / "junk.json").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("junk.json"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace ttp
