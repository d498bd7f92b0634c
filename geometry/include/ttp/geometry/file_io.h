// File helpers: whole-file reads with clear errors, and atomic writes
// (temporary file in the same folder, then rename) so that no half-written
// output is ever left behind.
#pragma once

#include <filesystem>
#include <string>

namespace ttp {

// Reads a whole file; throws InputError naming the path if it cannot.
std::string ReadTextFile(const std::filesystem::path& path);

// Writes `content` to `path` atomically. Creates missing parent folders.
// Throws std::runtime_error (an environment problem, not bad input) on
// failure, removing the temporary file.
void WriteFileAtomic(const std::filesystem::path& path,
                     const std::string& content);

}  // namespace ttp
