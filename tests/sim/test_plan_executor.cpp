// The plan executor's pitch feedback on the hind wheels: it acts only while a two-step plan
// stands on its hind wheels (t1 <= t < t2, front legs without planned torque), adds
// kp e + kd e_rate to both hind wheels' torque, relative to the pitch measured at t = 0, and
// stays within its clamp; settings outside their range are rejected by name.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <Eigen/Geometry>

#include "error_of.h"
#include "planner/planner_settings.h"
#include "sim/plan_executor.h"
#include "test_robot.h"

namespace wj::sim {
namespace {

using model::jointIndex;
using model::JointKind;
using model::Leg;

using wj::test::loadRobot;

// Constant references: every body pitch 0.5 rad at 1 rad/s, every joint torque `tau`, except
// the front legs in [t1, t2) which carry `front_tau` (0: the front pair has lifted).
planner::JumpPlan makePlan(double front_tau) {
  planner::JumpPlan plan;
  plan.dt = 0.002;
  plan.t1 = 0.1;
  plan.t2 = 0.3;
  plan.t3 = 0.5;
  const int n = 251;
  plan.centroidal.assign(n, planner::PlanarState{0.0, 0.3, 0.5, 0.0, 0.0, 1.0});
  plan.q = Eigen::MatrixXd::Zero(n, model::kNumJoints);
  plan.qd = Eigen::MatrixXd::Zero(n, model::kNumJoints);
  plan.tau = Eigen::MatrixXd::Constant(n, model::kNumJoints, 2.0);
  for (int k = 50; k < 150; ++k)
    for (const Leg leg : {Leg::LF, Leg::RF})
      for (const JointKind kind : model::kJointKinds)
        plan.tau(k, jointIndex(leg, kind)) = front_tau;
  return plan;
}

// The body pitched nose-up by `pitch` (about -y), turning nose-up at `rate`.
model::SensorData pitched(double pitch, double rate) {
  model::SensorData s;
  s.imu.q_WB = Eigen::Quaterniond(Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()));
  s.imu.omega_B = Eigen::Vector3d(0.0, -rate, 0.0);  // about B's y = W's y here
  return s;
}

ExecutorSettings gains(double kp, double kd, double max_nm) {
  ExecutorSettings s;
  s.landing_gravity_feedforward = false;
  s.hind_pitch_kp = kp;
  s.hind_pitch_kd = kd;
  s.hind_pitch_max_nm = max_nm;
  return s;
}

double wheelTau(const model::JointCommands& c, Leg leg) {
  return c[jointIndex(leg, JointKind::Wheel)].tau_ff;
}

// The planner takes the wheels' margins at the loaded tyre's joint rate with the same tyre as
// the executor's wheel law (PlannerSettings::tyre_rolling_radius_ratio): one tyre, two places.
TEST(PlanExecutor, TyreFiguresAreThePlannersOwn) {
  const ExecutorSettings e;
  const planner::PlannerSettings p;
  EXPECT_DOUBLE_EQ(e.tyre_rolling_radius_ratio, p.tyre_rolling_radius_ratio);
  EXPECT_DOUBLE_EQ(e.tyre_slip_stiffness_n_s_m, p.tyre_slip_stiffness_n_s_m);
}

// All wheels off the ground for the debounce is the flight, unless a wheel touches again while
// the take-off runs: a robot placed a few mm off the ground by a measured start state falls or
// bounces at first, and that hop is not the jump (the verifier would take its lift-off as the
// take-off). Once the flight phase runs, a contact is the landing's, and the flag holds.
TEST(PlanExecutor, AHopInTheTakeoffIsNotTheFlight) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan(2.0);  // t2 = 0.3
  PlanExecutor ex(robot, plan, gains(0.0, 0.0, 0.0), 9.81);
  model::JointCommands c{};
  ex.update(0.000, pitched(0.5, 1.0), true, c);
  ex.update(0.005, pitched(0.5, 1.0), false, c);
  ex.update(0.016, pitched(0.5, 1.0), false, c);  // 11 ms off: past the 10 ms debounce
  EXPECT_TRUE(ex.wasAirborne());
  ex.update(0.020, pitched(0.5, 1.0), true, c);  // back on the ground in the push
  EXPECT_FALSE(ex.wasAirborne());
  EXPECT_EQ(ex.phase(), JumpPhase::Takeoff);
  ex.update(0.300, pitched(0.5, 1.0), false, c);  // the lift-off, then the flight
  ex.update(0.320, pitched(0.5, 1.0), false, c);
  EXPECT_TRUE(ex.wasAirborne());
  EXPECT_EQ(ex.phase(), JumpPhase::Flight);
  ex.update(0.330, pitched(0.5, 1.0), true, c);  // a contact in the flight phase
  EXPECT_TRUE(ex.wasAirborne());
}

