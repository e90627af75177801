#pragma once
/// @file Dimensions, vector types and index layout of the centroidal NMPC (paper Sec. II-A,
/// Eq. 3-4): state x = [theta, p, omega, v, q_j], input u = [f_1..f_4, qd_j].

#include <Eigen/Core>
#include <array>

#include "robot_model/robot_model.h"

namespace wj::nmpc {

inline constexpr int kNumLegs = model::kNumLegs;
/// Leg joints the NMPC models per leg (HAA, HFE, KFE); the wheel spin follows from rolling.
inline constexpr int kLegDofs = 3;
/// Leg joints of the whole robot in the NMPC (12).
inline constexpr int kNumLegJoints = kNumLegs * kLegDofs;
/// State: Euler angles, position, angular velocity, linear velocity, 12 leg joint positions.
inline constexpr int kStateDim = 12 + kNumLegJoints;
/// Input: 4 contact forces and 12 leg joint velocities.
inline constexpr int kInputDim = 3 * kNumLegs + kNumLegJoints;

/// Offsets of the state blocks.
namespace state_index {
inline constexpr int kTheta = 0;    ///< ZYX Euler angles (roll, pitch, yaw) [rad]
inline constexpr int kPos = 3;      ///< position of the body's CoM point in W [m]
inline constexpr int kOmega = 6;    ///< angular velocity of the body, in W [rad/s]
inline constexpr int kVel = 9;      ///< velocity of the CoM point, in W [m/s]
inline constexpr int kJoints = 12;  ///< leg joint positions, leg-major [rad]
/// First state index of the joints of leg `leg` (0..3).
constexpr int joints(int leg) {
  return kJoints + kLegDofs * leg;
}
}  // namespace state_index

/// Offsets of the input blocks.
namespace input_index {
/// First input index of the contact force of leg `leg` (in W, on the robot) [N].
constexpr int force(int leg) {
  return 3 * leg;
}
inline constexpr int kJointVel = 12;  ///< leg joint velocities, leg-major [rad/s]
/// First input index of the joint velocities of leg `leg`.
constexpr int jointVel(int leg) {
  return kJointVel + kLegDofs * leg;
}
}  // namespace input_index

using State = Eigen::Matrix<double, kStateDim, 1>;
using Input = Eigen::Matrix<double, kInputDim, 1>;
using StateMatrix = Eigen::Matrix<double, kStateDim, kStateDim>;       ///< d(state)/d(state)
using StateInputMatrix = Eigen::Matrix<double, kStateDim, kInputDim>;  ///< d(state)/d(input)
using InputMatrix = Eigen::Matrix<double, kInputDim, kInputDim>;       ///< d(input)/d(input)
using InputStateMatrix = Eigen::Matrix<double, kInputDim, kStateDim>;  ///< d(input)/d(state)
using LegJointVector = Eigen::Matrix<double, kNumLegJoints, 1>;

/// Contact flag per leg, leg order LF, RF, LH, RH.
using ContactFlags = std::array<bool, kNumLegs>;

/// Index of leg joint `dof` (0 = HAA, 1 = HFE, 2 = KFE) of `leg` in the 16-joint vectors of
/// the robot (model::jointIndex order).
constexpr int robotJointIndex(int leg, int dof) {
  return model::jointIndex(static_cast<model::Leg>(leg), static_cast<model::JointKind>(dof));
}

}  // namespace wj::nmpc
