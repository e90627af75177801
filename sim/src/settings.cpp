#include "sim/settings.h"

#include "robot_model/strict_yaml.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <set>
#include <stdexcept>

namespace wj::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Lateral and far extent of "unbounded" boxes (walls across the whole world, steps that go on).
constexpr double kFar = 1.0e3;
// How deep boxes reach below the ground, so that no seam opens between box and ground.
constexpr double kBuried = 1.0;

// A YAML map whose keys must all be read exactly once (robot_model/strict_yaml.h).
using StrictMap = StrictYamlMap;

template <class Enum, std::size_t N>
Enum parseEnum(StrictMap& map, const std::string& key, const std::array<Enum, N>& values) {
  const std::string text = map.text(key);
  std::string allowed;
  for (const Enum v : values) {
    if (text == toString(v)) return v;
    allowed += (allowed.empty() ? "" : ", ") + std::string(toString(v));
  }
  map.fail("key '" + key + "': '" + text + "' is not one of " + allowed);
}

Eigen::Vector3d parseVector3(StrictMap& map, const YAML::Node& node, const std::string& key) {
  if (!node.IsSequence() || node.size() != 3) map.fail("key '" + key + "' needs 3 numbers");
  return {node[0].as<double>(), node[1].as<double>(), node[2].as<double>()};
}

void requirePositive(double v, const char* name) {
  if (!(v > 0.0) || !std::isfinite(v))
    throw std::invalid_argument(std::string("sim settings: ") + name +
                                " must be finite and > 0, got " + std::to_string(v));
}

void requireNonNegative(double v, const char* name) {
  if (!(v >= 0.0) || !std::isfinite(v))
    throw std::invalid_argument(std::string("sim settings: ") + name +
                                " must be finite and >= 0, got " + std::to_string(v));
}

}  // namespace

//==============================================================================================
Terrain Terrain::flat() {
  return Terrain{};
}

Terrain Terrain::none() {
  Terrain t;
  t.has_ground = false;
  return t;
}

Terrain Terrain::slope(double slope_rad) {
  Terrain t;
  t.slope_rad = slope_rad;
  return t;
}

Terrain Terrain::step(double x_m, double height_m) {
  Terrain t;
  t.boxes.push_back({{x_m, -kFar, -kBuried}, {x_m + kFar, kFar, height_m}, false});
  return t;
}

Terrain Terrain::wall(double x_min_m, double x_max_m, double height_m) {
  Terrain t;
  t.boxes.push_back({{x_min_m, -kFar, -kBuried}, {x_max_m, kFar, height_m}, true});
  return t;
}

Terrain Terrain::platform(double x_min_m, double x_max_m, double height_m) {
  Terrain t;
  t.boxes.push_back({{x_min_m, -kFar, -kBuried}, {x_max_m, kFar, height_m}, false});
  return t;
}

double Terrain::heightAt(double x, double y) const {
  double h = has_ground ? x * std::tan(slope_rad) : -kInf;
  for (const Box& b : boxes)
    if (x >= b.min.x() && x <= b.max.x() && y >= b.min.y() && y <= b.max.y())
      h = std::max(h, b.max.z());
  return h;
}

