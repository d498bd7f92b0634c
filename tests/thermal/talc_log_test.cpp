// TALC log reader: the sample runs, and one bad log per rule of
// talc-log.md section 4 (strict: rejected naming line and field; lenient:
// warning, row dropped or kept).
#include "ttp/thermal/talc_log.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <string>

#include "ttp/geometry/error.h"

namespace ttp::thermal {
namespace {

const std::string kHead =
    "# talc-log: 1\n"
    "# machine: test\n"
    "# start: 2026-03-02T06:00:00+01:00\n"
    "# compensation: off\n";
const std::string kColumns =
    "t_s,event,T_env,c_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,feature,c_deg,"
    "dur_s\n";
const std::string kRows =
    "0,sample,20.0,0,,,,,,,,,0,\n"       // line 6
    "95,rtest,,,0,0,0,0,0,0,0,,,95\n"    // line 7
    "120,sample,20.1,1200,,,,,,,,,0,\n"  // line 8
    "130,cut,,,,,,,,,,X1-5,60,\n"        // line 9
    "180,sample,20.2,1200,,,,,,,,,0,\n"  // line 10
    "395,rtest,,,1,2,3,4,5,6,7,,,95\n";  // line 11

// Expects InputError at `line` naming `field`.
void ExpectRejected(const std::string& text, int line,
                    const std::string& field) {
  try {
    ParseTalcLog(text, "bad.csv");
    FAIL() << "accepted a bad log; expected line " << line << " " << field;
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "bad.csv");
    EXPECT_EQ(e.line(), line) << e.what();
    EXPECT_EQ(e.field(), field) << e.what();
  }
}

TEST(TalcLog, ReadsAGoodLog) {
  const TalcLog log = ParseTalcLog(kHead + kColumns + kRows, "good.csv");
  EXPECT_EQ(log.rows.size(), 6u);
  ASSERT_EQ(log.rtests.size(), 2u);
  EXPECT_DOUBLE_EQ(log.rtests[1].t_end_s, 395);
  EXPECT_DOUBLE_EQ(log.rtests[1].t_ref_s, 395 - 47.5);
  EXPECT_NEAR(log.rtests[1].measured.ex0c_mm, 1e-3, 1e-15);
  EXPECT_NEAR(log.rtests[1].measured.ec0c_rad, 7e-6, 1e-15);
  ASSERT_EQ(log.cuts.size(), 1u);
  EXPECT_EQ(log.cuts[0].feature, FeatureId::Facet(Segment::kX1, 5));
  EXPECT_NEAR(log.cuts[0].c_rad, M_PI / 3, 1e-12);
  EXPECT_FALSE(log.compensation);
  EXPECT_TRUE(log.warnings.empty());
  EXPECT_EQ(log.machine, "test");
}

TEST(TalcLog, ReadsTheSampleRuns) {
  for (const char* run : {"run-a", "run-b"}) {
    const TalcLog log = ReadTalcLog(std::string(TTP_DATA_DIR) + "/samples/" +
                                    run + "/talc.csv");
    EXPECT_EQ(log.cuts.size(), 45u) << run;
    EXPECT_GE(log.rtests.size(), 90u) << run;
    EXPECT_TRUE(log.gaps.empty()) << run;
    EXPECT_EQ(log.compensation, std::string(run) == "run-b") << run;
    EXPECT_EQ(log.has_pred_columns, std::string(run) == "run-b") << run;
    EXPECT_DOUBLE_EQ(log.sphere_distance_mm, 160);
    EXPECT_GE(log.LastTimeS() - log.FirstTimeS(), 8 * 3600.0) << run;
  }
}

TEST(TalcLog, UnknownKeysAndColumnsAreKeptAndIgnored) {
  const std::string text =
      "# talc-log: 1\n# operator: anna\n"
      "# start: 2026-03-02T06:00:00Z\n"
      "# compensation: off\n"
      "event,spare,t_s\nsample,abc,0\nsample,,60\n";
  const TalcLog log = ParseTalcLog(text, "x.csv");
  EXPECT_EQ(log.header.at("operator"), "anna");
  ASSERT_EQ(log.unknown_columns.size(), 1u);
  EXPECT_EQ(log.unknown_columns[0], "spare");
  EXPECT_EQ(log.rows.size(), 2u);
}

// Strict: missing required header keys.
TEST(TalcLog, RejectsMissingRequiredHeaderKeys) {
  for (const std::string key : {"talc-log", "start", "compensation"}) {
    std::string head;
    for (const std::string& line :
         {std::string("# talc-log: 1\n"),
          std::string("# start: 2026-03-02T06:00:00+01:00\n"),
          std::string("# compensation: off\n")}) {
      if (line.find(key + ":") == std::string::npos) head += line;
    }
    ExpectRejected(head + kColumns + kRows, 3, key);
  }
}

// Strict: missing t_s or event column.
TEST(TalcLog, RejectsMissingTimeOrEventColumn) {
  ExpectRejected(kHead + "event,T_env\nsample,20\n", 5, "t_s");
  ExpectRejected(kHead + "t_s,T_env\n0,20\n", 5, "event");
  // A file that is no TALC log at all (a PLY given as the log) says so.
  try {
    ParseTalcLog("ply\nformat ascii 1.0\n", "piece.ply");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not a TALC log"), std::string::npos)
        << e.what();
  }
  // A file separated by semicolons says so.
  try {
    ParseTalcLog(kHead + "t_s;event\n0;sample\n", "semi.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no comma but ';'"), std::string::npos)
        << e.what();
  }
}

