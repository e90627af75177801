#include "robot_model/momentum.h"

#include <Eigen/Geometry>
#include <vector>

namespace wj::model {

Eigen::Vector3d calcCentralAngularMomentum(const RobotModel& robot, const Eigen::Matrix3d& R_WB,
                                           const Eigen::Vector3d& w_WB, const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& qd, WheelSpin wheels) {
  return CentralMomentum(robot).calc(R_WB, w_WB, q, qd, wheels);
}

CentralMomentum::CentralMomentum(const RobotModel& robot)
    : robot_(robot),
      X_(robot.links().size()),
      X_plus_(robot.links().size()),
      X_minus_(robot.links().size()),
      p_(robot.links().size()),
      v_(robot.links().size()),
      w_(robot.links().size()),
      q_step_(kNumJoints),
      is_wheel_(robot.links().size(), false) {
  for (const Leg leg : kLegs) is_wheel_[robot.joint(leg, JointKind::Wheel).child_link] = true;
}

Eigen::Vector3d CentralMomentum::calc(const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& w_WB,
                                      const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                                      WheelSpin wheels) {
  constexpr double h = 1e-6;  // step of the central difference along qd [s]
  robot_.calcLinkPoses(q, X_);
  q_step_ = q + h * qd;
  robot_.calcLinkPoses(q_step_, X_plus_);
  q_step_ = q - h * qd;
  robot_.calcLinkPoses(q_step_, X_minus_);
  const auto& links = robot_.links();
  const std::size_t n = links.size();
  Eigen::Vector3d c = Eigen::Vector3d::Zero(), v_c = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Inertia& li = links[i].inertia;
    // Link CoM and its velocity relative to the base, in B; the link's angular velocity
    // relative to the base from dR R^T = [w]x.
    const Eigen::Vector3d v_rel = (X_plus_[i] * li.com - X_minus_[i] * li.com) / (2.0 * h);
    const Eigen::Matrix3d W =
        (X_plus_[i].linear() - X_minus_[i].linear()) / (2.0 * h) * X_[i].linear().transpose();
    p_[i] = R_WB * (X_[i] * li.com);
    v_[i] = w_WB.cross(p_[i]) + R_WB * v_rel;
    w_[i] = w_WB + R_WB * Eigen::Vector3d(W(2, 1), W(0, 2), W(1, 0));
    c += li.mass * p_[i];
    v_c += li.mass * v_[i];
  }
  c /= robot_.totalMass();
  v_c /= robot_.totalMass();
  Eigen::Vector3d H = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Inertia& li = links[i].inertia;
    const Eigen::Matrix3d R_WL = R_WB * X_[i].linear();
    const Eigen::Vector3d orbit = li.mass * (p_[i] - c).cross(v_[i] - v_c);
    if (wheels == WheelSpin::Excluded && is_wheel_[i])
      H += orbit;
    else
      H += orbit + R_WL * li.inertia_com * R_WL.transpose() * w_[i];
  }
  return H;
}

}  // namespace wj::model
