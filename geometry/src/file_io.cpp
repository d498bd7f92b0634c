#include "ttp/geometry/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <system_error>

#include "ttp/geometry/error.h"
#include "ttp/geometry/limits.h"

namespace ttp {
namespace fs = std::filesystem;
namespace {

// Inputs read and files written by this process (the output policy).
struct NotedFiles {
  std::mutex mutex;
  std::vector<fs::path> inputs;
  std::vector<fs::path> written;
};
// The bytes of the pipes read (ReadStreamOnce), by path.
struct StreamsRead {
  std::mutex mutex;
  std::map<std::string, std::string> bytes;
};
StreamsRead& Streams() {
  static StreamsRead streams;
  return streams;
}
NotedFiles& Noted() {
  static NotedFiles noted;
  return noted;
}

bool SameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  const bool same = fs::equivalent(a, b, ec);
  return !ec && same;
}

// Throws OutputError if `path` (an existing file) is a noted input.
void RefuseInput(const fs::path& path) {
  NotedFiles& n = Noted();
  std::lock_guard<std::mutex> lock(n.mutex);
  for (const fs::path& in : n.inputs) {
    if (SameFile(in, path)) {
      throw OutputError("will not write " + path.string() +
                        ": it is an input of this command (" + in.string() +
                        "); name another output file");
    }
  }
}

void NoteWritten(const fs::path& path) {
  NotedFiles& n = Noted();
  std::lock_guard<std::mutex> lock(n.mutex);
  n.written.push_back(path);
}

std::string ErrnoText() { return std::strerror(errno); }

// What writing to `path` means under the output policy.
struct Target {
  fs::path path;        // where to write: a symbolic link resolved
  bool direct = false;  // a device or FIFO: write into it, no rename
};

Target ResolveTarget(const fs::path& path) {
  if (path.empty()) throw OutputError("empty output file name");
  std::error_code ec;
  Target t{path, false};
  const fs::file_status link = fs::symlink_status(path, ec);
  if (fs::is_symlink(link)) {
    const fs::path resolved = fs::weakly_canonical(path, ec);
    const fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st)) {
      // A dangling link: its target may be anywhere; writing there
      // would create a file the user cannot see from the name.
      throw OutputError("will not write " + path.string() +
                        ": a symbolic link to a missing file");
    }
    t.path = resolved;
  }
  const fs::file_status st = fs::status(t.path, ec);
  if (fs::is_directory(st)) {
    throw OutputError("cannot write " + path.string() +
                      ": it is a folder, not a file");
  }
  if (fs::is_character_file(st) || fs::is_block_file(st) || fs::is_fifo(st)) {
    t.direct = true;
  } else if (fs::exists(st) && !fs::is_regular_file(st)) {
    throw OutputError("will not write " + path.string() +
                      ": not a regular file, device or FIFO");
  }
  if (fs::exists(st)) RefuseInput(t.path);
  return t;
}

// Writes all of `content` to fd, again after a signal; false with the
// reason when a write fails.
bool WriteAll(int fd, const std::string& content, std::string* why) {
  size_t done = 0;
  while (done < content.size()) {
    const ssize_t w = ::write(fd, content.data() + done, content.size() - done);
    if (w < 0) {
      if (errno == EINTR) continue;
      *why = ErrnoText();
      return false;
    }
    done += static_cast<size_t>(w);
  }
  return true;
}

void WriteDirect(const Target& t, const std::string& content) {
  const int fd = ::open(t.path.c_str(), O_WRONLY | O_CLOEXEC);
  if (fd < 0)
    throw OutputError("cannot open " + t.path.string() + ": " + ErrnoText());
  std::string why;
  if (!WriteAll(fd, content, &why)) {
    ::close(fd);
    throw OutputError("write failed: " + t.path.string() + ": " + why);
  }
  if (::close(fd) != 0)
    throw OutputError("write failed: " + t.path.string() + ": " + ErrnoText());
}

// Writes a temporary file beside `target` and returns its path. The
// temporary keeps the mode of an existing target.
fs::path WriteTemporary(const fs::path& target, const std::string& content) {
  const fs::path parent =
      target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(parent, ec);
  std::string name = parent / ("." + target.filename().string() + ".tmpXXXXXX");
  const int fd = ::mkstemp(name.data());
  if (fd < 0) {
    throw OutputError("cannot write into " + parent.string() + ": " +
                      ErrnoText());
  }
  const fs::path tmp = name;
  struct stat old {};
  if (::stat(target.c_str(), &old) == 0) {
    ::fchmod(fd, old.st_mode & 07777);
  } else {
    const mode_t mask = ::umask(0);  // mkstemp made it 0600
    ::umask(mask);
    ::fchmod(fd, 0666 & ~mask);
  }
  std::string why;
  if (!WriteAll(fd, content, &why)) {
    ::close(fd);
    fs::remove(tmp, ec);
    throw OutputError("write failed: " + target.string() + ": " + why);
  }
  if (::close(fd) != 0) {
    const std::string why = ErrnoText();
    fs::remove(tmp, ec);
    throw OutputError("write failed: " + target.string() + ": " + why);
  }
  return tmp;
}