TEST(PlanExecutor, HindWheelsCloseThePitchLoopOnlyOnTheHindWheels) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan(0.0);
  PlanExecutor ex(robot, plan, gains(4.0, 3.0, 100.0), 9.81);
  model::JointCommands c{};
  // The start is pitched 0.1 rad: the plan's pitch is relative to it.
  ex.update(0.0, pitched(0.1, 0.0), true, c);
  ex.update(0.05, pitched(0.1, 0.0), true, c);  // four-wheel push: the plan's torques only
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::LH), 2.0);
  // Hind-only: pitch 0.2 rad (0.1 from the start) at 0.25 rad/s against 0.5 rad at 1 rad/s.
  ex.update(0.2, pitched(0.2, 0.25), true, c);
  const double expected = 2.0 + 4.0 * (0.5 - 0.1) + 3.0 * (1.0 - 0.25);
  EXPECT_NEAR(wheelTau(c, Leg::LH), expected, 1e-9);
  EXPECT_NEAR(wheelTau(c, Leg::RH), expected, 1e-9);
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::LF), 0.0);  // the plan's (lifted) front wheels untouched
  // Ahead of the plan: the feedback brakes (nose-down).
  ex.update(0.22, pitched(0.9, 2.0), true, c);
  EXPECT_LT(wheelTau(c, Leg::LH), 2.0);
}

TEST(PlanExecutor, PitchFeedbackIsClampedAndOffWithoutAHindOnlyPhase) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan lifted = makePlan(0.0);
  PlanExecutor clamped(robot, lifted, gains(100.0, 10.0, 3.0), 9.81);
  model::JointCommands c{};
  clamped.update(0.0, pitched(0.0, 0.0), true, c);
  clamped.update(0.2, pitched(-1.0, -5.0), true, c);
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::RH), 2.0 + 3.0);
  clamped.update(0.21, pitched(2.0, 20.0), true, c);
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::RH), 2.0 - 3.0);

  // Front legs still pushing in [t1, t2): not a hind-only phase, no feedback.
  const planner::JumpPlan four_wheel = makePlan(2.0);
  PlanExecutor open(robot, four_wheel, gains(100.0, 10.0, 30.0), 9.81);
  open.update(0.0, pitched(0.0, 0.0), true, c);
  open.update(0.2, pitched(-1.0, -5.0), true, c);
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::RH), 2.0);
}

TEST(PlanExecutor, NegativePitchGainsAreRejectedByName) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan(0.0);
  for (const char* field : {"hind_pitch_kp", "hind_pitch_kd", "hind_pitch_max_nm"}) {
    ExecutorSettings s = gains(1.0, 1.0, 1.0);
    if (std::string(field) == "hind_pitch_kp") s.hind_pitch_kp = -1.0;
    if (std::string(field) == "hind_pitch_kd") s.hind_pitch_kd = -1.0;
    if (std::string(field) == "hind_pitch_max_nm") s.hind_pitch_max_nm = std::nan("");
    EXPECT_THAT(
        test::errorOf<std::invalid_argument>([&] { return PlanExecutor(robot, plan, s, 9.81); }),
        test::HasSubstr(field));
  }
}

