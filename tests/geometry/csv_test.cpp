#include "ttp/geometry/csv.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ttp/geometry/error.h"

namespace ttp {
namespace {

TEST(Csv, ParsesHeaderRowsAndLineNumbers) {
  const CsvTable t =
      ParseCsv("# comment\nfeature, reading_um\n\nX1-1, -1.5\nZ3,2\n", "d.csv");
  ASSERT_EQ(t.rows.size(), 2u);
  EXPECT_EQ(t.header_line, 2);
  EXPECT_EQ(t.rows[0].line, 4);
  EXPECT_EQ(t.Text(t.rows[0], t.Require("feature")), "X1-1");
  EXPECT_DOUBLE_EQ(t.Number(t.rows[1], t.Require("reading_um")), 2.0);
}

TEST(Csv, ErrorsNameFileLineAndColumn) {
  const CsvTable t = ParseCsv("a,b\n1,x\n2,nan\n", "f.csv");
  try {
    t.Number(t.rows[0], 1);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "f.csv:2: b: 'x' is not a number");
  }
  EXPECT_THROW(t.Number(t.rows[1], 1), InputError);  // NaN
  EXPECT_THROW(t.Require("c"), InputError);
  EXPECT_THROW(ParseCsv("a,b\n1,2,3\n", "f.csv"), InputError);
  EXPECT_THROW(ParseCsv("# only\n", "f.csv"), InputError);
  EXPECT_THROW(ParseCsv("a,a\n", "f.csv"), InputError);
}

// A header read as one cell because the file is separated by something
// else says so; a comma-separated header missing a column says nothing more.
TEST(Csv, MissingColumnOfAFileSeparatedOtherwiseNamesTheSeparator) {
  const CsvTable semicolons = ParseCsv("feature;reading_um\nX1-1;2\n", "d.csv");
  try {
    semicolons.Require("feature");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "d.csv:1: feature: required column is missing from the header: "
              "the header holds no comma but ';' (a file separated by ';'); "
              "the format is comma separated");
  }
  EXPECT_EQ(SeparatorHint({"a\tb"}),
            ": the header holds no comma but a tab (a file separated by a "
            "tab); the format is comma separated");
  EXPECT_EQ(SeparatorHint({"a", "b;c"}), "");
  EXPECT_EQ(SeparatorHint({"reading_um"}), "");
}

// A number too small for a normal double (1e-320, strtod's ERANGE on
// underflow) is still a number near zero; one too large for a double is
// not finite. Each table cell reads numbers the same way.
TEST(Csv, UnderflowIsANumberOverflowIsNot) {
  const CsvTable t = ParseCsv("a\n1e-320\n-1e-400\n1e400\n", "f.csv");
  EXPECT_EQ(t.Number(t.rows[0], 0), 1e-320);
  EXPECT_EQ(std::abs(t.Number(t.rows[1], 0)), 0.0);
  try {
    t.Number(t.rows[2], 0);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "f.csv:4: a: '1e400' is not a finite number");
  }
}

}  // namespace
}  // namespace ttp
