#pragma once
/// @file One period of the robot client's 1 kHz control loop:
///   read -> estimate -> evaluate policy (NMPC or jump plan) -> PD and wheel law -> safety -> write
/// step() neither allocates, locks nor logs: telemetry and state-machine transitions leave the
/// loop through lock-free rings that a non-real-time thread drains; the NMPC runs in its own
/// thread (MpcWorker), plan requests in theirs (PlanRequester).

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>

#include "estimator/state_estimator.h"
#include "nmpc/locomotion_controller.h"
#include "planner/leg_kinematics.h"
#include "robot_client/client_settings.h"
#include "robot_client/jump_state_machine.h"
#include "robot_client/mpc_worker.h"
#include "robot_client/plan_requester.h"
#include "robot_model/robot_interface.h"
#include "rt/spsc_ring.h"
#include "sim/plan_executor.h"

namespace wj::robot_client {

/// One telemetry record (trivially copyable; one per control period).
struct TelemetrySample {
  double t = 0.0;
  Mode mode = Mode::Stand;
  std::array<double, 3> p_WB{};    ///< estimated base position [m]
  std::array<double, 3> v_WB{};    ///< estimated base velocity [m/s]
  double roll = 0.0, pitch = 0.0;  ///< [rad]
  double com_x = 0.0;              ///< estimated CoM x [m]
  std::array<double, model::kNumJoints> q{}, qd{}, tau{};
  std::array<double, model::kNumLegs> contact_force{};  ///< estimated normal force [N]
  double compute_us = 0.0;  ///< loop body time of the previous period [µs]
};

/// Anything outside the loop that wants to know about faults (hardware backends) implements it.
struct FaultSource {
  virtual ~FaultSource() = default;
  virtual bool hasFault() const = 0;
};

/// A forward range sensor (depth camera, lidar): the horizontal distance from the base origin
/// to the near face of the obstacle ahead [m]. read() is called once per period in the loop:
/// real-time safe; false when nothing is in range.
struct RangeSensor {
  virtual ~RangeSensor() = default;
  virtual bool read(double& distance_m) = 0;
  /// Standard deviation of one reading [m].
  virtual double noiseStd() const = 0;
};

class ControlLoop {
 public:
  using TelemetryRing = rt::SpscRing<TelemetrySample, 4096>;
  using TransitionRing = rt::SpscRing<Transition, 64>;

  /// All references must outlive the loop. `requester` may be null (no planning service: the
  /// jump is aborted at the decision point). `faults` may be null.
  ControlLoop(const model::RobotModel& robot, const ClientSettings& settings,
              const ScenarioSettings& scenario, model::RobotInterface& backend,
              nmpc::LocomotionController& controller, MpcWorker& mpc, PlanRequester* requester,
              const FaultSource* faults, RangeSensor* range = nullptr);

  /// Reads the sensors once and initialises the estimator at the measured posture, with the
  /// base at `p_WB` (the robot's known start position). Not real-time.
  void initialise(const Eigen::Vector3d& p_WB);
  /// One control period (see the file comment), including backend.advance().
  void step();
  /// Tells the loop how long its last body took (the runner measures it) [µs].
  void setLastCompute(double us) { last_compute_us_ = us; }
  /// Set by the watchdog thread.
  void tripWatchdog() { watchdog_.store(true, std::memory_order_release); }

  const JumpStateMachine& stateMachine() const { return fsm_; }
  /// The estimator's latest state.
  const estimation::EstimatedState& estimate() const { return estimator_.state(); }
  /// The latest commands written (after the safety check).
  const model::JointCommands& commands() const { return commands_; }
  Mode mode() const { return fsm_.mode(); }
  double time() const { return t_; }
  TelemetryRing& telemetry() { return telemetry_; }
  TransitionRing& transitions() { return transitions_; }
  /// Estimated speed at the start of take-off [m/s] (NaN before).
  double takeoffSpeed() const { return takeoff_speed_; }
  /// Start of take-off, robot time [s] (NaN before).
  double takeoffTime() const { return takeoff_t_; }
  /// Largest |applied torque| per joint over the run [Nm].
  const std::array<double, model::kNumJoints>& maxAbsTorque() const { return max_abs_tau_; }

 private:
  void estimate();
  // Reads the range sensor: a position fix for the estimator and the wall's perceived place.
  void senseRange();
  void updateContacts();
  void computeCommands(const FsmOutput& out);
  // The legs' integral carried into a jump's push and landing (ClientSettings::jump_leg_support).
  void addJumpLegSupport(const sim::PlanExecutor& ex);
  void applySafety();
  void postPlanRequest();
  // The executor of the requested plan, or null.
  sim::PlanExecutor* executor() const {
    return requester_ != nullptr ? requester_->executor() : nullptr;
  }
  void setSpeedCommand(double v_target, double accel);
  // The heading the NMPC is to hold: the run's, offset towards its line (RouteSettings).
  double routeHeading() const;

  const model::RobotModel& robot_;
  const ClientSettings& settings_;
  const ScenarioSettings& scenario_;
  model::RobotInterface& backend_;
  nmpc::LocomotionController& controller_;
  MpcWorker& mpc_;
  PlanRequester* requester_;
  const FaultSource* faults_;
  RangeSensor* range_;
  double wall_x_est_ = 0.0;  // perceived near face of the wall, estimator frame [m]
  int wall_readings_ = 0;
  int wall_index_ = 0;  // the state machine's wall the readings belong to
  // A platform the jump lands on (ScenarioSettings::landsOnWall): the ground height under world
  // x, from the perceived near face (the configured one without range readings) [m].
  double groundHeightAt(double x) const;
  bool wheels_over_platform_ = false;  // every wheel past the platform's near face
  estimation::StateEstimator estimator_;
  JumpStateMachine fsm_;
  planner::PlanarLeg leg_;
  sim::LandingHandover handover_;  // where the landing leaves the robot for the NMPC

  model::SensorData sensors_;
  model::JointCommands commands_{};
  nmpc::State x_ = nmpc::State::Zero();
  MpcInput mpc_input_;
  int mpc_every_ = 10;
  std::uint64_t k_ = 0;
  std::uint64_t last_mpc_k_ = 0;  // period of the last post to the NMPC
  double t_ = 0.0;
  double yaw_ = 0.0;
  // The run's heading and the point it starts from, the robot's estimated pose at its first
  // control period: every speed command heads along it, so that a landing that turned the
  // robot rolls on along the run, not along where it was turned (RouteSettings).
  double route_yaw_ = 0.0;
  Eigen::Vector2d route_origin_ = Eigen::Vector2d::Zero();
  bool route_yaw_set_ = false;
  double com_x_ = 0.0, speed_ = 0.0, roll_ = 0.0, pitch_ = 0.0;
  Eigen::Vector3d com_offset_B_ = Eigen::Vector3d::Zero();  // CoM in the base frame
  std::array<double, model::kNumLegs> contact_force_{};
  std::array<bool, model::kNumLegs> contact_{};
  // Consecutive periods in contact with the wheel's torque within its traction (rolling).
  std::array<int, model::kNumLegs> rolling_periods_{};
  int settle_periods_ = 50;
  bool pending_request_ = false;
  double takeoff_speed_;
  double takeoff_t_;
  double last_compute_us_ = 0.0;
  std::atomic<bool> watchdog_{false};
  int journal_seen_ = 0;
  std::array<double, model::kNumJoints> max_abs_tau_{};
  std::array<double, model::kNumJoints> q_start_{};  // posture at initialise()
  TelemetryRing telemetry_;
  TransitionRing transitions_;
};

}  // namespace wj::robot_client
