#include "ttp/geometry/format.h"

#include <gtest/gtest.h>

#include <limits>

namespace ttp {
namespace {

// Text for a person: never "-0.000", "nan", "inf" or an exponent.
TEST(FormatNumber, NoNegativeZeroNanOrExponent) {
  EXPECT_EQ(FormatNumber(-0.0004, 3), "0.000");
  EXPECT_EQ(FormatNumber(-0.0, 2), "0.00");
  EXPECT_EQ(FormatNumber(-0.004, 2), "0.00");
  EXPECT_EQ(FormatNumber(-0.006, 2), "-0.01");
  EXPECT_EQ(FormatNumber(std::numeric_limits<double>::quiet_NaN(), 2), "-");
  EXPECT_EQ(FormatNumber(std::numeric_limits<double>::infinity(), 2, "n/a"),
            "n/a");
  EXPECT_EQ(FormatNumber(100.0, -1), "100");
  EXPECT_EQ(FormatNumber(2.5, -1), "2.5");
  EXPECT_EQ(FormatNumber(0.0012, -1), "0.0012");
  EXPECT_EQ(FormatNumber(123456789.0, -1), "123456789");
  EXPECT_EQ(FormatNumber(-1e-9, -1), "-0.000000001");
  EXPECT_EQ(FormatNumber(-1e-14, -1), "0");
}

}  // namespace
}  // namespace ttp
