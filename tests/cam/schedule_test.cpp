#include "ttp/cam/schedule.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <sstream>

#include "cam_testing.h"
#include "test_dir.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/features.h"
#include "ttp/geometry/file_io.h"

namespace ttp::cam {
namespace {

class ScheduleTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { schedule_ = new Schedule(BuildSchedule({})); }
  static void TearDownTestSuite() { delete schedule_; }
  static Schedule* schedule_;
};
Schedule* ScheduleTest::schedule_;

TEST_F(ScheduleTest, HasEveryTestFeatureOnceWithItsCycle) {
  const Config config;
  const auto features = TestFeatures(config.part);
  ASSERT_EQ(schedule_->cuts.size(), features.size());
  std::set<FeatureId> seen;
  for (const ScheduledCut& cut : schedule_->cuts) {
    EXPECT_TRUE(seen.insert(cut.feature).second) << cut.feature;
    EXPECT_EQ(cut.cycle, CycleForIndex(config.part, cut.index));
    EXPECT_EQ(cut.tool, config.process.finishing.number);
    EXPECT_EQ(cut.tool_name, config.process.finishing.name);
    EXPECT_GT(cut.end_s, cut.start_s);
  }
  for (const NominalFeature& f : features)
    EXPECT_TRUE(seen.count(f.Key())) << f.id;
}

// Cycles start on the hour; every cut of cycle k lies in its hour, a few
// minutes after the cycle's start, in the same place of the cycle as in the
// reference cycle (the strips' Y shift changes the approach at the
// positioning feed by less than two seconds).
TEST_F(ScheduleTest, CutsAreOnTheHour) {
  const double period = schedule_->cycle_period_s;
  EXPECT_EQ(period, 3600.0);
  ASSERT_EQ(schedule_->cycle_start_s.size(), 9u);
  for (size_t k = 0; k < 9; ++k)
    EXPECT_NEAR(schedule_->cycle_start_s[k],
                schedule_->cycle_start_s[0] + k * period, 1e-3);
  for (size_t i = 0; i < schedule_->cuts.size(); ++i) {
    const ScheduledCut& cut = schedule_->cuts[i];
    const double start = schedule_->cycle_start_s[cut.cycle];
    EXPECT_GE(cut.start_s, start);
    EXPECT_LT(cut.end_s, start + 600.0);
    const ScheduledCut& reference = schedule_->cuts[i % 5];
    EXPECT_NEAR(cut.end_s - start,
                reference.end_s - schedule_->cycle_start_s[0], 2.0)
        << cut.feature;
  }
  EXPECT_GT(schedule_->total_s, 8 * period);
  EXPECT_LT(schedule_->total_s, 9 * period);
}

TEST_F(ScheduleTest, FanucProgramGivesTheSameSchedule) {
  const Config config;
  const auto canon = testing::ReadBack(BuildTestCycleProgram(config),
                                       gcode::Dialect::kFanuc, config);
  const Schedule fanuc = ScheduleFromCanon(canon, config, "fanuc");
  ASSERT_EQ(fanuc.cuts.size(), schedule_->cuts.size());
  for (size_t i = 0; i < fanuc.cuts.size(); ++i) {
    EXPECT_EQ(fanuc.cuts[i].feature, schedule_->cuts[i].feature);
    EXPECT_NEAR(fanuc.cuts[i].start_s, schedule_->cuts[i].start_s, 1e-6);
    EXPECT_NEAR(fanuc.cuts[i].end_s, schedule_->cuts[i].end_s, 1e-6);
    EXPECT_EQ(fanuc.cuts[i].c_deg, schedule_->cuts[i].c_deg);
  }
}

TEST_F(ScheduleTest, CsvAndJsonHoldEveryCut) {
  const auto dir = test::TestDir("schedule");
  WriteScheduleCsv(dir / "s.csv", *schedule_);
  WriteScheduleJson(dir / "s.json", *schedule_);
  std::istringstream csv(ReadTextFile(dir / "s.csv"));
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("feature,cycle,index,start_s,end_s,c_deg,tool", 0), 0u);
  size_t rows = 0;
  while (std::getline(csv, line)) {
    EXPECT_EQ(line.substr(0, line.find(',')),
              schedule_->cuts[rows].feature.ToString());
    ++rows;
  }
  EXPECT_EQ(rows, schedule_->cuts.size());
  const auto doc = nlohmann::json::parse(ReadTextFile(dir / "s.json"));
  ASSERT_EQ(doc["cuts"].size(), schedule_->cuts.size());
  EXPECT_EQ(doc["cuts"][7]["feature"], schedule_->cuts[7].feature.ToString());
  EXPECT_DOUBLE_EQ(doc["cuts"][7]["end_s"].get<double>(),
                   schedule_->cuts[7].end_s);
  EXPECT_EQ(doc["cycle_start_s"].size(), 9u);
  std::filesystem::remove_all(dir);
}

TEST(ScheduleFromCanonTest, RejectsAReportOfAnUnknownFeature) {
  gcode::CanonStatement feed;
  feed.kind = gcode::CanonKind::kFeed;
  feed.end_mm = Eigen::Vector3d(10, 0, 0);
  feed.feed_per_min = 100;
  gcode::CanonStatement report;
  report.kind = gcode::CanonKind::kReport;
  report.text = "cut,W7,0.000";
  report.source_line = 12;
  try {
    ScheduleFromCanon({feed, report}, Config{}, "prog");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 12);
    EXPECT_EQ(e.field(), "report");
  }
}