void SimSettings::validate() const {
  requirePositive(control_period_s, "control_period_s");
  requireNonNegative(gravity_m_s2, "gravity_m_s2");
  requirePositive(contact.stiffness_pa, "contact.stiffness_pa");
  requireNonNegative(contact.dissipation_s_m, "contact.dissipation_s_m");
  requireNonNegative(contact.dynamic_friction, "contact.dynamic_friction");
  requireNonNegative(contact.viscous_friction_s_m, "contact.viscous_friction_s_m");
  if (contact.static_friction < contact.dynamic_friction)
    throw std::invalid_argument(
        "sim settings: contact.static_friction must be >= dynamic_friction");
  requirePositive(contact.transition_velocity_m_s, "contact.transition_velocity_m_s");
  requirePositive(contact.base_sphere_radius_m, "contact.base_sphere_radius_m");
  requirePositive(contact.body_sphere_radius_m, "contact.body_sphere_radius_m");
  requirePositive(integrator.accuracy, "integrator.accuracy");
  requirePositive(integrator.max_step_s, "integrator.max_step_s");
  if (integrator.max_step_s > control_period_s)
    throw std::invalid_argument(
        "sim settings: integrator.max_step_s must not exceed "
        "control_period_s");
  for (const double sigma :
       {noise.joint_position_rad, noise.joint_velocity_rad_s, noise.joint_torque_nm,
        noise.gyro_rad_s, noise.accel_m_s2, noise.orientation_rad})
    requireNonNegative(sigma, "noise standard deviations");
  if (!(std::abs(terrain.slope_rad) < 1.2))
    throw std::invalid_argument("sim settings: terrain.slope_rad must be within +-1.2 rad");
  plant.validate();
  for (const Box& b : terrain.boxes)
    if (!(b.min.array() < b.max.array()).all())
      throw std::invalid_argument("sim settings: every terrain box needs min < max");
}

SimSettings applyPlant(const SimSettings& nominal, const PlantSettings& plant) {
  plant.validate();
  SimSettings s = nominal;
  s.plant = plant;
  const double ratio = nominal.contact.dynamic_friction > 0.0
                           ? nominal.contact.static_friction / nominal.contact.dynamic_friction
                           : 1.0;
  s.contact.dynamic_friction = plant.friction;
  s.contact.static_friction = plant.friction * ratio;
  double near_face = kInf;  // nearest obstacle's near face after the shift
  for (Box& b : s.terrain.boxes) {
    if (!b.obstacle) continue;
    b.min.x() += plant.wall_position_error_m;
    b.max.x() += plant.wall_position_error_m;
    near_face = std::min(near_face, b.min.x());
  }
  if (plant.ground_height_m != 0.0) {
    if (!s.terrain.has_ground || s.terrain.slope_rad != 0.0)
      throw std::invalid_argument(
          "plant settings: ground_height_m needs flat ground in the scenario");
    const double h = plant.ground_height_m;
    const double x_end = std::isfinite(near_face) ? near_face : kFar;  // take-off side ends
    if (h > 0.0) {
      // The take-off side raised on a box (terrain, not an obstacle).
      s.terrain.boxes.push_back({{-kFar, -kFar, -kBuried}, {x_end, kFar, h}, false});
    } else {
      // The take-off side sunk: no ground plane; boxes carry both sides.
      s.terrain.has_ground = false;
      s.terrain.boxes.push_back({{-kFar, -kFar, h - kBuried}, {x_end, kFar, h}, false});
      if (x_end < kFar)
        s.terrain.boxes.push_back({{x_end, -kFar, -kBuried}, {kFar, kFar, 0.0}, false});
    }
  }
  s.validate();
  return s;
}

std::string_view toString(WheelShape shape) {
  switch (shape) {
    case WheelShape::Sphere:
      return "sphere";
    case WheelShape::Ellipsoid:
      return "ellipsoid";
  }
  return "?";
}

std::string_view toString(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::SemiExplicitEuler:
      return "semi_explicit_euler";
    case IntegratorKind::SemiExplicitEuler2:
      return "semi_explicit_euler2";
    case IntegratorKind::RungeKutta3:
      return "runge_kutta3";
    case IntegratorKind::RungeKuttaMerson:
      return "runge_kutta_merson";
    case IntegratorKind::SemiExplicitEulerSimbody:
      return "semi_explicit_euler_simbody";
  }
  return "?";
}

std::string_view toString(ActuatorUpdate update) {
  switch (update) {
    case ActuatorUpdate::Continuous:
      return "continuous";
    case ActuatorUpdate::ZeroOrderHold:
      return "zero_order_hold";
  }
  return "?";
}

