// CanRobot with MIT motor emulators on in-process buses: the special frames, commands that
// arrive quantized through the motor map, decoded replies, wheel unwrapping, and the faults
// (missing replies, error frames, refused frames, unknown and malformed frames).
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "can_test_util.h"

namespace wj::can {
namespace {

using model::jointIndex;
using model::JointKind;
using model::kJointsPerLeg;
using model::kNumJoints;
using model::kNumLegs;
using model::Leg;
using test::Harness;
using test::MotorStates;

double wrapSymmetric(double d, double span) {
  double w = std::fmod(d + 0.5 * span, span);
  if (w < 0.0) w += span;
  return w - 0.5 * span;
}

// A motor map with mirrored motors and offsets, as a real robot has.
CanRobotSettings mappedSettings() {
  CanRobotSettings s;
  for (int j = 0; j < kNumJoints; ++j) {
    s.motors[j].direction = (j % 3 == 1) ? -1.0 : 1.0;
    s.motors[j].offset_rad = (j % kJointsPerLeg == 3) ? 0.0 : 0.1 * (j % 5) - 0.2;
  }
  s.motors[jointIndex(Leg::RH, JointKind::HAA)].can_id = 17;  // ids need not be 1..4
  return s;
}

std::vector<CanFrame> drain(CanBus& bus) {
  std::vector<CanFrame> frames;
  CanFrame f;
  while (bus.receive(f)) frames.push_back(f);
  return frames;
}

TEST(CanRobot, EnableZeroAndDisableSendTheSpecialFrames) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, mappedSettings());
  model::JointCommands commands{};
  h.robot->write(commands);
  for (auto& bus : h.buses) EXPECT_EQ(bus->pending(BusSide::Motor), 0u) << "disabled: silent";

  const std::array<std::pair<std::function<bool()>, MitSpecial>, 3> steps = {
      {{[&] { return h.robot->enable(); }, MitSpecial::EnterMotorMode},
       {[&] { return h.robot->zero(); }, MitSpecial::ZeroPosition},
       {[&] { return h.robot->disable(); }, MitSpecial::ExitMotorMode}}};
  for (const auto& [action, special] : steps) {
    ASSERT_TRUE(action());
    for (int leg = 0; leg < kNumLegs; ++leg) {
      const auto frames = drain(h.buses[leg]->motorSide());
      ASSERT_EQ(frames.size(), 4u);
      for (int k = 0; k < kJointsPerLeg; ++k) {
        EXPECT_EQ(frames[k].id, h.settings.motors[leg * kJointsPerLeg + k].can_id);
        EXPECT_EQ(parseSpecialFrame(frames[k]), special);
      }
    }
  }
}

TEST(CanRobot, EmulatorsFollowEnableAndExit) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, mappedSettings());
  model::SensorData out;
  MotorStates states{};
  h.enable(states, out);
  for (auto& motor : h.motors) EXPECT_TRUE(motor->enabled());
  EXPECT_FALSE(h.robot->hasFault());
  h.robot->disable();
  h.serviceMotors();
  for (auto& motor : h.motors) {
    EXPECT_FALSE(motor->enabled());
    EXPECT_DOUBLE_EQ(motor->physicalCommand().kp, 0.0);
  }
  // Disabled: nothing is sent and no answer is expected.
  for (int k = 0; k < 10; ++k) h.step({}, states, out);
  EXPECT_FALSE(h.robot->hasFault());
  for (auto& bus : h.buses) EXPECT_EQ(bus->motorSide().stats().received, 8u);  // 4 enter + 4 exit
}

