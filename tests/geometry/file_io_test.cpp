#include "ttp/geometry/file_io.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <thread>

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

// A device would be read without end: refused, naming the path. A FIFO
// is read once, whole, and its bytes kept: its head and then all of it,
// as a measurement is read (format from the head, then the whole).
TEST(FileIo, DevicesRefusedPipesReadOnce) {
  namespace fs = std::filesystem;
  for (const char* device : {"/dev/zero", "/dev/null"}) {
    try {
      ReadTextFile(device);
      FAIL() << device;
    } catch (const InputError& e) {
      EXPECT_EQ(e.source(), device);
      EXPECT_NE(std::string(e.what()).find("is a device"), std::string::npos)
          << e.what();
    }
  }
  const fs::path dir = test::TestDir("fileio-fifo");
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path fifo = dir / "in.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string text;
  for (int i = 0; i < 100000; ++i) text += std::to_string(i) + " 1 2\n";
  std::thread writer([&] { std::ofstream(fifo) << text; });
  const std::string head = ReadFileHead(fifo, 10);
  const std::string all = ReadTextFile(fifo);
  writer.join();
  EXPECT_EQ(head, text.substr(0, 10));
  EXPECT_EQ(all, text);
  EXPECT_FALSE(IsRegularInput(fifo));
}

std::string Slurp(const std::filesystem::path& p) { return ReadTextFile(p); }

TEST(FileIo, NeverWritesOverAnInputWhateverItsName) {
  namespace fs = std::filesystem;
  ClearNotedFiles();
  const fs::path dir = test::TestDir("fileio");
  WriteFileAtomic(dir / "in.csv", "input\n");
  ClearNotedFiles();  // as if another program had written it
  EXPECT_EQ(ReadTextFile(dir / "in.csv"), "input\n");
  fs::create_hard_link(dir / "in.csv", dir / "hard.csv");
  fs::create_symlink(dir / "in.csv", dir / "soft.csv");
  for (const char* name : {"in.csv", "hard.csv", "soft.csv"}) {
    EXPECT_THROW(WriteFileAtomic(dir / name, "x"), OutputError) << name;
  }
  EXPECT_EQ(ReadTextFile(dir / "in.csv"), "input\n");
  // A file this process wrote and then read back is its own output.
  WriteFileAtomic(dir / "mine.csv", "1");
  ReadTextFile(dir / "mine.csv");
  EXPECT_NO_THROW(WriteFileAtomic(dir / "mine.csv", "2"));
  ClearNotedFiles();
}

TEST(FileIo, LinksAreWrittenThroughAndModesKept) {
  namespace fs = std::filesystem;
  ClearNotedFiles();
  const fs::path dir = test::TestDir("fileio");
  WriteFileAtomic(dir / "target.txt", "old");
  fs::permissions(dir / "target.txt", fs::perms::owner_read |
                                          fs::perms::owner_write |
                                          fs::perms::group_read);
  fs::create_symlink("target.txt", dir / "link.txt");
  WriteFileAtomic(dir / "link.txt", "new");
  EXPECT_TRUE(fs::is_symlink(dir / "link.txt"));
  EXPECT_EQ(Slurp(dir / "target.txt"), "new");
  EXPECT_EQ(
      fs::status(dir / "target.txt").permissions() & fs::perms::all,
      fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  fs::create_symlink(dir / "missing" / "x", dir / "dangling.txt");
  EXPECT_THROW(WriteFileAtomic(dir / "dangling.txt", "x"), OutputError);
  fs::create_directories(dir / "folder");
  EXPECT_THROW(WriteFileAtomic(dir / "folder", "x"), OutputError);
  // A device is written into, not replaced.
  WriteFileAtomic("/dev/null", "discarded");
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  ClearNotedFiles();
}

TEST(FileIo, BatchWritesAllOrNone) {
  namespace fs = std::filesystem;
  ClearNotedFiles();
  const fs::path dir = test::TestDir("fileio");
  WriteFileAtomic(dir / "a.txt", "old a");
  fs::create_directories(dir / "b.txt");  // the second output cannot be
  OutputBatch batch;
  batch.Add(dir / "a.txt", "new a");
  batch.Add(dir / "b.txt", "new b");
  EXPECT_THROW(batch.Commit(), OutputError);
  EXPECT_EQ(Slurp(dir / "a.txt"), "old a");
  fs::remove(dir / "b.txt");
  OutputBatch ok;
  ok.Add(dir / "a.txt", "new a");
  ok.Add(dir / "sub" / "b.txt", "new b");
  ok.Commit();
  EXPECT_EQ(Slurp(dir / "a.txt"), "new a");
  EXPECT_EQ(Slurp(dir / "sub" / "b.txt"), "new b");
  OutputBatch twice;
  twice.Add(dir / "a.txt", "1");
  twice.Add(dir / "." / "a.txt", "2");
  EXPECT_THROW(twice.Commit(), OutputError);
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos);
    ++files;
  }
  EXPECT_EQ(files, 2);  // a.txt and sub/
  ClearNotedFiles();
}

TEST(FileIo, StagedFolderMovesInOnlyOnCommit) {
  namespace fs = std::filesystem;
  ClearNotedFiles();
  const fs::path dir = test::TestDir("fileio");
  const fs::path out = dir / "out";
  WriteFileAtomic(out / "keep.txt", "user's");
  WriteFileAtomic(out / "a.txt", "old");
  {
    StagedFolder staged(out);
    WriteFileAtomic(staged.path() / "a.txt", "new");
    WriteFileAtomic(staged.path() / "sub" / "b.txt", "b");
    // No commit: an exception on the way.
  }
  EXPECT_EQ(Slurp(out / "a.txt"), "old");
  EXPECT_FALSE(fs::exists(out / "sub"));
  {
    StagedFolder staged(out);
    WriteFileAtomic(staged.path() / "a.txt", "new");
    WriteFileAtomic(staged.path() / "sub" / "b.txt", "b");
    staged.Commit();
  }
  EXPECT_EQ(Slurp(out / "a.txt"), "new");
  EXPECT_EQ(Slurp(out / "sub" / "b.txt"), "b");
  EXPECT_EQ(Slurp(out / "keep.txt"), "user's");
  int entries = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    EXPECT_EQ(e.path().filename().string().find("staging"), std::string::npos);
    ++entries;
  }
  EXPECT_EQ(entries, 1);
  ClearNotedFiles();
}

}  // namespace
}  // namespace ttp
