#include <fmt/format.h>

#include <cmath>

#include "ttp/geometry/error.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/limits.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {
namespace {

constexpr double kPi = 3.14159265358979323846;

void Check(bool ok, const char* field, const std::string& problem) {
  if (!ok) throw InputError("ProbeOptions", 0, field, problem);
}

}  // namespace

void ProbeOptions::Validate() const {
  Check(clearance_mm > 0 && clearance_mm <= 100, "clearance_mm",
        fmt::format("{:g} mm is not in (0, 100] mm", clearance_mm));
  // The probing move ends overtravel_mm beyond the nominal surface: on the
  // strips and the top face that is downwards, towards the table. A probe
  // overtravels a few millimetres at most before its stylus breaks.
  Check(overtravel_mm > 0 && overtravel_mm <= limits::kMaxOvertravelMm,
        "overtravel_mm",
        fmt::format("{:g} mm is not in (0, {:g}] mm (further would drive the "
                    "stylus through the piece towards the table)",
                    overtravel_mm, limits::kMaxOvertravelMm));
  Check(safe_z_mm > 0 && safe_z_mm <= 1000, "safe_z_mm",
        fmt::format("{:g} mm is not above the top face (> 0) and within "
                    "1000 mm",
                    safe_z_mm));
}

gcode::Program BuildProbeProgram(const Config& config,
                                 const std::vector<PlannedPoint>& points,
                                 const ProbeOptions& options) {
  options.Validate();
  using namespace gcode;
  const ToolSpec& probe = config.process.probe;
  Program program;
  program.name = "probe";
  program.number = config.machine.program_number + 2;
  program.title = "TTP ON-MACHINE PROBING OF THE FINISHED PIECE";
  auto& out = program.statements;
  out.push_back(Comment{fmt::format(
      "touch probe T{}, stylus {:.3f} mm; {} points; report = skip position",
      probe.number, probe.diameter_mm, points.size())});
  out.push_back(ToolChange{probe.number, probe.name});
  out.push_back(Rapid{{std::nullopt, std::nullopt, options.safe_z_mm, 0.0}});
  const double r_stylus = probe.diameter_mm / 2;
  const int sense = config.machine.c_sense;
  // Horizontal start positions must clear the piece's widest part above
  // the point (the rim is gone after finishing; the 199 band is widest).
  double widest_radius_mm = 0;
  for (const RefCylinder& c : config.part.ref_cylinders)
    widest_radius_mm = std::max(widest_radius_mm, c.diameter_mm / 2);
  double last_c = 0.0;
  for (const PlannedPoint& p : points) {
    const Eigen::Vector3d& n = p.normal_w;
    const bool vertical = std::abs(n.z()) > 0.999;
    if (!vertical && std::abs(n.z()) > 1e-9)
      throw InputError("plan", p.id, "normal",
                       "only horizontal and vertical normals can be probed "
                       "with one linear axis");
    // Table angle: horizontal normals point along machine +X.
    double c_rad = 0.0;
    if (!vertical) c_rad = TableAngleFor(std::atan2(n.y(), n.x()), 0.0, sense);
    // Keep C in (-180, 180] for a short index.
    double c_deg = std::remainder(c_rad * 180.0 / kPi, 360.0);
    if (c_deg == -180.0) c_deg = 180.0;
    c_rad = c_deg * kPi / 180.0;
    const Eigen::Vector3d surface_p = MachineToProgram(
        config, WorkpieceToMachine(config, p.point_w_mm, c_rad));
    const Eigen::Vector3d n_m =
        WorkpieceToMachineRotation(c_rad, sense) * n;  // +X or +Z
    const Eigen::Vector3d centre = surface_p + r_stylus * n_m;
    double standoff = options.clearance_mm;
    if (!vertical) {
      // Start outside every surface the stylus passes on its way down.
      const double radial = p.point_w_mm.head<2>().norm();
      if (p.feature.rfind("CYL", 0) == 0 || radial > 90.0)
        standoff = std::max(standoff, widest_radius_mm + 1.0 - radial);
    }
    const Eigen::Vector3d start = centre + standoff * n_m;
    const Eigen::Vector3d target = centre - options.overtravel_mm * n_m;
    out.push_back(Comment{fmt::format("point {} on {}", p.id, p.feature)});
    if (c_deg != last_c) {
      out.push_back(
          Rapid{{std::nullopt, std::nullopt, options.safe_z_mm, std::nullopt}});
      out.push_back(Rapid{{std::nullopt, std::nullopt, std::nullopt, c_deg}});
      last_c = c_deg;
    }
    out.push_back(Rapid{{start.x(), start.y(), std::nullopt, std::nullopt}});
    out.push_back(Rapid{{std::nullopt, std::nullopt, start.z(), std::nullopt}});
    Axes to;
    if (vertical)
      to.z_mm = target.z();
    else
      to.x_mm = target.x();
    out.push_back(Probe{to, probe.feed_mm_min, p.id});
    // Back off along the normal before lifting: never drag the stylus.
    out.push_back(Rapid{
        {vertical ? std::nullopt : std::optional(start.x()), std::nullopt,
         vertical ? std::optional(start.z()) : std::nullopt, std::nullopt}});
    out.push_back(
        Rapid{{std::nullopt, std::nullopt, options.safe_z_mm, std::nullopt}});
  }
  out.push_back(Rapid{{std::nullopt, std::nullopt, options.safe_z_mm, 0.0}});
  out.push_back(ProgramEnd{});
  return program;
}

}  // namespace ttp::plan
