#pragma once
/// @file Verification of a jump plan in the multibody simulation: execute the plan on a
/// SimRobot at the control rate, measure what the jump really does, and judge it.
///
/// Usage:
///   wj::sim::Verifier verifier(model, settings);
///   wj::sim::VerificationReport r = verifier.verify(plan, scenario);
///
/// Thread safety: Verifier::verify() is const and builds its own Simbody system per call, so
/// one Verifier may be used from several threads at once (e.g. the best K DE candidates).
/// Determinism: same model, settings, plan and scenario give the same report, bit for bit.

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "planner/jump_plan.h"
#include "planner/jump_task.h"
#include "robot_model/robot_model.h"
#include "sim/plan_executor.h"
#include "sim/settings.h"
#include "sim/sim_robot.h"
#include "sim/telemetry.h"

namespace wj::sim {

/// Why a verification failed.
enum class FailureReason : std::uint8_t {
  InvalidPlan,          ///< the plan's arrays or times are malformed
  InvalidInitialState,  ///< the initial CoM height does not put the wheels on the terrain
  SimulationError,      ///< the integrator failed
  NoTakeoff,            ///< the wheels never left the ground
  NoTouchdown,          ///< the robot did not land in time
  TorqueLimit,          ///< a drive demanded more than its envelope in take-off or flight
  SpeedLimit,           ///< a joint turned faster than its no-load speed
  JointLimit,           ///< a joint left its URDF position range
  ObstacleCollision,    ///< the robot touched an obstacle box
  BaseContact,          ///< the base touched the terrain
  LegContact,           ///< a thigh, shank or knee touched the terrain
  NotUpright,           ///< pitch or roll out of bounds after landing
  BaseHeight,           ///< base height out of bounds after landing
  NotSettled,           ///< still rotating after landing
  TargetMissed,         ///< measured outcome too far from the plan's prediction
};
/// Number of FailureReason values.
inline constexpr int kNumFailureReasons = 15;
/// Stable lower-case name, e.g. "torque_limit".
std::string_view toString(FailureReason reason);

/// A set of FailureReason (a bit set; no allocation).
class FailureSet {
 public:
  /// Adds `reason`.
  void insert(FailureReason reason) { bits_ |= bit(reason); }
  /// True if `reason` is in the set.
  bool contains(FailureReason reason) const { return (bits_ & bit(reason)) != 0; }
  /// True if no reason is in the set.
  bool empty() const { return bits_ == 0; }
  /// Number of reasons in the set.
  int size() const;
  /// The reasons, in enum order.
  std::vector<FailureReason> toVector() const;
  /// Same reasons.
  bool operator==(const FailureSet&) const = default;

 private:
  static std::uint32_t bit(FailureReason r) { return 1u << static_cast<unsigned>(r); }
  std::uint32_t bits_ = 0;
};

/// What a passing jump must satisfy. Bounds on the landing are evaluated at the end of the
/// run, landing_duration_s after touchdown.
struct AcceptanceCriteria {
  /// Largest allowed |PD + feedforward demand| / envelope torque limit at the current speed,
  /// over the take-off (t < t2), where the plan's feedforward acts. Saturation at the switch
  /// to flight and at landing impacts is reported in JointMetrics but is no failure.
  double max_envelope_ratio = 1.0;
  double max_speed_ratio = 1.0;  ///< largest allowed |qd| / no-load speed, take-off and flight
  double joint_limit_tolerance_rad = 0.02;  ///< allowed excursion beyond the URDF limits [rad]
  double base_height_tolerance_m = 0.06;    ///< |final height - standing height of q_landing| [m]
  double max_final_pitch_rad = 0.25;        ///< |pitch relative to the ground slope| at the end
  double max_final_roll_rad = 0.25;         ///< |roll| at the end [rad]
  double max_final_angular_speed_rad_s = 0.5;  ///< |angular velocity of the base| at the end
  /// The run ends early once every end-of-run bound above (pitch, roll, height, angular speed,
  /// no base contact) has held without a break for this long in the landing phase: the robot
  /// is at rest, and simulating the rest of landing_duration_s only costs time. 0 = always
  /// run the whole landing phase.
  double settle_window_s = 0.2;
  double initial_gap_tolerance_m = 0.01;  ///< |lowest wheel's distance to terrain| at t = 0 [m]
  /// |measured - predicted| limits on the outcome (plan.predicted); infinity disables a check.
  /// The defaults are sanity bounds for any task; a caller that knows the task's target
  /// event (apex or touchdown) should tighten that one and may disable the other.
  double max_apex_height_error_m = 0.05;        ///< CoM height at the apex [m]
  double max_touchdown_dx_error_m = 0.15;       ///< CoM x at touchdown [m]
  double max_touchdown_pitch_error_rad = 0.35;  ///< pitch at touchdown [rad]
};

/// Everything the verifier needs besides the robot and the plan.
/// The multibody model a verification runs on.
enum class VerificationModel : std::uint8_t {
  /// SimModel::Sagittal (11 DoF, about half the work) when the robot, the simulation and the
  /// plan are mirror-symmetric, which makes roll, yaw and lateral motion identically zero;
  /// SimModel::Full otherwise (docs/sim.md, "The sagittal model").
  SagittalWhenSymmetric,
  Full,  ///< always SimModel::Full (22 DoF)
};

struct VerifierSettings {
  SimSettings sim;  ///< physics (its terrain is replaced by the scenario's)
  VerificationModel model = VerificationModel::SagittalWhenSymmetric;  ///< see the enum
  ExecutorSettings executor;      ///< gains and timing of the plan execution
  AcceptanceCriteria acceptance;  ///< pass/fail bounds

