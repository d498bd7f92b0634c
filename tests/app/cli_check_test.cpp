// `ttp check`: the sample runs (run-b agrees, run-a's hidden workpiece
// expansion does not), and logs that do not belong to the program, each a
// mutated copy of run-a's talc.csv (exit 2 naming line and field).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "run_ttp.h"
#include "ttp/geometry/file_io.h"

namespace ttp {
namespace {

namespace fs = std::filesystem;

const std::string kCheckSamples = std::string(TTP_DATA_DIR) + "/samples/";

std::vector<std::string> Lines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

double TimeOf(const std::string& line) { return std::stod(line); }
bool IsData(const std::string& line) {
  return !line.empty() && std::isdigit(static_cast<unsigned char>(line[0]));
}

// Writes run-a's log after `mutate` (on the data rows, re-sorted by time).
std::string Mutated(const std::string& name,
                    const std::function<void(std::vector<std::string>&)>& f) {
  std::vector<std::string> head, rows;
  for (const auto& line : Lines(kCheckSamples + "run-a/talc.csv")) {
    (IsData(line) ? rows : head).push_back(line);
  }
  f(rows);
  std::stable_sort(rows.begin(), rows.end(),
                   [](const std::string& a, const std::string& b) {
                     return TimeOf(a) < TimeOf(b);
                   });
  const fs::path path = test::TestDir("check") / (name + ".csv");
  std::ofstream out(path);
  for (const auto& l : head) out << l << "\n";
  for (const auto& l : rows) out << l << "\n";
  return path.string();
}

// Index of the cut row of `feature`.
size_t CutRow(const std::vector<std::string>& rows, const std::string& f) {
  for (size_t i = 0; i < rows.size(); ++i) {
    if (rows[i].find(",cut,") != std::string::npos &&
        rows[i].find("," + f + ",") != std::string::npos)
      return i;
  }
  ADD_FAILURE() << "no cut row " << f;
  return 0;
}

void Replace(std::string& s, const std::string& from, const std::string& to) {
  const auto p = s.find(from);
  ASSERT_NE(p, std::string::npos) << from;
  s.replace(p, from.size(), to);
}

test::RunResult Check(const std::string& log, const std::string& extra = "") {
  return test::RunTtp("check --log " + log + " " + kCheckSamples +
                      "run-a/piece.ply " + extra);
}

// A log that was read but does not follow the program (or cover its cuts):
// refused, exit 1, saying why (diagnosis.md section 3), not bad input.
void ExpectRefused(const test::RunResult& r,
                   const std::vector<std::string>& words) {
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("status: refused"), std::string::npos) << r.output;
  for (const auto& w : words) {
    EXPECT_NE(r.output.find(w), std::string::npos) << w << "\n" << r.output;
  }
}

TEST(CliCheck, RunBAgrees) {
  const fs::path json = test::TestDir("check") / "b.json";
  const auto r =
      test::RunTtp("check --log " + kCheckSamples + "run-b/talc.csv " +
                   kCheckSamples + "run-b/piece.xyz --json " + json.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("45 cuts match the program"), std::string::npos);
  std::ifstream in(json);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["compared"], 40);
  EXPECT_EQ(j["agree"], true);
  EXPECT_EQ(j["cycles"].size(), 8u);
  EXPECT_TRUE(j["cycles"][0]["temperature"].contains("table_rtest_K"));
}

