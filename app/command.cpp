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

bool StdoutIsTerminal() { return ::isatty(STDOUT_FILENO) != 0; }

}  // namespace ttp::app