// Strict: non-numeric cell, naming the line and the column.
TEST(TalcLog, RejectsNonNumericCell) {
  std::string rows = kRows;
  rows.replace(rows.find("20.1"), 4, "20,1x");  // breaks the cell count too
  ExpectRejected(kHead + kColumns + rows, 8, "row");
  rows = kRows;
  rows.replace(rows.find("20.1"), 4, "warm");
  ExpectRejected(kHead + kColumns + rows, 8, "T_env");
}

// Strict: non-finite numbers.
TEST(TalcLog, RejectsNonFiniteCell) {
  for (const char* bad : {"nan", "inf", "-inf", "1e999"}) {
    std::string rows = kRows;
    rows.replace(rows.find("1,2,3"), 1, bad);
    ExpectRejected(kHead + kColumns + rows, 11, "EX0C");
  }
}

// Strict: t_s required in every row.
TEST(TalcLog, RejectsRowWithoutTime) {
  std::string rows = kRows;
  rows.replace(rows.find("180,"), 3, "");
  ExpectRejected(kHead + kColumns + rows, 10, "t_s");
}

// Strict: rows out of order in time.
TEST(TalcLog, RejectsRowsOutOfOrder) {
  std::string rows = kRows;
  rows.replace(rows.find("180,"), 3, "100");
  ExpectRejected(kHead + kColumns + rows, 10, "t_s");
}

// Strict: comment lines only before the header.
TEST(TalcLog, RejectsCommentAfterTheHeaderRow) {
  ExpectRejected(kHead + kColumns + "0,sample,20,0,,,,,,,,,0,\n# late\n", 7,
                 "#");
}

// Lenient: exact duplicate rows are dropped with a warning.
TEST(TalcLog, DropsExactDuplicateRows) {
  const std::string dup = "180,sample,20.2,1200,,,,,,,,,0,\n";
  std::string rows = kRows;
  rows.insert(rows.find(dup) + dup.size(), dup);
  const TalcLog log = ParseTalcLog(kHead + kColumns + rows, "dup.csv");
  EXPECT_EQ(log.rows.size(), 6u);
  ASSERT_EQ(log.warnings.size(), 1u);
  EXPECT_EQ(log.warnings[0].rule, "duplicate");
  EXPECT_EQ(log.warnings[0].line, 11);
  // Same time, different content: both kept.
  rows = kRows;
  rows.insert(rows.find(dup) + dup.size(), "180,sample,20.3,1200,,,,,,,,,0,\n");
  EXPECT_EQ(ParseTalcLog(kHead + kColumns + rows, "x").rows.size(), 7u);
}

// Lenient: a gap of more than 10 min is reported, rows kept.
TEST(TalcLog, ReportsGapsOverTenMinutes) {
  std::string rows = kRows +
                     "995,sample,20.3,0,,,,,,,,,0,\n"    // 600 s: ok
                     "1596,sample,20.3,0,,,,,,,,,0,\n";  // 601 s
  const TalcLog log = ParseTalcLog(kHead + kColumns + rows, "gap.csv");
  EXPECT_EQ(log.rows.size(), 8u);
  ASSERT_EQ(log.gaps.size(), 1u);
  EXPECT_EQ(log.gaps[0].line, 13);
  EXPECT_DOUBLE_EQ(log.gaps[0].from_s, 995);
  EXPECT_DOUBLE_EQ(log.gaps[0].to_s, 1596);
  ASSERT_EQ(log.warnings.size(), 1u);
  EXPECT_EQ(log.warnings[0].rule, "gap");
}

// Lenient: an unknown event is kept as a note.
TEST(TalcLog, KeepsUnknownEventAsNote) {
  std::string rows = kRows;
  rows.replace(rows.find("180,sample"), 10, "180,coffee");
  const TalcLog log = ParseTalcLog(kHead + kColumns + rows, "ev.csv");
  EXPECT_EQ(log.rows.size(), 6u);
  EXPECT_EQ(log.rows[4].event, LogEvent::kNote);
  EXPECT_NE(log.rows[4].text.find("coffee"), std::string::npos);
  ASSERT_EQ(log.warnings.size(), 1u);
  EXPECT_EQ(log.warnings[0].rule, "unknown event");
  EXPECT_EQ(log.warnings[0].line, 10);
}