void RenameInto(const fs::path& tmp, const fs::path& target) {
  std::error_code ec;
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw OutputError("cannot rename into " + target.string() + ": " +
                      ec.message());
  }
  NoteWritten(target);
}

}  // namespace

void NoteInput(const fs::path& path) {
  NotedFiles& n = Noted();
  std::lock_guard<std::mutex> lock(n.mutex);
  for (const fs::path& w : n.written)
    if (SameFile(w, path)) return;  // our own output read back
  n.inputs.push_back(path);
}

void ClearNotedFiles() {
  NotedFiles& n = Noted();
  std::lock_guard<std::mutex> lock(n.mutex);
  n.inputs.clear();
  n.written.clear();
  StreamsRead& streams = Streams();
  std::lock_guard<std::mutex> streams_lock(streams.mutex);
  streams.bytes.clear();
}

namespace {

// What an input path is: a regular file, or a pipe (a FIFO, process
// substitution `<(zcat cloud.xyz.gz)`, /dev/stdin fed by a pipe), which
// can be read only once, front to back. Anything else (a device:
// /dev/zero, /dev/urandom, a terminal) would be read without end.
enum class InputKind { kRegular, kStream };

InputKind CheckInput(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    throw InputError(path.string(), 0, "", "file does not exist");
  }
  if (fs::is_directory(path, ec)) {
    throw InputError(path.string(), 0, "", "is a folder, not a file");
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path.string(), 0, "", "cannot be opened");
  if (S_ISREG(st.st_mode)) {
    if (static_cast<std::uint64_t>(st.st_size) > limits::kMaxInputBytes)
      throw InputError(path.string(), 0, "",
                       std::to_string(st.st_size) +
                           " bytes, beyond the limit of " +
                           std::to_string(limits::kMaxInputBytes) + " bytes");
    return InputKind::kRegular;
  }
  if (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode)) return InputKind::kStream;
  throw InputError(path.string(), 0, "",
                   "is a device, not a file: give a regular file or a pipe");
}

// The UTF-8 byte order mark that some programs write first (a
// spreadsheet's "CSV UTF-8", editors on Windows) is not content: a dial
// CSV beginning with it would not show its header.
void DropByteOrderMark(std::string* text) {
  if (text->compare(0, 3, "\xEF\xBB\xBF") == 0) text->erase(0, 3);
}

std::ifstream OpenInput(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "", "cannot be opened");
  NoteInput(path);
  return in;
}

// A pipe's bytes, read whole on first use and kept for the process: the
// format is told from its head, then it is read again from the start (and
// a command may read one input twice), which a pipe cannot do.
// The reference stays valid until ClearNotedFiles (map nodes do not move).
const std::string& ReadStreamOnce(const fs::path& path) {
  StreamsRead& streams = Streams();
  std::lock_guard<std::mutex> lock(streams.mutex);
  auto& read = streams.bytes;
  const auto it = read.find(path.string());
  if (it != read.end()) return it->second;
  std::ifstream in = OpenInput(path);
  std::string all;
  std::vector<char> chunk(1 << 20);
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    all.append(chunk.data(), static_cast<size_t>(in.gcount()));
    if (all.size() > limits::kMaxInputBytes)
      throw InputError(path.string(), 0, "",
                       "more than " + std::to_string(limits::kMaxInputBytes) +
                           " bytes, beyond the limit");
  }
  DropByteOrderMark(&all);
  return read.emplace(path.string(), std::move(all)).first->second;
}

}  // namespace

bool IsRegularInput(const fs::path& path) {
  return CheckInput(path) == InputKind::kRegular;
}

std::string ReadTextFile(const fs::path& path) {
  if (CheckInput(path) == InputKind::kStream) return ReadStreamOnce(path);
  std::ifstream in = OpenInput(path);
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string text = std::move(ss).str();
  DropByteOrderMark(&text);
  return text;
}

