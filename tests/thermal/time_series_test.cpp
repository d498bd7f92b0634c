// TALC log -> thermal time series: inputs held from their last logged value,
// R-tests as sparse outputs at their reference time, relative to the first
// R-test, angles as um at the sphere radius.
#include "ttp/thermal/time_series.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

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
