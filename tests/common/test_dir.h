// A fresh folder per test for files the test writes.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <set>
#include <string>

namespace ttp::test {

// `<build>/test-tmp/<prefix>_<suite>_<test>`, emptied the first time a test
// asks for it. ctest runs every test as its own process, in parallel, so a
// fixed name (or a shared file in /tmp) lets two tests overwrite each
// other's files.
inline std::filesystem::path TestDir(const std::string& prefix = "t") {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = prefix;
  if (info != nullptr)
    name += std::string("_") + info->test_suite_name() + "_" + info->name();
  for (char& c : name)
    if (c == '/') c = '_';
  const std::filesystem::path dir =
      std::filesystem::path(TTP_BINARY_DIR) / "test-tmp" / name;
  static std::set<std::string> made;
  if (made.insert(name).second) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  return dir;
}

}  // namespace ttp::test