TEST(ScheduleTableTest, PrintsOneRowPerCut) {
  Schedule s;
  s.cycle_period_s = 3600;
  s.cuts.push_back(
      {FeatureId::Strip(5), 0, 5, 1.5, 45.5, 0.0, 4, "finisher", 20});
  s.cuts.push_back({FeatureId::Facet(Segment::kX1, 5), 0, 5, 46, 60, 60.0, 4,
                    "finisher", 25});
  const std::string table = FormatScheduleTable(s);
  EXPECT_NE(table.find("X1-5"), std::string::npos);
  EXPECT_NE(table.find("60.000"), std::string::npos);
  EXPECT_EQ(std::count(table.begin(), table.end(), '\n'), 4);
}

}  // namespace
}  // namespace ttp::cam

namespace ttp::cam {
namespace {

// R-tests every 30 min: those due in a wait start on time, those due while
// a cycle cuts start after its cuts; each gives one TALC log row at its
// last report covering its five measurements (talc-log.md: rtest rows,
// dur_s); FANUC gives the same R-tests, and the dry run the same table
// angles in a shorter program.
TEST(ScheduleRTestTest, RTestsAtTheirDueTimesWithTheirLogRows) {
  Config config;
  config.process.rtest_interval_s = 1800;
  const Schedule s = BuildSchedule(config);
  const double period = config.process.cycle_period_s;
  const double t0 = s.cycle_start_s[0];
  ASSERT_EQ(s.rtests.size(), 17u);  // due at 0, 0.5 h, ... 8 h
  for (const ScheduledRTest& r : s.rtests) {
    const double due = t0 + r.number * 1800.0;
    if (r.number % 2 == 1) {
      EXPECT_NEAR(r.start_s, due, 2e-3) << r.number;
    } else {
      // Due at a cycle's start: after that cycle's last cut.
      const int k = r.number / 2;
      double last_cut = 0;
      for (const ScheduledCut& c : s.cuts)
        if (c.cycle == k) last_cut = std::max(last_cut, c.end_s);
      EXPECT_GT(r.start_s, last_cut) << r.number;
      EXPECT_LT(r.start_s, last_cut + 60) << r.number;
    }
    EXPECT_EQ(r.after_cycle, r.number / 2);
    ASSERT_EQ(r.positions.size(), static_cast<size_t>(kRTestPositions));
    for (size_t k = 1; k < r.positions.size(); ++k)
      EXPECT_GT(r.positions[k].measure_s, r.positions[k - 1].report_s);
    for (const auto& p : r.positions)
      EXPECT_NEAR(p.report_s - p.measure_s, config.process.rtest_measure_s,
                  1e-9);
    EXPECT_EQ(r.log_t_s, r.positions.back().report_s);
    EXPECT_NEAR(r.dur_s, r.log_t_s - r.positions.front().measure_s, 1e-9);
    EXPECT_GT(r.end_s, r.log_t_s);
    // Not while a cycle cuts.
    for (const ScheduledCut& c : s.cuts)
      EXPECT_TRUE(c.end_s < r.start_s || c.start_s > r.end_s) << c.feature;
  }
  for (int k = 0; k <= config.part.cycles(); ++k)
    EXPECT_NEAR(s.cycle_start_s[k], t0 + k * period, 2e-3);

  const auto canon = testing::ReadBack(BuildTestCycleProgram(config),
                                       gcode::Dialect::kFanuc, config);
  const Schedule fanuc = ScheduleFromCanon(canon, config, "fanuc");
  ASSERT_EQ(fanuc.rtests.size(), s.rtests.size());
  for (size_t i = 0; i < s.rtests.size(); ++i) {
    EXPECT_NEAR(fanuc.rtests[i].log_t_s, s.rtests[i].log_t_s, 1e-6);
    EXPECT_NEAR(fanuc.rtests[i].dur_s, s.rtests[i].dur_s, 1e-6);
  }
  EXPECT_EQ(fanuc.table_angles_deg, s.table_angles_deg);

  const Schedule dry = BuildSchedule(config, 0.01);
  EXPECT_EQ(dry.table_angles_deg, s.table_angles_deg);
  EXPECT_LT(dry.total_s, 0.1 * s.total_s);
  const std::string csv = RTestsToCsv(s);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 17 * kRTestPositions);
}

TEST(ScheduleRTestTest, RTestReportOutOfOrderIsRejected) {
  gcode::CanonStatement open;
  open.kind = gcode::CanonKind::kComment;
  open.text = RTestCommentText(0);
  gcode::CanonStatement dwell;
  dwell.kind = gcode::CanonKind::kDwell;
  gcode::CanonStatement report;
  report.kind = gcode::CanonKind::kReport;
  report.text = "rtest," + RTestPositionFeature(0, 2) + ",90.000";
  report.source_line = 7;
  try {
    ScheduleFromCanon({open, dwell, report}, Config{}, "prog");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("prog:7"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace ttp::cam
