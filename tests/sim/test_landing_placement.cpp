// The plan executor's leg placement for the measured pitch (touchdown_pitch_placement): in
// the descent every leg's HFE reference moves by the body's pitch error beyond its band
// (nose-up error: HFE up, the legs swing back to the plan's angle in the world), ramped in
// from the plan's apex, clamped; the touchdown's offset is held in the landing and fades with
// the hand-over blend; off, the legs follow the plan. The landing's wheel braking against a
// wheelie acts beyond its pitch limit only, never forward, clamped. Bad settings are refused
// by name.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "error_of.h"
#include "sim/plan_executor.h"
#include "test_robot.h"

namespace wj::sim {
namespace {

using model::jointIndex;
using model::JointKind;
using model::Leg;

using wj::test::loadRobot;

// Take-off until t2 = 0.2 s, flight to t3 = 0.5 s with the apex at 0.35 s (vz > 0 before);
// the planned pitch is 0.3 rad all along; every leg holds HFE 0.8 rad.
constexpr double kPlanPitch = 0.3;
constexpr double kHfe = 0.8;

planner::JumpPlan makePlan() {
  planner::JumpPlan plan;
  plan.dt = 0.002;
  plan.t1 = 0.2;
  plan.t2 = 0.2;
  plan.t3 = 0.5;
  const int n = 251;
  plan.centroidal.resize(n);
  for (int k = 0; k < n; ++k)
    plan.centroidal[k] =
        planner::PlanarState{0.0, 0.3, kPlanPitch, 2.5, k * plan.dt < 0.35 ? 1.0 : -1.0, 0.0};
  plan.q = Eigen::MatrixXd::Zero(n, model::kNumJoints);
  plan.qd = Eigen::MatrixXd::Zero(n, model::kNumJoints);
  plan.tau = Eigen::MatrixXd::Zero(n, model::kNumJoints);
  for (int leg = 0; leg < model::kNumLegs; ++leg) {
    const int j = jointIndex(static_cast<Leg>(leg), JointKind::HFE);
    plan.q.col(j).setConstant(kHfe);
    plan.q_landing[j] = kHfe;
  }
  return plan;
}

// The body pitched nose-up by `pitch` (about -y).
model::SensorData pitched(double pitch) {
  model::SensorData s;
  s.imu.q_WB = Eigen::Quaterniond(Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()));
  return s;
}

ExecutorSettings placement(double fraction) {
  ExecutorSettings s;
  s.landing_gravity_feedforward = false;
  s.touchdown_pitch_placement = fraction;
  s.touchdown_placement_max_rad = 0.4;
  s.touchdown_placement_lead_s = 0.05;  // whole from 0.45 s
  s.touchdown_placement_band_up_rad = 0.0;
  s.touchdown_placement_band_down_rad = 0.1;
  return s;
}

double hfe(const model::JointCommands& c, Leg leg) {
  return c[jointIndex(leg, JointKind::HFE)].q_des;
}

// Runs the executor from the start (pitch 0) to the flight time `t` at body pitch `pitch`.
model::JointCommands flyTo(PlanExecutor& ex, double t, double pitch) {
  model::JointCommands c{};
  ex.update(0.0, pitched(0.0), true, c);
  ex.update(0.21, pitched(pitch), false, c);  // past t2: flight
  ex.update(0.25, pitched(pitch), false, c);  // airborne (debounce over)
  ex.update(t, pitched(pitch), false, c);
  return c;
}

TEST(LandingPlacement, LegsSwingBackByTheNoseUpErrorInTheDescentOnly) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan();
  const double error = 0.2;  // 0.5 rad nose-up against the plan's 0.3
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    const model::JointCommands c = flyTo(ex, 0.3, kPlanPitch + error);  // before the apex
    for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
      EXPECT_NEAR(hfe(c, leg), kHfe, 1e-12);
  }
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    const model::JointCommands c = flyTo(ex, 0.4, kPlanPitch + error);  // half the ramp
    EXPECT_NEAR(hfe(c, Leg::LH), kHfe + 0.5 * error, 1e-9);
  }
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    const model::JointCommands c = flyTo(ex, 0.46, kPlanPitch + error);
    for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
      EXPECT_NEAR(hfe(c, leg), kHfe + error, 1e-9);
  }
  {
    PlanExecutor off(robot, plan, placement(0.0), 9.81);
    const model::JointCommands c = flyTo(off, 0.46, kPlanPitch + error);
    EXPECT_NEAR(hfe(c, Leg::RH), kHfe, 1e-12);
  }
}

