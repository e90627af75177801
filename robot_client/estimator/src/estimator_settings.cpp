#include "estimator/estimator_settings.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace wj::estimation {
namespace {

void requirePositive(double value, const char* field) {
  if (!(value > 0.0) || !std::isfinite(value))
    throw std::invalid_argument(std::string("EstimatorSettings.") + field +
                                " must be finite and > 0, got " + std::to_string(value));
}

void requireNonNegative(double value, const char* field) {
  if (!(value >= 0.0) || !std::isfinite(value))
    throw std::invalid_argument(std::string("EstimatorSettings.") + field +
                                " must be finite and >= 0, got " + std::to_string(value));
}

}  // namespace

void EstimatorSettings::validate() const {
  requirePositive(accel_noise_density, "accel_noise_density");
  requireNonNegative(position_noise_density, "position_noise_density");
  requirePositive(wheel_velocity_std_m_s, "wheel_velocity_std_m_s");
  requirePositive(wheel_height_std_m, "wheel_height_std_m");
  if (!std::isfinite(ground_height_m))
    throw std::invalid_argument("EstimatorSettings.ground_height_m must be finite");
  requirePositive(initial_position_std_m, "initial_position_std_m");
  requirePositive(initial_velocity_std_m_s, "initial_velocity_std_m_s");
  requirePositive(velocity_gate_chi2, "velocity_gate_chi2");
  requirePositive(height_gate_chi2, "height_gate_chi2");
  if (max_consecutive_rejections < 1)
    throw std::invalid_argument("EstimatorSettings.max_consecutive_rejections must be >= 1, got " +
                                std::to_string(max_consecutive_rejections));
  requirePositive(max_velocity_std_m_s, "max_velocity_std_m_s");
  requirePositive(max_speed_m_s, "max_speed_m_s");
  requirePositive(gravity_m_s2, "gravity_m_s2");
}

EstimatorSettings parseEstimatorSettings(std::string_view yaml_text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(origin + ": not valid YAML: " + e.what());
  }
  if (!root.IsMap()) throw std::runtime_error(origin + ": expected a map of estimator settings");
  EstimatorSettings s;
  std::set<std::string> seen;
  const auto read = [&](const char* key, auto& field) {
    const YAML::Node n = root[key];
    if (!n) throw std::runtime_error(origin + ": missing key '" + key + "'");
    try {
      field = n.as<std::remove_reference_t<decltype(field)>>();
    } catch (const YAML::Exception&) {
      throw std::runtime_error(origin + ": key '" + key + "' has the wrong type");
    }
    seen.insert(key);
  };
  read("accel_noise_density", s.accel_noise_density);
  read("position_noise_density", s.position_noise_density);
  read("wheel_velocity_std_m_s", s.wheel_velocity_std_m_s);
  read("wheel_height_std_m", s.wheel_height_std_m);
  read("ground_height_m", s.ground_height_m);
  read("initial_position_std_m", s.initial_position_std_m);
  read("initial_velocity_std_m_s", s.initial_velocity_std_m_s);
  read("velocity_gate_chi2", s.velocity_gate_chi2);
  read("height_gate_chi2", s.height_gate_chi2);
  read("max_consecutive_rejections", s.max_consecutive_rejections);
  read("max_velocity_std_m_s", s.max_velocity_std_m_s);
  read("max_speed_m_s", s.max_speed_m_s);
  read("gravity_m_s2", s.gravity_m_s2);
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (seen.count(key) == 0) throw std::runtime_error(origin + ": unknown key '" + key + "'");
  }
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(origin + ": " + e.what());
  }
  return s;
}

EstimatorSettings loadEstimatorSettings(const std::filesystem::path& yaml_file) {
  std::ifstream in(yaml_file);
  if (!in) throw std::runtime_error(yaml_file.string() + ": cannot open");
  std::ostringstream text;
  text << in.rdbuf();
  return parseEstimatorSettings(text.str(), yaml_file.string());
}

}  // namespace wj::estimation
