// R-test evaluation (thesis 5.2, eqs. 5.4-5.10; test-piece.md section 6):
// the seven C-axis errors as the least-squares solution of the rigid-table
// equations for the displacements of a sphere measured at table angles c_k.
// With the thesis' four positions at 0/90/180/270 deg and the sphere at
// table height this reproduces eqs. 5.4-5.10 (up to their printed signs).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "ttp/geometry/rigid_table.h"

namespace ttp {

struct RTestGeometry {
  double sphere_distance_mm = 160.0;  // d/2
  double sphere_height_mm = 80.0;     // centre above the table surface
  double sphere_phi0_deg = 0.0;       // sphere direction on the table at C=0
  int c_sense = 1;                    // as MachineProfile::c_sense
};

// One measured sphere centre (machine frame, mm) at a table angle.
struct SphereMeasurement {
  double c_rad = 0;
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();
  int line = 0;  // of the file it was read from (0: not read from a file)
};

// The sphere centres of an R-test file (CSV `cycle,c_deg,x,y,z`, machine
// frame, mm; `ttp rtest`), one entry per cycle in the order the file first
// names them, positions in file order. InputError naming the line and the
// column for a cycle that is not a whole number within limits::kMaxCycleId,
// an angle beyond +-3600 deg, a coordinate beyond
// limits::kMaxProgramCoordinate, or fewer than two cycles.
struct SphereCycle {
  long cycle = 0;
  std::vector<SphereMeasurement> positions;
};
std::vector<SphereCycle> ParseSphereMeasurements(const std::string& text,
                                                 const std::string& source);

// InputError naming `source`, the line and --distance-mm when the centres
// of one cycle do not move as a sphere d/2 off the C axis does: two
// positions c_a, c_b lie 2 (d/2) sin(|c_a - c_b| / 2) apart, whatever the
// machine's thermal state (its errors are micrometres). A distance off by
// more than kRTestChordTolerance of d/2 means another set-up (a wrong d/2,
// or centres that are not an R-test's, such as one point repeated); the
// errors solved from it would be scaled wrongly or meaningless.
inline constexpr double kRTestChordTolerance = 0.1;
void CheckSpheresFollowGeometry(const RTestGeometry& g,
                                const SphereCycle& cycle,
                                const std::string& source);

// Nominal machine position of the sphere centre at table angle c.
Eigen::Vector3d NominalSpherePosition(const RTestGeometry& g, double c_rad);

// Design matrix (3 rows per angle) mapping the seven errors (AsVector
// order, mm and rad) to the sphere displacements.
Eigen::MatrixXd RTestDesignMatrix(const RTestGeometry& g,
                                  const std::vector<double>& c_rad);

struct RTestSolution {
  CAxisErrors errors;
  Eigen::Matrix<double, 7, 7> covariance_unit;  // (A^T A)^-1: per mm^2 of
                                                // coordinate variance
  double rms_residual_mm = 0;
};

// Errors of `cycle` relative to `reference` (same angles, same order).
// Throws InputError if the angles cannot determine all seven errors.
RTestSolution SolveRTest(const RTestGeometry& g,
                         const std::vector<SphereMeasurement>& reference,
                         const std::vector<SphereMeasurement>& cycle);

// Resolution of each error (AsVector order; mm and rad): the largest change
// of the result caused by one coordinate moving by one axis increment
// (thesis table 5.4, "measurement resolution").
Eigen::Matrix<double, 7, 1> RTestResolution(const RTestGeometry& g,
                                            const std::vector<double>& c_rad,
                                            double axis_resolution_mm);

}  // namespace ttp
