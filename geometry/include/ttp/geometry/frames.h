// Frames of test-piece.md section 1. W: workpiece; M: machine (origin where
// the C axis meets the table surface); the program frame P is M shifted so
// that W's origin at C = 0 is P's origin (the G54 offset of the programs).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "ttp/geometry/config.h"

namespace ttp {

// Height of W's origin above the table surface (adapter + piece), mm.
double WorkpieceOriginHeightMm(const Config& config);

// Rotation taking W directions to M directions at commanded table angle c:
// with c_sense = +1 a W direction at phi points along M angle phi - c.
Eigen::Matrix3d WorkpieceToMachineRotation(double c_rad, int c_sense);

// Point in W -> point in M at table angle c.
Eigen::Vector3d WorkpieceToMachine(const Config& config,
                                   const Eigen::Vector3d& p_w, double c_rad);
Eigen::Vector3d MachineToWorkpiece(const Config& config,
                                   const Eigen::Vector3d& p_m, double c_rad);

// Program coordinates (G54) <-> M.
Eigen::Vector3d ProgramToMachine(const Config& config,
                                 const Eigen::Vector3d& p_prog);
Eigen::Vector3d MachineToProgram(const Config& config,
                                 const Eigen::Vector3d& p_m);

// Table angle (rad) that turns W direction phi to M direction psi.
double TableAngleFor(double phi_w_rad, double psi_m_rad, int c_sense);

}  // namespace ttp