// A platform's plan: its apex (0.47 s) comes later than touchdown_placement_lead_s before
// its touchdown (0.45 s). Until the apex the legs follow the plan (the offset was whole from
// the lift-off before session 21); from it the offset ramps in to be whole at the touchdown.
TEST(LandingPlacement, ALateApexRampsTheOffsetToTheTouchdown) {
  const model::RobotModel robot = loadRobot();
  planner::JumpPlan plan = makePlan();
  for (int k = 0; k < plan.numSamples(); ++k)
    plan.centroidal[k].vz = k * plan.dt < 0.47 ? 1.0 : -1.0;
  const double error = 0.2;
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.3, kPlanPitch + error), Leg::LF), kHfe, 1e-12);
  }
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.46, kPlanPitch + error), Leg::LF), kHfe, 1e-12);
  }
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.485, kPlanPitch + error), Leg::RH), kHfe + 0.5 * error, 1e-9);
  }
  {
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.5, kPlanPitch + error), Leg::RF), kHfe + error, 1e-9);
  }
}

TEST(LandingPlacement, BandAndClampBoundTheOffset) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan();
  {  // nose-down by 0.08: inside the nose-down band
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.46, kPlanPitch - 0.08), Leg::LF), kHfe, 1e-12);
  }
  {  // nose-down by 0.25: 0.15 beyond the band, legs forward
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.46, kPlanPitch - 0.25), Leg::LF), kHfe - 0.15, 1e-9);
  }
  {  // nose-up by 0.9: clamped at 0.4
    PlanExecutor ex(robot, plan, placement(1.0), 9.81);
    EXPECT_NEAR(hfe(flyTo(ex, 0.46, kPlanPitch + 0.9), Leg::RF), kHfe + 0.4, 1e-9);
  }
}

TEST(LandingPlacement, TouchdownOffsetIsHeldAndFadesWithTheHandover) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan();
  PlanExecutor ex(robot, plan, placement(1.0), 9.81);
  LandingHandover handover;
  for (int leg = 0; leg < model::kNumLegs; ++leg)
    handover.q[jointIndex(static_cast<Leg>(leg), JointKind::HFE)] = kHfe;
  handover.blend_start_s = 0.25;
  ex.setHandover(handover);
  model::JointCommands c = flyTo(ex, 0.48, kPlanPitch + 0.2);
  ex.update(0.49, pitched(kPlanPitch + 0.2), true, c);  // touchdown
  ASSERT_EQ(ex.phase(), JumpPhase::Landing);
  EXPECT_NEAR(hfe(c, Leg::LH), kHfe + 0.2, 1e-9);
  ex.update(0.6, pitched(0.0), true, c);  // the body pitches down: the offset stays
  EXPECT_NEAR(hfe(c, Leg::LH), kHfe + 0.2, 1e-9);
  ex.update(0.49 + 1.0, pitched(0.0), true, c);  // end of the landing: the hand-over posture
  EXPECT_NEAR(hfe(c, Leg::LH), kHfe, 1e-9);
}

// The body pitched nose-up by `pitch`, turning nose-up at `rate`.
model::SensorData pitching(double pitch, double rate) {
  model::SensorData s = pitched(pitch);
  s.imu.omega_B = Eigen::Vector3d(0.0, -rate, 0.0);  // about B's y = W's y here
  return s;
}

// No placement; the wheels brake against a wheelie beyond 0.4 rad (40 Nm/rad, 4 Nm s/rad,
// at most 8 Nm).
ExecutorSettings wheelieBrake() {
  ExecutorSettings s = placement(0.0);
  s.landing_pitch_limit_rad = 0.4;
  s.landing_pitch_kp = 40.0;
  s.landing_pitch_kd = 4.0;
  s.landing_pitch_max_nm = 8.0;
  return s;
}

double wheelTau(const model::JointCommands& c, Leg leg) {
  return c[jointIndex(leg, JointKind::Wheel)].tau_ff;
}

