#include "sim/executor_settings_file.h"

#include <yaml-cpp/yaml.h>

#include <optional>
#include <stdexcept>

#include "robot_model/strict_yaml.h"

namespace wj::sim {

namespace {

ExecutorSettings readFields(StrictYamlMap& m) {
  ExecutorSettings e;
  e.takeoff_kp = m.number("takeoff_kp");
  e.takeoff_kd = m.number("takeoff_kd");
  e.wheel_kd = m.number("wheel_kd");
  e.flight_wheel_kd = m.number("flight_wheel_kd");
  e.takeoff_wheel_kd = m.number("takeoff_wheel_kd");
  e.takeoff_wheel_slip_band_m_s = m.number("takeoff_wheel_slip_band_m_s");
  e.tyre_slip_stiffness_n_s_m = m.number("tyre_slip_stiffness_n_s_m");
  e.tyre_rolling_radius_ratio = m.number("tyre_rolling_radius_ratio");
  e.takeoff_momentum_kp = m.number("takeoff_momentum_kp");
  e.takeoff_momentum_kd = m.number("takeoff_momentum_kd");
  e.takeoff_momentum_max_nm = m.number("takeoff_momentum_max_nm");
  e.flight_kp = m.number("flight_kp");
  e.flight_kd = m.number("flight_kd");
  e.flight_blend_s = m.number("flight_blend_s");
  e.joint_limit_margin_rad = m.number("joint_limit_margin_rad");
  e.landing_kp = m.number("landing_kp");
  e.landing_kd = m.number("landing_kd");
  e.landing_gravity_feedforward = m.flag("landing_gravity_feedforward");
  e.landing_wheel_decel_m_s2 = m.number("landing_wheel_decel_m_s2");
  e.landing_duration_s = m.number("landing_duration_s");
  e.airborne_debounce_s = m.number("airborne_debounce_s");
  e.max_flight_overrun_s = m.number("max_flight_overrun_s");
  e.touchdown_pitch_placement = m.number("touchdown_pitch_placement");
  e.touchdown_placement_max_rad = m.number("touchdown_placement_max_rad");
  e.touchdown_placement_lead_s = m.number("touchdown_placement_lead_s");
  e.touchdown_placement_band_up_rad = m.number("touchdown_placement_band_up_rad");
  e.touchdown_placement_band_down_rad = m.number("touchdown_placement_band_down_rad");
  e.landing_pitch_limit_rad = m.number("landing_pitch_limit_rad");
  e.landing_nose_down_limit_rad = m.number("landing_nose_down_limit_rad");
  e.landing_pitch_kp = m.number("landing_pitch_kp");
  e.landing_pitch_kd = m.number("landing_pitch_kd");
  e.landing_pitch_max_nm = m.number("landing_pitch_max_nm");
  e.hind_pitch_kp = m.number("hind_pitch_kp");
  e.hind_pitch_kd = m.number("hind_pitch_kd");
  e.hind_pitch_max_nm = m.number("hind_pitch_max_nm");
  e.lifted_pair_margin_rad = m.number("lifted_pair_margin_rad");
  e.two_step_takeoff_kp = m.number("two_step_takeoff_kp");
  e.two_step_takeoff_kd = m.number("two_step_takeoff_kd");
  e.two_step_flight_kp = m.number("two_step_flight_kp");
  e.two_step_flight_kd = m.number("two_step_flight_kd");
  e.two_step_landing_wheel_decel_m_s2 = m.number("two_step_landing_wheel_decel_m_s2");
  m.finish();
  return e;
}

}  // namespace

ExecutorSettings parseExecutorSettings(std::string_view yaml_text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("jump executor settings " + origin +
                             ": cannot parse YAML: " + e.what());
  }
  StrictYamlMap m(root, "", "jump executor settings " + origin);
  const ExecutorSettings e = readFields(m);
  try {
    e.validate();
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument("jump executor settings " + origin + ": " + error.what());
  }
  return e;
}

ExecutorSettings loadExecutorSettings(const std::filesystem::path& yaml_file) {
  const std::optional<std::string> text = readSettingsText(yaml_file);
  if (!text) throw std::runtime_error("jump executor settings: cannot open " + yaml_file.string());
  return parseExecutorSettings(*text, yaml_file.string());
}

}  // namespace wj::sim
