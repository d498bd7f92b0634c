// The CMM program (DMIS 5) of the finished piece: a program a CMM runs as
// it is. Header, units, the stylus (SNSDEF/SNSLCT), feeds and probing
// distances; a preliminary alignment the operator takes by hand (MODE/MAN:
// three points on the top face, three on the -Y flank, four on the 199
// cylinder); the datums TOP, FLANK+Y, FLANK-Y and CYL199 measured
// automatically and made the part frame W with DATDEF/DATSET (top face ->
// Z and z = 0, the flanks' mid plane -> Y, the circle -> X and Y origin);
// then every strip and facet in W. Between features the stylus moves up to
// a clearance height and across; around the cylinder it follows the
// approach circle. Plane patterns span two directions. The CMM writes
// every feature (OUTPUT/FA) into a DMIS output file that `ttp inspect`
// reads (labels X1_5, Z3, TOP, FLANK_PY, FLANK_NY, CYL199).
#pragma once

#include <string>
#include <vector>

#include "ttp/geometry/config.h"
#include "ttp/plan/plan.h"

namespace ttp::plan {

struct DmisOptions {
  double stylus_diameter_mm = 4.0;  // ball
  double stylus_length_mm = 50.0;   // probe tip below the probe head
  double approach_mm = 3.0;         // SNSET/APPRCH: ball gap at the start
  double retract_mm = 3.0;          // SNSET/RETRCT
  double search_mm = 4.0;           // SNSET/SEARCH: past the nominal
  // Height of the ball centre above the top face (W z) for every move
  // between features.
  double clearance_height_mm = 20.0;
  double positioning_speed_mm_s = 50.0;  // FEDRAT/POSVEL
  double measuring_speed_mm_s = 3.0;     // FEDRAT/MESVEL
  std::string results_file = "ttp_cmm_results.dmo";
  // Ceres style: false with "DmisOptions.<field>: <problem>".
  bool IsValid(std::string* error) const;
};

// The points the CMM takes: PlanPoints with the flank points on two
// heights and the strip points on two lines (a plane needs points that
// span two directions), the same counts; the datum circle's points as low
// in its band as the stylus ball clears the step to the next reference
// cylinder below by 0.1 mm (InputError naming stylus_diameter_mm when the
// ball cannot fit the band). Ids renumbered in order.
std::vector<PlannedPoint> CmmPoints(const PartSpec& part,
                                    const PlanOptions& options = {},
                                    const DmisOptions& dmis = {});

// The program for these points. InputError naming the field for invalid
// options, a missing datum (TOP, FLANK+Y, FLANK-Y, CYL199) or a plane
// whose points lie on a line.
std::string WriteDmisProgram(const PartSpec& part,
                             const std::vector<PlannedPoint>& points,
                             const DmisOptions& options = {});

}  // namespace ttp::plan
