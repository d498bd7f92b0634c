// Limits on what the readers and planners accept. Every limit is checked
// before anything is allocated for it, and an input beyond one throws
// InputError naming the limit and the value. The values are far above any
// real measurement or program of a test piece and far below what the
// machine running ttp could hold (docs/ARCHITECTURE.md, "Limits").
#pragma once

#include <cstddef>
#include <cstdint>

namespace ttp::limits {

// Point clouds: points per cloud (a dense CMM scan of the piece holds about
// 1e5; 5e7 points in double are 1.2 GB), fields per PCD/PLY record and the
// COUNT/SIZE of one field.
constexpr std::int64_t kMaxCloudPoints = 50'000'000;
constexpr int kMaxCloudFields = 256;
constexpr int kMaxFieldCount = 1024;  // PCD COUNT of one field
constexpr int kMaxRecordBytes = 65'536;
constexpr std::int64_t kMaxCloudBytes = 4'000'000'000;  // records x points
// Bytes of one input (a file or a pipe; most are read into memory): a
// 50-million point text cloud or a 5-million row log fits; a device or a pipe
// without end does not run the machine out of memory.
constexpr std::uint64_t kMaxInputBytes = 4'000'000'000;
// Coordinates of a measured point, mm (the piece is 200 mm, a CMM table a
// few metres; 1e6 mm rules out 1e300 while leaving every unit mix-up to the
// inspection's own plausibility checks).
constexpr double kMaxCoordinateMm = 1.0e6;

// TALC log: rows and time span (a run lasts hours; 30 days at one row per
// second is 2.6e6 rows), and the magnitudes of its values.
constexpr std::int64_t kMaxLogRows = 5'000'000;
constexpr double kMaxLogSpanS = 30.0 * 24 * 3600;
constexpr double kMaxLogTimeS = 1.0e9;         // |t_s|
constexpr double kMaxRTestValueMicro = 1.0e5;  // |R-test value|, um or um/m
constexpr double kMinSphereDistanceMm = 1.0;   // sphere_distance_mm
constexpr double kMaxSphereDistanceMm = 10'000.0;
constexpr double kMaxTemperatureC = 1000.0;          // |T_env|, |T_ws|, ...
constexpr double kAbsoluteZeroC = -273.15;           // no temperature below
// Thermal log (models/time_series): a displacement at the tool (um) and a
// speed (1/min) far beyond any machine's.
constexpr double kMaxDisplacementUm = 1.0e5;
constexpr double kMaxSpeedPerMin = 1.0e6;
constexpr std::int64_t kMaxCycleId = 1'000'000'000;  // R-test cycle numbers
// Points of a strategy sweep's grid (talc sweep): the thesis' 8,764
// replays and far beyond; a grid past it is a typo, not a plan.
constexpr std::int64_t kMaxGridPoints = 1'000'000;

// Measured feature values (inspection JSON, DMIS, dial): a thermal test
// piece deviates from nominal by micrometres; a feature more than this far
// from its nominal place is not a measurement of this piece (wrong units,
// wrong frame, wrong file).
constexpr double kMaxFeatureDeviationMm = 5.0;
constexpr double kMaxFeatureAngleRad = 0.1;
constexpr double kMaxFigureMicro = 1.0e4;  // |E_X..E_TTP| um, um/m
constexpr double kMaxReadingUm = 5'000.0;  // dial gauge reading

// Measurement plans: probe points per facet and strip, CMM rows.
constexpr int kMaxFacetColumns = 100;
constexpr int kMaxFacetRows = 100;
constexpr int kMaxStripPoints = 1000;
constexpr double kMaxOvertravelMm = 10.0;  // past the surface, probe G31

// Programs: coordinates and dwells the reader accepts (mm or inch, s).
constexpr double kMaxProgramCoordinate = 1.0e5;
constexpr double kMaxDwellS = 24.0 * 3600;
constexpr std::int64_t kMaxProgramLines = 10'000'000;
// Characters in one line (LinuxCNC reads at most 256): beyond it a line is
// not a block, and a line of millions of comments would be millions of
// statements.
constexpr std::int64_t kMaxProgramLineChars = 65'536;

}  // namespace ttp::limits
