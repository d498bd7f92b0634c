// The rigid-table model of test-piece.md section 6 (thesis eqs. 6.3-6.5):
// seven thermal errors of the C axis displace a table point. Inside the
// toolkit errors are in mm and rad; the log and the figures use um and um/m,
// converted only at I/O (FromMicro / ToMicro).
#pragma once

#include <Eigen/Core>
#include <array>

namespace ttp {

struct CAxisErrors {
  double ex0c_mm = 0, ey0c_mm = 0, ez0t_mm = 0, er0t_mm = 0;
  double ea0c_rad = 0, eb0c_rad = 0, ec0c_rad = 0;

  // Order of the log columns: EX0C EY0C EZ0T ER0T (um) EA0C EB0C EC0C (um/m).
  static CAxisErrors FromMicro(const std::array<double, 7>& um_and_um_per_m);
  std::array<double, 7> ToMicro() const;
  Eigen::Matrix<double, 7, 1> AsVector() const;  // mm, rad
  static CAxisErrors FromVector(const Eigen::Matrix<double, 7, 1>& v);

  CAxisErrors operator+(const CAxisErrors& o) const;
  CAxisErrors operator-(const CAxisErrors& o) const;
  CAxisErrors operator*(double s) const;
};

constexpr const char* kErrorNames[7] = {"EX0C", "EY0C", "EZ0T", "ER0T",
                                        "EA0C", "EB0C", "EC0C"};

// dP(p): displacement (mm) of the table point at machine position p (mm,
// Z above the table surface), B = 0. sphere_distance_mm is d/2.
Eigen::Vector3d TableDisplacement(const CAxisErrors& e,
                                  const Eigen::Vector3d& p_machine_mm,
                                  double sphere_distance_mm);

// Jacobian d dP / d (the seven errors as AsVector()) at p: 3x7, linear.
Eigen::Matrix<double, 3, 7> TableDisplacementJacobian(
    const Eigen::Vector3d& p_machine_mm, double sphere_distance_mm);

// Displacement of a cut surface along its outward normal n (machine frame)
// at material point p, with the compensation offset computed at axis
// position q from predicted errors: n . (o(q) - dP(p)). Pass zero
// predictions when compensation is off.
double SurfaceShiftMm(const CAxisErrors& machine_errors,
                      const CAxisErrors& predicted_errors,
                      const Eigen::Vector3d& p_machine_mm,
                      const Eigen::Vector3d& q_axis_mm,
                      const Eigen::Vector3d& n_machine,
                      double sphere_distance_mm);

}  // namespace ttp
