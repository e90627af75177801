#pragma once
/// @file The robot simulated in Simbody behind the hardware-shaped RobotInterface.
/// Simbody-free header (pimpl): the Simbody code is compiled as C++17 in wj_sim_simbody.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>

#include "robot_model/robot_interface.h"
#include "robot_model/robot_model.h"
#include "sim/settings.h"

namespace wj::sim {

/// A value per actuated joint, jointIndex() order.
using JointVector = Eigen::Matrix<double, model::kNumJoints, 1>;

/// Contact of one wheel with the terrain (ground plane and boxes), ground truth.
struct WheelContact {
  bool in_contact = false;                            ///< any overlap with the terrain
  Eigen::Vector3d force_W = Eigen::Vector3d::Zero();  ///< force of the terrain on the wheel [N]
  double penetration_m = 0.0;                         ///< deepest overlap [m]
};

/// The complete simulated state: what tests and the verifier may know and a controller may not.
struct GroundTruth {
  double t = 0.0;                                          ///< simulation time [s]
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();  ///< base pose
  Eigen::Vector3d v_WB = Eigen::Vector3d::Zero();      ///< velocity of the base origin, in W [m/s]
  Eigen::Vector3d w_WB = Eigen::Vector3d::Zero();      ///< angular velocity of the base, in W
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();      ///< whole-robot centre of mass [m]
  Eigen::Vector3d v_WC = Eigen::Vector3d::Zero();      ///< its velocity [m/s]
  JointVector q = JointVector::Zero();                 ///< joint positions [rad]
  JointVector qd = JointVector::Zero();                ///< joint velocities [rad/s]
  JointVector tau = JointVector::Zero();               ///< torque the drives apply [Nm]
  JointVector tau_demand = JointVector::Zero();        ///< PD + feedforward before saturation [Nm]
  std::array<WheelContact, model::kNumLegs> wheels{};  ///< leg order LF, RF, LH, RH
  bool base_in_contact = false;  ///< the base touches the terrain (ground or a box)
  bool legs_in_contact = false;  ///< a thigh, shank or knee touches the terrain
  /// Smallest signed distance between the robot's collision spheres and any obstacle box
  /// [m]; negative = penetration; +infinity without obstacles.
  double obstacle_clearance_m = 0.0;
};

/// Where and how fast the robot is, for SimRobot::reset().
struct RobotPlacement {
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();  ///< base pose
  Eigen::Vector3d v_WB = Eigen::Vector3d::Zero();          ///< base origin velocity, in W [m/s]
  Eigen::Vector3d w_WB = Eigen::Vector3d::Zero();          ///< base angular velocity, in W [rad/s]
  JointVector q = JointVector::Zero();                     ///< joint positions [rad]
  JointVector qd = JointVector::Zero();                    ///< joint velocities [rad/s]
};

/// Work counters of the integrator since the last reset().
struct IntegratorStats {
  long steps_taken = 0;      ///< accepted internal steps
  long steps_attempted = 0;  ///< including rejected ones
  long realizations = 0;     ///< evaluations of the dynamics by the integrator
};

/// Which multibody model a SimRobot builds.
enum class SimModel : std::uint8_t {
  Full,  ///< the 22-DoF robot
  /// The robot restricted to motion symmetric about its sagittal plane: a planar base (x, z,
  /// pitch) and the two left legs, each standing for itself and its right mirror image (double
  /// mass, inertia, drive torque and contact force); 11 DoF. Exact for a mirror-symmetric
  /// robot, simulation and commands (docs/sim.md, "The sagittal model"): the right legs'
  /// readings and ground truth are the left legs' mirrored, roll, yaw and lateral motion zero.
  Sagittal,
};

/// Thrown by a SimRobot built as SimModel::Sagittal when it is placed or commanded
/// asymmetrically, which that model cannot represent.
class AsymmetryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The 22-DoF robot (free base + 16 pin joints built from the RobotModel) with compliant
/// wheel, base and leg contact, drives with PD law and torque-speed envelope, and an IMU at
/// the base origin whose accelerometer reports the mean specific force over the last control
/// period (velocity difference; the exact value right after reset()). See docs/sim.md.
/// One SimRobot per thread: instances share nothing, so different instances may run
/// concurrently; one instance is not thread-safe.
class SimRobot final : public model::RobotInterface {
 public:
  /// Builds the Simbody system from `model` (copied) and places the robot standing still at
  /// the origin with all joints at zero; call reset() to place it. Throws
  /// std::invalid_argument if the settings are out of range, or for SimModel::Sagittal if the
  /// robot or the simulation is not mirror-symmetric (findAsymmetry()).
  SimRobot(const model::RobotModel& model, const SimSettings& settings,
           SimModel kind = SimModel::Full);
  ~SimRobot() override;
  SimRobot(const SimRobot&) = delete;
  SimRobot& operator=(const SimRobot&) = delete;
  SimRobot(SimRobot&&) noexcept;
  SimRobot& operator=(SimRobot&&) noexcept;

  // RobotInterface ---------------------------------------------------------------------------
  double controlPeriod() const override;
  void read(model::SensorData& out) override;
  void write(const model::JointCommands& commands) override;
  void advance() override;

  // Simulation control and ground truth -------------------------------------------------------
  /// Sets time to 0, the state to `placement`, commands to zero, the noise generator to its
  /// seed, and restarts the integrator.
  void reset(const RobotPlacement& placement);
  /// Simulation time [s].
  double time() const;
  /// The full state at the current time into `out`. The contact forces of the spheres (on
  /// the ground and on boxes) are always filled; those of ellipsoid wheels, which Simbody's
  /// compliant contact subsystem computes, only with `with_forces` (it costs a force
  /// evaluation per call; without it their flags and overlaps are still exact).
  void calcGroundTruth(GroundTruth& out, bool with_forces = true) const;
  /// Whole-robot mass, centre of mass and central inertia as Simbody computes them, in the
  /// base frame (to compare with RobotModel::calcCompositeInertia). Full model only (throws
  /// std::logic_error for the sagittal one, whose merged legs have the wrong lateral moments).
  model::Inertia calcCompositeInertia() const;
  /// Kinetic + gravitational + elastic contact energy [J].
  double calcMechanicalEnergy() const;
  /// Work of the integrator since reset().
  IntegratorStats integratorStats() const;
  /// The settings the robot was built with.
  const SimSettings& settings() const;
  /// The robot description it was built from.
  const model::RobotModel& model() const;
  /// The multibody model it was built as.
  SimModel kind() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace wj::sim