TEST(LandingPlacement, WheelsBrakeAgainstAWheelieBeyondTheLimitOnly) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan();
  PlanExecutor ex(robot, plan, wheelieBrake(), 9.81);
  model::JointCommands c = flyTo(ex, 0.48, kPlanPitch);
  ex.update(0.49, pitching(0.35, 1.0), true, c);  // touchdown below the limit: no brake
  ASSERT_EQ(ex.phase(), JumpPhase::Landing);
  for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
    EXPECT_DOUBLE_EQ(wheelTau(c, leg), 0.0);
  ex.update(0.5, pitching(0.45, 0.5), true, c);  // 0.05 beyond, rising at 0.5 rad/s
  for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
    EXPECT_NEAR(wheelTau(c, leg), -(40.0 * 0.05 + 4.0 * 0.5), 1e-9);
  ex.update(0.51, pitching(0.7, 3.0), true, c);  // far beyond: clamped
  EXPECT_NEAR(wheelTau(c, Leg::RH), -8.0, 1e-12);
  ex.update(0.52, pitching(0.45, -3.0), true, c);  // coming down fast: never a forward torque
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::LH), 0.0);
  ex.update(0.53, pitching(-0.1, -1.0), true, c);  // nose-down within 0.15: nothing
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::LF), 0.0);

  PlanExecutor off(robot, plan, placement(0.0), 9.81);  // kp = kd = 0 by default
  c = flyTo(off, 0.48, kPlanPitch);
  off.update(0.49, pitching(0.7, 3.0), true, c);
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::LH), 0.0);
}

// The wheelie brake's gains, against a stoppie too beyond 0.15 rad of nose-down pitch.
ExecutorSettings stoppieGuard() {
  ExecutorSettings s = wheelieBrake();
  s.landing_nose_down_limit_rad = 0.15;
  return s;
}

// An executor under `s` that has flown the test plan and touched down level (its landing).
struct LevelLanding {
  model::RobotModel robot = loadRobot();
  planner::JumpPlan plan = makePlan();
  PlanExecutor ex;
  model::JointCommands c{};
  explicit LevelLanding(const ExecutorSettings& s) : ex(robot, plan, s, 9.81) {
    c = flyTo(ex, 0.48, kPlanPitch);
    ex.update(0.49, pitching(0.0, 0.0), true, c);
  }
};

// A front-heavy robot tipping over its front wheels in a braking landing: beyond 0.15 rad of
// nose-down pitch every wheel drives (kp and kd as the wheelie's), never brakes.
TEST(LandingPlacement, WheelsDriveAgainstAStoppieBeyondTheLimitOnly) {
  ExecutorSettings s = stoppieGuard();
  LevelLanding l(s);
  ASSERT_EQ(l.ex.phase(), JumpPhase::Landing);
  PlanExecutor& ex = l.ex;
  model::JointCommands& c = l.c;
  ex.update(0.5, pitching(-0.14, -1.0), true, c);  // nose-down, falling, inside the limit
  for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
    EXPECT_DOUBLE_EQ(wheelTau(c, leg), 0.0);
  ex.update(0.51, pitching(-0.2, -0.5), true, c);  // 0.05 beyond, falling at 0.5 rad/s
  for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
    EXPECT_NEAR(wheelTau(c, leg), 40.0 * 0.05 + 4.0 * 0.5, 1e-9);
  ex.update(0.52, pitching(-0.6, -2.0), true, c);  // far beyond: clamped
  EXPECT_NEAR(wheelTau(c, Leg::LF), 8.0, 1e-12);
  ex.update(0.53, pitching(-0.2, 3.0), true, c);  // coming up fast: never a braking torque
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::RF), 0.0);

  s.landing_nose_down_limit_rad = -0.1;  // a limit below zero is refused by name
  EXPECT_THAT(
      test::errorOf<std::invalid_argument>([&] { return PlanExecutor(l.robot, l.plan, s, 9.81); }),
      test::HasSubstr("landing_nose_down_limit_rad"));
}

