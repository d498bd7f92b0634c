// Runs the built `ttp` binary for end-to-end CLI tests.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

namespace ttp::test {

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

inline RunResult RunTtp(const std::string& args) {
  const std::string cmd =
      std::string(TTP_BINARY_DIR) + "/app/ttp " + args + " 2>&1";
  RunResult r;
  FILE* pipe = ::popen(cmd.c_str(), "r");
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

// A fresh folder per test in the build tree, named after the test: ctest
// runs the tests as parallel processes, and /tmp is shared.
inline std::filesystem::path TestDir(const std::string& prefix) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name =
      prefix + "_" + info->test_suite_name() + "_" + info->name();
  for (char& c : name)
    if (c == '/') c = '_';
  const std::filesystem::path d =
      std::filesystem::path(TTP_BINARY_DIR) / "test-tmp" / name;
  static std::string made;
  if (made != name) {
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    made = name;
  }
  return d;
}

}  // namespace ttp::test
