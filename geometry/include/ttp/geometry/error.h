// Error policy shared by every module: bad input throws InputError, which
// names the source (file or option), the line (0 = not line-based) and the
// field. The CLI maps InputError to exit code 2.
#pragma once

#include <stdexcept>
#include <string>

namespace ttp {

class InputError : public std::runtime_error {
 public:
  InputError(std::string source, int line, std::string field,
             std::string problem);

  const std::string& source() const { return source_; }
  int line() const { return line_; }
  const std::string& field() const { return field_; }
  const std::string& problem() const { return problem_; }

 private:
  std::string source_;
  int line_;
  std::string field_;
  std::string problem_;
};

// Formats "source:line: field: problem" leaving out the empty parts.
std::string FormatInputError(const std::string& source, int line,
                             const std::string& field,
                             const std::string& problem);

}  // namespace ttp
