// TALC log -> thermal time series: inputs held from their last logged value,
// R-tests as sparse outputs at their reference time, relative to the first
// R-test, angles as um at the sphere radius.
#include "ttp/thermal/time_series.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"

namespace ttp::thermal {
namespace {

const std::string kLog =
    "# talc-log: 1\n"
    "# machine: test\n"
    "# start: 2026-03-02T06:00:00+01:00\n"
    "# compensation: off\n"
    "# sphere_distance_mm: 200\n"
    "t_s,event,T_env,spindle_rpm,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,feature,"
    "c_deg,dur_s\n"
    "0,sample,20.0,0,,,,,,,,,0,\n"
    "95,rtest,,,1,0,0,0,0,0,0,,,90\n"
    "120,sample,20.1,1200,,,,,,,,,0,\n"
    "180,sample,20.2,1200,,,,,,,,,0,\n"
    "395,rtest,,,3,2,-3,4,5,6,7,,,90\n";

TEST(TalcTimeSeries, InputsHeldAndRTestsAsSparseOutputs) {
  const TalcLog log = ParseTalcLog(kLog, "talc.csv");
  const models::TimeSeries ts = TalcLogToTimeSeries(log);
  EXPECT_EQ(ts.input_names, (std::vector<std::string>{"T_env", "n_spindle"}));
  ASSERT_EQ(ts.output_names.size(), 7u);
  EXPECT_EQ(ts.output_names[4], "d_EA0C_r");
  // Rows: samples at 0, 120, 180 and R-tests at 95 - 45 = 50 and 350.
  ASSERT_EQ(ts.t_s, (std::vector<double>{0, 50, 120, 180, 350}));
  // The R-test at 50 s holds the inputs logged at 0 s (not later ones).
  EXPECT_DOUBLE_EQ(ts.inputs(1, 0), 20.0);
  EXPECT_DOUBLE_EQ(ts.inputs(1, 1), 0.0);
  EXPECT_DOUBLE_EQ(ts.inputs(4, 0), 20.2);
  EXPECT_DOUBLE_EQ(ts.inputs(4, 1), 1200.0);
  // Outputs only at R-test rows, relative to the first R-test.
  EXPECT_TRUE(std::isnan(ts.outputs_um(0, 0)));
  EXPECT_TRUE(std::isnan(ts.outputs_um(2, 3)));
  EXPECT_NEAR(ts.outputs_um(1, 0), 0.0, 1e-9);
  EXPECT_NEAR(ts.outputs_um(4, 0), 2.0, 1e-9);  // 3 - 1 um
  EXPECT_NEAR(ts.outputs_um(4, 2), -3.0, 1e-9);
  // 5 um/m at a 200 mm radius = 1 um.
  EXPECT_NEAR(ts.outputs_um(4, 4), 5.0 * 0.2, 1e-9);
  EXPECT_NEAR(ts.outputs_um(4, 6), 7.0 * 0.2, 1e-9);
  EXPECT_TRUE(ts.gap_rows.empty());
}

// Compensation on: the R-test sees the residual, and the machine's own
// error is the residual plus the prediction in force (talc-log.md section
// 2), linear between the rows giving pred_ and held after the last.
TEST(TalcTimeSeries, CompensatedRTestsBecomeTheMachinesOwnError) {
  const std::string log_on =
      "# talc-log: 1\n"
      "# start: 2026-03-02T06:00:00+01:00\n"
      "# compensation: on\n"
      "# sphere_distance_mm: 200\n"
      "t_s,event,T_env,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,pred_EX0C,"
      "pred_EY0C,pred_EZ0T,pred_ER0T,pred_EA0C,pred_EB0C,pred_EC0C,dur_s\n"
      "0,sample,20.0,,,,,,,,0,0,0,0,0,0,0,\n"
      "95,rtest,,1,0,0,0,0,0,0,,,,,,,,90\n"
      "200,sample,20.1,,,,,,,,2,0,-1,0,0,0,0,\n"
      "300,sample,20.1,,,,,,,,4,0,-2,0,5,0,0,\n"
      "395,rtest,,3,0,0,0,0,0,0,,,,,,,,90\n";
  const models::TimeSeries ts =
      TalcLogToTimeSeries(ParseTalcLog(log_on, "on.csv"));
  // R-tests at 50 s (pred a quarter of the way to the 200 s row: EX0C
  // 0.5 um, EZ0T -0.25 um) and 350 s (pred held at 4 um, -2 um, 5 um/m):
  // EX0C (3 + 4) - (1 + 0.5) = 5.5 um; EZ0T -2 + 0.25 = -1.75 um; EA0C
  // 5 um/m at 200 mm = 1 um.
  ASSERT_EQ(ts.t_s.back(), 350);
  const Eigen::Index last = static_cast<Eigen::Index>(ts.rows()) - 1;
  EXPECT_NEAR(ts.outputs_um(last, 0), 5.5, 1e-9);
  EXPECT_NEAR(ts.outputs_um(last, 2), -1.75, 1e-9);
  EXPECT_NEAR(ts.outputs_um(last, 4), 1.0, 1e-9);
  // Without the pred_ columns the machine's error cannot be recovered.
  std::string no_pred =
      "# talc-log: 1\n# start: 2026-03-02T06:00:00+01:00\n"
      "# compensation: on\n# sphere_distance_mm: 200\n"
      "t_s,event,T_env,EX0C,EY0C,EZ0T,ER0T,EA0C,EB0C,EC0C,dur_s\n"
      "0,sample,20.0,,,,,,,,\n95,rtest,,1,0,0,0,0,0,0,90\n"
      "395,rtest,,3,0,0,0,0,0,0,90\n";
  try {
    TalcLogToTimeSeries(ParseTalcLog(no_pred, "no_pred.csv"));
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "pred_EX0C") << e.what();
  }
}

// `ttp thermal` and `ttp talc` tell the two kinds of log apart by the
// talc-log key, a byte-order mark before it or not.
TEST(TalcTimeSeries, ReadsEitherKindOfLogWithOrWithoutAByteOrderMark) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ttp-ts-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string talc_path = (dir / "talc.csv").string();
  const std::string bom_path = (dir / "bom.csv").string();
  WriteFileAtomic(talc_path, kLog);
  WriteFileAtomic(bom_path, "\xEF\xBB\xBF" + kLog);
  const models::TimeSeries a = ReadThermalOrTalcLog(talc_path);
  const models::TimeSeries b = ReadThermalOrTalcLog(bom_path);
  EXPECT_EQ(a.header.at("converted-from"), "TALC log (talc-log.md)");
  EXPECT_EQ(b.header.at("converted-from"), "TALC log (talc-log.md)");
  EXPECT_EQ(a.t_s, b.t_s);
  const models::TimeSeries thermal = ReadThermalOrTalcLog(
      std::string(TTP_DATA_DIR) + "/reference/fl-thermal/train.csv");
  EXPECT_EQ(thermal.header.count("converted-from"), 0u);
  std::filesystem::remove_all(dir);
}

TEST(TalcTimeSeries, ReadsTheSampleRun) {
  const TalcLog log =
      ReadTalcLog(std::string(TTP_DATA_DIR) + "/samples/run-a/talc.csv");
  const models::TimeSeries ts = TalcLogToTimeSeries(log);
  EXPECT_GT(ts.rows(), 10u);
  EXPECT_EQ(ts.outputs_um.cols(), 7);
  EXPECT_GE(ts.InputIndex("T_env"), 0);
  for (size_t i = 1; i < ts.rows(); ++i) EXPECT_LT(ts.t_s[i - 1], ts.t_s[i]);
  EXPECT_FALSE(ts.inputs.hasNaN());
  int measured = 0;
  for (Eigen::Index i = 0; i < ts.outputs_um.rows(); ++i)
    measured += std::isfinite(ts.outputs_um(i, 0));
  EXPECT_EQ(measured, static_cast<int>(log.rtests.size()));
}

}  // namespace
}  // namespace ttp::thermal
