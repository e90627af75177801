#pragma once
/// @file Torque-speed envelope of a geared electric actuator (output side).

#include <string>

namespace wj::model {

/// What limits a drive's torque against its motion (braking, torque and speed of opposite signs).
enum class Braking {
  Peak,      ///< the current limit alone: the peak torque at every speed (a drive that regenerates)
  Envelope,  ///< the driving envelope, as if the back-EMF opposed the current (no regeneration)
};

/// Torque-speed envelope: driving, full peak torque up to the corner speed, then falling
/// linearly to zero at the no-load speed (the classic DC-motor envelope with a current limit:
/// the back-EMF eats the supply voltage). Braking, the back-EMF drives the current instead, so
/// only the current limit binds (Braking::Peak; docs/robot-model.md, "Actuator envelope").
struct ActuatorEnvelope {
  double peak_torque_nm = 0.0;       ///< continuous-current-limited peak output torque [Nm]
  double corner_speed_rad_s = 0.0;   ///< output speed up to which peak torque is available [rad/s]
  double no_load_speed_rad_s = 0.0;  ///< output speed at which available torque reaches 0 [rad/s]
  double gear_ratio = 1.0;           ///< motor turns per output turn [-]
  Braking braking = Braking::Peak;   ///< the limit of a torque against the motion

  /// Largest |torque| [Nm] available along the motion at output speed `speed_rad_s` (driving);
  /// 0 beyond the no-load speed.
  [[nodiscard]] double torqueLimit(double speed_rad_s) const;

  /// Largest |torque| [Nm] available for a torque of the sign of `torque_nm` at `speed_rad_s`:
  /// the driving limit, or when it opposes the motion the braking one.
  [[nodiscard]] double torqueLimit(double torque_nm, double speed_rad_s) const;

  /// Signed distance to the envelope: torqueLimit(torque, speed) - |torque| [Nm]. Negative =
  /// outside.
  [[nodiscard]] double torqueMargin(double torque_nm, double speed_rad_s) const;

  /// torqueLimit(speed) - |torque| [Nm]: the margin as if the torque drove the motion, a bound
  /// that holds in either quadrant (the planner's, docs/planner.md).
  [[nodiscard]] double drivingMargin(double torque_nm, double speed_rad_s) const;

  /// Speed margin: no_load_speed - |speed| [rad/s]. Negative = faster than the motor can turn.
  [[nodiscard]] double speedMargin(double speed_rad_s) const;

  /// `torque_nm` clipped into the envelope at `speed_rad_s` (for its sign).
  [[nodiscard]] double saturate(double torque_nm, double speed_rad_s) const;

  /// Throws std::invalid_argument naming `name` if the figures are not physically ordered
  /// (0 < corner <= no-load, peak > 0, gear ratio > 0).
  void validate(const std::string& name) const;
};

}  // namespace wj::model
