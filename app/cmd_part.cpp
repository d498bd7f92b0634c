// `ttp part export -o DIR [--format stl|obj|ply|all] [--stage ...]`: the
// blank, the pre-machined and the finished piece as meshes with every face
// tagged by its feature, plus the nominal feature tables (CSV and JSON).
#include <fmt/format.h>

#include <iostream>

#include "command.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/part_mesh.h"

namespace ttp::app {
namespace {

struct PartExportOptions {
  std::string output_dir;
  std::string format = "all";
  std::string stage = "all";
  double chord_error_mm = PartMeshOptions{}.chord_error_mm;
};

void RegisterPart(CLI::App& root, GlobalOptions& global) {
  auto* part = root.add_subcommand("part", "the part model: meshes, features");
  part->require_subcommand(1);
  auto opts = std::make_shared<PartExportOptions>();
  auto* exp = part->add_subcommand(
      "export",
      "write the blank, pre-machined and finished piece as meshes (faces "
      "tagged by feature) and the nominal feature tables");
  exp->add_option("-o,--output", opts->output_dir,
                  "folder for the files (created if missing)")
      ->required();
  exp->add_option("--format", opts->format, "stl, obj, ply or all (default)");
  exp->add_option("--stage", opts->stage,
                  "blank, pre, finished or all (default)");
  exp->add_option("--chord-error", opts->chord_error_mm,
                  "largest distance of a circle's polygon to the circle, mm "
                  "(default 0.005)");
  exp->callback([&global, opts] {
    const Config config = global.LoadConfig();
    std::vector<MeshFormat> formats;
    if (opts->format == "all") {
      formats = {MeshFormat::kStl, MeshFormat::kObj, MeshFormat::kPly};
    } else {
      formats = {ParseMeshFormat(opts->format, "--format", "format")};
    }
    std::vector<Stage> stages;
    if (opts->stage == "all") {
      stages = {Stage::kBlank, Stage::kPreMachined, Stage::kFinished};
    } else {
      stages = {ParseStage(opts->stage, "--stage", "stage")};
    }
    if (!(opts->chord_error_mm >= 1e-4 && opts->chord_error_mm <= 1.0)) {
      throw InputError("--chord-error", 0, "chord_error_mm",
                       "must be in [0.0001, 1] mm");
    }
    const std::filesystem::path dir(opts->output_dir);
    std::error_code ec;
    if (std::filesystem::exists(dir, ec) &&
        !std::filesystem::is_directory(dir, ec)) {
      throw InputError("-o", 0, "output", dir.string() + " is not a folder");
    }
    PartMeshOptions mesh_options;
    mesh_options.chord_error_mm = opts->chord_error_mm;
    // Every mesh or none; the folder is made only when they are all written.
    StagedFolder staged(dir);
    auto files =
        WritePartMeshes(config, staged.path(), stages, formats, mesh_options);
    staged.Commit();
    for (auto& f : files) f = dir / f.lexically_relative(staged.path());
    if (!global.quiet) {
      for (const auto& f : files) std::cout << f.string() << "\n";
      std::cout << fmt::format("{} files written to {}\n", files.size(),
                               dir.string());
    }
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(22, RegisterPart);
}  // namespace ttp::app
