#include "sim/plant.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "robot_model/strict_yaml.h"

namespace wj::sim {

namespace {

void inRange(double v, double lo, double hi, const std::string& key) {
  if (std::isfinite(v) && v >= lo && v <= hi) return;
  std::ostringstream m;
  m << "plant settings: " << key << " must be in [" << lo << ", " << hi << "], got " << v;
  throw std::invalid_argument(m.str());
}

void inRange(const Eigen::Vector3d& v, double lo, double hi, const std::string& key) {
  for (int a = 0; a < 3; ++a) inRange(v[a], lo, hi, key + "[" + std::to_string(a) + "]");
}

// Reads `key` into `out` if present.
void optional(StrictYamlMap& m, const std::string& key, double& out) {
  if (m.has(key)) out = m.number(key);
}

void optional(StrictYamlMap& m, const std::string& key, Eigen::Vector3d& out) {
  if (!m.has(key)) return;
  const YAML::Node n = m.node(key);
  if (!n.IsSequence() || n.size() != 3) m.fail("key '" + key + "' needs 3 numbers");
  try {
    out = {n[0].as<double>(), n[1].as<double>(), n[2].as<double>()};
  } catch (const YAML::Exception&) {
    m.fail("key '" + key + "' needs 3 numbers");
  }
}

std::string vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << std::setprecision(17) << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  return s.str();
}

}  // namespace

bool PlantSettings::nominal() const {
  return payload.mass_kg == 0.0 && link_mass_scale == 1.0 && friction == PlantSettings{}.friction &&
         torque_scale == 1.0 && corner_speed_scale == 1.0 && motor_latency_s == 0.0 &&
         imu_gyro_bias_rad_s.isZero(0.0) && imu_accel_bias_m_s2.isZero(0.0) &&
         wall_position_error_m == 0.0 && range_bias_m == 0.0 && ground_height_m == 0.0;
}

void PlantSettings::validate() const {
  inRange(payload.mass_kg, 0.0, 10.0, "payload.mass_kg");
  inRange(payload.offset_m, -1.0, 1.0, "payload.offset_m");
  inRange(link_mass_scale, 0.5, 1.5, "link_mass_scale");
  inRange(friction, 0.1, 2.0, "friction");
  inRange(torque_scale, 0.1, 2.0, "torque_scale");
  inRange(corner_speed_scale, 0.1, 1.9, "corner_speed_scale");
  inRange(motor_latency_s, 0.0, 0.05, "motor_latency_s");
  inRange(imu_gyro_bias_rad_s, -0.5, 0.5, "imu_gyro_bias_rad_s");
  inRange(imu_accel_bias_m_s2, -2.0, 2.0, "imu_accel_bias_m_s2");
  inRange(wall_position_error_m, -1.0, 1.0, "wall_position_error_m");
  inRange(range_bias_m, -1.0, 1.0, "range_bias_m");
  inRange(ground_height_m, -0.2, 0.2, "ground_height_m");
}

PlantSettings parsePlantSettings(std::string_view yaml_text, const std::string& origin) {
  YAML::Node root_node;
  try {
    root_node = YAML::Load(std::string(yaml_text));
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("plant settings " + origin + ": cannot parse YAML: " + e.what());
  }
  PlantSettings p;
  if (root_node.IsNull()) return p;  // an empty file: the nominal plant
  StrictYamlMap root(root_node, "", "plant settings " + origin);
  if (root.has("payload")) {
    StrictYamlMap m = root.map("payload");
    optional(m, "mass_kg", p.payload.mass_kg);
    optional(m, "offset_m", p.payload.offset_m);
    m.finish();
  }
  optional(root, "link_mass_scale", p.link_mass_scale);
  optional(root, "friction", p.friction);
  optional(root, "torque_scale", p.torque_scale);
  optional(root, "corner_speed_scale", p.corner_speed_scale);
  optional(root, "motor_latency_s", p.motor_latency_s);
  optional(root, "imu_gyro_bias_rad_s", p.imu_gyro_bias_rad_s);
  optional(root, "imu_accel_bias_m_s2", p.imu_accel_bias_m_s2);
  optional(root, "wall_position_error_m", p.wall_position_error_m);
  optional(root, "range_bias_m", p.range_bias_m);
  optional(root, "ground_height_m", p.ground_height_m);
  root.finish();
  p.validate();
  return p;
}

PlantSettings loadPlantSettings(const std::filesystem::path& yaml_file) {
  const std::optional<std::string> text = readSettingsText(yaml_file);
  if (!text) throw std::runtime_error("cannot read plant settings " + yaml_file.string());
  return parsePlantSettings(*text, yaml_file.string());
}

std::string toYaml(const PlantSettings& p) {
  std::ostringstream s;
  s << std::setprecision(17);
  s << "payload: {mass_kg: " << p.payload.mass_kg << ", offset_m: " << vec(p.payload.offset_m)
    << "}\n"
    << "link_mass_scale: " << p.link_mass_scale << "\n"
    << "friction: " << p.friction << "\n"
    << "torque_scale: " << p.torque_scale << "\n"
    << "corner_speed_scale: " << p.corner_speed_scale << "\n"
    << "motor_latency_s: " << p.motor_latency_s << "\n"
    << "imu_gyro_bias_rad_s: " << vec(p.imu_gyro_bias_rad_s) << "\n"
    << "imu_accel_bias_m_s2: " << vec(p.imu_accel_bias_m_s2) << "\n"
    << "wall_position_error_m: " << p.wall_position_error_m << "\n"
    << "range_bias_m: " << p.range_bias_m << "\n"
    << "ground_height_m: " << p.ground_height_m << "\n";
  return s.str();
}

model::Inertia scaleInertia(const model::Inertia& link, double scale) {
  model::Inertia out = link;
  out.mass *= scale;
  out.inertia_com *= scale;
  return out;
}

model::Inertia addPointMass(const model::Inertia& body, const Payload& payload) {
  if (!(payload.mass_kg > 0.0)) return body;
  const double m = body.mass + payload.mass_kg;
  model::Inertia out;
  out.mass = m;
  out.com = (body.mass * body.com + payload.mass_kg * payload.offset_m) / m;
  // Parallel axis: each part's inertia about the new CoM, I + m (|d|^2 E - d d^T).
  const auto shift = [](double mass, const Eigen::Vector3d& d) {
    return mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  };
  out.inertia_com = body.inertia_com + shift(body.mass, body.com - out.com) +
                    shift(payload.mass_kg, payload.offset_m - out.com);
  return out;
}

model::ActuatorEnvelope scaleEnvelope(const model::ActuatorEnvelope& envelope, double torque_scale,
                                      double speed_scale) {
  model::ActuatorEnvelope out = envelope;
  out.peak_torque_nm *= torque_scale;
  out.corner_speed_rad_s *= speed_scale;
  return out;
}

}  // namespace wj::sim