// The wheels' speed law (kd towards the landing's decelerating reference) never works against
// either guard on the pair the body tips over: a wheel spinning faster than its reference
// brakes, which tipped a front-heavy robot further over its front wheels than the stoppie
// guard's 8 Nm could hold (platform campaign, seed 23). Beyond a limit that pair's reference is
// held on the guard's side of the wheel's own rate; the other pair's, and within the limits
// every wheel's, is the landing's.
TEST(LandingPlacement, TheWheelsSpeedLawNeverWorksAgainstThePitchGuards) {
  LevelLanding l(stoppieGuard());
  ASSERT_EQ(l.ex.phase(), JumpPhase::Landing);
  PlanExecutor& ex = l.ex;
  model::JointCommands& c = l.c;
  const int lf = jointIndex(Leg::LF, JointKind::Wheel);
  const double reference = c[lf].qd_des;
  ASSERT_GT(reference, 5.0);  // rolling forward
  auto spinning = [&](double pitch, double rate, double wheel_rate) {
    model::SensorData d = pitching(pitch, rate);
    for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH})
      d.joints[jointIndex(leg, JointKind::Wheel)].qd = wheel_rate;
    return d;
  };
  // Within the limits the speed law brakes a wheel that spins too fast.
  ex.update(0.5, spinning(-0.1, -1.0, reference + 5.0), true, c);
  EXPECT_LT(c[lf].qd_des, reference + 5.0);
  // A stoppie beyond the limit: the wheel's reference is at least its own rate (no braking).
  ex.update(0.51, spinning(-0.3, -1.0, reference + 5.0), true, c);
  for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH}) {
    const model::JointCommand& w = c[jointIndex(leg, JointKind::Wheel)];
    if (model::isFront(leg))
      EXPECT_GE(w.qd_des, reference + 5.0);
    else
      EXPECT_LT(w.qd_des, reference + 5.0);  // the lifted hind pair keeps its speed law
    EXPECT_GT(w.tau_ff, 0.0);
  }
  // ... and a wheel slower than its reference keeps the reference (the law drives as well).
  ex.update(0.52, spinning(-0.3, -1.0, reference - 5.0), true, c);
  EXPECT_GT(c[lf].qd_des, reference - 5.0);
  // A wheelie beyond the limit: the reference at most the wheel's rate (no driving).
  ex.update(0.53, spinning(0.6, 1.0, reference - 5.0), true, c);
  for (const Leg leg : {Leg::LF, Leg::RF, Leg::LH, Leg::RH}) {
    const model::JointCommand& w = c[jointIndex(leg, JointKind::Wheel)];
    if (model::isFront(leg))
      EXPECT_GT(w.qd_des, reference - 5.0);  // the lifted front pair keeps its speed law
    else
      EXPECT_LE(w.qd_des, reference - 5.0);
    EXPECT_LT(w.tau_ff, 0.0);
  }
}

// After a backflip the running (unwrapped) pitch is a turn more than the body's attitude: the
// wheelie brake acts on the folded pitch, as after any other jump.
TEST(LandingPlacement, TheWheelieBrakeSeesTheAttitudeAfterAFullTurn) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan();
  PlanExecutor ex(robot, plan, wheelieBrake(), 9.81);
  model::JointCommands c{};
  ex.update(0.0, pitched(0.0), true, c);
  // A full backward turn in flight, in steps the unwrapping follows.
  for (int i = 1; i <= 64; ++i)
    ex.update(0.21 + 0.004 * i, pitched(2.0 * M_PI * i / 64.0 + 0.1), false, c);
  ex.update(0.49, pitching(2.0 * M_PI + 0.1, 0.5), true, c);  // upright: no brake
  ASSERT_EQ(ex.phase(), JumpPhase::Landing);
  EXPECT_DOUBLE_EQ(wheelTau(c, Leg::LH), 0.0);
  ex.update(0.5, pitching(2.0 * M_PI + 0.45, 0.5), true, c);  // 0.05 beyond the limit
  EXPECT_NEAR(wheelTau(c, Leg::LH), -(40.0 * 0.05 + 4.0 * 0.5), 1e-9);
}

TEST(LandingPlacement, SettingsOutOfRangeAreRejectedByName) {
  const model::RobotModel robot = loadRobot();
  const planner::JumpPlan plan = makePlan();
  const std::string fields[] = {"touchdown_pitch_placement",
                                "touchdown_placement_max_rad",
                                "touchdown_placement_lead_s",
                                "touchdown_placement_band_up_rad",
                                "touchdown_placement_band_down_rad",
                                "landing_pitch_kp",
                                "landing_pitch_max_nm"};
  for (const std::string& field : fields) {
    ExecutorSettings s = placement(1.0);
    if (field == "touchdown_pitch_placement") s.touchdown_pitch_placement = 1.5;
    if (field == "touchdown_placement_max_rad") s.touchdown_placement_max_rad = -0.1;
    if (field == "touchdown_placement_lead_s") s.touchdown_placement_lead_s = std::nan("");
    if (field == "touchdown_placement_band_up_rad") s.touchdown_placement_band_up_rad = -1.0;
    if (field == "touchdown_placement_band_down_rad") s.touchdown_placement_band_down_rad = -1.0;
    if (field == "landing_pitch_kp") s.landing_pitch_kp = -1.0;
    if (field == "landing_pitch_max_nm") s.landing_pitch_max_nm = std::nan("");
    EXPECT_THAT(
        test::errorOf<std::invalid_argument>([&] { return PlanExecutor(robot, plan, s, 9.81); }),
        test::HasSubstr(field));
  }
}

}  // namespace
}  // namespace wj::sim
