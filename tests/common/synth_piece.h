// Synthetic measured pieces for the tests (sim/synth.h, the project's
// generator): the finished piece's mesh, built once (it takes a while),
// and a piece of the default part with random deviations in a random pose.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "ttp/geometry/part_mesh.h"
#include "ttp/sim/synth.h"

namespace ttp::test {

inline const PartMesh& FinishedMesh() {
  static const PartMesh mesh = BuildPartMesh(PartSpec{}, Stage::kFinished);
  return mesh;
}

// `points` on the piece with the generator's default noise and strays;
// `missing` features left without points.
inline sim::SynthPiece RandomSynthPiece(uint32_t seed, int points = 20000,
                                        std::vector<std::string> missing = {}) {
  const PartSpec part;
  sim::SynthOptions o;
  o.points = points;
  o.seed = seed;
  o.missing = std::move(missing);
  return sim::SynthesizePiece(part, FinishedMesh(),
                              sim::RandomDeviations(part, o), o);
}

}  // namespace ttp::test
