#pragma once
/// @file Statics of the robot standing on level ground: wheel loads, the joint torques that
/// hold a posture, and the standing height. Used for gravity-compensating feedforward
/// (executor landing phase, tests) and for closed-form expectations in tests.

#include <Eigen/Core>
#include <array>

#include "robot_model/robot_model.h"
#include "sim/settings.h"
#include "sim/sim_robot.h"

namespace wj::sim {

/// The robot held still in posture q with the base level and all four wheels loaded.
struct StandingStatics {
  /// Vertical load of each wheel on the ground [N], leg order. Split between the front and
  /// hind pair by the moment balance about the CoM, equally between left and right.
  std::array<double, model::kNumLegs> wheel_load_n{};
  /// Joint torques that balance gravity and the wheel loads [Nm]:
  /// tau = -sum_l J_l^T m_l g - sum_i J_i^T f_i (virtual work; J by central differences of
  /// RobotModel::calcLinkPoses). Wheels get 0: a vertical load through the axle has no moment.
  JointVector tau = JointVector::Zero();
  /// Height of the base origin over the ground with rigid wheels just touching [m].
  double base_height_m = 0.0;
};

/// Statics of posture q under gravity `gravity_m_s2` plus a vertical acceleration
/// `vertical_accel_m_s2` of the whole robot (d'Alembert: the loads scale with g + a).
StandingStatics calcStandingStatics(const model::RobotModel& model, const JointVector& q,
                                    double gravity_m_s2, double vertical_accel_m_s2 = 0.0);

/// Wheel centres in the base frame at posture q [m], leg order.
std::array<Eigen::Vector3d, model::kNumLegs> calcWheelCenters(const model::RobotModel& model,
                                                              const JointVector& q);

/// Static Hertz overlap of a sphere of `radius` pressed on flat ground by `load_n`, with the
/// contact law of `contact` (E = k / 2^(3/2)): x = (3 F / (4 E sqrt(R)))^(2/3) [m].
double calcHertzPenetration(const ContactSettings& contact, double radius, double load_n);

}  // namespace wj::sim
