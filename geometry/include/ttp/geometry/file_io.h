// File helpers: whole-file reads with clear errors, and writes under one
// output policy (docs/ARCHITECTURE.md, "Outputs"):
// - a regular file is written atomically (temporary file in the same
//   folder, then rename): no half-written output is ever left behind, and
//   an existing output survives a failure;
// - a symbolic link is written through to its target (never replaced by a
//   file); a dangling link is refused;
// - a device or FIFO (/dev/null, a pipe) is written into, never replaced;
// - a file this process has read as an input is never written over;
// - OutputBatch writes several files all or none.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace ttp {

// Reads a whole file; throws InputError naming the path if it cannot.
// The file is noted as an input (NoteInput). An input is a regular file
// or a pipe (a FIFO, `<(...)`, /dev/stdin fed by a pipe), at most
// limits::kMaxInputBytes; a device (/dev/zero, a terminal) is refused. A
// pipe is read whole on first use and its bytes kept for the process, so
// ReadFileHead and ReadTextFile may both read it. A UTF-8 byte order
// mark at the start is dropped (a spreadsheet's "CSV UTF-8" writes one).
std::string ReadTextFile(const std::filesystem::path& path);

// Reads the first `max_bytes` bytes of a file (all of a shorter one), to
// tell its format; throws and notes the input as ReadTextFile does.
std::string ReadFileHead(const std::filesystem::path& path, size_t max_bytes);

// True for a regular file (which may be mapped), false for a pipe (read
// it with ReadTextFile); throws as ReadTextFile does for anything else.
bool IsRegularInput(const std::filesystem::path& path);

// Notes `path` as an input of this process: WriteFileAtomic and OutputBatch
// refuse to write over it (compared with filesystem::equivalent, so another
// name, a hard link or a symbolic link to it is caught too). Files this
// process wrote itself before reading them are not inputs.
void NoteInput(const std::filesystem::path& path);
// Forgets every noted input and written file, and the pipes' bytes kept
// (tests, long-lived callers).
void ClearNotedFiles();

// Writes `content` to `path` by the output policy above. Creates missing
// parent folders. Throws OutputError naming the path when it cannot or
// must not write, removing its temporary file.
void WriteFileAtomic(const std::filesystem::path& path,
                     const std::string& content);

// Several output files, written all or none: Commit() checks every path,
// writes every content to a temporary file beside its target, and only
// when all are written renames them into place. On failure no target has
// changed and every temporary is removed. "-" writes to standard output
// (after the files are in place).
class OutputBatch {
 public:
  void Add(const std::filesystem::path& path, std::string content);
  void Commit();
  bool empty() const { return files_.empty(); }

 private:
  std::vector<std::pair<std::filesystem::path, std::string>> files_;
};

// Files for an output folder written all or none: they are written into a
// fresh staging folder beside `target` (path()); Commit() checks them by
// the output policy and only then moves every one into `target` (a rename
// each, over an existing file of the same name; other files in `target`
// stay). Without Commit() (an exception) the staging folder is removed and
// `target` is untouched.
class StagedFolder {
 public:
  explicit StagedFolder(const std::filesystem::path& target);
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;
  const std::filesystem::path& path() const { return staging_; }
  const std::filesystem::path& target() const { return target_; }
  void Commit();

 private:
  std::filesystem::path target_, staging_;
};

}  // namespace ttp
