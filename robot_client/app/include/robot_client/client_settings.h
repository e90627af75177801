#pragma once
/// @file Configuration of the robot client (config/robot_client.yaml): loop timing, the jump
/// scenarios, the abort and safety limits, and the planner connection. Read strictly: unknown
/// or missing keys and out-of-range values are errors that name the key.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "estimator/estimator_settings.h"
#include "nmpc/locomotion_controller.h"
#include "planner/jump_plan.h"
#include "sim/executor_settings_file.h"
#include "sim/plan_executor.h"

namespace wj::robot_client {

/// Timing and real-time setup of the loops.
struct LoopSettings {
  double period_s = 0.001;           ///< control loop period [s] (1 kHz)
  double mpc_period_s = 0.01;        ///< NMPC cycle [s]
  int rt_priority = 80;              ///< SCHED_FIFO priority of the control loop (1..99)
  bool lock_memory = true;           ///< mlockall before the loop starts
  int cpu = -1;                      ///< CPU the loop is pinned to, -1 = no pinning
  double watchdog_timeout_s = 0.02;  ///< loop silent this long -> damping mode [s]
  int telemetry_decimation = 1;      ///< one telemetry sample every N periods
  /// Busy-wait this long before each deadline instead of sleeping through it [µs] (0 = sleep).
  double spin_us = 0.0;
};

/// Limits whose violation ends in damping mode or a stop.
struct SafetySettings {
  double max_roll_rad = 0.7;        ///< |roll| beyond this outside a jump -> damping [rad]
  double max_pitch_rad = 0.8;       ///< |pitch| beyond this outside a jump -> damping [rad]
  double damping_kd = 1.5;          ///< joint damping of damping mode [Nm s/rad]
  double brake_decel_m_s2 = 2.5;    ///< deceleration of a safe stop [m/s^2]
  double stopped_speed_m_s = 0.05;  ///< below this the robot counts as stopped [m/s]
};

/// Where the robot drives between its jumps (YAML `nmpc.route`): every speed command heads
/// along the run, the robot's heading at its start, so that a landing that turned the robot
/// rolls on along the run; while rolling it also steers back onto the run's line through its
/// start (docs/robot-client.md, "The route").
struct RouteSettings {
  /// Heading offset towards the line per metre off it, while the commanded speed is at
  /// least min_speed_m_s; 0: the heading only [rad/m].
  double lateral_gain_rad_per_m = 0.0;
  double max_heading_offset_rad = 0.15;  ///< bound of that offset [rad]
  double min_speed_m_s = 0.5;            ///< below it, the heading only [m/s]
};

/// Contact detection from the leg torques: the ground force of a leg is estimated from its
/// HFE and KFE torques through the planar leg Jacobian, gated by the wheel's estimated height.
struct ContactSettings {
  double force_threshold_n = 25.0;  ///< normal force above which a wheel is on the ground [N]
  /// ... and only if the estimated wheel bottom is at most this far above the ground [m].
  double max_wheel_clearance_m = 0.03;
  /// ... and only if the wheel centre does not rise faster than this in the world by the
  /// estimator's state [m/s]. A leg tucking in flight swings its wheel up at 2-4 m/s and loads
  /// its joints like a ground force; passing 2-3 cm over a platform's edge that counted as a
  /// touchdown (docs/robot-client.md, "Contact").
  double max_rise_speed_m_s = 0.5;
  /// In a jump, a wheel's rolling constraint feeds the estimator only after its contact has
  /// lasted this long (impact and spin-up slip) [s].
  double settle_s = 0.05;
  /// In a jump, a wheel whose measured torque exceeds traction_mu x its estimated normal force
  /// x the wheel radius cannot roll without slipping: it counts as out of rolling contact for
  /// the estimator (and must then roll settle_s again) [-].
  double traction_mu = 0.7;
};

/// How the robot client reaches the planning service.
struct PlannerConnection {
  double deadline_s = 1.5;            ///< deadline of one PlanJump call [s]
  std::uint32_t max_evaluations = 0;  ///< DE budget sent with the request (0 = server default)
  std::uint64_t seed = 0;             ///< DE seed sent with the request (0 = server default)
  /// Requests again, each time with the next DE seed (1000 + n when `seed` is 0,
  /// else seed + n) and the state measured then, after an infeasible or failed answer, at
  /// most this many times and only while the decision point is ahead (docs/robust.md).
  int retries = 0;
  bool skip_verification = false;  ///< ask for the planner's plan without verification
  /// How the trajectory travels (YAML `trajectory_format`): compact_knots
  /// (TRAJECTORY_FORMAT_COMPACT_KNOTS: knots with each distinct joint column once, 16-bit,
  /// about a third of the knots' bytes), knots (TRAJECTORY_FORMAT_KNOTS, float32, about a
  /// fifth of the dense bytes) or dense; knots of either kind are made 1 kHz references here.
  enum class Format { Dense, Knots, CompactKnots };
  Format format = Format::CompactKnots;
  /// Spread calls over every address the target resolves to (several service replicas
  /// behind a headless Service, docs/scaling.md) instead of sticking to the first.
  bool round_robin = false;
  /// TLS to the service (the workstation profile requires mutual TLS; docs/service.md).
  /// Off: plaintext, which the service accepts on loopback only. Files are PEM.
  bool tls = false;
  std::string tls_root_ca_file;  ///< CA that signed the service's certificate
  std::string tls_cert_file;     ///< this robot's certificate ("" = no client certificate)
  std::string tls_key_file;      ///< its key
  std::string tls_server_name;   ///< expected name in the service's certificate ("" = host)
  /// Not from the YAML (robot_client --request-log): every PlanJumpRequest sent is appended to
  /// this file as one line of JSON (proto field names), for replaying it outside the loop
  /// (planner_cli plan --request). "" = none. Written by the requester's worker thread.
  std::string request_log_file;
};

/// What the robot does once a jump's landing is over.
enum class AfterLanding : std::uint8_t {
  Stop,    ///< the NMPC takes over and brakes to a stop
  RollOn,  ///< the NMPC takes over and rolls on at roll_on_speed_m_s, then stops
};
/// "stop", "roll_on".
std::string_view toString(AfterLanding after);

/// The planner's lowest initial speed along the heading (planner::InitialState::validate) [m/s]:
/// a plan request's measured speed is clamped to it (ControlLoop), so that a backward run-up at
/// -1 m/s, measured within its speed_tolerance_m_s past it, is still planned.
inline constexpr double kPlannerLowestSpeedMS = -1.0;
/// A request's speed is clamped this far inside kPlannerLowestSpeedMS, so that the service's
/// own projection on the heading cannot round it past the bound [m/s].
inline constexpr double kRequestSpeedMarginMS = 1e-9;

/// What a scenario does. Forward: roll up to `run_up_speed_m_s`, request a plan, jump over the
/// wall at `wall_x_m` (world), land and stop. Course: several walls (`wall_x_m` a list), each
/// jumped in turn, rolling on from one landing to the next run-up. Vertical: stand, request,
/// jump in place.
struct ScenarioSettings {
  std::string name = "forward";
  double stand_s = 1.0;  ///< standing before anything starts [s]
  /// Along the heading [m/s], in [-1, 5]: 0 = jump from standing, negative = rolling
  /// backward into the jump (no wall).
  double run_up_speed_m_s = 3.0;
  double acceleration_m_s2 = 1.5;  ///< run-up acceleration [m/s^2]
  /// The plan is requested once the speed ramp has ended and the speed is this close to the
  /// run-up speed: the plan starts from the measured v0, so it must be the take-off speed.
  double speed_tolerance_m_s = 0.03;
  bool has_wall = true;  ///< a wall stands in the way
  /// Near faces of the walls in world x, increasing; one jump each, in order [m]. YAML
  /// `wall.x_m`: a number (one wall) or a list (a course).
  std::vector<double> wall_x_m = {6.0};
  double wall_thickness_m = 0.1;   ///< [m]
  double wall_height_m = 0.25;     ///< [m]
  double takeoff_to_wall_m = 1.2;  ///< CoM to the wall's near face at the start of take-off
  /// The take-off starts this much before the point the plan was made for (the plan keeps the
  /// wall at takeoff_to_wall_m) [m]: trades clearance at the far edge for clearance at the near
  /// edge where the simulated jump and the plan differ (docs/robust.md, "Take-off lead").
  /// Optional YAML key, default 0.
  double takeoff_lead_m = 0.0;
  /// The take-off posture (optional YAML `takeoff_posture: {hfe_rad, kfe_rad, max_offset_rad}`,
  /// every leg alike): the plan is requested from it instead of the measured leg angles when
  /// each measured HFE and KFE is within max_offset_rad of it (else from the measured ones).
  /// The executor imposes the plan's first posture at the take-off's start (stiff PD), so the
  /// legs are a commanded quantity, unlike the speed, the pitch and its rate, which stay
  /// measured. The backflip's plans and their Simbody verdicts jump with 5-10 mrad of leg
  /// angle (docs/backflip.md, "Session 15"), and the NMPC's crouch wanders by that much.
  bool has_takeoff_posture = false;
  double takeoff_hfe_rad = 1.0;                  ///< [rad]
  double takeoff_kfe_rad = -2.0;                 ///< [rad]
  double takeoff_posture_max_offset_rad = 0.03;  ///< [rad]
  /// Base height the NMPC holds while standing and rolling [m]: the run-up is done in the
  /// posture the jump starts from (the planner plans from the measured posture).
  double nmpc_base_height_m = 0.36;
  /// The plan must be in hand this far before the take-off point; otherwise the robot
  /// brakes and stops before the wall [m].
  double decision_margin_m = 1.0;
  double target_dx_m = 1.9;               ///< CoM displacement from take-off start to the event [m]
  double target_com_height_m = 0.27;      ///< CoM height at the event above the ground [m]
  double target_pitch_change_rad = 0.25;  ///< nose-up positive [rad]
  planner::TargetEvent event = planner::TargetEvent::Touchdown;
  planner::TakeoffMode mode = planner::TakeoffMode::Simultaneous;
  /// Fly the planner's closest approach when the target is out of reach (every constraint
  /// met, the target missed, the service's simulation passed): "as high as it can".
  bool accept_closest_approach = false;
  double plan_timeout_s = 3.0;  ///< standing jumps: no plan by then -> no jump [s]
  /// After the landing (YAML `after_landing: {mode, speed_m_s, roll_s}`): the executor's
  /// landing phase ends in the NMPC's posture at this speed and the NMPC takes over.
  AfterLanding after_landing = AfterLanding::Stop;
  double roll_on_speed_m_s = 3.0;  ///< roll_on: speed along the heading [m/s]
  double roll_on_s = 2.0;          ///< roll_on: how long it rolls on before it stops [s]
  /// roll_on onto a platform (landsOnWall()): the roll-on ends early, and the robot brakes at
  /// SafetySettings::brake_decel_m_s2, once that stop would end this close to the platform's
  /// far end (estimated CoM) [m]. Optional YAML key `after_landing.edge_margin_m`.
  double edge_margin_m = 0.5;
  double duration_s = 12.0;  ///< end of the run [s]
  /// Actuator file of the robot in this scenario (models folder; optional key, default the
  /// real robot's). The simulated robot and the planning service must use the same one: the
  /// service's `actuators_file` (docs/backflip.md).
  std::string actuators_file = "actuators.yaml";

