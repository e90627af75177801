#pragma once
/// @file What a robot_client run leaves behind: the telemetry CSV (drained from the loop's
/// lock-free rings outside the loop), the logged state-machine transitions, the ground-truth
/// metrics of a simulated run, the summary table / JSON and the figures.

#include <array>
#include <fstream>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "robot_client/client_settings.h"
#include "robot_client/control_loop.h"
#include "robot_client/mpc_worker.h"
#include "robot_model/robot_model.h"
#include "viz/recording.h"

namespace wj::sim {
struct GroundTruth;
}

namespace wj::robot_client {

class Backend;
class PlanRequester;

/// Ground-truth metrics of a simulated run.
struct TruthMetrics {
  bool available = false;
  double apex_base_z = 0.0;  ///< highest base height between take-off and landing
  double apex_com_z = 0.0;   ///< highest CoM height in that interval
  double min_clearance = std::numeric_limits<double>::infinity();   ///< to the wall [m]
  double takeoff_speed = std::numeric_limits<double>::quiet_NaN();  ///< CoM vx at take-off
  double touchdown_dx = std::numeric_limits<double>::quiet_NaN();   ///< CoM x travel in the jump
  double takeoff_com_x = std::numeric_limits<double>::quiet_NaN();
  /// CoM velocity when the last wheel left the ground (start of FLIGHT) [m/s].
  double liftoff_vx = std::numeric_limits<double>::quiet_NaN();
  double liftoff_vz = std::numeric_limits<double>::quiet_NaN();
  double liftoff_pitch_rate = std::numeric_limits<double>::quiet_NaN();  ///< nose-up [rad/s]
  /// Body rotation nose-up since the start of the take-off, unwrapped (a backflip: 2 pi),
  /// at the first touchdown and at the end [rad].
  double touchdown_rotation = std::numeric_limits<double>::quiet_NaN();
  double final_rotation = std::numeric_limits<double>::quiet_NaN();
  bool body_hit_ground = false;  ///< base or a leg link touched the terrain
  /// Base speed along x at the end of the roll-on after the landing (NaN without one) [m/s].
  double roll_on_speed = std::numeric_limits<double>::quiet_NaN();
  double final_x = 0.0;              ///< base x at the end [m]
  double final_front_wheel_x = 0.0;  ///< front wheels' foremost x at the end [m]
  double final_pitch = 0.0, final_roll = 0.0, final_speed = 0.0, final_height = 0.0;
  /// Base y and heading (yaw) at the end, and the largest |heading| from the first
  /// touchdown on: the scenarios run along +x, so a landing that turns the robot shows here
  /// [m, rad].
  double final_y = 0.0, final_heading = 0.0, max_heading_after_landing = 0.0;
  double est_pos_rms = 0.0, est_vel_rms = 0.0;  ///< estimator error vs truth (RMS)
  double est_pos_max = 0.0;                     ///< largest position error over the run [m]
  /// Largest |torque| the simulated drives applied, per joint kind (HAA, HFE, KFE, WHEEL) [Nm]:
  /// the saturated drive torque, without the torque sensor's noise.
  std::array<double, model::kJointsPerLeg> max_applied_torque{};
  /// Per jump (a course has several): the smallest wall clearance from its take-off to the
  /// end of its landing [m].
  std::vector<double> jump_clearance;
};

struct RunSummary {
  std::string scenario, backend;
  bool jumped = false;
  int landings = 0;          ///< jumps whose landing phase ended (a course: one per wall)
  std::string abort_reason;  ///< "" if none
  std::string final_mode;
  double takeoff_speed_est = std::numeric_limits<double>::quiet_NaN();
  double plan_latency_ms = std::numeric_limits<double>::quiet_NaN();
  std::string plan_source, plan_verification, plan_summary;
  double plan_target_height = std::numeric_limits<double>::quiet_NaN();  ///< requested CoM z
  double planned_apex_base_z = std::numeric_limits<double>::quiet_NaN();
  double planned_apex_com_z = std::numeric_limits<double>::quiet_NaN();  ///< CoM z at the apex
  double planned_clearance = std::numeric_limits<double>::quiet_NaN();
  double planned_touchdown_dx = std::numeric_limits<double>::quiet_NaN();
  /// The service's own verification (Simbody, from the plan's ideal initial state).
  planner::JumpOutcome service_verified;
  bool service_verified_available = false;
  double planned_liftoff_vx = std::numeric_limits<double>::quiet_NaN();
  double planned_liftoff_vz = std::numeric_limits<double>::quiet_NaN();
  double planned_liftoff_pitch_rate = std::numeric_limits<double>::quiet_NaN();
  double planned_touchdown_rotation = std::numeric_limits<double>::quiet_NaN();  ///< [rad]
  std::string actuators_file;  ///< the robot's actuator file (scenario's actuators_file)
  TruthMetrics truth;
  std::array<double, model::kJointsPerLeg> max_torque{};  ///< per joint kind [Nm]
  std::string max_torque_source;  ///< "applied" (simulated drives) or "measured" (sensors)
  std::array<double, model::kJointsPerLeg> torque_limit{};
  std::vector<Transition> transitions;
  MpcCounters mpc;
  double sim_time_s = 0.0;
  double wall_s = 0.0;
  nlohmann::json loop_stats;  ///< hardware runs: jitter and compute time
  std::string can_report;
  bool success = false;
  std::string verdict;

