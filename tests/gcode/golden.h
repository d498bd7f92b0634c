// Hand-written expected canonical statements for golden transcripts.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "ttp/gcode/canon.h"

namespace ttp::gcode::testing {

struct Expected {
  CanonKind kind;
  int line;
  double x = 0, y = 0, z = 0, c_deg = 0;  // position after the statement
  double feed = 0;
  double value = 0;
  std::string text;
  bool clockwise = true;
};

inline void ExpectTranscript(const std::vector<CanonStatement>& got,
                             const std::vector<Expected>& want,
                             double tolerance_mm = 1e-12) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    SCOPED_TRACE("statement " + std::to_string(i) + " (line " +
                 std::to_string(want[i].line) + ")");
    const CanonStatement& g = got[i];
    const Expected& w = want[i];
    EXPECT_EQ(g.kind, w.kind)
        << CanonKindName(g.kind) << " vs " << CanonKindName(w.kind);
    if (w.line > 0) {
      EXPECT_EQ(g.source_line, w.line);
    }
    EXPECT_NEAR(g.end_mm.x(), w.x, tolerance_mm);
    EXPECT_NEAR(g.end_mm.y(), w.y, tolerance_mm);
    EXPECT_NEAR(g.end_mm.z(), w.z, tolerance_mm);
    EXPECT_NEAR(g.end_c_rad, w.c_deg * M_PI / 180.0, 1e-12);
    EXPECT_NEAR(g.feed_per_min, w.feed, 1e-9);
    EXPECT_NEAR(g.value, w.value, 1e-9);
    EXPECT_EQ(g.text, w.text);
    if ((w.kind == CanonKind::kSpindle || w.kind == CanonKind::kCSpin) &&
        w.value > 0) {
      EXPECT_EQ(g.clockwise, w.clockwise);
    }
  }
}

}  // namespace ttp::gcode::testing
