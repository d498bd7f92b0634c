// Every command shown in a ```sh block of README.md and docs/*.md runs as
// written: from a temporary folder holding a copy of the repository files
// it names (samples/, reference/, ...), with the built `ttp` on PATH, one
// document's commands in order in one folder. A command expected to exit
// non-zero says so with a trailing `# exit N`. A failure names the
// document, the line and the command.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "run_ttp.h"
#include "test_dir.h"

namespace {

namespace fs = std::filesystem;

struct DocCommand {
  int line = 0;  // where the command starts in the document
  std::string command;
  int expected_exit = 0;
};

// The commands of the ```sh blocks of `text`: continuation lines (trailing
// backslash) joined, blank lines and comment lines skipped.
std::vector<DocCommand> ExtractCommands(const std::string& text) {
  std::vector<DocCommand> out;
  std::istringstream in(text);
  std::string line;
  bool in_sh = false;
  int n = 0;
  DocCommand pending;
  bool continuing = false;
  std::string heredoc_end;  // while inside a here-document: its terminator
  static const std::regex exit_marker(R"(#\s*exit\s+(\d+)\s*$)");
  static const std::regex heredoc(
      R"(<<-?\s*['"]?([A-Za-z_][A-Za-z0-9_]*)['"]?)");
  const auto finish = [&] {
    std::smatch m;
    const std::string first_line =
        pending.command.substr(0, pending.command.find('\n'));
    if (std::regex_search(first_line, m, exit_marker))
      pending.expected_exit = std::stoi(m.str(1));
    out.push_back(pending);
  };
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (!heredoc_end.empty()) {  // kept verbatim, up to the terminator
      pending.command += "\n" + line;
      const size_t start = line.find_first_not_of('\t');
      if (start != std::string::npos && line.substr(start) == heredoc_end) {
        heredoc_end.clear();
        finish();
      }
      continue;
    }
    const size_t first = line.find_first_not_of(" \t");
    const std::string trimmed =
        first == std::string::npos ? std::string() : line.substr(first);
    if (!in_sh) {
      if (trimmed == "```sh" || trimmed.rfind("```sh ", 0) == 0) in_sh = true;
      continue;
    }
    if (trimmed.rfind("```", 0) == 0) {
      in_sh = false;
      continuing = false;
      continue;
    }
    if (!continuing) {
      if (trimmed.empty() || trimmed[0] == '#') continue;
      pending = DocCommand{};
      pending.line = n;
    }
    std::string part = trimmed;
    continuing = !part.empty() && part.back() == '\\';
    if (continuing) part.pop_back();
    pending.command += (pending.command.empty() ? "" : " ") + part;
    if (continuing) continue;
    std::smatch m;
    if (std::regex_search(part, m, heredoc)) {
      heredoc_end = m.str(1);
      continue;
    }
    finish();
  }
  return out;
}

// README.md and docs/*.md, relative to the source folder.
std::vector<std::string> Documents() {
  std::vector<std::string> docs = {"README.md"};
  const fs::path dir = fs::path(TTP_SOURCE_DIR) / "docs";
  std::vector<std::string> more;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".md")
      more.push_back("docs/" + e.path().filename().string());
  }
  std::sort(more.begin(), more.end());
  docs.insert(docs.end(), more.begin(), more.end());
  return docs;
}

// The top-level repository entries a command names (samples/..., reference/
// ...): copied into the test folder.
std::set<std::string> NamedEntries(const std::string& command) {
  std::set<std::string> out;
  static const std::regex path_word(R"(([A-Za-z0-9_.-]+)/)");
  for (auto it =
           std::sregex_iterator(command.begin(), command.end(), path_word);
       it != std::sregex_iterator(); ++it) {
    const std::string name = it->str(1);
    if (name == "build" || name == "." || name == "..") continue;
    if (fs::exists(fs::path(TTP_SOURCE_DIR) / name)) out.insert(name);
  }
  return out;
}

