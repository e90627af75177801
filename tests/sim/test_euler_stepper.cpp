// The project's semi-explicit Euler stepper (sim/src/simbody/euler_stepper.h), which steps the
// sagittal model instead of Simbody's SemiExplicitEulerIntegrator: the same method, so the
// same trajectory bit for bit (IntegratorKind::SemiExplicitEulerSimbody is Simbody's), on the
// ground with slip and contact, in a whole verification, and with several steps per control
// period.
#include <gtest/gtest.h>

#include <filesystem>

#include "sim/reference_plans.h"
#include "sim/statics.h"
#include "sim/verifier.h"

namespace wj::sim {
namespace {

constexpr double kG = 9.81;

model::RobotModel loadRobot() {
  const std::filesystem::path dir = WJ_MODELS_DIR;
  return model::RobotModel::load(dir / "wheeljump.urdf", dir / "actuators.yaml");
}

SimSettings simbodyIntegrator(SimSettings s = {}) {
  s.integrator.kind = IntegratorKind::SemiExplicitEulerSimbody;
  return s;
}

// Rolling at 0.5 m/s, 2 mm into the ground, legs held by PD: contact and slip from the start.
void driveBoth(const model::RobotModel& robot, const SimSettings& settings, int steps) {
  SimRobot ours(robot, settings, SimModel::Sagittal);
  SimRobot simbody(robot, simbodyIntegrator(settings), SimModel::Sagittal);
  JointVector q = JointVector::Zero();
  for (const model::Leg leg : model::kLegs) {
    q[model::jointIndex(leg, model::JointKind::HFE)] = 0.8;
    q[model::jointIndex(leg, model::JointKind::KFE)] = -1.6;
  }
  const StandingStatics statics = calcStandingStatics(robot, q, kG);
  RobotPlacement p;
  p.q = q;
  p.X_WB.translation() = Eigen::Vector3d(0.0, 0.0, statics.base_height_m - 0.002);
  p.v_WB = Eigen::Vector3d(0.5, 0.0, 0.0);
  model::JointCommands hold{};
  for (int j = 0; j < model::kNumJoints; ++j) {
    p.qd[j] = model::isWheel(j) ? 0.5 / robot.wheelRadius() : 0.0;
    hold[j] = {q[j], p.qd[j], 150.0, 3.0, statics.tau[j]};
    if (model::isWheel(j)) hold[j] = {0.0, p.qd[j], 0.0, 1.0, 0.0};
  }
  ours.reset(p);
  simbody.reset(p);
  GroundTruth a, b;
  model::SensorData sa, sb;
  bool touched = false;
  for (int k = 0; k < steps; ++k) {
    // A crouch command half-way: the drives' torques change while the wheels roll.
    if (k == steps / 2)
      for (const model::Leg leg : model::kLegs) {
        hold[model::jointIndex(leg, model::JointKind::HFE)].q_des = 1.0;
        hold[model::jointIndex(leg, model::JointKind::KFE)].q_des = -2.0;
      }
    ours.write(hold);
    simbody.write(hold);
    ours.advance();
    simbody.advance();
    ours.read(sa);
    simbody.read(sb);
    ours.calcGroundTruth(a);
    simbody.calcGroundTruth(b);
    ASSERT_EQ(a.t, b.t);
    ASSERT_EQ(a.p_WC, b.p_WC) << "t = " << a.t;
    ASSERT_EQ(a.v_WC, b.v_WC) << "t = " << a.t;
    ASSERT_EQ(a.w_WB, b.w_WB) << "t = " << a.t;
    ASSERT_EQ(a.q, b.q) << "t = " << a.t;
    ASSERT_EQ(a.qd, b.qd) << "t = " << a.t;
    ASSERT_EQ(a.tau, b.tau) << "t = " << a.t;
    ASSERT_EQ(sa.imu.accel_B, sb.imu.accel_B) << "t = " << a.t;
    for (int l = 0; l < model::kNumLegs; ++l) {
      ASSERT_EQ(a.wheels[l].force_W, b.wheels[l].force_W) << "leg " << l << ", t = " << a.t;
      touched = touched || a.wheels[l].in_contact;
    }
  }
  EXPECT_TRUE(touched);
  EXPECT_EQ(ours.integratorStats().steps_taken, simbody.integratorStats().steps_taken);
  EXPECT_EQ(ours.calcMechanicalEnergy(), simbody.calcMechanicalEnergy());
}

TEST(EulerStepper, SameTrajectoryAsSimbodysIntegratorOnTheGround) {
  driveBoth(loadRobot(), SimSettings{}, 400);
}

// A fixed step of 0.4 ms in 1 ms control periods: two full steps and a short one per period,
// the step ends chosen as Simbody chooses them.
TEST(EulerStepper, SameTrajectoryWithStepsShorterThanThePeriod) {
  SimSettings s;
  s.integrator.max_step_s = 0.0004;
  driveBoth(loadRobot(), s, 200);
}

// A vertical jump verified with either stepper: the same report, field for field.
TEST(EulerStepper, SameVerificationReport) {
  const auto robot = loadRobot();
  VerticalJumpSpec spec;
  spec.v0_m_s = 0.5;
  const planner::JumpPlan plan = makeVerticalJumpPlan(robot, spec, ContactSettings{}, kG);
  VerifierSettings simbody;
  simbody.sim.integrator.kind = IntegratorKind::SemiExplicitEulerSimbody;
  const VerificationReport a = Verifier(robot, VerifierSettings{}).verify(plan, Scenario{});
  const VerificationReport b = Verifier(robot, simbody).verify(plan, Scenario{});
  ASSERT_EQ(a.model, SimModel::Sagittal);
  ASSERT_EQ(b.model, SimModel::Sagittal);
  EXPECT_TRUE(a.took_off);
  EXPECT_TRUE(a.touched_down);
  EXPECT_EQ(a.passed, b.passed);
  EXPECT_EQ(a.failures, b.failures);
  EXPECT_EQ(a.reasons, b.reasons);
  EXPECT_EQ(a.final_time_s, b.final_time_s);
  EXPECT_EQ(a.integrator_steps, b.integrator_steps);
  EXPECT_EQ(a.measured.apex.state.z, b.measured.apex.state.z);
  EXPECT_EQ(a.measured.touchdown.t, b.measured.touchdown.t);
  EXPECT_EQ(a.measured.touchdown.state.x, b.measured.touchdown.state.x);
  EXPECT_EQ(a.measured.touchdown.state.pitch, b.measured.touchdown.state.pitch);
  EXPECT_EQ(a.max_envelope_ratio, b.max_envelope_ratio);
  EXPECT_EQ(a.max_speed_ratio, b.max_speed_ratio);
  EXPECT_EQ(a.final_pitch_rad, b.final_pitch_rad);
  EXPECT_EQ(a.final_base_height_m, b.final_base_height_m);
  EXPECT_EQ(a.final_angular_speed_rad_s, b.final_angular_speed_rad_s);
  for (int j = 0; j < model::kNumJoints; ++j) {
    EXPECT_EQ(a.joints[j].max_abs_demand_nm, b.joints[j].max_abs_demand_nm);
    EXPECT_EQ(a.joints[j].min_q_rad, b.joints[j].min_q_rad);
    EXPECT_EQ(a.joints[j].max_q_rad, b.joints[j].max_q_rad);
  }
}

// The full model (a free base with a quaternion) stays on Simbody's integrator: both settings
// give the same run there too.
TEST(EulerStepper, TheFullModelKeepsSimbodysIntegrator) {
  const auto robot = loadRobot();
  SimRobot a(robot, SimSettings{}, SimModel::Full);
  SimRobot b(robot, simbodyIntegrator(), SimModel::Full);
  RobotPlacement p;
  p.X_WB.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  p.w_WB = Eigen::Vector3d(0.3, -0.5, 0.2);
  a.reset(p);
  b.reset(p);
  for (int k = 0; k < 50; ++k) {
    a.advance();
    b.advance();
  }
  GroundTruth ga, gb;
  a.calcGroundTruth(ga);
  b.calcGroundTruth(gb);
  EXPECT_EQ(ga.X_WB.matrix(), gb.X_WB.matrix());
  EXPECT_EQ(ga.w_WB, gb.w_WB);
}

}  // namespace
}  // namespace wj::sim
