#include "ttp/geometry/file_io.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "test_dir.h"
#include "ttp/geometry/error.h"

namespace ttp {
namespace {

TEST(FileIo, AtomicWriteLeavesNoTemporary) {
  namespace fs = std::filesystem;
  const fs::path dir = test::TestDir("fileio");
  fs::remove_all(dir);
  WriteFileAtomic(dir / "sub" / "out.txt", "hello\n");
  EXPECT_EQ(ReadTextFile(dir / "sub" / "out.txt"), "hello\n");
  int files = 0;
  for (auto& e : fs::directory_iterator(dir / "sub")) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST(FileIo, ErrorsNameThePath) {
  try {
    ReadTextFile("/nonexistent/x.csv");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.source(), "/nonexistent/x.csv");
  }
  EXPECT_EQ(FormatInputError("a.csv", 3, "t_s", "not a number"),
            "a.csv:3: t_s: not a number");
}

}  // namespace
}  // namespace ttp
