// `ttp thermal fit|predict|compare` end to end on the real FL spindle data
// and on bad input (exit codes 0 / 2, messages naming file, line, column).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "run_ttp.h"
#include "thermal_log_text.h"

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
    const std::vector<std::string> cells = CsvCells(line);
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

// A temperature sensor that jumps inside the fitted log (3 K added to T_t7
// from t = 9000 s on, 2.5 h into a 6.7 h excerpt, in a speed block, inside
// the span the thermal page's comparison fits): `fit`
// warns, shifts it back and keeps the jump in the model file; `predict`
// shifts the same log's later rows; --keep-jumps warns and keeps it.
TEST(CliModels, FitWarnsOfAndShiftsOutASensorThatJumps) {
  const auto dir = TestDir();
  const std::filesystem::path log =
      WriteWithStep(Excerpt(dir / "head.csv", 0, 1600, true),
                    dir / "jumped.csv", "T_t7", 9000, 3.0);
  const auto model = dir / "model.json";
  RunResult r =
      RunTtp("thermal fit " + log.string() + " -o " + model.string() +
             " --outputs d_ch3 --json " + (dir / "fit.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("warning: T_t7 jumps by +"), std::string::npos)
      << r.output;
  const auto m = ReadJson(model);
  ASSERT_EQ(m["fitted_jumps"].size(), 1u);
  EXPECT_EQ(m["fitted_jumps"][0]["input"], "T_t7");
  EXPECT_NEAR(m["fitted_jumps"][0]["step_k"].get<double>(), 3.0, 0.03);
  const auto fit = ReadJson(dir / "fit.json");
  EXPECT_EQ(fit["fitted_jumps"], m["fitted_jumps"]);
  ASSERT_EQ(fit["warnings"].size(), 1u);

  r = RunTtp("thermal predict --model " + model.string() + " " + log.string() +
             " -o " + (dir / "pred.csv").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("T_t7: shifted back by +"), std::string::npos)
      << r.output;
  EXPECT_EQ(r.output.find("T_t7 jumps"), std::string::npos) << r.output;

  // The thermal page says it too (its comparison's fitted span has the
  // jump).
  const auto page = dir / "page.html";
  r = RunTtp("report --log " + log.string() + " -o " + page.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream html(page);
  const std::string body((std::istreambuf_iterator<char>(html)),
                         std::istreambuf_iterator<char>());
  EXPECT_NE(body.find("<ul class=\"warnings\">\n<li>T_t7 jumps by +"),
            std::string::npos);

  r = RunTtp("thermal fit " + log.string() + " -o " + model.string() +
             " --outputs d_ch3 --keep-jumps");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("not repaired (--keep-jumps)"), std::string::npos)
      << r.output;
  EXPECT_TRUE(ReadJson(model)["fitted_jumps"].empty());
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
  // Given where a measurement goes, the thermal log is still its page.
  const RunResult positional =
      RunTtp("report " + log + " -o " + (dir / "p.html").string() + " --json " +
             (dir / "p.json").string());
  ASSERT_EQ(positional.exit_code, 0) << positional.output;
  EXPECT_EQ(ReadJson(dir / "p.json"), data);

  // The TALC replay on the same page: the default strategy, its
  // calibration (8.5 h) shortened to a third of this 10 h excerpt, at five
  // intervals; each point is what `ttp talc replay` reports for that
  // strategy on that log, and the hourly one is drawn over time with every
  // measurement marked.
  EXPECT_NE(page.find("TALC replayed"), std::string::npos);
  const auto& replay = data["replay"];
  ASSERT_TRUE(replay.contains("curve")) << replay.dump();
  EXPECT_TRUE(replay["calibration_shortened"].get<bool>());
  const double calibration_s = replay["strategy"]["calibration_s"];
  EXPECT_NEAR(calibration_s, 2399 * 15.0 / 3.0, 1e-9);
  ASSERT_EQ(replay["curve"].size(), 5u);
  const auto& hourly = replay["curve"][2];
  ASSERT_EQ(hourly["interval_s"].get<double>(), 3600.0);
  const RunResult cli =
      RunTtp(fmt::format("talc replay {} --interval-s 3600 --calibration-s {} "
                         "--json {}",
                         log, calibration_s, (dir / "replay.json").string()));
  ASSERT_EQ(cli.exit_code, 0) << cli.output;
  const auto expected = ReadJson(dir / "replay.json");
  EXPECT_EQ(hourly["measurements"], expected["measurements"]);
  ASSERT_EQ(expected["outputs"].size(), 5u);
  for (const auto& o : expected["outputs"]) {
    const auto& shown = hourly["outputs"][o["name"].get<std::string>()];
    EXPECT_DOUBLE_EQ(shown["talc_p99_um"].get<double>(),
                     o["talc"]["p99_um"].get<double>());
    EXPECT_DOUBLE_EQ(shown["hold_p99_um"].get<double>(),
                     o["hold"]["p99_um"].get<double>());
  }
  ASSERT_EQ(replay["outputs"].size(), 5u);
  for (const auto& o : replay["outputs"]) {
    ASSERT_EQ(o["measured"].size(), replay["t_h"].size());
    ASSERT_EQ(o["talc"].size(), replay["t_h"].size());
    ASSERT_EQ(o["hold"].size(), replay["t_h"].size());
    size_t marked = 0;
    for (const auto& v : o["measurement"]) marked += v.is_number();
    EXPECT_EQ(marked, expected["measurement_times_s"].size());
  }

  // A thermal log's page shows no piece: one given beside it is refused,
  // not silently left out.
  const RunResult with_piece =
      RunTtp("report --log " + log + " " + std::string(TTP_DATA_DIR) +
             "/samples/run-a/piece.ply -o " + (dir / "y.html").string());
  EXPECT_EQ(with_piece.exit_code, 2) << with_piece.output;
  EXPECT_NE(with_piece.output.find("MEASUREMENT"), std::string::npos)
      << with_piece.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "y.html"));
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
  // --outputs naming nothing, or one output twice.
  r = RunTtp("thermal fit " + kTrain + " -o " + (dir / "m.json").string() +
             " --outputs ,,");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--outputs: names no column"), std::string::npos)
      << r.output;
  r = RunTtp("thermal fit " + kTrain + " -o " + (dir / "m.json").string() +
             " --outputs d_ch1,d_ch1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("d_ch1: output asked for more than once"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "m.json"));
  // Nothing half-written: the model and its summary, the prediction and
  // its summary are written all or none (here the summary's path is a
  // folder); the thermal page refuses such a --json before it computes.
  const auto folder = dir / "a_folder";
  std::filesystem::create_directories(folder);
  r = RunTtp("thermal fit " + kTrain + " -o " + (dir / "m.json").string() +
             " --outputs d_ch1 --model static --json " + folder.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "m.json"));
  r = RunTtp("thermal fit " + kTrain + " -o " + (dir / "m.json").string() +
             " --outputs d_ch1 --model static");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  r = RunTtp("thermal predict --model " + (dir / "m.json").string() + " " +
             kTrain + " -o " + (dir / "p.csv").string() + " --json " +
             folder.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "p.csv"));
  r = RunTtp("report --log " + Excerpt(dir / "short.csv", 0, 300, true) +
             " -o " + (dir / "page.html").string() + " --json " +
             folder.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--json: output: '" + folder.string() +
                          "' is a folder, not a file"),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(dir / "page.html"));
  r = RunTtp("thermal compare " + kTrain + " --holdout-from 99999999");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  r = RunTtp("thermal predict --model " + bad.string() + " " + kTrain + " -o " +
             (dir / "p.csv").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
}

}  // namespace
}  // namespace ttp::test
