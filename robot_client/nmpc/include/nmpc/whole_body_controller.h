#pragma once
/// @file Whole-body conversion of the NMPC's policy into drive commands, once per control
/// period (paper Sec. II-D): the legs track the planned joint positions and velocities with PD
/// plus the inverse-dynamics torque of paper Eq. 9 (the planned contact forces, the planned
/// base acceleration, the measured joint velocities); the wheels in contact follow the paper's
/// law tau_w = K_d (v_des,t - v_t) + f_t r plus a slip damper that is zero while the wheel
/// rolls without slip (it stops a planned-stance wheel that is still in the air from spinning
/// up under the traction torque); the swinging wheels spin at the body's ground speed so that
/// they touch down without slip.
///
/// Real time: calcCommands() neither allocates nor throws nor logs.

#include "nmpc/centroidal_model.h"
#include "nmpc/gait.h"
#include "nmpc/inverse_dynamics.h"
#include "nmpc/policy.h"
#include "nmpc/problem.h"
#include "robot_model/robot_interface.h"

namespace wj::nmpc {

/// Gains of the whole-body conversion.
struct WholeBodySettings {
  double leg_kp = 60.0;         ///< leg joint stiffness around the planned position [Nm/rad]
  double leg_kd = 2.0;          ///< leg joint damping around the planned velocity [Nm s/rad]
  double wheel_kd = 40.0;       ///< K_d of the paper's wheel law, on the speed along t [Nm s/m]
  double swing_wheel_kd = 0.3;  ///< speed gain of a swinging wheel [Nm s/rad]
  /// Slip damper of a stance wheel: torque per rad/s of spin beyond rolling [Nm s/rad].
  double wheel_slip_kd = 0.3;
  bool inverse_dynamics = true;        ///< add the RNEA torque of paper Eq. 9 to the legs
  bool policy_feedback = true;         ///< apply the policy's feedback gains (else feed-forward)
  double max_feedback_force_n = 80.0;  ///< |K dx| beyond this (per wheel) is clipped [N]

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Diagnostics of one calcCommands() call.
struct WholeBodyOutput {
  Input u = Input::Zero();                             ///< policy input used (feedback included)
  State x_des = State::Zero();                         ///< planned state at this instant
  RobotJointVector tau_ff = RobotJointVector::Zero();  ///< feed-forward torques [Nm]
};

/// See the file comment. Immutable apart from the caller's output; thread-compatible.
class WholeBodyController {
 public:
  /// Throws std::invalid_argument on bad settings.
  WholeBodyController(const model::RobotModel& robot, const CentroidalModel& model,
                      const WholeBodySettings& settings);

  /// Commands of all 16 drives at time t for the measured state x (NMPC layout) and the
  /// measured joints `sensors`, from `policy`; `contact` is the planned contact of each wheel
  /// at t and `normal` the ground normal.
  void calcCommands(double t, const Policy& policy, const State& x,
                    const model::SensorData& sensors, const ContactFlags& contact,
                    const Eigen::Vector3d& normal, model::JointCommands& out,
                    WholeBodyOutput& diagnostics) const;

  /// Gains.
  const WholeBodySettings& settings() const { return settings_; }

 private:
  CentroidalModel model_;
  InverseDynamics inverse_dynamics_;
  WholeBodySettings settings_;
};

}  // namespace wj::nmpc