// Row meaning: cut rows need a known feature name and a table angle;
// rtest rows need all seven values.
TEST(TalcLog, RejectsBadCutAndRTestRows) {
  std::string rows = kRows;
  rows.replace(rows.find("X1-5"), 4, "X5-1");
  ExpectRejected(kHead + kColumns + rows, 9, "feature");
  rows = kRows;
  rows.replace(rows.find("X1-5,60"), 7, "X1-5,");
  ExpectRejected(kHead + kColumns + rows, 9, "c_deg");
  rows = kRows;
  rows.replace(rows.find("1,2,3"), 1, "");
  ExpectRejected(kHead + kColumns + rows, 11, "EX0C");
  // A second R-test describing the machine at the same time (not an exact
  // duplicate: other values) contradicts the first.
  ExpectRejected(kHead + kColumns + kRows + "395,rtest,,,2,2,3,4,5,6,7,,,95\n",
                 12, "t_s");
}

TEST(TalcLog, RejectsBadHeaderValues) {
  std::string head = kHead;
  head.replace(head.find("off"), 3, "maybe");
  // Each error names the line of its key.
  ExpectRejected(head + kColumns + kRows, 4, "compensation");
  head = kHead;
  head.replace(head.find("2026-03-02T06:00:00+01:00"), 25, "yesterday");
  ExpectRejected(head + kColumns + kRows, 3, "start");
  head = kHead;
  head.replace(head.find("talc-log: 1"), 11, "talc-log: 2");
  ExpectRejected(head + kColumns + kRows, 1, "talc-log");
}

// A day with a row a minute (and an R-test every 5 min) reads completely.
TEST(TalcLog, ReadsADayWithARowAMinute) {
  std::string text = kHead + kColumns;
  for (int i = 0; i < 1440; ++i) {
    text += fmt::format("{},sample,{:.3f},{},,,,,,,,,0,\n", i * 60,
                        20 + 0.001 * i, (i / 60) % 2 ? 1200 : 0);
    if (i % 5 == 4)
      text += fmt::format("{},rtest,,,{},0,0,0,0,0,0,,,95\n", i * 60 + 30,
                          0.01 * i);
  }
  const TalcLog log = ParseTalcLog(text, "day.csv");
  EXPECT_EQ(log.CountEvent(LogEvent::kSample), 1440);
  EXPECT_EQ(log.rtests.size(), 288u);
  EXPECT_TRUE(log.warnings.empty());
  EXPECT_DOUBLE_EQ(log.LastTimeS(), 1439 * 60 + 30);
}

TEST(TalcLog, SummaryNamesWhatItFound) {
  const TalcLog log = ParseTalcLog(kHead + kColumns + kRows, "good.csv");
  const auto j = LogSummaryJson(log);
  EXPECT_EQ(j["rtests"], 2);
  EXPECT_EQ(j["cuts"], 1);
  EXPECT_EQ(j["compensation"], "off");
  EXPECT_NE(LogSummaryText(log).find("X1-5"), std::string::npos);
}

// Header values that cannot be, and values far beyond any machine's, are
// refused naming the line and the key; real edge cases are read.
TEST(TalcLog, RejectsImpossibleHeaderValuesAndHugeReadings) {
  const auto with_start = [](const std::string& start) {
    return "# talc-log: 1\n# machine: test\n# start: " + start +
           "\n# compensation: off\n" + kColumns + kRows;
  };
  ExpectRejected(with_start("2026-02-30T06:00:00+01:00"), 3, "start");
  ExpectRejected(with_start("2026-13-01T06:00:00+01:00"), 3, "start");
  ExpectRejected(with_start("2026-03-02T24:00:00+01:00"), 3, "start");
  ExpectRejected(with_start("2026-03-02T06:00:00+25:00"), 3, "start");
  ExpectRejected(with_start("2026-03-02T06:00:00-13:00"), 3, "start");
  for (const char* ok :
       {"2024-02-29T06:00:00+01:00", "2026-03-02T06:00:00+14:00",
        "2026-03-02T06:00:00-12:00", "2026-03-02T23:59:60Z",
        "2026-03-02T06:00+0530"})
    EXPECT_NO_THROW(ParseTalcLog(with_start(ok), "ok.csv")) << ok;
  ExpectRejected(kHead + "# compensation: on\n" + kColumns + kRows, 5,
                 "compensation");
  ExpectRejected("# sphere_distance_mm: 1e-300\n" + kHead + kColumns + kRows, 1,
                 "sphere_distance_mm");
  std::string huge = kRows;
  huge.replace(huge.find("1,2,3"), 1, "1e300");
  ExpectRejected(kHead + kColumns + huge, 11, "EX0C");
  ExpectRejected(kHead + kColumns + kRows + "1e12,sample,20,0,,,,,,,,,0,\n", 12,
                 "t_s");
  ExpectRejected(kHead + kColumns + kRows + "9e6,sample,20,0,,,,,,,,,0,\n", 12,
                 "t_s");
  // Below absolute zero; a subnormal is a number near zero, not non-finite.
  ExpectRejected(kHead + kColumns + kRows + "400,sample,-300,0,,,,,,,,,0,\n",
                 12, "T_env");
  EXPECT_NO_THROW(ParseTalcLog(
      kHead + kColumns + kRows + "400,sample,1e-320,0,,,,,,,,,0,\n", "ok.csv"));
}

}  // namespace
}  // namespace ttp::thermal
