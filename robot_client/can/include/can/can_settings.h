#pragma once
/// @file Configuration of the CAN hardware backend: one bus per leg, the MIT-mode ranges of
/// each joint kind, the motor map (CAN id, direction, offset per joint) and fault detection.
/// Read from YAML (config/can.yaml) strictly: every key required, unknown keys refused.

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "can/mit_codec.h"
#include "robot_model/robot_model.h"

namespace wj::can {

/// Where one joint's motor sits and how its shaft relates to the joint:
/// q_joint = direction * p_motor + offset_rad (and qd, tau scale by direction).
struct MotorMapEntry {
  std::uint32_t can_id = 1;  ///< id on its leg's bus, 1..255 (the reply's first byte)
  double direction = 1.0;    ///< +1 or -1: sign of the motor axis against the joint axis
  double offset_rad = 0.0;   ///< joint position at which the motor reads zero [rad]
};

/// Everything CanRobot needs beyond the robot description.
struct CanRobotSettings {
  double control_period_s = 1e-3;  ///< period of the control loop [s]
  /// SocketCAN interface of each leg's bus, leg order LF, RF, LH, RH.
  std::array<std::string, model::kNumLegs> interfaces = {"can0", "can1", "can2", "can3"};
  std::uint32_t host_can_id = 0;  ///< identifier the motors answer with (0..2047)
  /// A motor that has not answered for this many consecutive periods is at fault (>= 1).
  int reply_timeout_periods = 3;
  /// MIT-mode ranges per joint kind (HAA, HFE, KFE, WHEEL); the motors must use the same.
  std::array<MitLimits, model::kJointsPerLeg> limits{};
  /// Motor of each joint, jointIndex() order. Default: ids 1..4 (HAA..WHEEL) on every bus,
  /// direction +1, offset 0.
  std::array<MotorMapEntry, model::kNumJoints> motors = defaultMotors();

  /// Ranges of joint `j` (jointIndex order).
  const MitLimits& limitsOf(int j) const { return limits[j % model::kJointsPerLeg]; }

  /// Throws std::invalid_argument naming the field when a value is out of range: period in
  /// (0, 0.1] s, host id 0..2047, timeout 1..1000 periods, valid limits, CAN ids 1..255,
  /// distinct on a bus and different from the host id, direction +-1, finite offsets, non-empty
  /// distinct interface names.
  void validate() const;
  /// validate(), plus: the ranges cover what `model`'s drives can do (torque range >= peak
  /// torque, velocity range >= no-load speed) and every joint's position limits map into the
  /// position range (continuous joints wrap instead). Throws std::invalid_argument.
  void validateAgainst(const model::RobotModel& model) const;

  /// The default motor map.
  static std::array<MotorMapEntry, model::kNumJoints> defaultMotors();
};

/// Reads CanRobotSettings from YAML (layout: config/can.yaml). Every key is required and
/// unknown keys are errors; throws std::runtime_error naming the file and the key, and
/// std::invalid_argument (from validate()) for values out of range.
CanRobotSettings loadCanRobotSettings(const std::filesystem::path& yaml_file);
/// Same from YAML text; `origin` names the source in error messages.
CanRobotSettings parseCanRobotSettings(std::string_view yaml_text,
                                       const std::string& origin = "<text>");
/// The project's configuration file: config/can.yaml of the source or install tree.
std::filesystem::path defaultCanConfigFile();

}  // namespace wj::can
