#pragma once
/// @file The hardware-shaped interface of the robot: what a controller reads and writes every
/// control period. Implemented by the Simbody simulation (wj::sim::SimRobot) and, later, by the
/// CAN hardware backend, so that the same control loop runs on both.
///
/// Real-time rules: every type here is fixed-size; read(), write() and advance() must not
/// allocate, log or throw in steady state. The header is Simbody-free and also compiles as
/// C++17, because the simulator's Simbody translation units (C++17) include it.

#include <Eigen/Geometry>
#include <array>

#include "robot_model/robot_model.h"

namespace wj::model {

/// Command of one joint drive. The drive applies
/// tau = kp (q_des - q) + kd (qd_des - qd) + tau_ff, clipped by its ActuatorEnvelope at the
/// current speed. Wheels normally run with kp = 0 (speed control, paper Sec. II-D).
struct JointCommand {
  double q_des = 0.0;   ///< desired position [rad]
  double qd_des = 0.0;  ///< desired velocity [rad/s]
  double kp = 0.0;      ///< position gain [Nm/rad]
  double kd = 0.0;      ///< velocity gain [Nm s/rad]
  double tau_ff = 0.0;  ///< feedforward torque [Nm]
};

/// Measured state of one joint.
struct JointMeasurement {
  double q = 0.0;    ///< position [rad]
  double qd = 0.0;   ///< velocity [rad/s]
  double tau = 0.0;  ///< torque the drive applies [Nm] (after saturation)
};

/// One reading of the inertial measurement unit, mounted at the base frame origin.
struct ImuReading {
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();  ///< orientation of B in W
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();  ///< angular velocity of B, in B [rad/s]
  /// Specific force (acceleration minus gravity) of the IMU, in B [m/s^2]: +g along the
  /// world's up axis when at rest, as an accelerometer measures.
  Eigen::Vector3d accel_B = Eigen::Vector3d::Zero();
};

/// Commands for all 16 joints, jointIndex() order.
using JointCommands = std::array<JointCommand, kNumJoints>;
/// Measurements of all 16 joints, jointIndex() order.
using JointMeasurements = std::array<JointMeasurement, kNumJoints>;

/// Everything the robot reports in one control period.
struct SensorData {
  double t = 0.0;  ///< robot clock at the measurement [s]
  JointMeasurements joints{};
  ImuReading imu;
};

/// The robot as a controller sees it. One control period: read(), compute, write(), advance().
/// Not thread-safe: one control loop owns one robot.
class RobotInterface {
 public:
  virtual ~RobotInterface() = default;

  /// Period of advance() [s] (1 ms on this robot).
  virtual double controlPeriod() const = 0;
  /// Latest measurement of joints and IMU into `out` (no allocation).
  virtual void read(SensorData& out) = 0;
  /// Sets the commands the drives apply from now on, until the next write().
  virtual void write(const JointCommands& commands) = 0;
  /// Advances one control period: the simulator integrates the dynamics over it, the
  /// hardware backend waits for the next absolute deadline of the loop.
  virtual void advance() = 0;

 protected:
  RobotInterface() = default;
  RobotInterface(const RobotInterface&) = default;
  RobotInterface& operator=(const RobotInterface&) = default;
  RobotInterface(RobotInterface&&) = default;
  RobotInterface& operator=(RobotInterface&&) = default;
};

}  // namespace wj::model
