// The plant that differs from the model (issue 18): the strict plant file, and each
// perturbation of the simulated robot against a closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include "error_of.h"
#include "sim/plant.h"
#include "sim/reference_plans.h"
#include "sim/sim_robot.h"
#include "sim/statics.h"

namespace wj::sim {
namespace {

model::RobotModel loadRobot() {
  const std::filesystem::path dir = WJ_MODELS_DIR;
  return model::RobotModel::load(dir / "wheeljump.urdf", dir / "actuators.yaml");
}

constexpr double kG = 9.81;

TEST(Plant, EmptyFileIsTheNominalPlantAndEveryKeyIsOptional) {
  EXPECT_TRUE(parsePlantSettings("").nominal());
  EXPECT_TRUE(parsePlantSettings("{}").nominal());
  const PlantSettings p = parsePlantSettings("friction: 0.5\npayload: {mass_kg: 1.5}\n");
  EXPECT_EQ(p.friction, 0.5);
  EXPECT_EQ(p.payload.mass_kg, 1.5);
  EXPECT_TRUE(p.payload.offset_m.isZero());
  EXPECT_EQ(p.torque_scale, 1.0);
  EXPECT_FALSE(p.nominal());
}

TEST(Plant, YamlRoundTripKeepsEveryValue) {
  PlantSettings p;
  p.payload = {1.25, {0.1, -0.05, 0.02}};
  p.link_mass_scale = 1.03;
  p.friction = 0.55;
  p.torque_scale = 0.93;
  p.corner_speed_scale = 1.07;
  p.motor_latency_s = 0.0013;
  p.imu_gyro_bias_rad_s = {0.01, -0.02, 0.003};
  p.imu_accel_bias_m_s2 = {0.1, 0.0, -0.2};
  p.wall_position_error_m = -0.07;
  p.range_bias_m = 0.07;
  p.ground_height_m = 0.02;
  const PlantSettings q = parsePlantSettings(toYaml(p));
  EXPECT_EQ(q.payload.mass_kg, p.payload.mass_kg);
  EXPECT_EQ(q.payload.offset_m, p.payload.offset_m);
  EXPECT_EQ(q.link_mass_scale, p.link_mass_scale);
  EXPECT_EQ(q.friction, p.friction);
  EXPECT_EQ(q.torque_scale, p.torque_scale);
  EXPECT_EQ(q.corner_speed_scale, p.corner_speed_scale);
  EXPECT_EQ(q.motor_latency_s, p.motor_latency_s);
  EXPECT_EQ(q.imu_gyro_bias_rad_s, p.imu_gyro_bias_rad_s);
  EXPECT_EQ(q.imu_accel_bias_m_s2, p.imu_accel_bias_m_s2);
  EXPECT_EQ(q.wall_position_error_m, p.wall_position_error_m);
  EXPECT_EQ(q.range_bias_m, p.range_bias_m);
  EXPECT_EQ(q.ground_height_m, p.ground_height_m);
}

TEST(Plant, BadValuesAreRefusedWithTheKeyAndItsRange) {
  const auto message = [](const std::string& yaml) -> std::string {
    return test::errorOf([&] { return parsePlantSettings(yaml, "p.yaml"); });
  };
  EXPECT_THAT(message("payload: {mass_kg: -1}"),
              test::HasSubstr("payload.mass_kg must be in [0, 10]"));
  EXPECT_THAT(message("friction: 3"), test::HasSubstr("friction must be in [0.1, 2]"));
  EXPECT_THAT(message("friction: .nan"), test::HasSubstr("friction must be in [0.1, 2]"));
  EXPECT_THAT(message("motor_latency_s: -0.001"), test::HasSubstr("motor_latency_s"));
  EXPECT_THAT(message("imu_gyro_bias_rad_s: [0, 0, 1]"), test::HasSubstr("imu_gyro_bias_rad_s[2]"));
  EXPECT_THAT(message("frictoin: 0.5"), test::HasSubstr("unknown key 'frictoin'"));
  EXPECT_THAT(message("payload: {mass: 1}"), test::HasSubstr("unknown key 'payload.mass'"));
  EXPECT_THAT(message("imu_gyro_bias_rad_s: [0, 0]"), test::HasSubstr("needs 3 numbers"));
  EXPECT_THAT(message("torque_scale: fast"), test::HasSubstr("wrong type"));
  EXPECT_THAT(message("range_bias_m: 1.5"), test::HasSubstr("range_bias_m must be in [-1, 1]"));
}

TEST(Plant, PayloadAndLinkMassesMoveTheMassAndCentreOfMassAsTheirSum) {
  const model::RobotModel m = loadRobot();
  const JointVector q = standingPosture(m, 0.33);
  const model::Inertia nominal = m.calcCompositeInertia(q);
  SimSettings s;
  s.terrain = Terrain::none();
  s.plant.link_mass_scale = 1.04;
  s.plant.payload = {1.7, {0.12, -0.05, 0.06}};
  SimRobot robot(m, s);
  RobotPlacement p;
  p.q = q;
  robot.reset(p);
  const model::Inertia got = robot.calcCompositeInertia();
  const double scaled = 1.04 * nominal.mass;
  EXPECT_NEAR(got.mass, scaled + 1.7, 1e-9);
  // Scaling every link keeps the centre of mass; the payload pulls it by its share.
  const Eigen::Vector3d com =
      (scaled * nominal.com + 1.7 * Eigen::Vector3d(0.12, -0.05, 0.06)) / (scaled + 1.7);
  EXPECT_LT((got.com - com).norm(), 1e-9);
  // Inertia: the scaled robot's plus the two point masses' parallel-axis terms.
  const auto shift = [](double mass, const Eigen::Vector3d& d) -> Eigen::Matrix3d {
    return mass * (d.squaredNorm() * Eigen::Matrix3d::Identity() - d * d.transpose());
  };
  const Eigen::Matrix3d I = 1.04 * nominal.inertia_com + shift(scaled, nominal.com - com) +
                            shift(1.7, Eigen::Vector3d(0.12, -0.05, 0.06) - com);
  EXPECT_LT((got.inertia_com - I).norm(), 1e-9);
}

TEST(Plant, FrictionSetsTheSlidingForce) {
  // Sliding sideways faster than three transition speeds: Simbody's Stribeck curve gives
  // exactly mu_d, here the plant's friction.
  const model::RobotModel m = loadRobot();
  PlantSettings plant;
  plant.friction = 0.45;
  const SimSettings s = applyPlant(SimSettings{}, plant);
  EXPECT_NEAR(s.contact.static_friction, 0.45 * 0.9 / 0.7, 1e-12);
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  RobotPlacement p;
  p.q = q;
  p.X_WB.translation().z() = calcStandingStatics(m, q, kG).base_height_m - 1.3e-3;
  p.v_WB = Eigen::Vector3d(0.0, 1.3, 0.0);
  robot.reset(p);
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  for (const auto& w : gt.wheels) {
    ASSERT_TRUE(w.in_contact);
    ASSERT_GT(w.force_W.z(), 10.0);
    EXPECT_NEAR(-w.force_W.y() / w.force_W.z(), 0.45, 5e-3);
  }
}

TEST(Plant, TorqueAndCornerSpeedScaleTheEnvelope) {
  const model::RobotModel m = loadRobot();
  SimSettings s;
  s.terrain = Terrain::none();
  s.plant.torque_scale = 0.9;
  s.plant.corner_speed_scale = 1.1;
  SimRobot robot(m, s);
  RobotPlacement p;
  p.q = standingPosture(m, 0.36);
  const int wheel = model::jointIndex(model::Leg::LF, model::JointKind::Wheel);
  const int knee = model::jointIndex(model::Leg::LF, model::JointKind::KFE);
  const model::ActuatorEnvelope& e = m.joints()[wheel].actuator;
  // Wheel between the scaled corner speed and the no-load speed, knee at rest.
  const double w = 0.5 * (1.1 * e.corner_speed_rad_s + e.no_load_speed_rad_s);
  p.qd[wheel] = w;
  robot.reset(p);
  model::JointCommands c{};
  c[wheel].tau_ff = 1e3;
  c[knee].tau_ff = -1e3;
  robot.write(c);
  model::SensorData sensors;
  robot.read(sensors);
  const double limit = 0.9 * e.peak_torque_nm * (e.no_load_speed_rad_s - w) /
                       (e.no_load_speed_rad_s - 1.1 * e.corner_speed_rad_s);
  EXPECT_NEAR(sensors.joints[wheel].tau, limit, 1e-9);
  EXPECT_NEAR(sensors.joints[knee].tau, -0.9 * m.joints()[knee].actuator.peak_torque_nm, 1e-9);
}

// Wheel speed of LF after `periods` periods of a torque step written at t = 0, in free space.
double wheelSpeedAfterStep(const model::RobotModel& m, double latency_s, int periods) {
  SimSettings s;
  s.terrain = Terrain::none();
  s.gravity_m_s2 = 0.0;
  s.plant.motor_latency_s = latency_s;
  SimRobot robot(m, s);
  RobotPlacement p;
  p.q = standingPosture(m, 0.36);
  robot.reset(p);
  model::JointCommands c{};
  c[model::jointIndex(model::Leg::LF, model::JointKind::Wheel)].tau_ff = 0.5;
  for (int k = 0; k < periods; ++k) {
    robot.write(c);
    robot.advance();
  }
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  return gt.qd[model::jointIndex(model::Leg::LF, model::JointKind::Wheel)];
}

TEST(Plant, MotorLatencyDelaysATorqueStepByTheSetTime) {
  // From rest a constant torque spins the wheel up at a constant rate (the rest of the robot
  // barely moves in 10 ms): the speed after T is rate * (T - latency), fractional periods
  // included.
  const model::RobotModel m = loadRobot();
  const double v0 = wheelSpeedAfterStep(m, 0.0, 10);
  ASSERT_GT(v0, 0.0);
  for (const double latency : {0.001, 0.0015, 0.0042}) {
    const double v = wheelSpeedAfterStep(m, latency, 10);
    EXPECT_NEAR(v, v0 * (0.010 - latency) / 0.010, 0.01 * v0) << latency;
  }
  // Nothing acts before the latency has passed.
  EXPECT_EQ(wheelSpeedAfterStep(m, 0.0042, 4), 0.0);
}

TEST(Plant, ImuBiasesAddToTheReadings) {
  const model::RobotModel m = loadRobot();
  SimSettings s;
  s.terrain = Terrain::none();
  s.plant.imu_gyro_bias_rad_s = {0.02, -0.01, 0.005};
  s.plant.imu_accel_bias_m_s2 = {0.1, 0.2, -0.3};
  SimRobot robot(m, s);
  RobotPlacement p;
  p.q = standingPosture(m, 0.36);
  robot.reset(p);
  robot.advance();
  robot.advance();
  model::SensorData sensors;
  robot.read(sensors);
  // Free fall without rotation: the gyro reads its bias, the accelerometer (specific force) too.
  EXPECT_LT((sensors.imu.omega_B - s.plant.imu_gyro_bias_rad_s).norm(), 1e-9);
  EXPECT_LT((sensors.imu.accel_B - s.plant.imu_accel_bias_m_s2).norm(), 1e-6);
}

TEST(Plant, WallErrorMovesTheObstacleAndGroundHeightRaisesTheTakeoffSide) {
  const SimSettings nominal = [] {
    SimSettings s;
    s.terrain = Terrain::wall(6.0, 6.1, 0.25);
    return s;
  }();
  PlantSettings plant;
  plant.wall_position_error_m = 0.08;
  plant.ground_height_m = 0.03;
  SimSettings s = applyPlant(nominal, plant);
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(6.05, 0.0), 0.03);  // the wall starts at 6.08 now
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(6.1, 0.0), 0.25);
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(6.2, 0.0), 0.0);  // landing side
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(2.0, 0.0), 0.03);
  plant.ground_height_m = -0.04;
  s = applyPlant(nominal, plant);
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(2.0, 0.0), -0.04);
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(6.1, 0.0), 0.25);
  EXPECT_DOUBLE_EQ(s.terrain.heightAt(7.0, 0.0), 0.0);
  // The robot stands on the sunk take-off side as on the ground, 4 cm lower.
  const model::RobotModel m = loadRobot();
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  const StandingStatics st = calcStandingStatics(m, q, kG);
  RobotPlacement p;
  p.q = q;
  p.X_WB.translation() = Eigen::Vector3d(2.0, 0.0, st.base_height_m - 0.04);
  robot.reset(p);
  model::JointCommands c{};
  for (int j = 0; j < model::kNumJoints; ++j)
    c[j] = model::isWheel(j) ? model::JointCommand{0.0, 0.0, 0.0, 1.0, 0.0}
                             : model::JointCommand{q[j], 0.0, 400.0, 8.0, st.tau[j]};
  for (int k = 0; k < 500; ++k) {
    robot.write(c);
    robot.advance();
  }
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  EXPECT_NEAR(gt.X_WB.translation().z(), st.base_height_m - 0.04, 3e-3);
  EXPECT_FALSE(gt.base_in_contact);
}

}  // namespace
}  // namespace wj::sim
