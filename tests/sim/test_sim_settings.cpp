// Settings of the simulation: YAML loading (strict keys), validation and terrain helpers.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "error_of.h"
#include "sim/settings.h"
#include "text_edit.h"

namespace wj::sim {
namespace {

using wj::test::replaceFirst;

std::string shippedYaml() {
  std::ifstream in(std::filesystem::path(WJ_SIM_CONFIG_DIR) / "sim_settings.yaml");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(SimSettings, ShippedFileEqualsDefaults) {
  const SimSettings d;
  const SimSettings s =
      loadSimSettings(std::filesystem::path(WJ_SIM_CONFIG_DIR) / "sim_settings.yaml");
  EXPECT_EQ(s.control_period_s, d.control_period_s);
  EXPECT_EQ(s.gravity_m_s2, d.gravity_m_s2);
  EXPECT_EQ(s.actuator_update, d.actuator_update);
  EXPECT_EQ(s.contact.stiffness_pa, d.contact.stiffness_pa);
  EXPECT_EQ(s.contact.dissipation_s_m, d.contact.dissipation_s_m);
  EXPECT_EQ(s.contact.static_friction, d.contact.static_friction);
  EXPECT_EQ(s.contact.dynamic_friction, d.contact.dynamic_friction);
  EXPECT_EQ(s.contact.viscous_friction_s_m, d.contact.viscous_friction_s_m);
  EXPECT_EQ(s.contact.transition_velocity_m_s, d.contact.transition_velocity_m_s);
  EXPECT_EQ(s.contact.wheel_shape, d.contact.wheel_shape);
  EXPECT_EQ(s.contact.base_sphere_radius_m, d.contact.base_sphere_radius_m);
  EXPECT_EQ(s.contact.body_sphere_radius_m, d.contact.body_sphere_radius_m);
  EXPECT_EQ(s.integrator.kind, d.integrator.kind);
  EXPECT_EQ(s.integrator.accuracy, d.integrator.accuracy);
  EXPECT_EQ(s.integrator.max_step_s, d.integrator.max_step_s);
  EXPECT_EQ(s.noise.enabled, d.noise.enabled);
  EXPECT_EQ(s.noise.seed, d.noise.seed);
  EXPECT_EQ(s.noise.joint_position_rad, d.noise.joint_position_rad);
  EXPECT_EQ(s.noise.joint_velocity_rad_s, d.noise.joint_velocity_rad_s);
  EXPECT_EQ(s.noise.joint_torque_nm, d.noise.joint_torque_nm);
  EXPECT_EQ(s.noise.gyro_rad_s, d.noise.gyro_rad_s);
  EXPECT_EQ(s.noise.accel_m_s2, d.noise.accel_m_s2);
  EXPECT_EQ(s.noise.orientation_rad, d.noise.orientation_rad);
  EXPECT_EQ(s.terrain.has_ground, d.terrain.has_ground);
  EXPECT_EQ(s.terrain.slope_rad, d.terrain.slope_rad);
  EXPECT_TRUE(s.terrain.boxes.empty());
}

TEST(SimSettings, ParsesEnumsAndBoxes) {
  std::string yaml = shippedYaml();
  yaml = replaceFirst(yaml, "kind: semi_explicit_euler ", "kind: runge_kutta_merson ");
  yaml = replaceFirst(yaml, "wheel_shape: sphere", "wheel_shape: ellipsoid");
  yaml = replaceFirst(yaml, "actuator_update: continuous", "actuator_update: zero_order_hold");
  yaml = replaceFirst(yaml, "boxes: []",
                      "boxes:\n    - {min: [0.5, -2, -1], max: [0.6, 2, 0.25], obstacle: true}");
  const SimSettings s = parseSimSettings(yaml);
  EXPECT_EQ(s.integrator.kind, IntegratorKind::RungeKuttaMerson);
  EXPECT_EQ(s.contact.wheel_shape, WheelShape::Ellipsoid);
  EXPECT_EQ(s.actuator_update, ActuatorUpdate::ZeroOrderHold);
  ASSERT_EQ(s.terrain.boxes.size(), 1u);
  EXPECT_EQ(s.terrain.boxes[0].max.z(), 0.25);
  EXPECT_TRUE(s.terrain.boxes[0].obstacle);
}

TEST(SimSettings, RejectsUnknownMissingAndBadKeys) {
  const std::string yaml = shippedYaml();
  const auto message = [](const std::string& text) {
    return test::errorOf<std::runtime_error>([&] { return parseSimSettings(text, "test.yaml"); });
  };
  // A misspelled key is unknown (and the real one missing): never silently defaulted.
  EXPECT_THAT(message(replaceFirst(yaml, "stiffness_pa:", "stifness_pa:")),
              test::HasSubstr("stifness_pa"));
  EXPECT_THAT(message(replaceFirst(yaml, "  seed: 1\n", "")),
              test::HasSubstr("missing key 'noise.seed'"));
  EXPECT_THAT(message(replaceFirst(yaml, "wheel_shape: sphere", "wheel_shape: torus")),
              test::HasSubstr("torus"));
  EXPECT_THAT(message(replaceFirst(yaml, "accuracy: 0.02", "accuracy: -1")),
              test::HasSubstr("accuracy"));
  EXPECT_THAT(message(replaceFirst(yaml, "max_step_s: 0.001", "max_step_s: 0.01")),
              test::HasSubstr("max_step_s"));
  EXPECT_THAT(message(yaml + "extra: 1\n"), test::HasSubstr("unknown key 'extra'"));
  EXPECT_THAT(message("[1, 2]"), test::HasSubstr("expected a map"));
}

TEST(Terrain, HeightAndFactories) {
  EXPECT_EQ(Terrain::flat().heightAt(3.0, 1.0), 0.0);
  EXPECT_TRUE(std::isinf(Terrain::none().heightAt(0.0, 0.0)));
  EXPECT_NEAR(Terrain::slope(0.3).heightAt(2.0, 0.0), 2.0 * std::tan(0.3), 1e-12);
  const Terrain step = Terrain::step(1.0, 0.1);
  EXPECT_EQ(step.heightAt(0.9, 0.0), 0.0);
  EXPECT_EQ(step.heightAt(1.1, 5.0), 0.1);
  EXPECT_FALSE(step.boxes[0].obstacle);
  const Terrain wall = Terrain::wall(0.5, 0.6, 0.25);
  EXPECT_EQ(wall.heightAt(0.55, 0.0), 0.25);
  EXPECT_EQ(wall.heightAt(0.65, 0.0), 0.0);
  EXPECT_TRUE(wall.boxes[0].obstacle);
}

}  // namespace
}  // namespace wj::sim
