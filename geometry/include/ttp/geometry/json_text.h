// JSON text read into nlohmann::json with the project's input errors.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace ttp {

// Parses `text` (read from `source`). Throws InputError naming `source` and
// the line: "not valid JSON: ..." for a syntax error, and for a number
// beyond the range of a double (which nlohmann reports without its place:
// the line of the number's first occurrence).
nlohmann::json ParseJsonText(const std::string& text,
                             const std::string& source);

// Reads a whole file (ReadTextFile) and parses it as above.
nlohmann::json ReadJsonFile(const std::filesystem::path& path);

}  // namespace ttp
