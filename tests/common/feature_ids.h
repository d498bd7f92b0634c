// Typed feature ids from their names, for tests that name features as the
// files do ("X1-2", "Z3").
#pragma once

#include <string>

#include "ttp/geometry/features.h"

namespace ttp::test {

inline FeatureId Fid(const std::string& name) {
  return FeatureId::Parse(name).value();
}

}  // namespace ttp::test
