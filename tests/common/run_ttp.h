// Runs shell commands and the built `ttp` binary for end-to-end tests.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "test_dir.h"

namespace ttp::test {

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout, and stderr where the command joins them
};

// `command` through /bin/sh; the output is what it writes to stdout.
inline RunResult RunCommand(const std::string& command) {
  RunResult r;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return r;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) {
    r.output.append(buf.data(), n);
  }
  const int status = ::pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline RunResult RunTtp(const std::string& args) {
  return RunCommand(std::string(TTP_BINARY_DIR) + "/app/ttp " + args + " 2>&1");
}

// A path as one /bin/sh word (the tests' paths hold no single quote).
inline std::string ShellQuoted(const std::filesystem::path& p) {
  return "'" + p.string() + "'";
}

// A file of the repository's data (samples/, reference/), by its path
// relative to the data folder.
inline std::string DataPath(const std::string& relative) {
  return (std::filesystem::path(TTP_DATA_DIR) / relative).string();
}

// The bytes of a file; empty when it cannot be read (the test's own
// assertions then say what is missing).
inline std::string FileBytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline nlohmann::json ReadJson(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

}  // namespace ttp::test
