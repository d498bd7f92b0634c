#include "ttp/geometry/error.h"

namespace ttp {

std::string FormatInputError(const std::string& source, int line,
                             const std::string& field,
                             const std::string& problem) {
  std::string out;
  if (!source.empty()) {
    out += source;
    if (line > 0) out += ":" + std::to_string(line);
    out += ": ";
  }
  if (!field.empty()) out += field + ": ";
  out += problem;
  return out;
}

InputError::InputError(std::string source, int line, std::string field,
                       std::string problem)
    : std::runtime_error(FormatInputError(source, line, field, problem)),
      source_(std::move(source)),
      line_(line),
      field_(std::move(field)),
      problem_(std::move(problem)) {}

}  // namespace ttp
