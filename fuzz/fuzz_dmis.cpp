// DMIS output: statements, then the features in W. DMIS programs: the
// statement table, the label order and the run checks (patterns, the
// stylus path against the piece).
#include "fuzz_common.h"
#include "ttp/geometry/part_mesh.h"
#include "ttp/inspect/dmis.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const ttp::PartSpec part;
  static const ttp::PartMesh mesh =
      ttp::BuildPartMesh(part, ttp::Stage::kFinished);
  return ttp::fuzz::Run([&] {
    const std::string text = ttp::fuzz::Text(data, size);
    try {
      const auto program = ttp::inspect::ParseDmisProgram(text, "fuzz.dmi");
      ttp::inspect::CheckDmisStandard(program);
      ttp::inspect::CheckDmisProgram(program, part, mesh);
    } catch (const ttp::InputError&) {
      // refused with file and line: fine; the output reader runs below
    }
    const auto dmis = ttp::inspect::ParseDmisOutput(text, "fuzz.dmo");
    ttp::inspect::DmisToFeatureResults(dmis, part);
  });
}