// Figures without their U (a lab's own evaluation, hand-written) are taken
// as exact, and `check` and `diagnose` say so on stderr and in their JSON;
// with U given there is no such warning. The figures are run-b's cloud
// read by `ttp inspect`.
TEST(CliCheck, FiguresWithoutUncertaintyAreNamed) {
  const fs::path dir = test::TestDir("check");
  const fs::path inspected = dir / "b_inspected.json";
  auto r = test::RunTtp("inspect " + kCheckSamples + "run-b/piece.xyz --json " +
                        inspected.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  nlohmann::json with_u, without_u;
  with_u["figures"] = test::ReadJson(inspected).at("figures");
  without_u = with_u;
  for (auto& f : without_u["figures"]) f.erase("U");
  without_u["figures"][2]["U"] = with_u["figures"][2]["U"];  // one given
  std::ofstream(dir / "with_u.json") << with_u.dump();
  std::ofstream(dir / "without_u.json") << without_u.dump();
  for (const std::string command : {"check", "diagnose"}) {
    for (const bool given : {true, false}) {
      SCOPED_TRACE(command + (given ? " with U" : " without U"));
      const fs::path in = dir / (given ? "with_u.json" : "without_u.json");
      const fs::path out = dir / ("out_" + command + ".json");
      r = test::RunTtp(command + " --log " + kCheckSamples + "run-b/talc.csv " +
                       in.string() + " --json " + out.string());
      ASSERT_NE(r.exit_code, 2) << r.output;
      const auto warnings = test::ReadJson(out).at("measurement_warnings");
      const std::string text = warnings.dump();
      if (given) {
        EXPECT_EQ(text.find("without an uncertainty"), std::string::npos)
            << text;
        continue;
      }
      // 7 cycles x 5 figures without U (cycle 3's are given)
      EXPECT_NE(text.find("35 figure(s) without an uncertainty "
                          "(figures[0].U.E_X"),
                std::string::npos)
          << text;
      EXPECT_NE(r.output.find("warning: " + in.string() + ": 35 figure(s)"),
                std::string::npos)
          << r.output;
    }
  }
}

// run-a hides a workpiece expansion (truth.json): the measured E_TTP
// exceeds the rigid-table simulation during the warm-up.
// A lab's CMM: its MPE (a + L/b) reaches the measured U of DMIS results,
// and options that cannot describe a CMM program are refused by name.
// Run-c's DMIS output (piece.dmo) with the default MPE (1.2 um + L/400)
// and with a = 5 um: every feature lies within 200 mm of W's origin, so
// the measured U of a figure grows by (5 + L/400) / (1.2 + L/400), between
// 3.2 (L = 200 mm) and 4.17 (L = 0).
TEST(CliCheck, TheCmmsMpeReachesTheMeasuredUncertainty) {
  const fs::path dir = test::TestDir("check");
  const std::string base = "check --log " + kCheckSamples + "run-c/talc.csv " +
                           kCheckSamples + "run-c/piece.dmo --json ";
  const auto a = test::RunTtp(base + (dir / "mpe_default.json").string());
  const auto b =
      test::RunTtp(base + (dir / "mpe_5.json").string() + " --cmm-mpe-um 5");
  ASSERT_NE(a.exit_code, 2) << a.output;
  ASSERT_NE(b.exit_code, 2) << b.output;
  std::ifstream ia(dir / "mpe_default.json"), ib(dir / "mpe_5.json");
  const auto ja = nlohmann::json::parse(ia), jb = nlohmann::json::parse(ib);
  int compared = 0;
  for (size_t c = 1; c < ja["cycles"].size(); ++c)
    for (const char* f : {"E_X", "E_Y", "E_Z"}) {
      const double ua = ja["cycles"][c][f]["U_measured"];
      const double ub = jb["cycles"][c][f]["U_measured"];
      EXPECT_GT(ub / ua, 3.2) << f << " cycle " << c;
      EXPECT_LT(ub / ua, 4.17) << f << " cycle " << c;
      ++compared;
    }
  EXPECT_GT(compared, 10);
  const auto bad =
      test::RunTtp(base + (dir / "bad.json").string() + " --cmm-touches 2");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--cmm-touches"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("three touches"), std::string::npos) << bad.output;
}

TEST(CliCheck, RunAsWorkpieceExpansionDisagrees) {
  const fs::path json = test::TestDir("check") / "a.json";
  const auto r =
      Check(kCheckSamples + "run-a/talc.csv", "--json " + json.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("DISAGREE"), std::string::npos);
  std::ifstream in(json);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["agree"], false);
  const auto& c4 = j["cycles"][3];
  EXPECT_EQ(c4["E_TTP"]["agree"], false);
  EXPECT_GT(c4["E_TTP"]["difference"].get<double>(), 2.0);
  // Thesis 7.10: the piece warmed more than the rigid model says.
  EXPECT_GT(c4["temperature"]["piece_measured_K"].get<double>(),
            c4["temperature"]["piece_simulated_K"].get<double>() + 1.0);
}

TEST(CliCheck, CutNameThatIsNotAFeature) {
  const auto log = Mutated("name", [](auto& rows) {
    Replace(rows[CutRow(rows, "X1-3")], ",X1-3,", ",X7-3,");
  });
  // Not a feature of the piece at all: the log breaks its format
  // (talc-log.md), bad input naming the line.
  const auto r = Check(log);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  for (const char* w : {"name.csv", "feature", "X7-3"})
    EXPECT_NE(r.output.find(w), std::string::npos) << w << "\n" << r.output;
}

TEST(CliCheck, CutsOutOfOrder) {
  const auto log = Mutated("order", [](auto& rows) {
    const size_t first = CutRow(rows, "X1-1"), second = CutRow(rows, "X2-1");
    Replace(rows[first], ",X1-1,", ",X2-1,");
    Replace(rows[second], ",X2-1,", ",X1-1,");
  });
  ExpectRefused(Check(log), {"order.csv", "feature", "out of the program"});
}

TEST(CliCheck, CutTimeOffTheSchedule) {
  const auto log = Mutated("time", [](auto& rows) {
    std::string& row = rows[CutRow(rows, "Y2-2")];
    row = std::to_string(TimeOf(row) + 400) + row.substr(row.find(','));
  });
  ExpectRefused(Check(log), {"time.csv", "t_s", "Y2-2", "tolerance"});
  // A wider tolerance accepts it.
  const auto wide = Check(log, "--time-tolerance-s 600");
  EXPECT_EQ(wide.output.find("status: refused"), std::string::npos)
      << wide.output;
}