  nlohmann::json toJson() const;
  void printTable(std::ostream& out) const;
};

class RunRecorder {
 public:
  /// Writes telemetry to `csv_path` ("" = no file).
  RunRecorder(const model::RobotModel& robot, const ClientSettings& settings,
              const ScenarioSettings& scenario, const std::string& csv_path);

  /// Drains the loop's telemetry and transition rings (logs each transition). Not real-time.
  void drain(ControlLoop& loop);
  /// Simulation: the ground truth right after a period of `loop`.
  void onTruth(const sim::GroundTruth& gt, const ControlLoop& loop);
  /// The summary of the run.
  RunSummary summarise(const ControlLoop& loop, const PlanRequester* requester,
                       const Backend& backend, const MpcCounters& mpc);
  /// Figures (gnuplot): speed, heights and modes; left-front joint torques with limits.
  void plot(const std::string& png, const ControlLoop& loop) const;
  /// The knees over the take-off with their limits (the paper's backflip figure, viz/
  /// knee_figure.h), simulated (else estimated) against the plan; needs keepFrames(). Writes
  /// nothing (and says so) when the robot did not jump.
  void plotKnees(const std::string& png, const ControlLoop& loop,
                 const PlanRequester* requester) const;
  /// Keeps every period's pose from now on, for the pictures (--snapshots, --gif, --html).
  void keepFrames() { keep_frames_ = true; }
  /// Simulation, between periods: keeps the CoM path of the plan each jump executes, so that a
  /// run with several jumps (the course) draws each against its own plan. Copies the plan once
  /// per jump: not for the real-time thread (on hardware only the last jump's plan is drawn).
  void notePlan(const PlanRequester* requester);
  /// The run for the viewers (viz/): the ground truth in simulation, else the estimate; the
  /// plan's CoM path placed where the take-off started; the scenario's wall.
  viz::Recording recording(const ControlLoop& loop, const PlanRequester* requester) const;

 private:
  const model::RobotModel& robot_;
  const ClientSettings& settings_;
  const ScenarioSettings& scenario_;
  std::string csv_path_;
  std::ofstream csv_;
  std::vector<Transition> transitions_;
  TruthMetrics truth_;
  bool have_truth_row_ = false;
  std::array<double, 9> truth_row_{};  // t, x, z, vx, pitch, com_x, com_z, clearance, contact
  double takeoff_truth_x_ = std::numeric_limits<double>::quiet_NaN();
  double truth_pitch_ = 0.0;  // unwrapped true pitch [rad]
  double takeoff_truth_pitch_ = std::numeric_limits<double>::quiet_NaN();
  double pos_err2_ = 0.0, vel_err2_ = 0.0;
  long err_n_ = 0;
  bool keep_frames_ = false;
  std::vector<viz::Frame> frames_;
  // The jumps seen in the frames: where each take-off started and the plan it executed.
  struct JumpTrace {
    double takeoff_t = 0.0;                   // first frame in TAKEOFF [s]
    double takeoff_com_x = 0.0;               // CoM x there [m]
    std::vector<viz::PathPoint> planned_com;  // world frame; empty until notePlan
  };
  std::vector<JumpTrace> jumps_;
  Mode last_frame_mode_ = Mode::Stand;
  void noteFrame(Mode m, double t, double com_x);
  std::vector<viz::PathPoint> plannedPath(const planner::JumpPlan& plan,
                                          const JumpTrace& jump) const;
};

}  // namespace wj::robot_client
