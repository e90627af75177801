#pragma once
/// @file ZYX Euler angles theta = (roll, pitch, yaw): R_WB = Rz(yaw) Ry(pitch) Rx(roll), the
/// map between their rates and the angular velocity in W, and the derivatives of both.

#include <Eigen/Geometry>
#include <array>

namespace wj::nmpc {

/// R_WB of the ZYX Euler angles theta = (roll, pitch, yaw).
Eigen::Matrix3d calcRotation(const Eigen::Vector3d& theta);

/// dR_WB / dtheta_k for k = roll, pitch, yaw.
std::array<Eigen::Matrix3d, 3> calcRotationDerivatives(const Eigen::Vector3d& theta);

/// Euler angle rates from the angular velocity in W: thetadot = E(theta)^-1 omega_W, where
/// omega_W = E(theta) thetadot (singular at pitch = +-pi/2).
Eigen::Vector3d calcEulerRates(const Eigen::Vector3d& theta, const Eigen::Vector3d& omega_W);

/// d thetadot / d theta and d thetadot / d omega of calcEulerRates().
void calcEulerRatesJacobians(const Eigen::Vector3d& theta, const Eigen::Vector3d& omega_W,
                             Eigen::Matrix3d& d_theta, Eigen::Matrix3d& d_omega);

/// ZYX Euler angles (roll, pitch, yaw) of a rotation, with pitch in [-pi/2, pi/2]; when
/// `yaw_near` is given, yaw is unwrapped to lie within pi of it.
Eigen::Vector3d calcEulerAngles(const Eigen::Matrix3d& R_WB, double yaw_near = 0.0);

/// Skew-symmetric matrix [a]x with [a]x b = a x b.
inline Eigen::Matrix3d skew(const Eigen::Vector3d& a) {
  Eigen::Matrix3d S;
  S << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return S;
}

}  // namespace wj::nmpc
