#include "robot_model/actuator.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace wj::model {

double ActuatorEnvelope::torqueLimit(double speed_rad_s) const {
  const double w = std::abs(speed_rad_s);
  if (w <= corner_speed_rad_s) return peak_torque_nm;
  if (w >= no_load_speed_rad_s) return 0.0;
  return peak_torque_nm * (no_load_speed_rad_s - w) / (no_load_speed_rad_s - corner_speed_rad_s);
}

double ActuatorEnvelope::torqueLimit(double torque_nm, double speed_rad_s) const {
  const bool against_motion = torque_nm * speed_rad_s < 0.0;
  return against_motion && braking == Braking::Peak ? peak_torque_nm : torqueLimit(speed_rad_s);
}

double ActuatorEnvelope::torqueMargin(double torque_nm, double speed_rad_s) const {
  return torqueLimit(torque_nm, speed_rad_s) - std::abs(torque_nm);
}

double ActuatorEnvelope::drivingMargin(double torque_nm, double speed_rad_s) const {
  return torqueLimit(speed_rad_s) - std::abs(torque_nm);
}

double ActuatorEnvelope::speedMargin(double speed_rad_s) const {
  return no_load_speed_rad_s - std::abs(speed_rad_s);
}

double ActuatorEnvelope::saturate(double torque_nm, double speed_rad_s) const {
  const double limit = torqueLimit(torque_nm, speed_rad_s);
  return std::clamp(torque_nm, -limit, limit);
}

void ActuatorEnvelope::validate(const std::string& name) const {
  const auto fail = [&](const std::string& what) {
    throw std::invalid_argument("actuator '" + name + "': " + what);
  };
  if (!(peak_torque_nm > 0.0) || !std::isfinite(peak_torque_nm))
    fail("peak torque must be finite and > 0 Nm, got " + std::to_string(peak_torque_nm));
  if (!(no_load_speed_rad_s > 0.0) || !std::isfinite(no_load_speed_rad_s))
    fail("no-load speed must be finite and > 0 rad/s, got " + std::to_string(no_load_speed_rad_s));
  if (!(corner_speed_rad_s > 0.0) || corner_speed_rad_s >= no_load_speed_rad_s)
    fail("corner_speed_rad_s must lie in (0, " + std::to_string(no_load_speed_rad_s) +
         ") rad/s, got " + std::to_string(corner_speed_rad_s));
  if (!(gear_ratio > 0.0) || !std::isfinite(gear_ratio))
    fail("gear_ratio must be finite and > 0, got " + std::to_string(gear_ratio));
}

}  // namespace wj::model
