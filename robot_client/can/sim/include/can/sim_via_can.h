#pragma once
/// @file The Simbody robot behind real CAN frames: CanRobot -> in-process buses -> MIT motor
/// emulators -> SimRobot, so that a simulated run exercises the codec, the quantization, the
/// motor map and the fault detection of the hardware backend (robot_client --via-can).

#include <array>
#include <cstddef>
#include <optional>

#include "can/can_bus.h"
#include "can/can_robot.h"
#include "can/can_settings.h"
#include "can/motor_emulator.h"
#include "robot_model/robot_interface.h"
#include "sim/settings.h"
#include "sim/sim_robot.h"

namespace wj::can {

/// A SimRobot driven through CAN: write() goes through CanRobot::write (encode, motor map,
/// clamping) onto four InProcessCanBus, the 16 MitMotorEmulator decode the frames (with the
/// protocol's quantization) and their commands drive the SimRobot; advance() advances the
/// SimRobot one period and the emulators answer with its joint states (as its read() reports
/// them: with sensor noise if enabled); read() returns what CanRobot decoded (quantized) plus
/// the SimRobot's IMU, at the simulation time.
///
/// The motors are enabled on construction and reset() (drives powered on, like SimRobot's);
/// canRobot().disable() and the emulators' fault injection are available for tests. Same
/// real-time rules as the parts: no allocation, lock or log in read(), write(), advance().
class SimViaCan final : public model::RobotInterface {
 public:
  /// Builds the simulation and the CAN side. Throws std::invalid_argument if the settings
  /// are out of range, do not fit `model`, or the control periods differ.
  SimViaCan(const model::RobotModel& model, const sim::SimSettings& sim_settings,
            const CanRobotSettings& can_settings, std::size_t queue_capacity = 64);
  SimViaCan(const SimViaCan&) = delete;
  SimViaCan& operator=(const SimViaCan&) = delete;

  // RobotInterface ---------------------------------------------------------------------------
  double controlPeriod() const override { return sim_.controlPeriod(); }
  void read(model::SensorData& out) override;
  void write(const model::JointCommands& commands) override;
  void advance() override;

  /// Resets the simulation to `placement` and the CAN side to power-on (empty queues, fresh
  /// CanRobot and emulators), then enables the motors. Prefer this to sim().reset(), which
  /// leaves the CAN side's unwrapped wheel angles and emulator zeros as they were.
  void reset(const sim::RobotPlacement& placement);

  /// The simulated robot: ground truth, settings.
  sim::SimRobot& sim() { return sim_; }
  /// The CAN backend: faults, enable/disable/zero, clamping.
  CanRobot& canRobot() { return *can_robot_; }
  /// The emulated motor of joint `j` (jointIndex order): fault injection, counters.
  MitMotorEmulator& motor(int j) { return *motors_[static_cast<std::size_t>(j)]; }
  /// The bus of leg `leg` (leg order): error injection, queue state.
  InProcessCanBus& bus(int leg) { return *buses_[static_cast<std::size_t>(leg)]; }
  /// The commands the SimRobot received in the last write(), in joint frame (quantized).
  const model::JointCommands& appliedCommands() const { return applied_; }
  /// Frames on the motor side addressed to no emulated motor, since the last reset().
  std::uint64_t unhandledFrames() const { return unhandled_frames_; }

 private:
  class SimImu final : public ImuSource {
   public:
    explicit SimImu(const model::SensorData& source) : source_(&source) {}
    bool read(model::ImuReading& out) override {
      out = source_->imu;
      return true;
    }

   private:
    const model::SensorData* source_;
  };

  void serviceMotors();
  void respondAll();
  void buildCanSide();

  CanRobotSettings can_settings_;
  sim::SimRobot sim_;
  model::SensorData measured_;  ///< SimRobot::read() at the end of the last period
  SimImu imu_{measured_};
  std::array<std::optional<InProcessCanBus>, model::kNumLegs> buses_;
  std::array<std::optional<MitMotorEmulator>, model::kNumJoints> motors_;
  std::optional<CanRobot> can_robot_;
  std::array<bool, model::kNumJoints> continuous_{};
  model::JointCommands applied_{};
  std::uint64_t unhandled_frames_ = 0;
};

}  // namespace wj::can
