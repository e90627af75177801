// The simulated robot against closed forms: free fall, mass properties, energy, Hertz
// contact, standing height, rolling, the slope and the box terrain.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>

#include "sim/reference_plans.h"
#include "sim/sim_robot.h"
#include "sim/statics.h"
#include "sim/verifier.h"
#include "test_robot.h"

namespace wj::sim {
namespace {

using wj::test::loadRobot;

constexpr double kG = 9.81;

// Accurate settings for closed-form checks of the model (not of the fast default integrator).
SimSettings accurateSettings(Terrain terrain) {
  SimSettings s;
  s.integrator.kind = IntegratorKind::RungeKuttaMerson;
  s.integrator.accuracy = 1e-8;
  s.terrain = std::move(terrain);
  return s;
}

// Commands that hold posture q: stiff PD on the legs plus the statics feedforward, wheels
// on speed control at `wheel_speed`.
model::JointCommands holdPosture(const model::RobotModel& m, const JointVector& q,
                                 double wheel_speed = 0.0, bool feedforward = true) {
  const StandingStatics st = calcStandingStatics(m, q, kG);
  model::JointCommands c{};
  for (int j = 0; j < model::kNumJoints; ++j) {
    if (m.joints()[j].kind == model::JointKind::Wheel)
      c[j] = {0.0, wheel_speed, 0.0, 1.0, 0.0};
    else
      c[j] = {q[j], 0.0, 400.0, 8.0, feedforward ? st.tau[j] : 0.0};
  }
  return c;
}

// Placement of posture q standing level on flat ground with the wheels sunk by `sink`.
RobotPlacement standing(const model::RobotModel& m, const JointVector& q, double sink,
                        double lift = 0.0) {
  RobotPlacement p;
  p.q = q;
  p.X_WB.translation().z() = calcStandingStatics(m, q, kG).base_height_m - sink + lift;
  return p;
}

void run(SimRobot& robot, const model::JointCommands& c, double duration) {
  const long n = std::lround(duration / robot.controlPeriod());
  for (long k = 0; k < n; ++k) {
    robot.write(c);
    robot.advance();
  }
}

// Base height expected from rigid kinematics minus the Hertz overlap of each wheel pair,
// interpolated to the base origin.
double expectedStandingHeight(const model::RobotModel& m, const JointVector& q,
                              const ContactSettings& contact) {
  const StandingStatics st = calcStandingStatics(m, q, kG);
  const auto wheels = calcWheelCenters(m, q);
  const int lf = static_cast<int>(model::Leg::LF), lh = static_cast<int>(model::Leg::LH);
  const double d_front = calcHertzPenetration(contact, m.wheelRadius(), st.wheel_load_n[lf]);
  const double d_hind = calcHertzPenetration(contact, m.wheelRadius(), st.wheel_load_n[lh]);
  const double x_f = wheels[lf].x(), x_h = wheels[lh].x();
  const double sink = d_hind + (d_front - d_hind) * (0.0 - x_h) / (x_f - x_h);
  return st.base_height_m - sink;
}

TEST(SimRobot, CompositeInertiaEqualsRobotModel) {
  const model::RobotModel m = loadRobot();
  SimRobot robot(m, accurateSettings(Terrain::none()));
  RobotPlacement p;
  for (int j = 0; j < model::kNumJoints; ++j) p.q[j] = 0.3 * std::sin(1.7 * j + 0.4);
  p.X_WB.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  p.X_WB.translation() = Eigen::Vector3d(0.3, -0.2, 1.1);
  robot.reset(p);
  const model::Inertia sim = robot.calcCompositeInertia();
  const model::Inertia ref = m.calcCompositeInertia(p.q);
  EXPECT_NEAR(sim.mass, ref.mass, 1e-12);
  EXPECT_LT((sim.com - ref.com).norm(), 1e-12);
  EXPECT_LT((sim.inertia_com - ref.inertia_com).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(sim.mass, m.totalMass(), 1e-12);
}

TEST(SimRobot, FreeFallFollowsParabola) {
  const model::RobotModel m = loadRobot();
  const Eigen::Vector3d g(0.0, 0.0, -kG);
  for (const bool accurate : {true, false}) {
    const SimSettings s = accurate ? accurateSettings(Terrain::none()) : [] {
      SimSettings d;
      d.terrain = Terrain::none();
      return d;
    }();
    SimRobot robot(m, s);
    RobotPlacement p;
    p.q = standingPosture(m, 0.35);
    p.X_WB.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
    p.v_WB = Eigen::Vector3d(0.5, 0.1, 1.0);
    p.w_WB = Eigen::Vector3d(0.2, -0.5, 0.1);
    for (int j = 0; j < model::kNumJoints; ++j) p.qd[j] = std::cos(0.9 * j);
    robot.reset(p);
    GroundTruth gt;
    robot.calcGroundTruth(gt);
    const Eigen::Vector3d c0 = gt.p_WC, v0 = gt.v_WC;
    const double T = 0.5;
    run(robot, model::JointCommands{}, T);
    robot.calcGroundTruth(gt);
    const Eigen::Vector3d expected = c0 + v0 * T + 0.5 * g * T * T;
    // Accurate: the model. Default (semi-explicit Euler, 1st order): its known bias for a
    // constant acceleration, x_n - x(t_n) = -g t h / 2 with h = max_step, plus a small drift
    // of the momentum because the step does not conserve it exactly while the legs move.
    const double tol = accurate ? 1e-9 : 0.5 * kG * T * s.integrator.max_step_s + 1e-4;
    EXPECT_LT((gt.p_WC - expected).norm(), tol) << (accurate ? "accurate" : "default");
    EXPECT_LT((gt.v_WC - (v0 + g * T)).norm(), accurate ? 1e-9 : 5e-4);
  }
}

TEST(SimRobot, EnergyConservedWithoutActuationOrDissipation) {
  const model::RobotModel m = loadRobot();
  SimRobot robot(m, accurateSettings(Terrain::none()));
  RobotPlacement p;
  p.q = standingPosture(m, 0.35);
  p.X_WB.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  p.v_WB = Eigen::Vector3d(0.3, 0.0, 2.0);
  p.w_WB = Eigen::Vector3d(0.5, 1.0, -0.3);
  for (int j = 0; j < model::kNumJoints; ++j) p.qd[j] = 2.0 * std::sin(1.3 * j);
  robot.reset(p);
  const double e0 = robot.calcMechanicalEnergy();
  double worst = 0.0;
  for (int k = 0; k < 10; ++k) {
    run(robot, model::JointCommands{}, 0.05);
    worst = std::max(worst, std::abs(robot.calcMechanicalEnergy() - e0));
  }
  EXPECT_LT(worst / std::abs(e0), 1e-7) << "E0 = " << e0 << " J";
}

TEST(SimRobot, DroppedRobotSettlesAtStandingHeight) {
  const model::RobotModel m = loadRobot();
  const SimSettings s;  // default (fast) settings
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  robot.reset(standing(m, q, 0.0, 0.05));
  run(robot, holdPosture(m, q), 1.5);
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  const double expected = expectedStandingHeight(m, q, s.contact);
  EXPECT_NEAR(gt.X_WB.translation().z(), expected, 1e-3);
  // The design target: less than ~2 mm of contact overlap under the robot's weight.
  for (const auto& w : gt.wheels) {
    EXPECT_TRUE(w.in_contact);
    EXPECT_LT(w.penetration_m, 2e-3);
  }
  EXPECT_NEAR(gt.wheels[0].force_W.z() + gt.wheels[1].force_W.z() + gt.wheels[2].force_W.z() +
                  gt.wheels[3].force_W.z(),
              m.totalMass() * kG, 0.5);
  EXPECT_FALSE(gt.base_in_contact);
  EXPECT_FALSE(gt.legs_in_contact);
}

TEST(SimRobot, EllipsoidWheelsCarryTheRobotToo) {
  // The flattened-ellipsoid tread has a much smaller lateral curvature radius, so it sinks a
  // little deeper than the sphere (2.1 mm at the hind wheels) but carries the same weight.
  const model::RobotModel m = loadRobot();
  SimSettings s;
  s.contact.wheel_shape = WheelShape::Ellipsoid;
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  robot.reset(standing(m, q, 0.0, 0.02));
  run(robot, holdPosture(m, q), 1.0);
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  double fz = 0.0;
  for (const auto& w : gt.wheels) {
    EXPECT_TRUE(w.in_contact);
    EXPECT_LT(w.penetration_m, 2.5e-3);
    fz += w.force_W.z();
  }
  EXPECT_NEAR(fz, m.totalMass() * kG, 0.5);
  // Within a millimetre of the sphere's closed form: the tread shape changes the overlap only.
  EXPECT_NEAR(gt.X_WB.translation().z(), expectedStandingHeight(m, q, s.contact), 1e-3);
}

TEST(SimRobot, StaticStandHoldsBaseHeightWithinOneMillimetre) {
  const model::RobotModel m = loadRobot();
  for (const ActuatorUpdate update : {ActuatorUpdate::Continuous, ActuatorUpdate::ZeroOrderHold}) {
    SimSettings s;
    s.actuator_update = update;
    SimRobot robot(m, s);
    const JointVector q = standingPosture(m, 0.34);
    const double expected = expectedStandingHeight(m, q, s.contact);
    robot.reset(standing(m, q, calcStandingStatics(m, q, kG).base_height_m - expected));
    const model::JointCommands hold = holdPosture(m, q);
    GroundTruth gt;
    double worst = 0.0;
    for (int k = 0; k < 2000; ++k) {
      robot.write(hold);
      robot.advance();
      robot.calcGroundTruth(gt);
      worst = std::max(worst, std::abs(gt.X_WB.translation().z() - expected));
    }
    EXPECT_LT(worst, 1e-3) << toString(update);
  }
}

TEST(SimRobot, RollingWheelsKeepSpeedEqualToOmegaTimesRadius) {
  const model::RobotModel m = loadRobot();
  const SimSettings s;
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  robot.reset(standing(m, q, 1e-3));
  const double v = 1.5, omega = v / m.wheelRadius();
  run(robot, holdPosture(m, q, omega), 2.0);
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  double mean_omega = 0.0;
  for (const model::Leg leg : model::kLegs)
    mean_omega += gt.qd[model::jointIndex(leg, model::JointKind::Wheel)] / model::kNumLegs;
  const double vx = gt.v_WC.x();
  EXPECT_NEAR(vx, mean_omega * m.wheelRadius(), 0.01 * vx);
  EXPECT_NEAR(mean_omega, omega, 0.02 * omega);  // the speed loop settled
  EXPECT_NEAR(gt.v_WC.y(), 0.0, 1e-3);
}

TEST(SimRobot, WheelsSlidingSidewaysFeelDynamicFriction) {
  // A pin wheel cannot roll sideways: pushed sideways, the robot slides on its wheels, and
  // above three transition speeds Simbody's Stribeck curve gives exactly mu_d, so the
  // friction on each wheel is mu_d times its normal force, against the slip.
  const model::RobotModel m = loadRobot();
  const SimSettings s;
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  RobotPlacement p = standing(
      m, q, calcStandingStatics(m, q, kG).base_height_m - expectedStandingHeight(m, q, s.contact));
  p.v_WB = Eigen::Vector3d(0.0, 1.3, 0.0);
  robot.reset(p);
  GroundTruth gt;
  for (int k = 0; k < 2; ++k) {  // at the start and 5 ms later (the robot starts to roll)
    robot.calcGroundTruth(gt);
    ASSERT_GT(gt.v_WC.y(), 3.0 * s.contact.transition_velocity_m_s);
    for (const auto& w : gt.wheels) {
      ASSERT_TRUE(w.in_contact);
      ASSERT_GT(w.force_W.z(), 10.0);
      EXPECT_NEAR(-w.force_W.y() / w.force_W.z(), s.contact.dynamic_friction, 5e-3) << k;
      EXPECT_NEAR(w.force_W.x(), 0.0, 0.01 * w.force_W.z()) << k;
    }
    run(robot, holdPosture(m, q), 0.005);
  }
}

TEST(SimRobot, RollsDownTheSlopeWithClosedFormAcceleration) {
  const model::RobotModel m = loadRobot();
  const double slope = 20.0 * std::numbers::pi / 180.0;
  const SimSettings s = [&] {
    SimSettings d;
    d.terrain = Terrain::slope(slope);
    return d;
  }();
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  InitialState init;
  init.q = q;
  init.com.z = comHeight(m, 0.36) - 1e-3;
  robot.reset(calcPlacement(m, init, s.terrain));
  model::JointCommands c = holdPosture(m, q);
  for (const model::Leg leg : model::kLegs)
    c[model::jointIndex(leg, model::JointKind::Wheel)] = {};  // free wheels
  GroundTruth gt;
  run(robot, c, 0.2);  // settle the contact transient
  robot.calcGroundTruth(gt);
  const Eigen::Vector3d down(-std::cos(slope), 0.0, -std::sin(slope));
  const double v1 = gt.v_WC.dot(down);
  run(robot, c, 0.5);
  robot.calcGroundTruth(gt);
  const double v2 = gt.v_WC.dot(down);
  // Rolling without slip: M a = M g sin(a) - sum I_w a / r^2.
  double wheel_inertia = 0.0;
  for (const model::Leg leg : model::kLegs)
    wheel_inertia +=
        m.links()[m.joint(leg, model::JointKind::Wheel).child_link].inertia.inertia_com(1, 1);
  const double r = m.wheelRadius();
  const double expected =
      kG * std::sin(slope) * m.totalMass() / (m.totalMass() + wheel_inertia / (r * r));
  EXPECT_NEAR((v2 - v1) / 0.5, expected, 0.02 * expected);
  for (const auto& w : gt.wheels) EXPECT_TRUE(w.in_contact);
  EXPECT_FALSE(gt.base_in_contact);
}

TEST(SimRobot, StandsOnABoxLikeOnTheGround) {
  // The box terrain uses its own force element; its Hertz law must match Simbody's.
  const model::RobotModel m = loadRobot();
  SimSettings s;
  const double height = 0.1;
  s.terrain = Terrain::step(-1.0, height);  // the whole robot stands on the step's top
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  RobotPlacement p = standing(m, q, 0.0, 0.02);
  p.X_WB.translation().z() += height;
  robot.reset(p);
  run(robot, holdPosture(m, q), 1.5);
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  EXPECT_NEAR(gt.X_WB.translation().z(), height + expectedStandingHeight(m, q, s.contact), 1e-3);
  double fz = 0.0;
  for (const auto& w : gt.wheels) {
    EXPECT_TRUE(w.in_contact);
    fz += w.force_W.z();
  }
  EXPECT_NEAR(fz, m.totalMass() * kG, 0.5);
  EXPECT_TRUE(std::isinf(gt.obstacle_clearance_m));  // a step is terrain, not an obstacle
}

TEST(SimRobot, CoastingRobotBouncesOffAWall) {
  const model::RobotModel m = loadRobot();
  SimSettings s;
  const double x_wall = 0.3, v0 = 0.5;
  s.terrain = Terrain::wall(x_wall, x_wall + 0.1, 0.4);
  SimRobot robot(m, s);
  const JointVector q = standingPosture(m, 0.36);
  RobotPlacement p = standing(m, q, 1e-3);
  p.v_WB.x() = v0;
  for (const model::Leg leg : model::kLegs)
    p.qd[model::jointIndex(leg, model::JointKind::Wheel)] = v0 / m.wheelRadius();
  robot.reset(p);
  model::JointCommands c = holdPosture(m, q);
  for (const model::Leg leg : model::kLegs)
    c[model::jointIndex(leg, model::JointKind::Wheel)] = {};  // free wheels: coasting
  GroundTruth gt;
  double min_clearance = 1.0, max_front = -1.0;
  const auto X = [&] { return m.calcLinkPoses(gt.q); };
  for (int k = 0; k < 1500; ++k) {
    robot.write(c);
    robot.advance();
    robot.calcGroundTruth(gt);
    min_clearance = std::min(min_clearance, gt.obstacle_clearance_m);
    const Eigen::Vector3d w =
        gt.X_WB * X()[m.joint(model::Leg::LF, model::JointKind::Wheel).child_link].translation();
    max_front = std::max(max_front, w.x() + m.wheelRadius());
  }
  // The wheels touch the wall, penetrate a few millimetres, and the robot comes back.
  EXPECT_LT(min_clearance, 0.0);
  EXPECT_GT(min_clearance, -5e-3);
  EXPECT_LT(max_front, x_wall + 5e-3);
  EXPECT_LT(gt.v_WC.x(), 0.0);
  EXPECT_GT(gt.obstacle_clearance_m, 0.0);
  EXPECT_FALSE(gt.base_in_contact);
}

TEST(SimRobot, ImuReadsGravityAtRestAndNoiseIsSeeded) {
  const model::RobotModel m = loadRobot();
  const JointVector q = standingPosture(m, 0.36);
  SimSettings s;
  SimRobot quiet(m, s);
  quiet.reset(standing(
      m, q, calcStandingStatics(m, q, kG).base_height_m - expectedStandingHeight(m, q, s.contact)));
  run(quiet, holdPosture(m, q), 1.0);
  model::SensorData a;
  quiet.read(a);
  EXPECT_NEAR(a.imu.accel_B.z(), kG, 0.05);
  EXPECT_LT(a.imu.accel_B.head<2>().norm(), 0.05);
  EXPECT_LT(a.imu.omega_B.norm(), 1e-3);
  EXPECT_NEAR(a.t, 1.0, 1e-12);
  for (int j = 0; j < model::kNumJoints; ++j) {
    if (m.joints()[j].kind != model::JointKind::Wheel) {
      EXPECT_NEAR(a.joints[j].q, q[j], 2e-3);
    }
  }

  s.noise.enabled = true;
  const auto noisy = [&](std::uint64_t seed) {
    SimSettings n = s;
    n.noise.seed = seed;
    SimRobot r(m, n);
    r.reset(standing(m, q, 1e-3));
    model::SensorData d;
    r.read(d);
    return d;
  };
  const model::SensorData n1 = noisy(7), n2 = noisy(7), n3 = noisy(8);
  EXPECT_EQ(n1.joints[2].q, n2.joints[2].q);
  EXPECT_EQ(n1.imu.accel_B, n2.imu.accel_B);
  EXPECT_NE(n1.joints[2].q, n3.joints[2].q);
}

TEST(SimRobot, DrivesSaturateAtTheEnvelope) {
  const model::RobotModel m = loadRobot();
  SimRobot robot(m, accurateSettings(Terrain::none()));
  RobotPlacement p;
  p.X_WB.translation().z() = 2.0;
  robot.reset(p);
  model::JointCommands c{};
  const int knee = model::jointIndex(model::Leg::LF, model::JointKind::KFE);
  c[knee].tau_ff = 1000.0;
  robot.write(c);
  GroundTruth gt;
  robot.calcGroundTruth(gt);
  EXPECT_DOUBLE_EQ(gt.tau_demand[knee], 1000.0);
  EXPECT_DOUBLE_EQ(gt.tau[knee], m.joints()[knee].actuator.peak_torque_nm);
  model::SensorData d;
  robot.read(d);
  EXPECT_DOUBLE_EQ(d.joints[knee].tau, m.joints()[knee].actuator.peak_torque_nm);
}

}  // namespace
}  // namespace wj::sim