TEST(CanRobot, CommandsArriveQuantizedThroughTheMotorMap) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, mappedSettings());
  model::SensorData out;
  MotorStates states{};
  h.enable(states, out);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int period = 0; period < 200; ++period) {
    model::JointCommands c{};
    for (int j = 0; j < kNumJoints; ++j) {
      const model::JointSpec& spec = m.joints()[j];
      const double lo = spec.continuous ? -30.0 : spec.lower_rad;
      const double hi = spec.continuous ? 30.0 : spec.upper_rad;
      c[j] = {lo + (hi - lo) * u(rng), -40.0 + 80.0 * u(rng), 500.0 * u(rng), 5.0 * u(rng),
              -42.0 + 84.0 * u(rng)};
    }
    h.step(c, states, out);
    for (int j = 0; j < kNumJoints; ++j) {
      ASSERT_EQ(h.robot->commandClamps()[j], 0) << j;
      const MotorMapEntry& mm = h.settings.motors[j];
      const MitLimits& l = h.settings.limitsOf(j);
      const MitSteps st = mitSteps(l);
      const MitCommand& got = h.motors[j]->lastCommand();
      // Wheels: the position is sent wrapped into the range.
      EXPECT_LE(std::abs(wrapSymmetric(got.p_des - mm.direction * (c[j].q_des - mm.offset_rad),
                                       l.p_max - l.p_min)),
                0.5 * st.p + 1e-9)
          << j;
      EXPECT_LE(std::abs(got.v_des - mm.direction * c[j].qd_des), 0.5 * st.v + 1e-9) << j;
      EXPECT_LE(std::abs(got.kp - c[j].kp), 0.5 * st.kp + 1e-9) << j;
      EXPECT_LE(std::abs(got.kd - c[j].kd), 0.5 * st.kd + 1e-9) << j;
      EXPECT_LE(std::abs(got.t_ff - mm.direction * c[j].tau_ff), 0.5 * st.t + 1e-9) << j;
    }
  }
  EXPECT_FALSE(h.robot->hasFault());
}

TEST(CanRobot, ClampedCommandsAreReported) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, CanRobotSettings{});
  model::SensorData out;
  h.enable({}, out);
  model::JointCommands c{};
  c[1].tau_ff = 100.0;
  c[2].kd = 8.0;
  h.step(c, {}, out);
  EXPECT_EQ(h.robot->commandClamps()[1], kClampTorque);
  EXPECT_EQ(h.robot->commandClamps()[2], kClampKd);
  EXPECT_EQ(h.robot->commandClamps()[0], 0);
  EXPECT_DOUBLE_EQ(h.motors[1]->lastCommand().t_ff, 48.0);
  EXPECT_DOUBLE_EQ(h.motors[2]->lastCommand().kd, 5.0);
}

TEST(CanRobot, RepliesAreDecodedIntoTheJointFrame) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, mappedSettings());
  h.imu.reading.omega_B = Eigen::Vector3d(0.1, -0.2, 0.3);
  model::SensorData out;
  h.enable({}, out);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int period = 0; period < 100; ++period) {
    MotorStates s{};
    for (int j = 0; j < kNumJoints; ++j)
      s[j] = {(j % kJointsPerLeg == 3) ? 0.0 : 2.0 * u(rng), 40.0 * u(rng), 42.0 * u(rng)};
    h.step({}, s, out);
    for (int j = 0; j < kNumJoints; ++j) {
      const MotorMapEntry& mm = h.settings.motors[j];
      const MitSteps st = mitSteps(h.settings.limitsOf(j));
      EXPECT_NEAR(out.joints[j].q, mm.direction * s[j].p + mm.offset_rad, 0.5 * st.p + 1e-9);
      EXPECT_NEAR(out.joints[j].qd, mm.direction * s[j].v, 0.5 * st.v + 1e-9);
      EXPECT_NEAR(out.joints[j].tau, mm.direction * s[j].t, 0.5 * st.t + 1e-9);
    }
  }
  EXPECT_EQ(out.imu.omega_B, h.imu.reading.omega_B);
  EXPECT_NEAR(out.t, 100 * 1e-3, 1e-12);
  EXPECT_FALSE(h.robot->hasFault());
  EXPECT_DOUBLE_EQ(h.robot->faults().joints[5].last_reply_age_s, 0.0);
}