  /// Jumps the scenario makes: one per wall, one without a wall.
  int jumps() const { return has_wall ? static_cast<int>(wall_x_m.size()) : 1; }
  /// The near face of wall `i` (world x) [m].
  double wallX(int i = 0) const { return wall_x_m[static_cast<std::size_t>(i)]; }

  /// The jump lands on top of the "wall" (a platform): a touchdown target whose CoM x lies
  /// over it, as the planner reads the same request (planner::JumpTask::landsOnObstacle()).
  bool landsOnWall() const {
    return has_wall && event == planner::TargetEvent::Touchdown &&
           target_dx_m > takeoff_to_wall_m && target_dx_m < takeoff_to_wall_m + wall_thickness_m;
  }
};

/// Everything in config/robot_client.yaml.
struct ClientSettings {
  LoopSettings loop;
  SafetySettings safety;
  ContactSettings contact;
  PlannerConnection planner;
  /// Take-off, flight and landing gains, read from `executor_file` (YAML key; a relative path
  /// is beside the configuration), which the planning service's verifier reads too.
  sim::ExecutorSettings executor;
  std::string executor_file;  ///< the file `executor` was read from, as resolved
  /// The state estimator's noises and limits (the estimator's defaults; docs/estimator.md).
  estimation::EstimatorSettings estimator;
  /// The legs' integral of the NMPC (YAML `nmpc.posture_integral`).
  nmpc::PostureIntegralSettings posture_integral;
  /// A jump's push and landing add what the legs' integral learnt while rolling (YAML
  /// `nmpc.jump_leg_support`; the push scaled by the plan's vertical load).
  bool jump_leg_support = false;
  /// The run's heading and line (YAML `nmpc.route`).
  RouteSettings route;
  /// The scenarios of `scenarios:` in document order (forward, vertical, ...), each named by
  /// its key; a new scenario is a new entry in the YAML, not new code.
  std::vector<ScenarioSettings> scenarios;

  /// The scenario called `name`; throws std::invalid_argument listing the names there are.
  const ScenarioSettings& scenario(std::string_view name) const;
  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
};

/// Parses YAML text; `origin` names it in errors and is the path a relative `executor_file` is
/// found beside. Throws std::runtime_error on unknown or missing keys or an unreadable executor
/// file, and std::invalid_argument on out-of-range values.
ClientSettings parseClientSettings(std::string_view yaml_text,
                                   const std::string& origin = "<text>");
/// Reads and parses a file.
ClientSettings loadClientSettings(const std::filesystem::path& yaml_file);

}  // namespace wj::robot_client