// The take-off's wheel law of a simultaneous plan: the plan's torque, and the speed gain only
// on the part of the error beyond the slip band around the plan's rate, which the tyre's
// rolling radius and the slip of the planned traction move. A two-step plan keeps wheel_kd on
// the whole error to the plan's rate. Out of range: rejected by name.
TEST(PlanExecutor, TakeoffWheelsGetThePlansTorqueAndASpeedLoopOnlyBeyondTheSlipBand) {
  const model::RobotModel robot = loadRobot();
  const double r = robot.wheelRadius();
  const int lh = jointIndex(Leg::LH, JointKind::Wheel);
  ExecutorSettings s = gains(0.0, 0.0, 0.0);
  s.wheel_kd = 0.7;
  s.takeoff_wheel_kd = 1.5;
  s.takeoff_wheel_slip_band_m_s = 0.03;
  s.tyre_rolling_radius_ratio = 1.0;
  s.tyre_slip_stiffness_n_s_m = 1e300;  // a rigid tyre: the reference is the plan's rate, 0
  // The drive's torque for command c at the measured rate qd.
  const auto drive = [](const model::JointCommand& c, double qd) {
    return c.tau_ff + c.kd * (c.qd_des - qd);
  };
  const auto at = [&](const planner::JumpPlan& plan, const ExecutorSettings& set, double qd) {
    PlanExecutor ex(robot, plan, set, 9.81);
    model::SensorData sensors = pitched(0.0, 0.0);
    for (model::JointMeasurement& m : sensors.joints) m.qd = qd;
    model::JointCommands c{};
    ex.update(0.0, sensors, true, c);
    ex.update(0.05, sensors, true, c);
    return c[lh];
  };
  const planner::JumpPlan simultaneous = makePlan(2.0);
  // Inside the band (0.2 rad/s = 0.017 m/s): the plan's torque alone.
  model::JointCommand c = at(simultaneous, s, 0.2);
  EXPECT_DOUBLE_EQ(c.kd, 1.5);
  EXPECT_NEAR(drive(c, 0.2), 2.0, 1e-12);
  // Beyond it (spinning up at 2 rad/s = 0.17 m/s): the gain on the excess only.
  c = at(simultaneous, s, 2.0);
  EXPECT_NEAR(drive(c, 2.0), 2.0 + 1.5 * (0.03 / r - 2.0), 1e-9);
  c = at(simultaneous, s, -2.0);
  EXPECT_NEAR(drive(c, -2.0), 2.0 + 1.5 * (2.0 - 0.03 / r), 1e-9);
  // The tyre: with no band the reference is the plan's rate over the rolling radius ratio
  // (the plan's wheel spins at the body's -1 rad/s about y: pitch rate 1 rad/s nose-up, legs
  // and wheel joint at rest) plus the slip of the planned traction (2 Nm / r).
  s.takeoff_wheel_slip_band_m_s = 0.0;
  s.tyre_rolling_radius_ratio = 0.98;
  s.tyre_slip_stiffness_n_s_m = 400.0;
  c = at(simultaneous, s, 5.0);
  EXPECT_NEAR(c.qd_des, (1.0 / 0.98 - 1.0) * -1.0 + 2.0 / (r * 400.0) / r, 1e-9);
  // A two-step plan: wheel_kd towards the plan's rate, whatever the tyre and the band.
  s.takeoff_wheel_slip_band_m_s = 0.5;
  const planner::JumpPlan two_step = makePlan(0.0);
  for (const double t : {0.05, 0.2}) {
    PlanExecutor ex(robot, two_step, s, 9.81);
    model::SensorData sensors = pitched(0.0, 0.0);
    for (model::JointMeasurement& m : sensors.joints) m.qd = 0.2;
    model::JointCommands cmd{};
    ex.update(0.0, sensors, true, cmd);
    ex.update(t, sensors, true, cmd);
    EXPECT_DOUBLE_EQ(cmd[lh].kd, 0.7);
    EXPECT_DOUBLE_EQ(cmd[lh].qd_des, 0.0);
  }
  for (const char* field : {"takeoff_wheel_kd", "takeoff_wheel_slip_band_m_s",
                            "tyre_slip_stiffness_n_s_m", "tyre_rolling_radius_ratio"}) {
    ExecutorSettings bad = s;
    const std::string f = field;
    if (f == "takeoff_wheel_kd") bad.takeoff_wheel_kd = -1.0;
    if (f == "takeoff_wheel_slip_band_m_s") bad.takeoff_wheel_slip_band_m_s = std::nan("");
    if (f == "tyre_slip_stiffness_n_s_m") bad.tyre_slip_stiffness_n_s_m = 0.0;
    if (f == "tyre_rolling_radius_ratio") bad.tyre_rolling_radius_ratio = 1.5;
    EXPECT_THAT(test::errorOf<std::invalid_argument>(
                    [&] { return PlanExecutor(robot, simultaneous, bad, 9.81); }),
                test::HasSubstr(field));
  }
}

