// Dial gauge and micrometer readings (measurements.md section 3): CSV with
// header `feature,reading_um`. Facet readings g are relative to the segment's
// reference facet (j = 5), positive towards the axis; strip readings are
// depths relative to strip 5, positive downwards.
#pragma once

#include <string>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"

namespace ttp::inspect {

struct DialOptions {
  // Smallest division of the gauge; its rounding is uniform: u = res/sqrt(12).
  double resolution_um = 1.0;
  // Standard uncertainty of setting and reading one value (repeatability).
  double repeatability_um = 0.5;
  // Ceres style: false with "DialOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
  // Throws InputError naming the field if a value is negative or not finite.
  void Validate() const;
};

// Per-feature results on the nominal finished piece shifted by the readings:
// facet d = nominal - g, strip depth = nominal + reading; the reference
// features get the nominal value and zero variance (they are the zero).
// Angles cannot be read with a gauge: they are NaN, so E_B is missing.
// Errors (InputError naming file, line and column): missing header column,
// non-numeric or non-finite reading, unknown or non-test feature, a feature
// given twice, a reading for a reference feature other than 0.
FeatureResults ReadDialReadings(const std::string& csv_text,
                                const std::string& source, const PartSpec& part,
                                const DialOptions& options = {});

}  // namespace ttp::inspect
