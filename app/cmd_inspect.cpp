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
  std::string units = "mm";
  bool units_given = false;
  std::string json;
  std::string instrument = "cmm";
  double probe_repeatability_um = 0.5;
  std::string probe_points;
  std::string probe_frame = "auto";
  double dial_resolution_um = 1.0;
  double dial_repeatability_um = 0.5;
};

inspect::MeasurementOptions ToOptions(const InspectArgs& a) {
  inspect::MeasurementOptions mo;
  mo.read.units = inspect::ParseLengthUnit(a.units);
  mo.read.units_given = a.units_given;
  if (a.instrument == "none")
    mo.inspect.instrument = inspect::Instrument::kNone;
  else if (a.instrument != "cmm")
    throw InputError("--instrument", 0, "instrument",
                     "'" + a.instrument + "' is not cmm or none");
  mo.inspect.check_units = !a.units_given;
  mo.probe.repeatability_um = a.probe_repeatability_um;
  mo.probe.points_csv_path = a.probe_points;
  if (a.probe_frame == "machine")
    mo.probe.frame = inspect::ProbeFrame::kMachine;
  else if (a.probe_frame == "program")
    mo.probe.frame = inspect::ProbeFrame::kProgram;
  else if (a.probe_frame != "auto")
    throw InputError("--probe-frame", 0, "probe_frame",
                     "'" + a.probe_frame + "' is not auto, machine or program");
  mo.probe.Validate();
  mo.dial.resolution_um = a.dial_resolution_um;
  mo.dial.repeatability_um = a.dial_repeatability_um;
  mo.dial.Validate();
  return mo;
}

void AddMeasurementOptions(CLI::App* cmd, InspectArgs* a) {
  cmd->add_option("--units", a->units,
                  "units of a point cloud: mm (default), m, in");
  cmd->add_option(
      "--instrument", a->instrument,
      "cloud uncertainty model: cmm (MPE 1.2 um + L/400, default) or none");
  cmd->add_option("--probe-repeatability-um", a->probe_repeatability_um,
                  "probe results: standard uncertainty of one touch (um)");
  cmd->add_option("--probe-points", a->probe_points,
                  "probe results: the point list of the program (ttp plan "
                  "probe); default: the default plan");
  cmd->add_option("--probe-frame", a->probe_frame,
                  "probe results: x, y, z in the machine frame (machine), the "
                  "work offset G54 as the program prints them (program), or "
                  "auto (default)");
  cmd->add_option("--dial-resolution-um", a->dial_resolution_um,
                  "dial readings: gauge resolution (um)");
  cmd->add_option("--dial-repeatability-um", a->dial_repeatability_um,
                  "dial readings: standard uncertainty of one reading (um)");
}

constexpr const char* kMeasurementHelp =
    "point cloud (PLY, PCD, .xyz/.txt/.csv), probe results CSV "
    "(point_id,x,y,z,c_deg), dial CSV (feature,reading_um), DMIS output or "
    "an inspection JSON; recognised from the content";

void Register(CLI::App& root, GlobalOptions& global) {
  auto args = std::make_shared<InspectArgs>();
  auto* cmd = root.add_subcommand(
      "inspect", "measured piece (any format) -> E_X..E_TTP with U (k=2)");
  cmd->add_option("measurement", args->measurement, kMeasurementHelp)
      ->required();
  AddJsonOption(cmd, &args->json,
                "the figures, facets and diagnostics as JSON");
  AddMeasurementOptions(cmd, args.get());
  cmd->callback([&global, args, cmd] {
    args->units_given = cmd->get_option("--units")->count() > 0;
    const Config config = global.LoadConfig();
    const inspect::Measurement m =
        inspect::LoadMeasurement(config, args->measurement, ToOptions(*args));
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
  AddMeasurementOptions(grade, gargs.get());
  grade->callback([&global, limits, figures, gargs, json_out, verbose, grade] {
    limits->figures = inspect::ParseFigureList(*figures);
    limits->Validate();
    gargs->units_given = grade->get_option("--units")->count() > 0;
    const Config config = global.LoadConfig();
    const inspect::Measurement m =
        inspect::LoadMeasurement(config, gargs->measurement, ToOptions(*gargs));
    const inspect::GradeResult r = inspect::GradeMeasurement(m, *limits);
    std::ostream& text = JsonToStdout(*json_out) ? std::cerr : std::cout;
    if (!global.quiet) text << inspect::GradeTable(r, *verbose);
    if (!json_out->empty()) WriteJson(*json_out, inspect::GradeToJson(r));
    if (r.overall != inspect::Verdict::kPass)
      global.exit_code = kExitJudgedFailure;
  });
}

}  // namespace
TTP_REGISTER_COMMANDS(40, Register);
}  // namespace ttp::app
