#pragma once
/// @file Torque-speed envelope of a geared electric actuator (output side).

#include <string>

namespace wj::model {

/// Torque-speed envelope: full peak torque up to the corner speed, then falling linearly to
/// zero at the no-load speed (the classic DC-motor envelope with a current limit). Symmetric in
/// the sign of torque and speed: braking is given no extra torque, which is conservative.
struct ActuatorEnvelope {
  double peak_torque_nm = 0.0;       ///< continuous-current-limited peak output torque [Nm]
  double corner_speed_rad_s = 0.0;   ///< output speed up to which peak torque is available [rad/s]
  double no_load_speed_rad_s = 0.0;  ///< output speed at which available torque reaches 0 [rad/s]
  double gear_ratio = 1.0;           ///< motor turns per output turn [-]

  /// Largest |torque| [Nm] available at output speed `speed_rad_s` (either sign); 0 beyond the
  /// no-load speed.
  [[nodiscard]] double torqueLimit(double speed_rad_s) const;

  /// Signed distance to the envelope: torqueLimit(speed) - |torque| [Nm]. Negative = outside.
  [[nodiscard]] double torqueMargin(double torque_nm, double speed_rad_s) const;

  /// Speed margin: no_load_speed - |speed| [rad/s]. Negative = faster than the motor can turn.
  [[nodiscard]] double speedMargin(double speed_rad_s) const;

  /// `torque_nm` clipped into the envelope at `speed_rad_s`.
  [[nodiscard]] double saturate(double torque_nm, double speed_rad_s) const;

  /// Throws std::invalid_argument naming `name` if the figures are not physically ordered
  /// (0 < corner <= no-load, peak > 0, gear ratio > 0).
  void validate(const std::string& name) const;
};

}  // namespace wj::model
