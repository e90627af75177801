#pragma once
/// @file The CAN hardware backend of the robot: 16 MIT-mode motors on four buses (one per
/// leg) behind the RobotInterface, with missing-reply and error-frame fault detection.

#include <array>
#include <cstdint>
#include <limits>
#include <memory>

#include "can/can_bus.h"
#include "can/can_settings.h"
#include "can/mit_codec.h"
#include "robot_model/robot_interface.h"
#include "robot_model/robot_model.h"

namespace wj::can {

/// Source of IMU readings: a serial IMU on hardware, the simulated IMU in simulation.
/// read() is called from the control loop: no allocation, lock or log.
class ImuSource {
 public:
  virtual ~ImuSource() = default;
  /// Writes the latest reading into `out`; false if there was none since the last call
  /// (`out` is then left unchanged).
  virtual bool read(model::ImuReading& out) = 0;
};

/// Fault state of one joint's motor.
struct JointFault {
  /// Consecutive periods without an answer to a command (0 after each answer).
  int missing_replies = 0;
  /// Latched: missing_replies reached CanRobotSettings::reply_timeout_periods.
  bool reply_timeout = false;
  /// Latched: an error frame arrived on this joint's bus.
  bool error_frame = false;
  /// Time since the last answer [s]: read() calls since then times the control period;
  /// +infinity before the first answer.
  double last_reply_age_s = std::numeric_limits<double>::infinity();
  /// Answers with this motor's id that could not be decoded (wrong length, RTR).
  std::uint32_t malformed_replies = 0;

  /// True for a timeout or an error frame.
  bool faulted() const { return reply_timeout || error_frame; }
};

/// Traffic state of one bus.
struct BusFault {
  std::uint64_t error_frames = 0;      ///< error frames received
  std::uint32_t last_error_class = 0;  ///< CAN_ERR_* class bits of the last one
  std::uint64_t unknown_frames = 0;    ///< frames from unknown ids or motors, ignored
  std::uint64_t send_failures = 0;     ///< frames the bus refused (full transmit queue)
};

/// Fault state of all motors and buses (fixed size, copyable in the control loop).
struct MotorFaults {
  std::array<JointFault, model::kNumJoints> joints{};  ///< jointIndex() order
  std::array<BusFault, model::kNumLegs> buses{};       ///< leg order
  /// True if any joint is at fault.
  bool any() const {
    for (const JointFault& j : joints)
      if (j.faulted()) return true;
    return false;
  }
};

/// The robot's 16 MIT-mode motors on four CAN buses (one per leg; HAA, HFE, KFE, WHEEL on
/// each) and an IMU, as a RobotInterface.
///
/// - write() encodes the 16 commands (joint frame -> motor frame through the motor map,
///   clamped into the MIT ranges; commandClamps() says which fields were) and sends them.
///   While disabled nothing is sent (drives outside motor mode ignore commands).
/// - read() drains every bus without waiting, decodes the answers into SensorData (motor
///   frame -> joint frame; continuous joints unwrapped from the wrapped position range) and
///   updates the faults. A joint that has not answered keeps its last measurement.
/// - advance() waits for nothing: on hardware the control loop owns the timing (absolute
///   deadlines); it only counts the period for SensorData::t.
///
/// Faults: a motor commanded in a period and not answered by the next read() counts one
/// missing reply; reply_timeout_periods in a row latch a timeout. An error frame on a bus
/// latches error_frame on its four joints. Faults stay until clearFaults().
///
/// read(), write() and advance() do not allocate, lock, log or throw. Not thread-safe.
class CanRobot final : public model::RobotInterface {
 public:
  /// The backend on `buses` (robot-side endpoints, leg order; not owned, must outlive it)
  /// and `imu` (not owned). Throws std::invalid_argument if `settings` do not fit `model`
  /// (CanRobotSettings::validateAgainst) or a bus is null.
  CanRobot(const model::RobotModel& model, const CanRobotSettings& settings,
           const std::array<CanBus*, model::kNumLegs>& buses, ImuSource& imu);
  CanRobot(const CanRobot&) = delete;
  CanRobot& operator=(const CanRobot&) = delete;

  // RobotInterface ---------------------------------------------------------------------------
  double controlPeriod() const override { return settings_.control_period_s; }
  void read(model::SensorData& out) override;
  void write(const model::JointCommands& commands) override;
  /// Does not wait (the control loop owns the timing); counts one period.
  void advance() override;

  // Motor management (not for the real-time loop's steady state, but real-time safe) -------
  /// Sends enter motor mode to all 16 motors; their answers are expected from now on.
  /// Returns false if a bus refused a frame.
  bool enable();
  /// Sends exit motor mode to all 16 motors (they stop applying torque and answering).
  bool disable();
  /// Sends zero position to all 16 motors: their present positions become their zeros
  /// (calibration posture; offset_rad is the joint angle there).
  bool zero();
  /// True between enable() and disable().
  bool enabled() const { return enabled_; }

  /// Fault state.
  const MotorFaults& faults() const { return faults_; }
  /// True if any motor is at fault.
  bool hasFault() const { return faults_.any(); }
  /// Clears latched faults and counters (e.g. after the cause was removed).
  void clearFaults();
  /// MitClampBits of each joint's last command (0: sent as given, up to quantization).
  const std::array<std::uint8_t, model::kNumJoints>& commandClamps() const { return clamps_; }
  /// The settings in use.
  const CanRobotSettings& settings() const { return settings_; }

 private:
  bool sendToAll(MitSpecial special);
  void handleFrame(int leg, const CanFrame& frame);

  CanRobotSettings settings_;
  std::array<CanBus*, model::kNumLegs> buses_;
  ImuSource* imu_;
  std::array<bool, model::kNumJoints> continuous_{};
  /// Joint index of each motor id per bus, -1 for none.
  std::array<std::array<std::int8_t, 256>, model::kNumLegs> joint_of_id_{};

  bool enabled_ = false;
  long periods_ = 0;
  long reads_ = 0;
  std::array<bool, model::kNumJoints> awaiting_{};
  std::array<bool, model::kNumJoints> answered_{};
  std::array<long, model::kNumJoints> last_reply_read_{};
  std::array<bool, model::kNumJoints> ever_answered_{};
  std::array<bool, model::kNumJoints> have_position_{};
  std::array<double, model::kNumJoints> last_raw_p_{};
  std::array<double, model::kNumJoints> unwrapped_p_{};
  std::array<std::uint8_t, model::kNumJoints> clamps_{};
  model::JointMeasurements joints_{};
  model::ImuReading imu_reading_;
  MotorFaults faults_;
};

/// Opens a SocketCanBus on each leg's interface of `settings` (leg order). Throws CanError
/// (see SocketCanBus) if one cannot be opened.
std::array<std::unique_ptr<SocketCanBus>, model::kNumLegs> openSocketCanBuses(
    const CanRobotSettings& settings);

}  // namespace wj::can