TEST(CanRobot, WheelAnglesAreUnwrappedPastThePositionRange) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, mappedSettings());
  model::SensorData out;
  MotorStates s{};
  h.enable(s, out);
  const double speed = 40.0;  // rad/s, 40 rad in 1 s: more than three times the range
  const MitSteps st = mitSteps(h.settings.limits[3]);
  for (int period = 1; period <= 1000; ++period) {
    model::JointCommands c{};
    for (const Leg leg : model::kLegs) {
      const int w = jointIndex(leg, JointKind::Wheel);
      // Position hold 0.1 rad ahead of the measured angle.
      c[w] = {out.joints[w].q + 0.1, 0.0, 10.0, 0.0, 0.0};
      s[w] = {speed * period * 1e-3 * (w == 7 ? -1.0 : 1.0), 0.0, 0.0};
    }
    h.step(c, s, out);
    for (const Leg leg : model::kLegs) {
      const int w = jointIndex(leg, JointKind::Wheel);
      const double dir = h.settings.motors[w].direction;
      ASSERT_NEAR(out.joints[w].q, dir * s[w].p, 0.5 * st.p + 1e-9) << period;
      // The drive sees the same error p_des - p as the controller intended (0.1 rad, within a
      // period of motion and quantization).
      const MitLimits& l = h.settings.limits[3];
      const double span = l.p_max - l.p_min;
      const double reported = std::fmod(std::fmod(s[w].p - l.p_min, span) + span, span) + l.p_min;
      ASSERT_NEAR(wrapSymmetric(h.motors[w]->lastCommand().p_des - reported, span), dir * 0.1,
                  speed * 1e-3 + st.p)
          << period;
    }
  }
}

TEST(CanRobot, ZeroMakesThePresentPositionTheOffset) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, mappedSettings());
  model::SensorData out;
  MotorStates s{};
  for (int j = 0; j < kNumJoints; ++j) s[j] = {0.3 + 0.01 * j, 0.0, 0.0};
  h.enable(s, out);
  h.step({}, s, out);
  ASSERT_TRUE(h.robot->zero());
  h.serviceMotors();
  h.respond(s);
  h.robot->read(out);
  const MitSteps st = mitSteps(MitLimits{});
  for (int j = 0; j < kNumJoints; ++j) {
    EXPECT_NEAR(h.motors[j]->zeroOffset(), s[j].p, 1e-12);
    // The calibration posture now reads as offset_rad.
    EXPECT_NEAR(out.joints[j].q, h.settings.motors[j].offset_rad, 0.5 * st.p + 1e-9) << j;
  }
  // Commands are relative to the new zero: the drive targets the same physical angle.
  model::JointCommands c{};
  const int j = jointIndex(Leg::LF, JointKind::KFE);
  c[j] = {h.settings.motors[j].offset_rad, 0.0, 50.0, 1.0, 0.0};
  h.step(c, s, out);
  EXPECT_NEAR(h.motors[j]->physicalCommand().p_des, s[j].p, 0.5 * st.p + 1e-9);
  EXPECT_FALSE(h.robot->hasFault());
}

class MissingReplies : public testing::TestWithParam<int> {};

TEST_P(MissingReplies, RaiseTheFaultAfterNPeriods) {
  const int n = GetParam();
  const model::RobotModel m = test::loadRobot();
  CanRobotSettings settings;
  settings.reply_timeout_periods = n;
  Harness h(m, settings);
  model::SensorData out;
  h.enable({}, out);
  h.step({}, {}, out);
  const int j = jointIndex(Leg::RF, JointKind::HFE);
  h.motors[j]->setSilent(true);
  for (int k = 1; k <= n; ++k) {
    EXPECT_FALSE(h.robot->hasFault()) << k;
    h.step({}, {}, out);
    EXPECT_EQ(h.robot->faults().joints[j].missing_replies, k);
    EXPECT_NEAR(h.robot->faults().joints[j].last_reply_age_s, k * 1e-3, 1e-12);
  }
  EXPECT_TRUE(h.robot->hasFault());
  EXPECT_TRUE(h.robot->faults().joints[j].reply_timeout);
  for (int i = 0; i < kNumJoints; ++i)
    if (i != j) {
      EXPECT_FALSE(h.robot->faults().joints[i].faulted()) << i;
    }
  // It answers again: the count restarts, the fault stays latched until cleared.
  h.motors[j]->setSilent(false);
  h.step({}, {}, out);
  EXPECT_EQ(h.robot->faults().joints[j].missing_replies, 0);
  EXPECT_TRUE(h.robot->hasFault());
  h.robot->clearFaults();
  EXPECT_FALSE(h.robot->hasFault());
}