  /// The slower setting the defaults are measured against (bench_verify --compare,
  /// docs/sim.md "Cost of one verification"): the same checks with the reference integrator
  /// (Runge-Kutta-Merson, accuracy 1e-5).
  static VerifierSettings reference();
};

/// The world of one verification.
struct Scenario {
  std::string name = "flat";          ///< for reports and logs
  Terrain terrain = Terrain::flat();  ///< replaces VerifierSettings::sim.terrain
};

/// The world of a planner task: flat ground, with its obstacle as a wall to clear, or as a
/// platform to land on when the task lands on it (planner::JumpTask::landsOnObstacle()).
Scenario scenarioForTask(const planner::JumpTask& task);

/// Where the robot starts: rolling in a posture with its CoM at a planar state.
struct InitialState {
  /// CoM in the jump frame J (= W): on a slope, x runs along and z normal to the ground, and
  /// pitch is relative to the slope.
  planner::PlanarState com;
  JointVector q = JointVector::Zero();   ///< joint positions [rad]
  JointVector qd = JointVector::Zero();  ///< joint velocities [rad/s] (wheels: v0 / r)
};

/// The initial state the plan assumes: CoM at plan.initial, posture plan.q_initial, leg
/// speeds from the first plan sample, wheels spinning at plan.initial.vx / r.
InitialState initialStateFromPlan(const model::RobotModel& model, const planner::JumpPlan& plan);

/// Peak values of one joint over a run.
struct JointMetrics {
  double max_abs_torque_nm = 0.0;  ///< applied (saturated) torque
  double max_abs_demand_nm = 0.0;  ///< PD + feedforward before saturation
  double max_abs_speed_rad_s = 0.0;
  double max_envelope_ratio = 0.0;  ///< |demand| / torque limit at speed, whole run
  double max_speed_ratio = 0.0;     ///< |qd| / no-load speed
  double min_q_rad = std::numeric_limits<double>::infinity();
  double max_q_rad = -std::numeric_limits<double>::infinity();
};

/// Verdict and measurements of one verification.
struct VerificationReport {
  SimModel model = SimModel::Full;   ///< the multibody model it ran on
  bool passed = false;               ///< no failure reason
  FailureSet failures;               ///< why it failed
  std::vector<std::string> reasons;  ///< one sentence per failure, in detection order

  /// Measured take-off (last wheel contact before flight), apex (highest CoM in flight) and
  /// touchdown (first wheel contact after flight), in J; min obstacle clearance over the run.
  planner::JumpOutcome measured;
  bool took_off = false;      ///< all wheels left the ground for airborne_debounce_s
  bool touched_down = false;  ///< a wheel touched the terrain after take-off
  double max_base_z_m = -std::numeric_limits<double>::infinity();  ///< highest base origin

  std::array<JointMetrics, model::kNumJoints> joints{};  ///< per joint, whole run
  double max_envelope_ratio = 0.0;                       ///< worst demand / limit over the take-off
  int worst_envelope_joint = -1;                         ///< jointIndex() of it
  double max_speed_ratio = 0.0;  ///< worst |qd| / no-load speed, take-off and flight

  bool base_contact = false;    ///< the base touched the terrain at some time
  bool leg_contact = false;     ///< a thigh, shank or knee touched the terrain
  bool landed_upright = false;  ///< base height, pitch and roll within bounds at the end

