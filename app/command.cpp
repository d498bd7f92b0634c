#include "command.h"

#include <unistd.h>

#include <iostream>
#include <map>

#include "ttp/geometry/file_io.h"

namespace ttp::app {
namespace {
std::multimap<int, Registrar>& Registry() {
  static std::multimap<int, Registrar> registry;
  return registry;
}
}  // namespace

Config GlobalOptions::LoadConfig() const {
  if (config_path.empty()) return Config{};
  return ::ttp::LoadConfig(config_path);
}

int AddRegistrar(int order, Registrar registrar) {
  Registry().emplace(order, std::move(registrar));
  return 0;
}

void RegisterAll(CLI::App& root, GlobalOptions& global) {
  for (auto& [order, registrar] : Registry()) registrar(root, global);
}

void WriteText(const std::string& path, const std::string& text) {
  if (path == "-") {
    std::cout << text;
    return;
  }
  WriteFileAtomic(path, text);
}

void WriteJson(const std::string& path, const nlohmann::json& doc) {
  WriteText(path, doc.dump(2) + "\n");
}

void AddLimitOptions(CLI::App* cmd, inspect::GradeLimits* limits,
                     std::string* figures) {
  cmd->add_option("--limit-linear-um", limits->linear_um,
                  "limit of E_X, E_Y, E_Z, E_TTP in um (thesis action limit)")
      ->capture_default_str();
  cmd->add_option("--limit-angular-um-per-m", limits->angular_um_per_m,
                  "limit of E_B (and E_C) in um/m (thesis action limit)")
      ->capture_default_str();
  cmd->add_option("--limits-basis", limits->basis,
                  "where the limits come from, shown with the verdict (e.g. "
                  "\"customer agreement 2026-04\")");
  cmd->add_option("--figures", *figures,
                  "figures graded: thesis (E_X,E_Y,E_Z,E_B,E_TTP), all (adds "
                  "E_C) or a comma-separated list")
      ->capture_default_str();
}

bool StdoutIsTerminal() { return ::isatty(STDOUT_FILENO) != 0; }

}  // namespace ttp::app
