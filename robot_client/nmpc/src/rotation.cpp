#include "nmpc/rotation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace wj::nmpc {

Eigen::Matrix3d calcRotation(const Eigen::Vector3d& theta) {
  const double cr = std::cos(theta.x()), sr = std::sin(theta.x());
  const double cp = std::cos(theta.y()), sp = std::sin(theta.y());
  const double cy = std::cos(theta.z()), sy = std::sin(theta.z());
  Eigen::Matrix3d R;
  R << cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr,  //
      sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr,   //
      -sp, cp * sr, cp * cr;
  return R;
}

std::array<Eigen::Matrix3d, 3> calcRotationDerivatives(const Eigen::Vector3d& theta) {
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(theta.x(), Eigen::Vector3d::UnitX()).matrix();
  const Eigen::Matrix3d Ry = Eigen::AngleAxisd(theta.y(), Eigen::Vector3d::UnitY()).matrix();
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(theta.z(), Eigen::Vector3d::UnitZ()).matrix();
  const Eigen::Matrix3d R = Rz * Ry * Rx;
  return {R * skew(Eigen::Vector3d::UnitX()), Rz * Ry * skew(Eigen::Vector3d::UnitY()) * Rx,
          skew(Eigen::Vector3d::UnitZ()) * R};
}

Eigen::Vector3d calcEulerRates(const Eigen::Vector3d& theta, const Eigen::Vector3d& w) {
  const double cp = std::cos(theta.y()), tp = std::tan(theta.y());
  const double cy = std::cos(theta.z()), sy = std::sin(theta.z());
  // omega_W = ez yawdot + Rz ey pitchdot + Rz Ry ex rolldot, inverted in closed form.
  const double c = cy * w.x() + sy * w.y();
  return {c / cp, -sy * w.x() + cy * w.y(), w.z() + tp * c};
}

void calcEulerRatesJacobians(const Eigen::Vector3d& theta, const Eigen::Vector3d& w,
                             Eigen::Matrix3d& d_theta, Eigen::Matrix3d& d_omega) {
  const double cp = std::cos(theta.y()), sp = std::sin(theta.y()), tp = sp / cp;
  const double cy = std::cos(theta.z()), sy = std::sin(theta.z());
  const double c = cy * w.x() + sy * w.y();
  const double d = -sy * w.x() + cy * w.y();   // dc/dyaw
  d_theta << 0.0, c * sp / (cp * cp), d / cp,  //
      0.0, 0.0, -c,                            //
      0.0, c / (cp * cp), tp * d;
  d_omega << cy / cp, sy / cp, 0.0,  //
      -sy, cy, 0.0,                  //
      tp * cy, tp * sy, 1.0;
}

Eigen::Vector3d calcEulerAngles(const Eigen::Matrix3d& R, double yaw_near) {
  const double pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R(2, 1), R(2, 2));
  double yaw = std::atan2(R(1, 0), R(0, 0));
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  yaw += kTwoPi * std::round((yaw_near - yaw) / kTwoPi);
  return {roll, pitch, yaw};
}

}  // namespace wj::nmpc