  double initial_ground_gap_m = 0.0;   ///< lowest wheel's distance to the terrain at t = 0
  double nominal_base_height_m = 0.0;  ///< rigid standing height of q_landing
  double final_time_s = 0.0;           ///< end of the run [s]
  bool settled_early = false;  ///< ended before landing_duration_s: at rest for settle_window_s
  double final_base_height_m = 0.0;  ///< base origin above the terrain at the end [m]
  /// Relative to the ground slope, folded to (-pi, pi]: after a backflip (a full turn) an
  /// upright robot reads 0, not 2 pi.
  double final_pitch_rad = 0.0;
  /// Total nose-up rotation from the start to the end of the run, unwrapped [rad] (2 pi after
  /// a backflip).
  double final_rotation_rad = 0.0;
  double final_roll_rad = 0.0;
  double final_angular_speed_rad_s = 0.0;

  /// Measured minus predicted (plan.predicted); NaN when not measured.
  double apex_height_error_m = std::numeric_limits<double>::quiet_NaN();
  double touchdown_dx_error_m = std::numeric_limits<double>::quiet_NaN();       ///< [m]
  double touchdown_pitch_error_rad = std::numeric_limits<double>::quiet_NaN();  ///< [rad]

  long integrator_steps = 0;         ///< accepted internal steps (work measure)
  long integrator_realizations = 0;  ///< dynamics evaluations by the integrator
};

/// Runs plans on a fresh SimRobot per call and judges them (see the file comment).
class Verifier {
 public:
  /// Copies the model and the settings; throws std::invalid_argument if settings are invalid.
  Verifier(model::RobotModel model, VerifierSettings settings);

  /// Verifies `plan` from the initial state it assumes (initialStateFromPlan()).
  VerificationReport verify(const planner::JumpPlan& plan, const Scenario& scenario,
                            const TelemetryCallback& telemetry = {}) const;
  /// Verifies `plan` from an explicit initial state.
  VerificationReport verify(const planner::JumpPlan& plan, const InitialState& initial,
                            const Scenario& scenario,
                            const TelemetryCallback& telemetry = {}) const;

  /// As verify(plan, scenario), but gives up as soon as `stop` is set (checked every control
  /// step): nullopt then.
  std::optional<VerificationReport> verifyUnless(const planner::JumpPlan& plan,
                                                 const Scenario& scenario,
                                                 const std::atomic<bool>& stop) const;

  /// The robot description.
  const model::RobotModel& model() const { return model_; }
  /// The settings.
  const VerifierSettings& settings() const { return settings_; }

 private:
  // One verification on `kind`; throws AsymmetryError when the sagittal model meets an
  // asymmetric state or command.
  // Nullopt when `stop` was set before the end.
  std::optional<VerificationReport> run(const planner::JumpPlan& plan, const InitialState& initial,
                                        const Scenario& scenario,
                                        const TelemetryCallback& telemetry, SimModel kind,
                                        const std::atomic<bool>* stop) const;
  // verify() and verifyUnless(): the model chosen, the full one on an AsymmetryError.
  std::optional<VerificationReport> verifyOn(const planner::JumpPlan& plan,
                                             const InitialState& initial, const Scenario& scenario,
                                             const TelemetryCallback& telemetry,
                                             const std::atomic<bool>* stop) const;

  model::RobotModel model_;
  VerifierSettings settings_;
  bool symmetric_robot_ = false;  // findAsymmetry(model_) is empty
};

/// One-shot form of Verifier::verify().
VerificationReport verify(const model::RobotModel& model, const VerifierSettings& settings,
                          const planner::JumpPlan& plan, const InitialState& initial,
                          const Scenario& scenario);

/// Base pose and twist that put the CoM of posture `initial.q` at `initial.com` on `terrain`
/// (rigid-body twist; SimRobot-independent). Joint q and qd are copied.
RobotPlacement calcPlacement(const model::RobotModel& model, const InitialState& initial,
                             const Terrain& terrain);

/// Nose-up pitch (rotation about -y) of the base orientation R_WB, unwrapped to be continuous
/// with `previous` (the pitch of the step before): a full turn reads 2 pi, not 0. Every pitch
/// the verifier measures (take-off, apex, touchdown) comes from this running value.
double calcUnwrappedPitch(const Eigen::Matrix3d& R_WB, double previous);

/// An angle folded to (-pi, pi] (how far from upright a pitch is, after any number of turns).
double foldAngle(double angle_rad);

/// Signed distance from a point to the terrain surface (ground plane or boxes) [m].
double calcTerrainDistance(const Terrain& terrain, const Eigen::Vector3d& p_W);

}  // namespace wj::sim