SimSettings parseSimSettings(std::string_view yaml_text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(yaml_text));
  } catch (const std::exception& e) {
    throw std::runtime_error("sim settings " + origin + ": cannot parse YAML: " + e.what());
  }
  SimSettings s;
  try {
    StrictMap top(root, "", "sim settings " + origin);
    s.control_period_s = top.number("control_period_s");
    s.gravity_m_s2 = top.number("gravity_m_s2");
    s.actuator_update =
        parseEnum(top, "actuator_update",
                  std::array{ActuatorUpdate::Continuous, ActuatorUpdate::ZeroOrderHold});

    StrictMap c = top.map("contact");
    s.contact.stiffness_pa = c.number("stiffness_pa");
    s.contact.dissipation_s_m = c.number("dissipation_s_m");
    s.contact.static_friction = c.number("static_friction");
    s.contact.dynamic_friction = c.number("dynamic_friction");
    s.contact.viscous_friction_s_m = c.number("viscous_friction_s_m");
    s.contact.transition_velocity_m_s = c.number("transition_velocity_m_s");
    s.contact.wheel_shape =
        parseEnum(c, "wheel_shape", std::array{WheelShape::Sphere, WheelShape::Ellipsoid});
    s.contact.base_sphere_radius_m = c.number("base_sphere_radius_m");
    s.contact.body_sphere_radius_m = c.number("body_sphere_radius_m");
    c.finish();

    StrictMap i = top.map("integrator");
    s.integrator.kind =
        parseEnum(i, "kind",
                  std::array{IntegratorKind::SemiExplicitEuler, IntegratorKind::SemiExplicitEuler2,
                             IntegratorKind::RungeKutta3, IntegratorKind::RungeKuttaMerson,
                             IntegratorKind::SemiExplicitEulerSimbody});
    s.integrator.accuracy = i.number("accuracy");
    s.integrator.max_step_s = i.number("max_step_s");
    i.finish();

    StrictMap n = top.map("noise");
    s.noise.enabled = n.flag("enabled");
    s.noise.seed = n.unsignedInt("seed");
    s.noise.joint_position_rad = n.number("joint_position_rad");
    s.noise.joint_velocity_rad_s = n.number("joint_velocity_rad_s");
    s.noise.joint_torque_nm = n.number("joint_torque_nm");
    s.noise.gyro_rad_s = n.number("gyro_rad_s");
    s.noise.accel_m_s2 = n.number("accel_m_s2");
    s.noise.orientation_rad = n.number("orientation_rad");
    n.finish();

    StrictMap t = top.map("terrain");
    s.terrain.has_ground = t.flag("has_ground");
    s.terrain.slope_rad = t.number("slope_rad");
    const YAML::Node boxes = t.node("boxes");
    if (!boxes.IsSequence()) t.fail("key 'terrain.boxes' must be a list");
    s.terrain.boxes.clear();
    for (std::size_t k = 0; k < boxes.size(); ++k) {
      StrictMap b(boxes[k], "terrain.boxes[" + std::to_string(k) + "].", "sim settings " + origin);
      Box box;
      box.min = parseVector3(b, b.node("min"), "min");
      box.max = parseVector3(b, b.node("max"), "max");
      box.obstacle = b.flag("obstacle");
      b.finish();
      s.terrain.boxes.push_back(box);
    }
    t.finish();
    top.finish();
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("sim settings " + origin + ": bad value: " + e.what());
  }
  try {
    s.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(origin + ": " + e.what());
  }
  return s;
}

SimSettings loadSimSettings(const std::filesystem::path& yaml_file) {
  const std::optional<std::string> text = readSettingsText(yaml_file);
  if (!text) throw std::runtime_error("sim settings: cannot open " + yaml_file.string());
  return parseSimSettings(*text, yaml_file.string());
}

}  // namespace wj::sim
