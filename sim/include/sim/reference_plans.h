#pragma once
/// @file Reference postures and a closed-form jump plan: leg inverse kinematics for level
/// standing, and a vertical jump from rolling with a constant-force push. For tests, the
/// benchmark and smoke runs of the verifier without the DE planner.

#include "planner/jump_plan.h"
#include "robot_model/robot_model.h"
#include "sim/settings.h"
#include "sim/sim_robot.h"

namespace wj::sim {

/// Posture with HAA = 0 and every wheel centre straight below its HFE axis (plus `x_offset_m`
/// along x), the base level at `base_height_m` above flat ground with rigid wheels; knees
/// bent backward (planar two-link inverse kinematics from RobotModel::legGeometry()).
JointVector standingPosture(const model::RobotModel& model, double base_height_m,
                            double x_offset_m = 0.0);

/// CoM height above flat ground of standingPosture(base_height_m), base level.
double comHeight(const model::RobotModel& model, double base_height_m);

/// Base height whose standingPosture() puts the CoM at `com_height_m` (bisection).
double baseHeightForCom(const model::RobotModel& model, double com_height_m);

/// A vertical jump from rolling: constant upward CoM acceleration from a crouch to take-off
/// height (all wheels leave together), ballistic flight, touchdown in a landing posture.
struct VerticalJumpSpec {
  double v0_m_s = 0.0;                  ///< rolling speed, kept constant
  double start_base_height_m = 0.30;    ///< crouch at t = 0
  double takeoff_base_height_m = 0.42;  ///< leg extension at take-off
  double landing_base_height_m = 0.36;  ///< posture q_landing
  double push_accel_m_s2 = 9.81;        ///< upward CoM acceleration during the push
  double dt_s = 0.001;                  ///< sample period of the dense references
};

/// The plan of `spec`: references from the closed form, feedforward torques from the statics
/// under g + a (calcStandingStatics), wheels at v0 / r, prediction of the ballistic flight.
/// The initial CoM height includes the static Hertz penetration of `contact`.
planner::JumpPlan makeVerticalJumpPlan(const model::RobotModel& model, const VerticalJumpSpec& spec,
                                       const ContactSettings& contact, double gravity_m_s2);

}  // namespace wj::sim
