#include "ttp/gcode/program.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "ttp/gcode/canon.h"
#include "ttp/geometry/error.h"

namespace ttp::gcode {
namespace {

TEST(ProgramTest, DialectNamesRoundTrip) {
  for (Dialect d : {Dialect::kFanuc, Dialect::kLinuxCnc})
    EXPECT_EQ(ParseDialect(DialectName(d), "test"), d);
}

TEST(ProgramTest, UnknownDialectNamesTheSource) {
  try {
    ParseDialect("heidenhain", "--dialect");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "--dialect");
    EXPECT_EQ(e.field(), "dialect");
  }
}

TEST(ProgramTest, CanonKindNamesAreDistinct) {
  std::set<std::string> names;
  for (int k = 0; k <= static_cast<int>(CanonKind::kProbe); ++k)
    names.insert(CanonKindName(static_cast<CanonKind>(k)));
  EXPECT_EQ(names.size(), static_cast<size_t>(CanonKind::kProbe) + 1);
  EXPECT_EQ(names.count("?"), 0u);
}

}  // namespace
}  // namespace ttp::gcode
