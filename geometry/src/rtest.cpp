#include "ttp/geometry/rtest.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>
#include <map>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/frames.h"
#include "ttp/geometry/limits.h"

namespace ttp {

Eigen::Vector3d NominalSpherePosition(const RTestGeometry& g, double c_rad) {
  const double phi = g.sphere_phi0_deg * M_PI / 180.0;
  const Eigen::Vector3d on_table(g.sphere_distance_mm * std::cos(phi),
                                 g.sphere_distance_mm * std::sin(phi),
                                 g.sphere_height_mm);
  return WorkpieceToMachineRotation(c_rad, g.c_sense) * on_table;
}

Eigen::MatrixXd RTestDesignMatrix(const RTestGeometry& g,
                                  const std::vector<double>& c_rad) {
  Eigen::MatrixXd a(3 * c_rad.size(), 7);
  for (size_t k = 0; k < c_rad.size(); ++k) {
    a.block<3, 7>(3 * k, 0) = TableDisplacementJacobian(
        NominalSpherePosition(g, c_rad[k]), g.sphere_distance_mm);
  }
  return a;
}

namespace {
// Solves with column scaling so that mm and rad columns are comparable.
Eigen::MatrixXd PseudoInverse(const Eigen::MatrixXd& a,
                              const std::string& source) {
  Eigen::VectorXd scale = a.colwise().norm();
  for (int i = 0; i < scale.size(); ++i) {
    if (scale[i] == 0) scale[i] = 1;
  }
  const Eigen::MatrixXd as = a * scale.cwiseInverse().asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(
      as, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto& s = svd.singularValues();
  if (s.size() < 7 || s[6] < 1e-9 * s[0]) {
    throw InputError(source, 0, "c_deg",
                     "these table angles cannot determine all seven errors "
                     "(need at least three well spread angles, e.g. 0, 90, "
                     "180, 270 deg)");
  }
  const Eigen::MatrixXd pinv_scaled =
      svd.matrixV() * s.cwiseInverse().asDiagonal() * svd.matrixU().transpose();
  return scale.cwiseInverse().asDiagonal() * pinv_scaled;
}
}  // namespace

std::vector<SphereCycle> ParseSphereMeasurements(const std::string& text,
                                                 const std::string& source) {
  const CsvTable t = ParseCsv(text, source);
  const int c_cycle = t.Require("cycle"), c_deg = t.Require("c_deg");
  const int cx = t.Require("x"), cy = t.Require("y"), cz = t.Require("z");
  std::vector<SphereCycle> out;
  std::map<long, size_t> index;
  for (const CsvRow& row : t.rows) {
    const double cycle = t.Number(row, c_cycle);
    if (cycle != std::floor(cycle))
      throw InputError(source, row.line, "cycle", "must be an integer");
    if (std::abs(cycle) > static_cast<double>(limits::kMaxCycleId))
      throw InputError(source, row.line, "cycle",
                       t.Text(row, c_cycle) + " is beyond the limit of " +
                           std::to_string(limits::kMaxCycleId));
    const double deg = t.Number(row, c_deg);
    if (std::abs(deg) > 3600.0)
      throw InputError(
          source, row.line, "c_deg",
          t.Text(row, c_deg) + " deg is beyond +-3600 deg: not a table angle");
    Eigen::Vector3d centre;
    const int columns[3] = {cx, cy, cz};
    for (int k = 0; k < 3; ++k) {
      centre[k] = t.Number(row, columns[k]);
      if (std::abs(centre[k]) > limits::kMaxProgramCoordinate)
        throw InputError(source, row.line,
                         t.columns[static_cast<size_t>(columns[k])],
                         t.Text(row, columns[k]) + " mm is beyond " +
                             std::to_string(limits::kMaxProgramCoordinate) +
                             " mm: not a position on a machine");
    }
    const long id = static_cast<long>(cycle);
    auto [it, fresh] = index.emplace(id, out.size());
    if (fresh) out.push_back({id, {}});
    out[it->second].positions.push_back({deg * M_PI / 180, centre, row.line});
  }
  if (out.size() < 2)
    throw InputError(source, 0, "cycle",
                     "need a reference cycle and at least one more");
  return out;
}

void CheckSpheresFollowGeometry(const RTestGeometry& g,
                                const SphereCycle& cycle,
                                const std::string& source) {
  const double r = g.sphere_distance_mm;
  if (cycle.positions.empty()) return;
  const SphereMeasurement& first = cycle.positions.front();
  for (const SphereMeasurement& p : cycle.positions) {
    const double nominal =
        2 * r * std::abs(std::sin((p.c_rad - first.c_rad) / 2));
    const double measured = (p.centre_mm - first.centre_mm).norm();
    if (std::abs(measured - nominal) <= kRTestChordTolerance * r) continue;
    throw InputError(
        source, p.line, "x,y,z",
        fmt::format("cycle {}: the sphere centres at c = {:g} deg (line {}) "
                    "and {:g} deg lie {:.3f} mm apart, but a sphere d/2 = "
                    "{:g} mm off the C axis moves {:.3f} mm between these "
                    "angles: not an R-test of this set-up (set "
                    "--distance-mm to the sphere's distance from the axis)",
                    cycle.cycle, first.c_rad * 180 / M_PI, first.line,
                    p.c_rad * 180 / M_PI, measured, r, nominal));
  }
}

RTestSolution SolveRTest(const RTestGeometry& g,
                         const std::vector<SphereMeasurement>& reference,
                         const std::vector<SphereMeasurement>& cycle) {
  if (reference.size() != cycle.size() || reference.empty()) {
    throw InputError("R-test", 0, "",
                     "a cycle must measure the same positions as the "
                     "reference cycle");
  }
  std::vector<double> angles;
  Eigen::VectorXd b(3 * cycle.size());
  for (size_t k = 0; k < cycle.size(); ++k) {
    if (std::abs(std::remainder(cycle[k].c_rad - reference[k].c_rad,
                                2 * M_PI)) > 1e-9) {
      throw InputError("R-test", 0, "c_deg",
                       "position " + std::to_string(k + 1) +
                           " is at another table angle than in the "
                           "reference cycle");
    }
    angles.push_back(cycle[k].c_rad);
    b.segment<3>(3 * k) = cycle[k].centre_mm - reference[k].centre_mm;
  }
  const Eigen::MatrixXd a = RTestDesignMatrix(g, angles);
  const Eigen::MatrixXd pinv = PseudoInverse(a, "R-test");
  RTestSolution out;
  const Eigen::Matrix<double, 7, 1> x = pinv * b;
  out.errors = CAxisErrors::FromVector(x);
  out.covariance_unit = pinv * pinv.transpose();
  const Eigen::VectorXd r = a * x - b;
  out.rms_residual_mm = std::sqrt(r.squaredNorm() / r.size());
  return out;
}

Eigen::Matrix<double, 7, 1> RTestResolution(const RTestGeometry& g,
                                            const std::vector<double>& c_rad,
                                            double axis_resolution_mm) {
  const Eigen::MatrixXd pinv =
      PseudoInverse(RTestDesignMatrix(g, c_rad), "R-test");
  return pinv.cwiseAbs().rowwise().maxCoeff() * axis_resolution_mm;
}

}  // namespace ttp