std::string ReadFileHead(const fs::path& path, size_t max_bytes) {
  if (CheckInput(path) == InputKind::kStream)
    return ReadStreamOnce(path).substr(0, max_bytes);
  std::ifstream in = OpenInput(path);
  std::string head(max_bytes, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<size_t>(in.gcount()));
  DropByteOrderMark(&head);
  return head;
}

void WriteFileAtomic(const fs::path& path, const std::string& content) {
  const Target t = ResolveTarget(path);
  if (t.direct) {
    WriteDirect(t, content);
    return;
  }
  RenameInto(WriteTemporary(t.path, content), t.path);
}

void OutputBatch::Add(const fs::path& path, std::string content) {
  files_.emplace_back(path, std::move(content));
}

void OutputBatch::Commit() {
  // Check every target before anything is written.
  std::vector<Target> targets;
  for (const auto& [path, content] : files_) {
    if (path == "-") {
      targets.push_back({path, true});
      continue;
    }
    targets.push_back(ResolveTarget(path));
    for (size_t k = 0; k + 1 < targets.size(); ++k) {
      if (targets[k].path == targets.back().path ||
          SameFile(targets[k].path, targets.back().path))
        throw OutputError("two outputs of one command are the same file: " +
                          path.string());
    }
  }
  std::vector<fs::path> temporaries(files_.size());
  try {
    for (size_t k = 0; k < files_.size(); ++k) {
      if (!targets[k].direct)
        temporaries[k] = WriteTemporary(targets[k].path, files_[k].second);
    }
  } catch (...) {
    std::error_code ec;
    for (const fs::path& tmp : temporaries)
      if (!tmp.empty()) fs::remove(tmp, ec);
    throw;
  }
  for (size_t k = 0; k < files_.size(); ++k) {
    if (!targets[k].direct) RenameInto(temporaries[k], targets[k].path);
  }
  for (size_t k = 0; k < files_.size(); ++k) {
    if (files_[k].first == "-") {
      std::cout << files_[k].second << std::flush;
    } else if (targets[k].direct) {
      WriteDirect(targets[k], files_[k].second);
    }
  }
  files_.clear();
}

StagedFolder::StagedFolder(const fs::path& target) : target_(target) {
  std::error_code ec;
  if (fs::exists(target_, ec) && !fs::is_directory(target_, ec))
    throw OutputError("cannot write into the folder " + target_.string() +
                      ": a file of that name exists");
  const fs::path abs = fs::absolute(target_, ec).lexically_normal();
  const fs::path parent =
      abs.has_filename() ? abs.parent_path() : abs.parent_path().parent_path();
  const std::string base = abs.has_filename()
                               ? abs.filename().string()
                               : abs.parent_path().filename().string();
  fs::create_directories(parent, ec);
  std::string name = parent / ("." + base + ".staging.XXXXXX");
  if (::mkdtemp(name.data()) == nullptr)
    throw OutputError("cannot create a folder in " + parent.string() + ": " +
                      ErrnoText());
  staging_ = name;
}

StagedFolder::~StagedFolder() {
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

namespace {

// Checks every file of `from` against the output policy at its place in
// `to` (no input overwritten, no folder where a file goes).
void CheckMerge(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(from)) {
    const fs::path dest = to / entry.path().filename();
    if (entry.is_directory()) {
      if (fs::exists(dest, ec) && !fs::is_directory(dest, ec))
        throw OutputError("cannot write the folder " + dest.string() +
                          ": a file of that name exists");
      if (fs::is_directory(dest, ec)) CheckMerge(entry.path(), dest);
    } else if (fs::exists(dest, ec)) {
      const Target t = ResolveTarget(dest);
      if (t.direct)
        throw OutputError("will not write " + dest.string() +
                          ": a device or FIFO inside an output folder");
    }
  }
}

// Moves every file of `from` into `to` (renames: `from` and `to` are on one
// file system), merging folders that exist in both.
void Merge(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::create_directories(to, ec);
  for (const auto& entry : fs::directory_iterator(from)) {
    const fs::path dest = to / entry.path().filename();
    if (entry.is_directory() && fs::is_directory(dest, ec)) {
      Merge(entry.path(), dest);
      continue;
    }
    fs::path real = dest;
    if (fs::is_symlink(fs::symlink_status(dest, ec)))
      real = fs::weakly_canonical(dest, ec);
    fs::rename(entry.path(), real, ec);
    if (ec)
      throw OutputError("cannot rename into " + dest.string() + ": " +
                        ec.message());
    NoteWritten(real);
  }
}

}  // namespace

void StagedFolder::Commit() {
  CheckMerge(staging_, target_);
  Merge(staging_, target_);
  std::error_code ec;
  fs::remove_all(staging_, ec);
}

}  // namespace ttp
