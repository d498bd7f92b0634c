#include "ttp/geometry/json_text.h"

#include <algorithm>
#include <map>
#include <set>
#include <vector>

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

// Line of the n-th (0-based) occurrence of "key" written as an object key.
int KeyLine(const std::string& text, const std::string& key, int n) {
  const std::string quoted = "\"" + key + "\"";
  size_t at = 0;
  for (int seen = 0;; ++at) {
    at = text.find(quoted, at);
    if (at == std::string::npos) return 0;
    size_t next = text.find_first_not_of(" \t\r\n", at + quoted.size());
    if (next != std::string::npos && text[next] == ':' && seen++ == n)
      return LineAt(text, at);
  }
}

}  // namespace

nlohmann::json ParseJsonText(const std::string& text,
                             const std::string& source) {
  // JSON leaves a repeated key to the reader (RFC 8259 section 4); nlohmann
  // keeps the last silently. In a measurement or a model two values for one
  // name are a broken file, so the first repeat is refused by name.
  std::vector<std::set<std::string>> open_objects;
  std::map<std::string, int> key_count;
  std::string repeated;
  int repeated_line = 0;
  const nlohmann::json::parser_callback_t callback =
      [&](int, nlohmann::json::parse_event_t event, nlohmann::json& parsed) {
        using Event = nlohmann::json::parse_event_t;
        if (event == Event::object_start) {
          open_objects.emplace_back();
        } else if (event == Event::object_end) {
          if (!open_objects.empty()) open_objects.pop_back();
        } else if (event == Event::key && !open_objects.empty()) {
          const std::string key = parsed.get<std::string>();
          const int n = key_count[key]++;
          if (!open_objects.back().insert(key).second && repeated.empty()) {
            repeated = key;
            repeated_line = KeyLine(text, key, n);
          }
        }
        return true;
      };
  try {
    nlohmann::json out = nlohmann::json::parse(text, callback);
    if (!repeated.empty())
      throw InputError(source, repeated_line, repeated,
                       "appears twice in one object: which value is meant?");
    return out;
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

std::string JsonText(const nlohmann::json& doc, int indent) {
  return doc.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace ttp
