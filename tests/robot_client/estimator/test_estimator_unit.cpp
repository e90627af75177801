// State estimator without the simulator: settings, leg kinematics against RobotModel and
// finite differences, the measurement of a rolling robot built in closed form, allocation.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include "error_of.h"
#include "estimator/state_estimator.h"

// Counts heap allocations of the whole process by interposing glibc's malloc, to check that
// update() does not allocate.
extern "C" void* __libc_malloc(std::size_t size);
namespace {
std::atomic<std::int64_t> g_malloc_calls{0};
}
extern "C" void* malloc(std::size_t size) noexcept {
  g_malloc_calls.fetch_add(1, std::memory_order_relaxed);
  return __libc_malloc(size);
}

namespace wj::estimation {
namespace {

using model::JointKind;
using model::Leg;

model::RobotModel loadRobot() {
  const std::filesystem::path dir = WJ_MODELS_DIR;
  return model::RobotModel::load(dir / "wheeljump.urdf", dir / "actuators.yaml");
}

// A crouched posture: HFE forward, knee bent back, small abduction.
model::JointMeasurements posture(double haa = 0.05) {
  model::JointMeasurements j{};
  for (const Leg leg : model::kLegs) {
    j[model::jointIndex(leg, JointKind::HAA)].q = haa * model::lateralSign(leg);
    j[model::jointIndex(leg, JointKind::HFE)].q = 0.7;
    j[model::jointIndex(leg, JointKind::KFE)].q = -1.4;
  }
  return j;
}

TEST(EstimatorSettings, ValidateNamesTheField) {
  EstimatorSettings s;
  EXPECT_NO_THROW(s.validate());
  s.wheel_velocity_std_m_s = 0.0;
  EXPECT_THAT(test::errorOf<std::invalid_argument>([&] { return s.validate(); }),
              test::HasSubstr("wheel_velocity_std_m_s"));
  s = {};
  s.max_consecutive_rejections = 0;
  EXPECT_THROW(s.validate(), std::invalid_argument);
  EXPECT_THROW(StateEstimator(loadRobot(), s), std::invalid_argument);
}

std::string fullYaml(const std::string& extra = "", const std::string& skip = "") {
  const char* keys[] = {"accel_noise_density: 0.4",
                        "position_noise_density: 0.01",
                        "wheel_velocity_std_m_s: 0.06",
                        "wheel_height_std_m: 0.02",
                        "ground_height_m: 0.1",
                        "initial_position_std_m: 0.02",
                        "initial_velocity_std_m_s: 0.1",
                        "velocity_gate_chi2: 20",
                        "height_gate_chi2: 25",
                        "max_consecutive_rejections: 40",
                        "max_velocity_std_m_s: 3",
                        "max_speed_m_s: 12",
                        "gravity_m_s2: 9.8"};
  std::string text;
  for (const char* k : keys)
    if (skip.empty() || std::string(k).rfind(skip, 0) != 0) text += std::string(k) + "\n";
  return text + extra;
}

TEST(EstimatorSettings, YamlReadsEveryKeyAndRejectsUnknownOrMissing) {
  const EstimatorSettings s = parseEstimatorSettings(fullYaml(), "test");
  EXPECT_DOUBLE_EQ(s.accel_noise_density, 0.4);
  EXPECT_DOUBLE_EQ(s.ground_height_m, 0.1);
  EXPECT_EQ(s.max_consecutive_rejections, 40);
  EXPECT_DOUBLE_EQ(s.gravity_m_s2, 9.8);
  const auto message = [](const std::string& text) {
    return test::errorOf<std::runtime_error>([&] { return parseEstimatorSettings(text, "test"); });
  };
  EXPECT_THAT(message(fullYaml("wheel_velocty_std: 1\n")),
              test::HasSubstr("unknown key 'wheel_velocty_std'"));
  EXPECT_THAT(message(fullYaml("", "gravity_m_s2")), test::HasSubstr("missing key 'gravity_m_s2'"));
  EXPECT_THAT(message(fullYaml("", "max_speed_m_s") + "max_speed_m_s: -1\n"),
              test::HasSubstr("max_speed_m_s"));
}

TEST(StateEstimator, WheelCentreMatchesRobotModelAndVelocityMatchesFiniteDifferences) {
  const model::RobotModel m = loadRobot();
  const StateEstimator est(m, {});
  model::JointMeasurements j = posture();
  for (int i = 0; i < model::kNumJoints; ++i) {
    j[i].q += 0.2 * std::sin(1.3 * i);
    j[i].qd = std::cos(0.7 * i + 0.2);
  }
  Eigen::VectorXd q(model::kNumJoints);
  for (int i = 0; i < model::kNumJoints; ++i) q[i] = j[i].q;
  const auto X_BL = m.calcLinkPoses(q);
  for (const Leg leg : model::kLegs) {
    Eigen::Vector3d p, v, axis, w;
    est.calcWheelKinematics(leg, j, p, v, axis, w);
    const model::JointSpec& wheel = m.joint(leg, JointKind::Wheel);
    EXPECT_LT((p - X_BL[wheel.child_link].translation()).norm(), 1e-12) << toString(leg);
    EXPECT_LT((axis - X_BL[wheel.child_link].linear() * wheel.axis).norm(), 1e-12);
    // d p / dt by central differences along qd.
    const double h = 1e-6;
    model::JointMeasurements jp = j, jm = j;
    for (int i = 0; i < model::kNumJoints; ++i) {
      jp[i].q += h * j[i].qd;
      jm[i].q -= h * j[i].qd;
    }
    Eigen::Vector3d pp, pm, dummy_v, dummy_a, dummy_w;
    est.calcWheelKinematics(leg, jp, pp, dummy_v, dummy_a, dummy_w);
    est.calcWheelKinematics(leg, jm, pm, dummy_v, dummy_a, dummy_w);
    EXPECT_LT((v - (pp - pm) / (2 * h)).norm(), 1e-8) << toString(leg);
  }
}

// Sensor data of the robot rolling at `speed` along x with a level base, wheels turning at
// speed / r and the legs still: the exact measurement of a rolling robot.
model::SensorData rollingSensors(const model::RobotModel& m, double speed) {
  model::SensorData s;
  s.joints = posture(0.0);
  for (const Leg leg : model::kLegs)
    s.joints[model::jointIndex(leg, JointKind::Wheel)].qd = speed / m.wheelRadius();
  s.imu.accel_B = Eigen::Vector3d(0.0, 0.0, 9.81);
  return s;
}

TEST(StateEstimator, RollingWheelsGiveTheBaseVelocityAndHeight) {
  const model::RobotModel m = loadRobot();
  StateEstimator est(m, {});
  const double speed = 1.2;
  model::SensorData s = rollingSensors(m, speed);
  // Height of the base over the ground from the kinematics of LF.
  Eigen::Vector3d p, v, axis, w;
  est.calcWheelKinematics(Leg::LF, s.joints, p, v, axis, w);
  const double height = -p.z() + m.wheelRadius();
  // Started 0.1 m/s and 3 cm off (within the gate of the initial covariance).
  est.reset(Eigen::Vector3d(0.0, 0.0, height + 0.03), Eigen::Vector3d(speed - 0.1, 0.0, 0.0));
  for (int k = 0; k < 500; ++k) {
    s.t = 1e-3 * k;
    est.update(s, {true, true, true, true}, 1e-3);
  }
  for (const Leg leg : model::kLegs) {
    EXPECT_LT(
        (est.state().wheel_velocity_W[static_cast<int>(leg)] - Eigen::Vector3d(speed, 0.0, 0.0))
            .norm(),
        1e-12);
  }
  EXPECT_LT((est.state().v_WB - Eigen::Vector3d(speed, 0.0, 0.0)).norm(), 1e-3);
  EXPECT_NEAR(est.state().p_WB.z(), height, 1e-3);  // the 3 cm error is corrected
  EXPECT_FALSE(est.diverged());
  EXPECT_EQ(est.rejectedMeasurements(), 0u);

  // A reset far from the truth (standing still while rolling at 1.2 m/s) is inconsistent with
  // every wheel: the gate rejects them all and the filter reports it after the set number of
  // updates instead of trusting either side.
  est.reset(Eigen::Vector3d(0.0, 0.0, height), Eigen::Vector3d::Zero());
  const int limit = est.settings().max_consecutive_rejections;
  for (int k = 0; k < limit - 1; ++k) est.update(s, {true, true, true, true}, 1e-3);
  EXPECT_FALSE(est.diverged());
  est.update(s, {true, true, true, true}, 1e-3);
  EXPECT_EQ(est.divergence(), Divergence::InnovationsRejected);
}

TEST(StateEstimator, UpdateDoesNotAllocate) {
  const model::RobotModel m = loadRobot();
  StateEstimator est(m, {});
  model::SensorData s = rollingSensors(m, 1.0);
  est.reset(Eigen::Vector3d(0.0, 0.0, 0.4), Eigen::Vector3d::Zero());
  est.update(s, {true, true, true, true}, 1e-3);
  const std::int64_t before = g_malloc_calls.load();
  for (int k = 0; k < 100; ++k) est.update(s, {true, k % 2 == 0, true, k % 3 == 0}, 1e-3);
  EXPECT_EQ(g_malloc_calls.load() - before, 0);
}

TEST(StateEstimator, FlightIntegratesTheImuExactly) {
  const model::RobotModel m = loadRobot();
  StateEstimator est(m, {});
  model::SensorData s;
  s.imu.accel_B.setZero();  // free fall: zero specific force
  const Eigen::Vector3d v0(2.0, 0.1, 1.5), p0(0.0, 0.0, 0.5);
  est.reset(p0, v0);
  const double dt = 1e-3;
  for (int k = 0; k < 300; ++k) est.update(s, {false, false, false, false}, dt);
  const double t = 0.3;
  const Eigen::Vector3d g(0.0, 0.0, -9.81);
  EXPECT_LT((est.state().v_WB - (v0 + g * t)).norm(), 1e-12);
  EXPECT_LT((est.state().p_WB - (p0 + v0 * t + 0.5 * g * t * t)).norm(), 1e-9);
  // The velocity covariance grows with the process noise only.
  EXPECT_NEAR(est.state().covariance_diagonal[3], 0.05 * 0.05 + 0.3 * 0.3 * t, 1e-9);
}

TEST(StateEstimator, APositionFixIsTheKalmanUpdateOfTheCovariance) {
  EstimatorSettings settings;
  StateEstimator est(loadRobot(), settings);
  est.reset(Eigen::Vector3d(1.0, 0.0, 0.3), Eigen::Vector3d(2.0, 0.0, 0.0));
  // Prior x 1.0 with std p0 and no position-velocity correlation after reset(): the posterior
  // is the weighted mean, x = 1 + p0^2 / (p0^2 + r^2) (x_meas - 1), and the velocity stays.
  const double p0 = settings.initial_position_std_m, r = 0.02;
  const double innovation = est.correctPositionX(1.3, r);
  EXPECT_DOUBLE_EQ(innovation, 0.3);
  const double gain = p0 * p0 / (p0 * p0 + r * r);
  EXPECT_NEAR(est.state().p_WB.x(), 1.0 + gain * 0.3, 1e-12);
  EXPECT_NEAR(est.state().covariance_diagonal[0], p0 * p0 * r * r / (p0 * p0 + r * r), 1e-15);
  EXPECT_DOUBLE_EQ(est.state().p_WB.y(), 0.0);
  EXPECT_DOUBLE_EQ(est.state().v_WB.x(), 2.0);
  // Without prediction steps, n fixes weigh as one of variance r^2 / n against the prior.
  for (int i = 1; i < 2000; ++i) est.correctPositionX(1.3, r);
  const double w = 2000.0 / (r * r), w0 = 1.0 / (p0 * p0);
  EXPECT_NEAR(est.state().p_WB.x(), 1.0 + 0.3 * w / (w + w0), 1e-9);
  // Bad input is ignored.
  EXPECT_EQ(est.correctPositionX(std::nan(""), r), 0.0);
  EXPECT_EQ(est.correctPositionX(5.0, 0.0), 0.0);
  EXPECT_NEAR(est.state().p_WB.x(), 1.0 + 0.3 * w / (w + w0), 1e-9);
  EXPECT_FALSE(est.diverged());
}

TEST(StateEstimator, DivergesOnNonFiniteInputAndRecoversOnReset) {
  const model::RobotModel m = loadRobot();
  StateEstimator est(m, {});
  model::SensorData s = rollingSensors(m, 0.0);
  est.reset(Eigen::Vector3d(0.0, 0.0, 0.4), Eigen::Vector3d::Zero());
  est.update(s, {true, true, true, true}, 1e-3);
  EXPECT_FALSE(est.diverged());
  // NaN in a leg that is not in contact is not used, so it does not matter.
  s.joints[model::jointIndex(Leg::RH, JointKind::KFE)].qd = std::nan("");
  est.update(s, {true, true, true, false}, 1e-3);
  EXPECT_FALSE(est.diverged());
  est.update(s, {true, true, true, true}, 1e-3);
  EXPECT_TRUE(est.diverged());
  EXPECT_EQ(est.divergence(), Divergence::NonFiniteInput);
  EXPECT_TRUE(est.state().p_WB.allFinite());  // the last good estimate stays
  est.reset(Eigen::Vector3d(0.0, 0.0, 0.4), Eigen::Vector3d::Zero());
  EXPECT_FALSE(est.diverged());
  s.imu.accel_B.x() = std::numeric_limits<double>::infinity();
  est.update(s, {false, false, false, false}, 1e-3);
  EXPECT_EQ(est.divergence(), Divergence::NonFiniteInput);
  EXPECT_STREQ(toString(est.divergence()), "non_finite_input");
}

}  // namespace
}  // namespace wj::estimation
