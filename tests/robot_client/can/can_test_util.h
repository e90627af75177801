#pragma once
// A CanRobot on four in-process buses with 16 MIT motor emulators, stepped by hand.

#include <array>
#include <filesystem>
#include <memory>
#include <optional>

#include "can/can_bus.h"
#include "can/can_robot.h"
#include "can/motor_emulator.h"
#include "robot_model/robot_model.h"
#include "test_robot.h"

namespace wj::can::test {

using wj::test::loadRobot;

/// An IMU that reports a fixed reading.
class FixedImu final : public ImuSource {
 public:
  bool read(model::ImuReading& out) override {
    out = reading;
    return true;
  }
  model::ImuReading reading;
};

/// Motor states, motor frame, per joint.
using MotorStates = std::array<MitState, model::kNumJoints>;

struct Harness {
  Harness(const model::RobotModel& model, const CanRobotSettings& s, std::size_t capacity = 64)
      : settings(s) {
    std::array<CanBus*, model::kNumLegs> robot_sides{};
    for (int leg = 0; leg < model::kNumLegs; ++leg) {
      buses[leg] = std::make_unique<InProcessCanBus>(capacity);
      robot_sides[leg] = &buses[leg]->robotSide();
    }
    for (int j = 0; j < model::kNumJoints; ++j) {
      MitMotorConfig c;
      c.can_id = s.motors[j].can_id;
      c.host_can_id = s.host_can_id;
      c.limits = s.limitsOf(j);
      c.wrap_position = model.joints()[j].continuous;
      motors[j].emplace(buses[j / model::kJointsPerLeg]->motorSide(), c);
    }
    robot.emplace(model, s, robot_sides, imu);
  }

  /// The emulators take the frames waiting on their buses.
  void serviceMotors() {
    for (int leg = 0; leg < model::kNumLegs; ++leg) {
      CanFrame f;
      while (buses[leg]->motorSide().receive(f))
        for (int k = 0; k < model::kJointsPerLeg; ++k)
          if (motors[leg * model::kJointsPerLeg + k]->handle(f)) break;
    }
  }
  /// The emulators answer with `states`.
  void respond(const MotorStates& states) {
    for (int j = 0; j < model::kNumJoints; ++j) motors[j]->respond(states[j]);
  }
  /// One period: write, the motors receive and answer, advance, read.
  void step(const model::JointCommands& commands, const MotorStates& states,
            model::SensorData& out) {
    robot->write(commands);
    serviceMotors();
    respond(states);
    robot->advance();
    robot->read(out);
  }
  /// enable(), the motors answer with `states`, read.
  void enable(const MotorStates& states, model::SensorData& out) {
    robot->enable();
    serviceMotors();
    respond(states);
    robot->read(out);
  }

  CanRobotSettings settings;
  FixedImu imu;
  std::array<std::unique_ptr<InProcessCanBus>, model::kNumLegs> buses;
  std::array<std::optional<MitMotorEmulator>, model::kNumJoints> motors;
  std::optional<CanRobot> robot;
};

}  // namespace wj::can::test