std::string Tail(const std::string& text, size_t n = 3000) {
  return text.size() <= n ? text : "..." + text.substr(text.size() - n);
}

TEST(ExtractCommands, JoinsContinuationsAndReadsExitMarkers) {
  const std::string doc =
      "text\n```sh\nttp a \\\n   --b 1\n\n# a comment\nttp c  # exit 1\n```\n"
      "```\nttp not-run\n```\n    ttp indented-not-run\n```sh\nttp d\n"
      "cat > a.toml <<'EOF'\n# kept\n\nx = 1\nEOF\nttp e\n```\n";
  const std::vector<DocCommand> got = ExtractCommands(doc);
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[0].command, "ttp a  --b 1");
  EXPECT_EQ(got[0].line, 3);
  EXPECT_EQ(got[0].expected_exit, 0);
  EXPECT_EQ(got[1].command, "ttp c  # exit 1");
  EXPECT_EQ(got[1].expected_exit, 1);
  EXPECT_EQ(got[1].line, 7);
  EXPECT_EQ(got[2].command, "ttp d");
  // A here-document is one command with its lines as written.
  EXPECT_EQ(got[3].command, "cat > a.toml <<'EOF'\n# kept\n\nx = 1\nEOF");
  EXPECT_EQ(got[3].line, 15);
  EXPECT_EQ(got[4].command, "ttp e");
  // A folder the command writes (a name no clone holds: `out/` would be
  // there after the README's main job) is not one of the repository's.
  const std::set<std::string> named = NamedEntries(
      "ttp report samples/run-a/piece.ply -o not-in-any-clone/x.html");
  EXPECT_TRUE(named.count("samples"));
  EXPECT_FALSE(named.count("not-in-any-clone"));
}

class DocCommands : public ::testing::TestWithParam<std::string> {};

TEST_P(DocCommands, RunAsWritten) {
  const std::string doc = GetParam();
  const std::vector<DocCommand> commands =
      ExtractCommands(ttp::test::FileBytes(fs::path(TTP_SOURCE_DIR) / doc));
  if (doc == "README.md") {
    ASSERT_FALSE(commands.empty()) << "README.md shows no ```sh command";
  }
  if (commands.empty()) GTEST_SKIP() << doc << " shows no ```sh command";
  std::string name = doc;
  for (char& c : name)
    if (c == '/' || c == '.') c = '-';
  const fs::path dir = ttp::test::TestDir("docs-" + name);
  std::set<std::string> entries;
  for (const DocCommand& c : commands) {
    for (const std::string& e : NamedEntries(c.command)) entries.insert(e);
  }
  for (const std::string& e : entries) {
    fs::copy(
        fs::path(TTP_SOURCE_DIR) / e, dir / e,
        fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  }
  const std::string path = std::string(TTP_BINARY_DIR) + "/app";
  for (const DocCommand& c : commands) {
    const ttp::test::RunResult r = ttp::test::RunCommand(
        "cd '" + dir.string() + "' && PATH='" + path +
        "':\"$PATH\" timeout 300 /bin/sh -c '" +
        std::regex_replace(c.command, std::regex("'"), "'\\''") + "' 2>&1");
    EXPECT_EQ(r.exit_code, c.expected_exit)
        << doc << ":" << c.line << ": `" << c.command << "` exited "
        << r.exit_code << ", the doc expects " << c.expected_exit
        << " (a command expected to exit non-zero ends with `# exit N`); "
           "its output:\n"
        << Tail(r.output);
  }
}

INSTANTIATE_TEST_SUITE_P(Docs, DocCommands, ::testing::ValuesIn(Documents()),
                         [](const auto& info) {
                           std::string n = info.param;
                           for (char& c : n)
                             if (!std::isalnum(static_cast<unsigned char>(c)))
                               c = '_';
                           return n;
                         });

}  // namespace
