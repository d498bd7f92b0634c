#include "ttp/geometry/frames.h"

namespace ttp {

double WorkpieceOriginHeightMm(const Config& c) {
  return c.machine.table_top_z_mm + c.part.adapter_height_mm +
         c.part.height_mm();
}

Eigen::Matrix3d WorkpieceToMachineRotation(double c_rad, int c_sense) {
  return Eigen::AngleAxisd(-c_sense * c_rad, Eigen::Vector3d::UnitZ())
      .toRotationMatrix();
}

Eigen::Vector3d WorkpieceToMachine(const Config& config,
                                   const Eigen::Vector3d& p_w, double c_rad) {
  return WorkpieceToMachineRotation(c_rad, config.machine.c_sense) * p_w +
         Eigen::Vector3d(0, 0, WorkpieceOriginHeightMm(config));
}

Eigen::Vector3d MachineToWorkpiece(const Config& config,
                                   const Eigen::Vector3d& p_m, double c_rad) {
  return WorkpieceToMachineRotation(c_rad, config.machine.c_sense).transpose() *
         (p_m - Eigen::Vector3d(0, 0, WorkpieceOriginHeightMm(config)));
}

Eigen::Vector3d ProgramToMachine(const Config& config,
                                 const Eigen::Vector3d& p_prog) {
  return p_prog + Eigen::Vector3d(0, 0, WorkpieceOriginHeightMm(config));
}

Eigen::Vector3d MachineToProgram(const Config& config,
                                 const Eigen::Vector3d& p_m) {
  return p_m - Eigen::Vector3d(0, 0, WorkpieceOriginHeightMm(config));
}

double TableAngleFor(double phi_w_rad, double psi_m_rad, int c_sense) {
  // psi = phi - sense * c  =>  c = (phi - psi) / sense
  return (phi_w_rad - psi_m_rad) * c_sense;
}

}  // namespace ttp
