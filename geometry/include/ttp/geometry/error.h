// Error policy shared by every module: bad input throws InputError, which
// names the source (file or option), the line (0 = not line-based) and the
// field. The CLI maps InputError to exit code 2; any other exception that
// escapes a command is a bug of ttp (exit code 3).
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

// An output that cannot be written where the user asked (no permission, a
// full disk, a path the output policy refuses: an input file, a device).
// The CLI maps it to exit code 2, like bad input: it is the environment's
// or the user's doing, not a bug of ttp.
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Formats "source:line: field: problem" leaving out the empty parts.
std::string FormatInputError(const std::string& source, int line,
                             const std::string& field,
                             const std::string& problem);

}  // namespace ttp