INSTANTIATE_TEST_SUITE_P(CanRobot, MissingReplies, testing::Values(1, 3, 5));

TEST(CanRobot, ErrorFrameRaisesTheFaultOfItsBus) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, CanRobotSettings{});
  model::SensorData out;
  h.enable({}, out);
  h.step({}, {}, out);
  EXPECT_FALSE(h.robot->hasFault());
  ASSERT_TRUE(h.motors[jointIndex(Leg::LH, JointKind::KFE)]->sendErrorFrame(0x40));
  h.step({}, {}, out);
  EXPECT_TRUE(h.robot->hasFault());
  for (int j = 0; j < kNumJoints; ++j)
    EXPECT_EQ(h.robot->faults().joints[j].error_frame, j / kJointsPerLeg == 2) << j;
  EXPECT_EQ(h.robot->faults().buses[2].error_frames, 1u);
  EXPECT_EQ(h.robot->faults().buses[2].last_error_class, 0x40u);
  // Injected by the bus itself (controller error), on another leg.
  h.buses[0]->injectErrorFrame(BusSide::Robot, 0x04);
  h.step({}, {}, out);
  EXPECT_TRUE(h.robot->faults().joints[0].error_frame);
  EXPECT_EQ(h.robot->faults().buses[0].last_error_class, 0x04u);
}

TEST(CanRobot, UnknownAndMalformedFramesAreCountedNotUsed) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, CanRobotSettings{});
  model::SensorData out;
  h.enable({}, out);
  CanBus& motor_side = h.buses[1]->motorSide();
  CanFrame f;
  encodeReply(MitLimits{}, 0, 9, {1.0, 0.0, 0.0}, f);  // no motor 9 on this bus
  motor_side.send(f);
  encodeReply(MitLimits{}, 0x55, 2, {1.0, 0.0, 0.0}, f);  // not to this host
  motor_side.send(f);
  encodeReply(MitLimits{}, 0, 2, {1.0, 0.0, 0.0}, f);
  f.dlc = 5;  // truncated answer of motor 2
  motor_side.send(f);
  h.robot->read(out);
  EXPECT_EQ(h.robot->faults().buses[1].unknown_frames, 2u);
  EXPECT_EQ(h.robot->faults().joints[jointIndex(Leg::RF, JointKind::HFE)].malformed_replies, 1u);
  // Still the answer to enable() (0 rad), not the truncated 1 rad.
  EXPECT_LT(std::abs(out.joints[jointIndex(Leg::RF, JointKind::HFE)].q), 1e-3);
}

TEST(CanRobot, BusThatRefusesFramesRaisesTheTimeout) {
  const model::RobotModel m = test::loadRobot();
  Harness h(m, CanRobotSettings{}, 4);
  model::SensorData out;
  h.robot->enable();  // 4 frames per bus: the queues are full, and nobody drains them
  for (int k = 0; k < 3; ++k) {
    h.robot->write({});
    h.robot->advance();
    h.robot->read(out);
  }
  EXPECT_EQ(h.robot->faults().buses[3].send_failures, 12u);
  EXPECT_TRUE(h.robot->hasFault());
  EXPECT_TRUE(h.robot->faults().joints[15].reply_timeout);
}

TEST(CanRobot, RefusesSettingsThatDoNotFit) {
  const model::RobotModel m = test::loadRobot();
  test::FixedImu imu;
  InProcessCanBus bus;
  std::array<CanBus*, kNumLegs> buses = {&bus.robotSide(), &bus.robotSide(), nullptr,
                                         &bus.robotSide()};
  EXPECT_THROW(CanRobot(m, CanRobotSettings{}, buses, imu), std::invalid_argument);
  buses[2] = &bus.robotSide();
  CanRobotSettings s;
  s.limits[0].t_max = 10.0;
  EXPECT_THROW(CanRobot(m, s, buses, imu), std::invalid_argument);
  EXPECT_NO_THROW(CanRobot(m, CanRobotSettings{}, buses, imu));
}

}  // namespace
}  // namespace wj::can
