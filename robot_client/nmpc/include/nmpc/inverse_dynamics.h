#pragma once
/// @file Inverse dynamics of the whole robot (floating base + 16 revolute joints, the URDF
/// tree of RobotModel) by the recursive Newton-Euler algorithm (Featherstone, "Rigid Body
/// Dynamics Algorithms", 2008, Sec. 5.3, written with classical accelerations):
///   [w_base; tau] = M(q) [a_base; qdd] + h(q, v) - J_c^T F.
/// The joint rows are paper Eq. 9, M_a qdd + h_a = tau + J_c,a^T F, with the base acceleration
/// the centroidal plan predicts; the base row w_base is the wrench the base would need from
/// outside (zero when the plan is consistent with the contact forces).

#include <Eigen/Geometry>
#include <array>

#include "robot_model/robot_model.h"

namespace wj::nmpc {

/// A value per robot joint, model::jointIndex() order.
using RobotJointVector = Eigen::Matrix<double, model::kNumJoints, 1>;

/// Motion of the base, everything in the base frame B.
struct BaseMotion {
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();     ///< angular velocity [rad/s]
  Eigen::Vector3d v_B = Eigen::Vector3d::Zero();         ///< velocity of the origin [m/s]
  Eigen::Vector3d omegadot_B = Eigen::Vector3d::Zero();  ///< angular acceleration [rad/s^2]
  /// Classical acceleration of the base origin (d/dt of its velocity in W, expressed in B)
  /// [m/s^2].
  Eigen::Vector3d a_B = Eigen::Vector3d::Zero();
};

/// A force on a wheel, in B: the contact force of the ground and the point where it acts.
struct WheelForce {
  Eigen::Vector3d f_B = Eigen::Vector3d::Zero();  ///< force on the robot [N]
  Eigen::Vector3d p_B = Eigen::Vector3d::Zero();  ///< point of application [m]
};

/// Result of the recursion.
struct InverseDynamicsResult {
  RobotJointVector tau = RobotJointVector::Zero();          ///< joint torques [Nm]
  Eigen::Vector3d base_torque_B = Eigen::Vector3d::Zero();  ///< about the base origin [Nm]
  Eigen::Vector3d base_force_B = Eigen::Vector3d::Zero();   ///< [N]
};

/// RNEA over the RobotModel tree. Immutable; calc() is allocation-free and thread-safe.
class InverseDynamics {
 public:
  /// Copies the tree (link inertias, joint frames and axes) from `robot`.
  explicit InverseDynamics(const model::RobotModel& robot);

  /// Joint torques and base wrench for joint positions q, velocities qd and accelerations qdd
  /// (16, jointIndex order), base motion `base`, gravity `gravity_B` (in B) and the ground
  /// forces on the four wheels (leg order).
  void calc(const Eigen::Vector3d& gravity_B, const BaseMotion& base, const RobotJointVector& q,
            const RobotJointVector& qd, const RobotJointVector& qdd,
            const std::array<WheelForce, model::kNumLegs>& wheel_forces,
            InverseDynamicsResult& out) const;

 private:
  static constexpr int kNumLinks = model::kNumJoints + 1;
  struct Link {
    int parent = -1;  // parent link, -1 for the base
    int joint = -1;   // joint index of the joint that carries it
    Eigen::Matrix3d R_PJ = Eigen::Matrix3d::Identity();
    Eigen::Vector3d p_PJ = Eigen::Vector3d::Zero();
    Eigen::Vector3d axis = Eigen::Vector3d::UnitY();
    double mass = 0.0;
    Eigen::Vector3d com = Eigen::Vector3d::Zero();
    Eigen::Matrix3d inertia_com = Eigen::Matrix3d::Zero();
  };
  std::array<Link, kNumLinks> links_{};
  std::array<int, model::kNumLegs> wheel_link_{};
};

}  // namespace wj::nmpc
