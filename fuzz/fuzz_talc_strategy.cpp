// A TALC replay strategy and a sweep grid (`ttp talc replay --strategy`,
// `ttp talc sweep GRID`), TOML or JSON, as ReadTomlOrJson tells them apart.
#include "fuzz_common.h"
#include "ttp/geometry/json_text.h"
#include "ttp/talc/strategy.h"
#include "ttp/talc/sweep.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return ttp::fuzz::Run([&] {
    const std::string text = ttp::fuzz::Text(data, size);
    const auto first = text.find_first_not_of(" \t\r\n");
    const nlohmann::json j = first != std::string::npos && text[first] == '{'
                                 ? ttp::ParseJsonText(text, "fuzz.json")
                                 : ttp::talc::TomlToJson(text, "fuzz.toml");
    try {
      ttp::talc::StrategyFromJson(j, "fuzz");
    } catch (const ttp::InputError&) {
      // a grid is not a strategy: read it as one below
    }
    const ttp::talc::Grid grid = ttp::talc::GridFromJson(j, "fuzz");
    if (grid.size() > 0) grid.At(grid.size() - 1);
  });
}
