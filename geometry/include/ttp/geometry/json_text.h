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

// `doc` as JSON text (nlohmann's dump, indent -1 = compact). JSON is UTF-8,
// and strings that come from input files need not be (a Latin-1 comment in
// an NC program, a file name, a log's note): bytes that are not UTF-8 are
// written as U+FFFD instead of failing the whole output.
std::string JsonText(const nlohmann::json& doc, int indent = -1);

}  // namespace ttp