TEST(CliCheck, TableAngleNotThePlannedOne) {
  const auto log = Mutated("angle", [](auto& rows) {
    Replace(rows[CutRow(rows, "Y1-6")], ",Y1-6,", ",Y1-6,1");
  });
  ExpectRefused(Check(log), {"angle.csv", "c_deg", "Y1-6"});
}

TEST(CliCheck, CutMissingFromTheLog) {
  const auto log = Mutated("missing", [](auto& rows) {
    rows.erase(rows.begin() + CutRow(rows, "Z7"));
  });
  ExpectRefused(Check(log), {"missing.csv", "Z7", "no cut row"});
}

TEST(CliCheck, LogEndsBeforeTheLastCut) {
  const auto log = Mutated("ends", [](auto& rows) {
    rows.erase(std::remove_if(rows.begin(), rows.end(),
                              [](const std::string& r) {
                                return TimeOf(r) > 8 * 3600 + 100;
                              }),
               rows.end());
  });
  ExpectRefused(Check(log), {"ends.csv", "t_s", "ends at", "last cut"});
  // The JSON says so too, with the reason.
  const fs::path json = test::TestDir("check") / "ends.json";
  EXPECT_EQ(Check(log, "--json " + json.string()).exit_code, 1);
  const nlohmann::json j = nlohmann::json::parse(ReadTextFile(json));
  EXPECT_EQ(j["status"], "refused");
  EXPECT_NE(j["reason"].get<std::string>().find("last cut"), std::string::npos);
  EXPECT_FALSE(j["agree"].get<bool>());
}

// Without the schedule check, a log that ends after cycle 4 simulates only
// cycles 1-4: the measured figures of cycles 5-8 are not compared, and a
// run not compared in full does not agree.
TEST(CliCheck, LogEndsBeforeTheLastCutWithoutTheScheduleCheck) {
  const auto log = Mutated("short", [](auto& rows) {
    rows.erase(std::remove_if(
                   rows.begin(), rows.end(),
                   [](const std::string& r) { return TimeOf(r) > 4.5 * 3600; }),
               rows.end());
  });
  const fs::path json = test::TestDir("check") / "short.json";
  const auto r = Check(log, "--no-schedule-check --json " + json.string());
  EXPECT_EQ(r.exit_code, 1) << r.output;
  const nlohmann::json j = nlohmann::json::parse(ReadTextFile(json));
  EXPECT_FALSE(j["agree"].get<bool>());
  EXPECT_GT(j["not_simulated"].get<int>(), 0);
  EXPECT_NE(r.output.find("have no simulated value"), std::string::npos)
      << r.output;
}

TEST(CliCheck, LogStartsAfterTheFirstCut) {
  const auto log = Mutated("starts", [](auto& rows) {
    rows.erase(
        std::remove_if(rows.begin(), rows.end(),
                       // The program's first cut starts about 317 s into
                       // the log (its report comes at 320 s).
                       [](const std::string& r) { return TimeOf(r) < 319; }),
        rows.end());
  });
  ExpectRefused(Check(log), {"starts.csv", "t_s", "starts at", "first cut"});
}

// A log that ends before an R-test follows the last cuts is checked: the
// machine errors there are extrapolated, and the output says so. A log
// without an R-test before the first cut is bad input.
TEST(CliCheck, NoRTestAfterTheLastCutIsExtrapolated) {
  const auto log = Mutated("rtest_after", [](auto& rows) {
    rows.erase(std::remove_if(rows.begin(), rows.end(),
                              [](const std::string& r) {
                                return TimeOf(r) > 8 * 3600 + 354 &&
                                       r.find(",rtest,") != std::string::npos;
                              }),
               rows.end());
  });
  const auto r = Check(log);
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  EXPECT_NE(r.output.find("cut(s) after the last R-test"), std::string::npos)
      << r.output;
  const auto first = Mutated("rtest", [](auto& rows) {
    rows.erase(std::remove_if(rows.begin(), rows.end(),
                              [](const std::string& r) {
                                return TimeOf(r) < 400 &&
                                       r.find(",rtest,") != std::string::npos;
                              }),
               rows.end());
  });
  ExpectRefused(Check(first), {"rtest.csv", "rtest", "no R-test before"});
}

TEST(CliCheck, BadMeasurementOrUsage) {
  EXPECT_EQ(test::RunTtp("check --log " + kCheckSamples + "run-a/talc.csv " +
                         (test::TestDir("check") / "nothing.ply").string())
                .exit_code,
            2);
  EXPECT_EQ(
      test::RunTtp("check " + kCheckSamples + "run-a/piece.ply").exit_code, 2);
}

}  // namespace
}  // namespace ttp
