// `ttp config`: prints the effective part/machine/process description.
#include "command.h"
#include "ttp/geometry/config.h"

namespace ttp::app {
namespace {

void RegisterConfig(CLI::App& root, GlobalOptions& global) {
  auto* cmd = root.add_subcommand(
      "config", "print the effective configuration (defaults + --config)");
  auto out = std::make_shared<std::string>("-");
  cmd->add_option("-o,--output", *out, "write JSON here (default stdout)");
  cmd->callback(
      [&global, out] { WriteJson(*out, ConfigToJson(global.LoadConfig())); });
}

}  // namespace
TTP_REGISTER_COMMANDS(90, RegisterConfig);
}  // namespace ttp::app
