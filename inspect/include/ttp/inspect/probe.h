// On-machine probe results (measurements.md section 2), read in any of
// three forms:
// - CSV with header `point_id,x,y,z,c_deg`: the stylus centre at trigger
//   with the table at c_deg, one row per planned point id;
// - the log the LinuxCNC probing program writes (plan/probe_program.h):
//   the same CSV with the columns `feature` and `pass` (qualify | measure |
//   drift) added;
// - the FANUC probing program's DPRNT output: a line `TTP PROBE LOG ...`,
//   then `<PASS> <id> <feature> X<x> Y<y> Z<z> C<c> T<hhmmss>` per touch
//   (values as DPRNT prints them, spaces after the letter allowed).
// Qualification rows (the R-test sphere: top and four equator touches) give
// the stylus' effective radius: a sphere fitted through the five ball
// centres, less machine.sphere_radius_mm. Without them the nominal radius
// (process.probe.diameter_mm / 2) is used, with a warning. Each measured
// point is taken to W (geometry frames), compensated by that radius along
// the planned approach vector, and each feature's points are fitted with a
// plane (FeatureResultFromPlane -> figures). Drift rows (the reference
// facets probed again at the end) give the drift along each normal.
#pragma once

#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"

namespace ttp::inspect {

// Which frame the x, y, z columns are in. measurements.md says the machine
// frame M; the probing program of `ttp plan probe` prints the skip
// position #5061..#5063, which FANUC and LinuxCNC give in the work offset
// (program frame P, G54). kAuto takes P for the program's logs (a `pass`
// column, or the FANUC log) and, for a plain CSV, M unless the first point
// lands on its planned surface only when read as P (then a warning says
// so).
enum class ProbeFrame { kAuto, kMachine, kProgram };

struct ProbeReadOptions {
  ProbeFrame frame = ProbeFrame::kAuto;
  // Standard uncertainty of one touch (probe repeatability), um.
  double repeatability_um = 0.5;
  // The point list the program was written for (plan's PointsToCsv); empty:
  // the default plan (PlanPoints with default options).
  std::string points_csv_path;
  // Ceres style: false with "ProbeReadOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
  void Validate() const;  // InputError naming the option
};

// Reference facet probed again at the end of the run: change of the touch
// along the outward normal (positive outwards), um.
struct ProbeDrift {
  FeatureId feature;
  int points = 0;
  double mean_um = 0;
  double max_abs_um = 0;
};

struct ProbeImport {
  FeatureResults results;
  std::vector<std::string> warnings;
  bool qualified = false;           // stylus radius from the sphere touches
  double stylus_radius_mm = 0;      // the radius used
  double qualification_rms_um = 0;  // sphere fit residual RMS
  std::vector<ProbeDrift> drift;
};

// InputError names file, line and field: unknown point id, a point given
// twice (in one pass), a feature that is not the point list's, missing
// column, non-numeric or non-finite value, a qualification whose radius is
// more than 0.1 mm off the nominal.
ProbeImport ReadProbeResults(const Config& config, const std::string& csv_text,
                             const std::string& source,
                             const ProbeReadOptions& options = {});

}  // namespace ttp::inspect
