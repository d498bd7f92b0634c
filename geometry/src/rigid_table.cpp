#include "ttp/geometry/rigid_table.h"

namespace ttp {

CAxisErrors CAxisErrors::FromMicro(const std::array<double, 7>& v) {
  CAxisErrors e;
  e.ex0c_mm = v[0] * 1e-3;
  e.ey0c_mm = v[1] * 1e-3;
  e.ez0t_mm = v[2] * 1e-3;
  e.er0t_mm = v[3] * 1e-3;
  e.ea0c_rad = v[4] * 1e-6;
  e.eb0c_rad = v[5] * 1e-6;
  e.ec0c_rad = v[6] * 1e-6;
  return e;
}

std::array<double, 7> CAxisErrors::ToMicro() const {
  return {ex0c_mm * 1e3,  ey0c_mm * 1e3,  ez0t_mm * 1e3, er0t_mm * 1e3,
          ea0c_rad * 1e6, eb0c_rad * 1e6, ec0c_rad * 1e6};
}

Eigen::Matrix<double, 7, 1> CAxisErrors::AsVector() const {
  Eigen::Matrix<double, 7, 1> v;
  v << ex0c_mm, ey0c_mm, ez0t_mm, er0t_mm, ea0c_rad, eb0c_rad, ec0c_rad;
  return v;
}

CAxisErrors CAxisErrors::FromVector(const Eigen::Matrix<double, 7, 1>& v) {
  return {v[0], v[1], v[2], v[3], v[4], v[5], v[6]};
}

CAxisErrors CAxisErrors::operator+(const CAxisErrors& o) const {
  return FromVector(AsVector() + o.AsVector());
}
CAxisErrors CAxisErrors::operator-(const CAxisErrors& o) const {
  return FromVector(AsVector() - o.AsVector());
}
CAxisErrors CAxisErrors::operator*(double s) const {
  return FromVector(AsVector() * s);
}

Eigen::Matrix<double, 3, 7> TableDisplacementJacobian(
    const Eigen::Vector3d& p, double sphere_distance_mm) {
  const double X = p.x(), Y = p.y(), Z = p.z();
  const double inv_r = 1.0 / sphere_distance_mm;
  Eigen::Matrix<double, 3, 7> J;
  //      EX0C EY0C EZ0T ER0T     EA0C EB0C EC0C
  J << 1, 0, 0, X * inv_r, 0, Z, -Y,  //
      0, 1, 0, Y * inv_r, -Z, 0, X,   //
      0, 0, 1, 0, Y, -X, 0;
  return J;
}

Eigen::Vector3d TableDisplacement(const CAxisErrors& e,
                                  const Eigen::Vector3d& p,
                                  double sphere_distance_mm) {
  return TableDisplacementJacobian(p, sphere_distance_mm) * e.AsVector();
}

double SurfaceShiftMm(const CAxisErrors& machine_errors,
                      const CAxisErrors& predicted_errors,
                      const Eigen::Vector3d& p, const Eigen::Vector3d& q,
                      const Eigen::Vector3d& n, double sphere_distance_mm) {
  const Eigen::Vector3d offset =
      TableDisplacement(predicted_errors, q, sphere_distance_mm);
  const Eigen::Vector3d dp =
      TableDisplacement(machine_errors, p, sphere_distance_mm);
  return n.dot(offset - dp);
}

}  // namespace ttp
