// The Simbody robot behind real CAN frames: standing under PD through CAN holds the posture
// like the SimRobot driven directly (within the quantization), the decoded measurements match
// the ground truth, wheels roll past the position range, and faults reach the CAN backend.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "can/sim_via_can.h"
#include "sim/reference_plans.h"
#include "sim/statics.h"
#include "test_robot.h"

namespace wj::can {
namespace {

using model::jointIndex;
using model::JointKind;
using model::kNumJoints;
using model::Leg;

constexpr double kG = 9.81;

using wj::test::loadRobot;

// Stiff PD on the legs plus the statics feedforward, wheels on speed control.
model::JointCommands holdPosture(const model::RobotModel& m, const sim::JointVector& q,
                                 double wheel_speed = 0.0) {
  const sim::StandingStatics st = sim::calcStandingStatics(m, q, kG);
  model::JointCommands c{};
  for (int j = 0; j < kNumJoints; ++j) {
    if (m.joints()[j].kind == JointKind::Wheel)
      c[j] = {0.0, wheel_speed, 0.0, 1.0, 0.0};
    else
      c[j] = {q[j], 0.0, 400.0, 4.0, st.tau[j]};
  }
  return c;
}

sim::RobotPlacement standing(const model::RobotModel& m, const sim::JointVector& q) {
  sim::RobotPlacement p;
  p.q = q;
  p.X_WB.translation().z() = sim::calcStandingStatics(m, q, kG).base_height_m + 0.002;
  return p;
}

// A motor map with mirrored motors and offsets, so that the bridge exercises it.
CanRobotSettings mappedSettings() {
  CanRobotSettings s;
  for (int j = 0; j < kNumJoints; ++j) {
    s.motors[j].direction = (j % 2 == 1) ? -1.0 : 1.0;
    s.motors[j].offset_rad = (j % model::kJointsPerLeg == 3) ? 0.0 : 0.05 * (j % 4) - 0.1;
  }
  return s;
}

TEST(SimViaCan, StandingThroughCanMatchesTheDirectSimulation) {
  const model::RobotModel m = loadRobot();
  const sim::SimSettings settings;
  sim::SimRobot direct(m, settings);  // driven with the original commands
  sim::SimRobot replay(m, settings);  // driven with the commands the emulators decoded
  SimViaCan via(m, settings, mappedSettings());
  const sim::JointVector q0 = sim::standingPosture(m, 0.36);
  direct.reset(standing(m, q0));
  replay.reset(standing(m, q0));
  via.reset(standing(m, q0));
  const model::JointCommands hold = holdPosture(m, q0);
  const MitSteps st = mitSteps(MitLimits{});

  sim::GroundTruth gt_direct, gt_via, gt_replay;
  model::SensorData measured;
  double worst_leg = 0.0, worst_wheel = 0.0, worst_replay = 0.0, worst_meas = 0.0,
         worst_height = 0.0;
  sim::JointVector prev_q = q0;
  for (int k = 0; k < 1000; ++k) {  // 1 s
    via.read(measured);
    via.write(hold);
    via.advance();
    direct.write(hold);
    direct.advance();
    replay.write(via.appliedCommands());
    replay.advance();
    direct.calcGroundTruth(gt_direct, false);
    replay.calcGroundTruth(gt_replay, false);
    via.sim().calcGroundTruth(gt_via, false);
    worst_replay = std::max(worst_replay, (gt_via.q - gt_replay.q).cwiseAbs().maxCoeff());
    for (int j = 0; j < kNumJoints; ++j) {
      const double d = std::abs(gt_via.q[j] - gt_direct.q[j]);
      double& worst = (j % model::kJointsPerLeg == 3) ? worst_wheel : worst_leg;
      worst = std::max(worst, d);
      if (k > 0) worst_meas = std::max(worst_meas, std::abs(measured.joints[j].q - prev_q[j]));
    }
    prev_q = gt_via.q;
    worst_height = std::max(
        worst_height, std::abs(gt_via.X_WB.translation().z() - gt_direct.X_WB.translation().z()));
  }
  via.read(measured);
  std::printf(
      "worst |q_can - q_direct|: legs %.3g rad, wheels %.3g rad (position step %.3g rad, "
      "velocity step %.3g rad/s); worst |measured - truth| %.3g rad; base height "
      "difference %.3g m; against the replay of the decoded commands %.3g rad\n",
      worst_leg, worst_wheel, st.p, st.v, worst_meas, worst_height, worst_replay);
  // The bridge adds nothing but the codec: the SimRobot fed the decoded commands moves alike.
  EXPECT_LT(worst_replay, 1e-9);
  // The commands differ by at most half a step per field: the legs agree within a few
  // position steps. A wheel told to stand still is sent v_des = -0.011 rad/s (0 is not a code
  // of the symmetric 12-bit range, docs/can.md): the robot creeps, ~0.02 rad of wheel in 1 s.
  EXPECT_LT(worst_leg, 5.0 * st.p);
  EXPECT_LT(worst_wheel, 0.05);
  EXPECT_LE(worst_meas, 0.5 * st.p + 1e-9);
  EXPECT_LT(worst_height, 1e-4);
  EXPECT_FALSE(via.canRobot().hasFault());
  EXPECT_EQ(via.unhandledFrames(), 0u);
  EXPECT_NEAR(measured.t, 1.0, 1e-9);
  // Commands really went through the codec: the applied ones are quantized, not the originals.
  const int hfe = jointIndex(Leg::LH, JointKind::HFE);
  EXPECT_NE(via.appliedCommands()[hfe].tau_ff, hold[hfe].tau_ff);
  EXPECT_NEAR(via.appliedCommands()[hfe].tau_ff, hold[hfe].tau_ff, 0.5 * st.t + 1e-9);
}

TEST(SimViaCan, WheelsRollPastThePositionRange) {
  const model::RobotModel m = loadRobot();
  SimViaCan via(m, sim::SimSettings{}, mappedSettings());
  const sim::JointVector q0 = sim::standingPosture(m, 0.36);
  via.reset(standing(m, q0));
  const model::JointCommands roll = holdPosture(m, q0, 15.0);
  sim::GroundTruth gt;
  model::SensorData measured;
  for (int k = 0; k < 2000; ++k) {
    via.read(measured);
    via.write(roll);
    via.advance();
  }
  via.read(measured);
  via.sim().calcGroundTruth(gt, false);
  const MitSteps st = mitSteps(MitLimits{});
  for (const Leg leg : model::kLegs) {
    const int w = jointIndex(leg, JointKind::Wheel);
    EXPECT_GT(std::abs(gt.q[w]), 20.0) << "the wheel turned well past the +-12.5 rad range";
    EXPECT_NEAR(measured.joints[w].q, gt.q[w], 0.5 * st.p + 1e-9);
    EXPECT_NEAR(measured.joints[w].qd, gt.qd[w], 0.5 * st.v + 1e-9);
  }
  EXPECT_GT(gt.X_WB.translation().x(), 1.0);
  EXPECT_FALSE(via.canRobot().hasFault());
}

TEST(SimViaCan, DisabledMotorsApplyNoTorque) {
  const model::RobotModel m = loadRobot();
  SimViaCan via(m, sim::SimSettings{}, CanRobotSettings{});
  const sim::JointVector q0 = sim::standingPosture(m, 0.36);
  via.reset(standing(m, q0));
  const model::JointCommands hold = holdPosture(m, q0);
  sim::GroundTruth gt;
  via.sim().calcGroundTruth(gt, false);
  const double h0 = gt.X_WB.translation().z();
  ASSERT_TRUE(via.canRobot().disable());
  for (int k = 0; k < 300; ++k) {
    via.write(hold);
    via.advance();
  }
  via.sim().calcGroundTruth(gt, false);
  EXPECT_LT(gt.X_WB.translation().z(), h0 - 0.05) << "the robot should have collapsed";
  for (int j = 0; j < kNumJoints; ++j) EXPECT_FALSE(via.motor(j).enabled());
  EXPECT_FALSE(via.canRobot().hasFault());
}

TEST(SimViaCan, SilentMotorAndBusErrorReachTheBackend) {
  const model::RobotModel m = loadRobot();
  SimViaCan via(m, sim::SimSettings{}, CanRobotSettings{});
  const sim::JointVector q0 = sim::standingPosture(m, 0.36);
  via.reset(standing(m, q0));
  const model::JointCommands hold = holdPosture(m, q0);
  model::SensorData measured;
  const int j = jointIndex(Leg::RH, JointKind::KFE);
  via.read(measured);  // the answers to enable()
  via.motor(j).setSilent(true);
  int periods_to_fault = 0;
  while (!via.canRobot().hasFault() && periods_to_fault < 100) {
    via.write(hold);
    via.advance();
    via.read(measured);
    ++periods_to_fault;
  }
  EXPECT_EQ(periods_to_fault, 3);
  EXPECT_TRUE(via.canRobot().faults().joints[j].reply_timeout);
  // reset() brings the CAN side back to power-on.
  via.reset(standing(m, q0));
  via.read(measured);
  EXPECT_FALSE(via.canRobot().hasFault());
  via.bus(1).injectErrorFrame(BusSide::Robot, 0x40);
  via.read(measured);
  EXPECT_TRUE(via.canRobot().faults().joints[jointIndex(Leg::RF, JointKind::HAA)].error_frame);
}

}  // namespace
}  // namespace wj::can
