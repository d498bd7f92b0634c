#include "ttp/geometry/json_text.h"

#include <algorithm>

#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"

namespace ttp {
namespace {

int LineAt(const std::string& text, size_t offset) {
  const size_t at = std::min(offset, text.size());
  return 1 + static_cast<int>(std::count(
                 text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

// nlohmann's message without its "[json.exception.<kind>.<id>] " prefix.
std::string Detail(const char* what) {
  const std::string s = what;
  const size_t end = s.find("] ");
  return end == std::string::npos ? s : s.substr(end + 2);
}

}  // namespace

nlohmann::json ParseJsonText(const std::string& text,
                             const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(source, LineAt(text, e.byte), "",
                     "not valid JSON: " + Detail(e.what()));
  } catch (const nlohmann::json::exception& e) {
    // out_of_range.406: "number overflow parsing '<token>'".
    const std::string detail = Detail(e.what());
    int line = 0;
    const std::string key = "parsing '";
    const size_t a = detail.find(key);
    if (a != std::string::npos) {
      const size_t b = detail.find('\'', a + key.size());
      const std::string token =
          b == std::string::npos
              ? ""
              : detail.substr(a + key.size(), b - a - key.size());
      const size_t at = token.empty() ? std::string::npos : text.find(token);
      if (at != std::string::npos) line = LineAt(text, at);
    }
    throw InputError(source, line, "",
                     "not valid JSON: " + detail +
                         " (a number beyond the range of a double)");
  }
}

nlohmann::json ReadJsonFile(const std::filesystem::path& path) {
  return ParseJsonText(ReadTextFile(path), path.string());
}

}  // namespace ttp
