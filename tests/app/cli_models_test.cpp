// `ttp thermal fit|predict|compare` end to end on the real FL spindle data
// and on bad input (exit codes 0 / 2, messages naming file, line, column).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "run_ttp.h"

namespace ttp::test {
namespace {

const std::string kTrain =
    std::string(TTP_DATA_DIR) + "/reference/fl-thermal/train.csv";

// The first `rows` data rows of train.csv, optionally without outputs.
std::string Excerpt(const std::filesystem::path& path, size_t first,
                    size_t rows, bool with_outputs) {
  std::ifstream in(kTrain);
  std::string line, text;
  size_t data = 0;
  std::vector<int> keep;
  while (std::getline(in, line)) {
    if (line[0] == '#') {
      text += line + "\n";
      continue;
    }
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string c;
    while (std::getline(ss, c, ',')) cells.push_back(c);
    if (keep.empty()) {
      for (size_t k = 0; k < cells.size(); ++k)
        if (with_outputs || cells[k].rfind("d_", 0) != 0)
          keep.push_back(int(k));
    } else if (data++ < first) {
      continue;
    }
    if (data > first + rows) break;
    std::string out;
    for (int k : keep) out += (out.empty() ? "" : ",") + cells[k];
    text += out + "\n";
  }
  std::ofstream(path) << text;
  return path.string();
}

TEST(CliModels, FitPredictContinuesAndCompare) {
  const auto dir = TestDir();
  const std::string head = Excerpt(dir / "head.csv", 0, 2400, true);
  const std::string tail = Excerpt(dir / "tail.csv", 2400, 400, false);
  const auto model = dir / "model.json";
  RunResult r = RunTtp("thermal fit " + head + " -o " + model.string() +
                       " --outputs d_ch1,d_ch3 --model lag --json " +
                       (dir / "fit.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto m = ReadJson(model);
  ASSERT_EQ(m["outputs"].size(), 2u);
  EXPECT_EQ(m["outputs"][0]["structure"], "lag");
  EXPECT_FALSE(m["outputs"][0]["end_state"].is_null());
  EXPECT_EQ(ReadJson(dir / "fit.json")["outputs"].size(), 2u);

  // The tail has no outputs at all and continues the fitted log.
  const auto pred = dir / "pred.csv";
  r = RunTtp("thermal predict --model " + model.string() + " " + tail + " -o " +
             pred.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("continuing"), std::string::npos) << r.output;
  std::ifstream in(pred);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "t_s,d_ch1,d_ch3");
  int rows = 0;
  while (std::getline(in, line)) ++rows;
  EXPECT_EQ(rows, 400);

  // A log without a column the model needs is refused, naming the column.
  const auto other = dir / "other.csv";
  std::ofstream(other) << "# thermal-log: 1\n# start: 2024-01-01T00:00:00Z\n"
                          "t_s,T_t1\n0,20\n15,20\n";
  r = RunTtp("thermal predict --model " + model.string() + " " +
             other.string() + " -o " + (dir / "x.csv").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("n_spindle"), std::string::npos) << r.output;

  // Compare on a short holdout of the excerpt.
  r = RunTtp("thermal compare " + head + " --holdout-from 27000 --json " +
             (dir / "cmp.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const auto cmp = ReadJson(dir / "cmp.json");
  // 3 references, 6 structures, select, auto
  EXPECT_EQ(cmp["models"].size(), 11u);
  EXPECT_TRUE(cmp.contains("select_candidates"));
  EXPECT_TRUE(cmp["diagnosis"].contains("d_ch5"));
  EXPECT_NE(r.output.find("simplest"), std::string::npos);
}

// `ttp report --log` on a thermal log: the comparison page (no measurement).
TEST(CliModels, ReportOnThermalLog) {
  const auto dir = TestDir();
  const std::string log = Excerpt(dir / "log.csv", 0, 2400, true);
  const auto html = dir / "r.html";
  const RunResult r = RunTtp("report --log " + log + " -o " + html.string() +
                             " --json " + (dir / "r.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(html);
  const std::string page((std::istreambuf_iterator<char>(in)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(page.find("uPlot"), std::string::npos);
  EXPECT_NE(page.find("What the best and the simplest get wrong"),
            std::string::npos);
  const auto data = ReadJson(dir / "r.json");
  ASSERT_EQ(data["outputs"].size(), 5u);
  EXPECT_EQ(data["outputs"][0]["measured"].size(), data["t_h"].size());
  // A TALC log still needs its measurement.
  const RunResult talc =
      RunTtp("report --log " + std::string(TTP_DATA_DIR) +
             "/samples/run-a/talc.csv -o " + (dir / "x.html").string());
  EXPECT_EQ(talc.exit_code, 2) << talc.output;
  EXPECT_NE(talc.output.find("MEASUREMENT"), std::string::npos);
}

// A TALC log is read as the same time series: R-tests as sparse outputs.
TEST(CliModels, FitsAndPredictsATalcLog) {
  const auto dir = TestDir();
  const std::string talc =
      std::string(TTP_DATA_DIR) + "/samples/run-a/talc.csv";
  RunResult r = RunTtp("thermal fit " + talc + " -o " +
                       (dir / "m.json").string() + " --model lag");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(ReadJson(dir / "m.json")["outputs"].size(), 7u);
  r = RunTtp("thermal predict --model " + (dir / "m.json").string() + " " +
             talc + " -o " + (dir / "p.csv").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "p.csv");
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header,
            "t_s,d_EX0C,d_EY0C,d_EZ0T,d_ER0T,d_EA0C_r,d_EB0C_r,d_EC0C_r");
}

TEST(CliModels, BadInputExitsTwoNamingLineAndColumn) {
  const auto dir = TestDir();
  const auto bad = dir / "bad.csv";
  std::ofstream(bad) << "# thermal-log: 1\n# start: 2024-01-01T00:00:00Z\n"
                        "t_s,T_a,d_x\n0,20,0\n15,,1\n";
  RunResult r = RunTtp("thermal fit " + bad.string() + " -o " +
                       (dir / "m.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.output.find("bad.csv:5: T_a"), std::string::npos) << r.output;
  r = RunTtp("thermal fit " + kTrain + " -o " + (dir / "m.json").string() +
             " --model neural");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunTtp("thermal compare " + kTrain + " --holdout-from 99999999");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunTtp("thermal predict --model " + bad.string() + " " + kTrain + " -o " +
             (dir / "p.csv").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace ttp::test
