// ttp: the thermal test piece toolkit.
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <iostream>

#include "command.h"
#include "ttp/geometry/error.h"

int main(int argc, char** argv) {
  using namespace ttp::app;
  CLI::App root{
      "ttp - thermal test pieces: G-code, inspection, TALC log checks and "
      "diagnosis.\nExit codes: 0 ok, 1 judged failure, 2 bad input or usage, "
      "3 internal error (a bug in ttp)."};
  root.require_subcommand(1);
  // Global options are also accepted after the subcommand
  // (`ttp grade --config machine.toml piece.ply`), and defaults show in
  // every --help.
  root.fallthrough();
  root.option_defaults()->always_capture_default();
  GlobalOptions global;
  root.add_option("--config", global.config_path,
                  "part/machine/process description (TOML or JSON)")
      ->check(CLI::ExistingFile);
  root.add_flag("-q,--quiet", global.quiet, "no progress or info output");
  root.set_version_flag("--version", "ttp " TTP_VERSION);
  RegisterAll(root, global);
  ApplyConventions(root);
  try {
    root.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const std::string hint = DidYouMean(root, argc, argv);
    if (!hint.empty()) std::cerr << "ttp: " << hint << "\n";
    // `ttp` or `ttp thermal` alone: what there is to run, not only that
    // something is missing.
    if (hint.empty() && e.get_name() == "RequiredError" &&
        std::string(e.what()) == "A subcommand is required") {
      const CLI::App* app = &root;
      while (!app->get_subcommands().empty())
        app = app->get_subcommands().front();
      std::cerr << app->help() << "\nttp: give one of the subcommands above\n";
      return kExitBadInput;
    }
    const int rc = root.exit(e);
    return rc == 0 ? kExitOk : kExitBadInput;
  } catch (const ttp::InputError& e) {
    // The checks that need a program or the part's solid (a waiting
    // position inside the route, reference cylinders with a gap) run where
    // those are built, which know the configuration only as "config" or
    // "part": name the file it came from.
    if (!global.config_path.empty() &&
        (e.source() == "config" || e.source() == "part")) {
      std::cerr << "ttp: error: "
                << ttp::FormatInputError(global.config_path, e.line(),
                                         e.field(), e.problem())
                << "\n";
      return kExitBadInput;
    }
    std::cerr << "ttp: error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const ttp::OutputError& e) {
    // An output that cannot be written (full disk, no permission, a path
    // the output policy refuses): the user's environment, not a bug.
    std::cerr << "ttp: error: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const std::bad_alloc&) {
    std::cerr << "ttp: internal error (a bug in ttp, not your input): out "
                 "of memory (std::bad_alloc); every input size has a checked "
                 "limit, so this one escaped it\n";
    return kExitInternalError;
  } catch (const std::exception& e) {
    // InputError covers every fault of the input; anything else escaping a
    // command (std::out_of_range, a library's exception) is a bug of ttp.
    std::cerr << "ttp: internal error (a bug in ttp, not your input): "
              << e.what() << "\n";
    return kExitInternalError;
  } catch (...) {
    std::cerr << "ttp: internal error (a bug in ttp, not your input): "
                 "unknown exception\n";
    return kExitInternalError;
  }
  // What went to standard output must have arrived: a full disk or a
  // closed pipe behind `> file` loses the result as surely as a failed -o.
  std::cout.flush();
  if (!std::cout || std::fflush(stdout) != 0 || std::ferror(stdout)) {
    std::cerr << "ttp: error: cannot write to standard output: "
              << std::strerror(errno) << "\n";
    return kExitBadInput;
  }
  return global.exit_code;
}