// A two-step plan (the backflip) runs its legs with its own take-off and flight gains and
// lands with its own wheel deceleration; any other plan with the common ones. Out of range:
// rejected by name.
TEST(PlanExecutor, TwoStepPlansRunWithTheirOwnGains) {
  const model::RobotModel robot = loadRobot();
  ExecutorSettings s = gains(0.0, 0.0, 0.0);
  s.takeoff_kp = 150.0;
  s.takeoff_kd = 3.0;
  s.flight_kp = 80.0;
  s.flight_kd = 2.0;
  s.two_step_takeoff_kp = 600.0;
  s.two_step_takeoff_kd = 8.0;
  s.two_step_flight_kp = 400.0;
  s.two_step_flight_kd = 7.0;
  const int hfe = jointIndex(Leg::LH, JointKind::HFE);
  for (const bool two_step : {true, false}) {
    const planner::JumpPlan plan = makePlan(two_step ? 0.0 : 2.0);
    PlanExecutor ex(robot, plan, s, 9.81);
    model::JointCommands c{};
    ex.update(0.0, pitched(0.0, 0.0), true, c);
    ex.update(0.05, pitched(0.0, 0.0), true, c);
    EXPECT_DOUBLE_EQ(c[hfe].kp, two_step ? 600.0 : 150.0);
    EXPECT_DOUBLE_EQ(c[hfe].kd, two_step ? 8.0 : 3.0);
    ex.update(0.31, pitched(0.0, 0.0), false, c);  // past t2: flight
    EXPECT_DOUBLE_EQ(c[hfe].kp, two_step ? 400.0 : 80.0);
    EXPECT_DOUBLE_EQ(c[hfe].kd, two_step ? 7.0 : 2.0);
  }
  for (const char* field : {"two_step_takeoff_kp", "two_step_takeoff_kd", "two_step_flight_kp",
                            "two_step_flight_kd", "two_step_landing_wheel_decel_m_s2"}) {
    ExecutorSettings bad = s;
    const std::string f = field;
    if (f == "two_step_takeoff_kp") bad.two_step_takeoff_kp = -1.0;
    if (f == "two_step_takeoff_kd") bad.two_step_takeoff_kd = -1.0;
    if (f == "two_step_flight_kp") bad.two_step_flight_kp = std::nan("");
    if (f == "two_step_flight_kd") bad.two_step_flight_kd = -1.0;
    if (f == "two_step_landing_wheel_decel_m_s2") bad.two_step_landing_wheel_decel_m_s2 = -1.0;
    try {
      PlanExecutor ex(robot, makePlan(0.0), bad, 9.81);
      ADD_FAILURE() << field << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
}

// On the hind wheels the lifted front legs' references stay lifted_pair_margin_rad inside their
// range (the plan rests the front knee 0.03 rad from its stop); before t1 and on the hind legs
// the plan's references pass unchanged.
TEST(PlanExecutor, TheLiftedPairIsKeptInsideItsRangeOnTheHindWheels) {
  const model::RobotModel robot = loadRobot();
  planner::JumpPlan plan = makePlan(0.0);
  const int lf_kfe = jointIndex(Leg::LF, JointKind::KFE),
            lh_kfe = jointIndex(Leg::LH, JointKind::KFE);
  const double upper = robot.joints()[lf_kfe].upper_rad;
  plan.q.col(lf_kfe).setConstant(upper - 0.03);
  plan.q.col(lh_kfe).setConstant(upper - 0.03);
  ExecutorSettings s = gains(0.0, 0.0, 0.0);
  s.lifted_pair_margin_rad = 0.12;
  PlanExecutor ex(robot, plan, s, 9.81);
  model::JointCommands c{};
  ex.update(0.0, pitched(0.0, 0.0), true, c);
  ex.update(0.05, pitched(0.0, 0.0), true, c);  // four-wheel push: as planned
  EXPECT_NEAR(c[lf_kfe].q_des, upper - 0.03, 1e-12);
  ex.update(0.2, pitched(0.0, 0.0), true, c);  // hind-only: the lifted knee kept inside
  EXPECT_NEAR(c[lf_kfe].q_des, upper - 0.12, 1e-12);
  EXPECT_NEAR(c[lh_kfe].q_des, upper - 0.03, 1e-12);
  s.lifted_pair_margin_rad = -0.1;
  EXPECT_THROW(PlanExecutor(robot, plan, s, 9.81), std::invalid_argument);
}

}  // namespace
}  // namespace wj::sim
