#include "ttp/models/time_series.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <optional>
#include <string>
#include <utility>

#include "test_dir.h"
#include "ttp/geometry/error.h"

namespace ttp::models {
namespace {

const std::string kHeader =
    "# thermal-log: 1\n"
    "# machine: test\n"
    "# start: 2024-01-01T00:00:00+01:00\n";

// Parses `text`, expects an InputError and returns it.
InputError ExpectError(const std::string& text) {
  try {
    ParseThermalLog(text, "bad.csv");
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no InputError for:\n" << text;
  return InputError("", 0, "", "");
}

// Unix times of these dates from Python's datetime.fromisoformat(...)
// .timestamp(): a leap day, a date before 1970, offsets either side of UTC,
// with and without seconds and a colon in the offset.
TEST(ThermalLog, StartIsReadAsUnixTime) {
  const std::pair<const char*, double> cases[] = {
      {"1970-01-01T00:00:00+00:00", 0.0},
      {"2000-03-01T00:00:00Z", 951868800.0},
      {"2024-01-01T00:00+00:00", 1704067200.0},
      {"2024-01-01T01:30:00+0130", 1704067200.0},
      {"1999-12-31T19:00:00-05:00", 946684800.0},
      {"2024-02-29T12:00:00+00:00", 1709208000.0},
      {"1969-07-20T20:17:40.5+00:00", -14182939.5},
  };
  for (const auto& [text, want] : cases) {
    const std::optional<double> got = Iso8601EpochS(text);
    ASSERT_TRUE(got.has_value()) << text;
    EXPECT_DOUBLE_EQ(*got, want) << text;
  }
  EXPECT_FALSE(Iso8601EpochS("2024-01-01 00:00:00+00:00"));
  EXPECT_FALSE(Iso8601EpochS("2024-01-01T00:00:00"));  // no offset
  EXPECT_FALSE(Iso8601EpochS("2024-13-01T00:00:00Z"));
  TimeSeries ts;
  EXPECT_FALSE(StartEpochS(ts));
  ts.header["start"] = "2024-01-01T00:00:00+00:00";
  EXPECT_DOUBLE_EQ(*StartEpochS(ts), 1704067200.0);
}

TEST(ThermalLog, ReadsValidFileWithSparseOutputsAndIgnoredColumns) {
  const TimeSeries ts = ParseThermalLog(kHeader +
                                            "t_s,n_spindle,T_a,note,d_x\n"
                                            "0,0,20.0,hello,0.0\n"
                                            "15,1000,20.5,,\n"
                                            "30,1000,21.0,x,1.5\n",
                                        "ok.csv");
  ASSERT_EQ(ts.rows(), 3u);
  EXPECT_EQ(ts.input_names, (std::vector<std::string>{"n_spindle", "T_a"}));
  EXPECT_EQ(ts.output_names, (std::vector<std::string>{"d_x"}));
  EXPECT_EQ(ts.InputIndex("T_a"), 1);
  EXPECT_EQ(ts.InputIndex("note"), -1);
  EXPECT_EQ(ts.OutputIndex("d_x"), 0);
  EXPECT_DOUBLE_EQ(ts.inputs(1, 0), 1000.0);
  EXPECT_TRUE(std::isnan(ts.outputs_um(1, 0)));
  EXPECT_DOUBLE_EQ(ts.outputs_um(2, 0), 1.5);
  EXPECT_EQ(ts.header.at("machine"), "test");
  EXPECT_TRUE(ts.gap_rows.empty());
}

TEST(ThermalLog, FileForPredictionWithoutOutputs) {
  const TimeSeries ts =
      ParseThermalLog(kHeader + "T_a,t_s\n20,0\n21,10\n", "p.csv");
  EXPECT_EQ(ts.rows(), 2u);
  EXPECT_EQ(ts.outputs_um.cols(), 0);
  EXPECT_DOUBLE_EQ(ts.t_s[1], 10.0);
}

TEST(ThermalLog, MissingTimeColumn) {
  const InputError e = ExpectError(kHeader + "n_s,T_a\n0,20\n");
  EXPECT_EQ(e.field(), "t_s");
  EXPECT_EQ(e.line(), 4);
  EXPECT_EQ(e.source(), "bad.csv");
}

TEST(ThermalLog, MissingTimeColumnOfASemicolonFileNamesTheSeparator) {
  const InputError e = ExpectError(kHeader + "t_s;n_s;T_a\n0;0;20\n");
  EXPECT_EQ(e.field(), "t_s");
  EXPECT_NE(std::string(e.what()).find("no comma but ';'"), std::string::npos)
      << e.what();
}

TEST(ThermalLog, MissingVersionKey) {
  const InputError e =
      ExpectError("# start: 2024-01-01T00:00:00Z\nt_s,T_a\n0,20\n");
  EXPECT_EQ(e.field(), "# thermal-log");
  EXPECT_EQ(e.line(), 2);
}

TEST(ThermalLog, MissingStartKey) {
  const InputError e = ExpectError("# thermal-log: 1\nt_s,T_a\n0,20\n");
  EXPECT_EQ(e.field(), "# start");
}

TEST(ThermalLog, StartWithoutOffset) {
  const InputError e = ExpectError(
      "# thermal-log: 1\n# start: 2024-01-01T00:00:00\nt_s,T_a\n0,20\n");
  EXPECT_EQ(e.field(), "# start");
}

// A start of the right form that names no real moment: each refused with
// its reason, naming the key and its line (the TALC log reader uses the
// same check).
TEST(ThermalLog, StartThatIsNoRealTime) {
  const std::pair<const char*, const char*> cases[] = {
      {"2023-02-29T00:00:00Z", "day 29 does not exist in 2023-02"},
      {"2024-13-01T00:00:00Z", "month 13 does not exist"},
      {"2024-01-01T24:00:00Z", "not a time of day"},
      {"2024-01-01T12:60:00Z", "not a time of day"},
      {"2024-01-01T12:00:00+15:00", "UTC offset +15:00 does not exist"},
      {"2024-01-01T12:00:00-12:30", "UTC offset -12:30 does not exist"},
  };
  for (const auto& [start, why] : cases) {
    const InputError e =
        ExpectError(std::string("# thermal-log: 1\n# start: ") + start +
                    "\nt_s,T_a\n0,20\n");
    EXPECT_EQ(e.field(), "# start") << start;
    EXPECT_EQ(e.line(), 3) << start;
    EXPECT_NE(std::string(e.what()).find(why), std::string::npos)
        << start << ": " << e.what();
    EXPECT_FALSE(Iso8601EpochS(start)) << start;
  }
  EXPECT_EQ(Iso8601Problem("2024-02-29T23:59:60.5+14:00"), "");
}

TEST(ThermalLog, TimeNotIncreasing) {
  const InputError e = ExpectError(kHeader + "t_s,T_a\n0,20\n15,20\n15,20.1\n");
  EXPECT_EQ(e.field(), "t_s");
  EXPECT_EQ(e.line(), 7);
  const InputError back =
      ExpectError(kHeader + "t_s,T_a\n0,20\n15,20\n10,20.1\n");
  EXPECT_EQ(back.line(), 7);
}

TEST(ThermalLog, NonNumericCell) {
  const InputError e = ExpectError(kHeader + "t_s,T_a,d_x\n0,20,0\n15,abc,1\n");
  EXPECT_EQ(e.field(), "T_a");
  EXPECT_EQ(e.line(), 6);
  const InputError out =
      ExpectError(kHeader + "t_s,T_a,d_x\n0,20,0\n15,20,1.2.3\n");
  EXPECT_EQ(out.field(), "d_x");
  const InputError time = ExpectError(kHeader + "t_s,T_a\nzero,20\n");
  EXPECT_EQ(time.field(), "t_s");
}

TEST(ThermalLog, NonFiniteCell) {
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a,d_x\n0,nan,0\n").field(), "T_a");
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a,d_x\n0,20,inf\n").field(), "d_x");
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a,d_x\n0,20,1e999\n").field(), "d_x");
}

// Finite but far beyond any machine's: refused with the limit named (a fit
// on 1e300 reports a model of 1e301 um with zero error).
TEST(ThermalLog, ValueBeyondAnyMachinesIsRefused) {
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a,d_x\n0,20,0\n15,20,1e300\n").field(),
            "d_x");
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a,d_x\n0,2000,0\n").field(), "T_a");
  EXPECT_EQ(ExpectError(kHeader + "t_s,n_s,T_a\n0,1e7,20\n").field(), "n_s");
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a\n1e10,20\n").field(), "t_s");
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a\n0,-300\n").field(), "T_a");
  const InputError e = ExpectError(kHeader + "t_s,T_a,d_x\n0,20,-2e5\n");
  EXPECT_EQ(e.line(), 5);
  EXPECT_NE(std::string(e.what()).find("limit"), std::string::npos);
}

TEST(ThermalLog, EmptyInputCell) {
  const InputError e =
      ExpectError(kHeader + "t_s,n_s,T_a,d_x\n0,0,20,0\n15,,20,\n");
  EXPECT_EQ(e.field(), "n_s");
  EXPECT_EQ(e.line(), 6);
}

TEST(ThermalLog, NoInputColumn) {
  const InputError e = ExpectError(kHeader + "t_s,d_x,other\n0,0,1\n");
  EXPECT_EQ(e.line(), 4);
  EXPECT_NE(e.problem().find("no input column"), std::string::npos);
}

TEST(ThermalLog, WrongCellCountAndLateComment) {
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a\n0,20,3\n").line(), 5);
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a\n0,20\n# late\n15,20\n").line(), 6);
  EXPECT_EQ(ExpectError(kHeader + "t_s,T_a,T_a\n0,20,20\n").field(), "T_a");
}

TEST(ThermalLog, GapKeptAsGapRowWithWarning) {
  std::string text = kHeader + "t_s,T_a,d_x\n";
  // Steps of 15 s, then one of 400 s (> 10 periods), then 15 s again.
  double t = 0;
  for (int i = 0; i < 20; ++i) {
    if (i == 12) t += 400 - 15;
    text += std::to_string(t) + ",20," + (i % 3 == 0 ? "1" : "") + "\n";
    t += 15;
  }
  const TimeSeries ts = ParseThermalLog(text, "gap.csv");
  ASSERT_EQ(ts.gap_rows.size(), 1u);
  EXPECT_EQ(ts.gap_rows[0], 12u);
  ASSERT_EQ(ts.warnings.size(), 1u);
  EXPECT_NE(ts.warnings[0].find("gap.csv:17"), std::string::npos)
      << ts.warnings[0];
  // A step of 10 periods exactly is not a gap.
  std::string edge = kHeader + "t_s,T_a\n0,1\n1,1\n2,1\n12,1\n13,1\n";
  EXPECT_TRUE(ParseThermalLog(edge, "edge.csv").gap_rows.empty());
}

TEST(ThermalLog, ReadsFileAndNamesItInErrors) {
  const auto dir = test::TestDir();
  const auto path = dir / "bad.csv";
  std::ofstream(path) << kHeader << "t_s,T_a\n0,20\n15,\n";
  try {
    ReadThermalLog(path);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), path.string());
    EXPECT_EQ(e.line(), 6);
    EXPECT_NE(std::string(e.what()).find("bad.csv:6: T_a"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ReadThermalLog(dir / "missing.csv"), InputError);
}

TEST(ThermalLog, ReadsRealSpindleTest) {
  const TimeSeries ts = ReadThermalLog(std::string(TTP_DATA_DIR) +
                                       "/reference/fl-thermal/train.csv");
  EXPECT_EQ(ts.rows(), 5560u);  // 15 s steps from 0 to 83385 s
  EXPECT_EQ(ts.input_names.size(), 17u);
  EXPECT_EQ(ts.input_names[0], "n_spindle");
  EXPECT_EQ(ts.output_names.size(), 5u);
  EXPECT_DOUBLE_EQ(ts.t_s.front(), 0.0);
  EXPECT_LT(ts.t_s.back(), 83400.0);
  EXPECT_GT(ts.t_s.back(), 83000.0);
  EXPECT_TRUE(ts.gap_rows.empty());
  EXPECT_EQ(ts.header.at("thermal-log"), "1");
  // Every output measured everywhere in this test; spindle reaches 5000/min
  // at most, temperatures stay in a plausible shop range.
  EXPECT_FALSE(ts.outputs_um.hasNaN());
  EXPECT_LE(ts.inputs.col(0).maxCoeff(), 5000.0);
  const auto temps = ts.inputs.rightCols(16);
  EXPECT_GT(temps.minCoeff(), 10.0);
  EXPECT_LT(temps.maxCoeff(), 60.0);
}

}  // namespace
}  // namespace ttp::models
