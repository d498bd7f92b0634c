// `ttp inspect MEASUREMENT`: any measurement of the piece (cloud, probe
// results, dial readings, DMIS output, inspection JSON) -> thermal figures
// (measurements.md). `ttp grade MEASUREMENT`: figures -> ISO 14253-1 verdict
// (exit 0/1/2).
#include <iostream>

#include "command.h"
#include "ttp/geometry/error.h"
#include "ttp/inspect/grade.h"
#include "ttp/inspect/measurement.h"

namespace ttp::app {
namespace {

struct InspectArgs {
  std::string measurement;
  std::string json;
  MeasurementArgs how;
};

constexpr const char* kMeasurementHelp =
    "point cloud (PLY, PCD, .xyz/.txt/.csv), probe results CSV "
    "(point_id,x,y,z,c_deg), dial CSV (feature,reading_um), DMIS output or "
    "an inspection JSON; recognised from the content";

void RegisterInspect(CLI::App& root, GlobalOptions& global) {
  auto args = std::make_shared<InspectArgs>();
  auto* cmd = root.add_subcommand(
      "inspect", "measured piece (any format) -> E_X..E_TTP with U (k=2)");
  cmd->add_option("measurement", args->measurement, kMeasurementHelp)
      ->required();
  AddJsonOption(cmd, &args->json,
                "the figures, facets and diagnostics as JSON");
  AddMeasurementOptions(cmd, &args->how);
  cmd->callback([&global, args, cmd] {
    const Config config = global.LoadConfig();
    const inspect::Measurement m = inspect::LoadMeasurement(
        config, args->measurement, ToMeasurementOptions(args->how, *cmd));
    // With --json - stdout is pure JSON: the table goes to stderr.
    std::ostream& text = JsonToStdout(args->json) ? std::cerr : std::cout;
    if (!global.quiet) {
      text << "(" << inspect::MeasurementKindName(m.kind) << ") "
           << inspect::InspectionTable(m.result);
    }
    if (!args->json.empty())
      WriteJson(args->json, inspect::MeasurementToJson(m));
  });

  auto limits = std::make_shared<inspect::GradeLimits>();
  auto figures = std::make_shared<std::string>("thesis");
  auto gargs = std::make_shared<InspectArgs>();
  auto json_out = std::make_shared<std::string>();
  auto verbose = std::make_shared<bool>(false);
  auto* grade =
      root.add_subcommand("grade",
                          "grade figures against limits (ISO 14253-1); exit 0 "
                          "pass, 1 fail or undecidable, 2 bad input");
  grade->add_option("measurement", gargs->measurement, kMeasurementHelp)
      ->required();
  AddLimitOptions(grade, limits.get(), figures.get());
  AddJsonOption(grade, json_out.get(), "the verdict as JSON");
  AddVerboseFlag(grade, verbose.get());
  AddMeasurementOptions(grade, &gargs->how);
  grade->callback([&global, limits, figures, gargs, json_out, verbose, grade] {
    limits->figures = inspect::ParseFigureList(*figures);
    limits->Validate();
    const Config config = global.LoadConfig();
    const inspect::Measurement m = inspect::LoadMeasurement(
        config, gargs->measurement, ToMeasurementOptions(gargs->how, *grade));
    const inspect::GradeResult r = inspect::GradeMeasurement(m, *limits);
    std::ostream& text = JsonToStdout(*json_out) ? std::cerr : std::cout;
    if (!global.quiet) text << inspect::GradeTable(r, *verbose);
    if (!json_out->empty()) WriteJson(*json_out, inspect::GradeToJson(r));
    if (r.overall != inspect::Verdict::kPass)
      global.exit_code = kExitJudgedFailure;
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(40, RegisterInspect);
}  // namespace ttp::app
