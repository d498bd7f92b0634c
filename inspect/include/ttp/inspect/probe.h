// On-machine probe results (measurements.md section 2): CSV with header
// `point_id,x,y,z,c_deg`, the stylus centre at trigger in the machine frame
// with the table at c_deg, one row per planned point id (ttp plan probe).
// Each point is taken to W (geometry frames), compensated for the stylus
// radius along the planned approach vector, and each feature's points are
// fitted with a plane (FeatureResultFromPlane -> figures).
#pragma once

#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/geometry/figures.h"

namespace ttp::inspect {

// Which frame the x, y, z columns are in. measurements.md says the machine
// frame M; the probing program of `ttp plan probe` prints the skip
// position #5061..#5063, which FANUC and LinuxCNC give in the work offset
// (program frame P, G54). kAuto takes M unless the first point lands on
// its planned surface only when read as P (then a warning says so).
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

struct ProbeImport {
  FeatureResults results;
  std::vector<std::string> warnings;
};

// InputError names file, line and field: unknown point id, a point given
// twice, missing column, non-numeric or non-finite value.
ProbeImport ReadProbeResults(const Config& config, const std::string& csv_text,
                             const std::string& source,
                             const ProbeReadOptions& options = {});

}  // namespace ttp::inspect
