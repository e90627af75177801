#pragma once
/// @file The locomotion controller of paper Sec. II: the NMPC (reference, gait, SQP) and the
/// whole-body conversion, behind two calls that a control loop makes:
///   updateMpc(t, x)                  every MPC period (>= 100 Hz), in the MPC thread
///   calcCommands(t, x, sensors, cmd) every control period (1 kHz), in the real-time loop
/// updateMpc() publishes the policy through a lock-free triple buffer (PolicyExchange) and
/// calcCommands() fetches the latest one, so the two may run in two threads (one each; the
/// setters belong to the MPC thread) or, as in the tests, synchronously in one.

#include "nmpc/gait.h"
#include "nmpc/policy.h"
#include "nmpc/problem.h"
#include "nmpc/reference.h"
#include "nmpc/sqp_solver.h"
#include "nmpc/whole_body_controller.h"
#include "robot_model/robot_interface.h"

#include <utility>
#include <vector>

namespace wj::nmpc {

/// Integral action on the legs' support (offset-free standing and rolling). The NMPC's model is
/// the nominal robot, and its forces and the inverse dynamics carry the nominal weight only: a
/// payload or weaker drives leave the legs short of torque, and the joints' PD holds them
/// where the missing torque is its error, with the base sagging (a 1.9 kg payload 18 cm
/// forward and 10 cm left of the base's centre: 0.08 rad nose-down, 0.11 rad of roll, 1 cm
/// low; docs/robot-client.md, "The legs' integral"). While every wheel is planned on the
/// ground, each leg integrates how much its wheel sits higher under the base than in the
/// nominal posture into a vertical force, which its joints add (-J^T f) while it is planned
/// on the ground.
struct PostureIntegralSettings {
  double gain_n_per_m_s = 0.0;  ///< force rate per m of leg compression [N/(m s)]; 0: off
  double max_force_n = 40.0;    ///< |integral force| of a leg at most [N]
  /// A leg further than this from its nominal length (a landing, a push) holds its integral
  /// [m].
  double band_m = 0.05;
  /// Control periods further apart than this (after a pause, e.g. a jump) are not integrated
  /// [s].
  double max_step_s = 0.05;

  /// Throws std::invalid_argument naming the field when a value is out of range.
  void validate() const;
};

/// Everything that configures the locomotion controller.
struct LocomotionSettings {
  CentroidalModelSettings model;  ///< centroidal model
  ProblemSettings problem;        ///< cost and constraints
  SqpSettings sqp;                ///< solver
  GaitSettings gait;              ///< trot timing and swing height
  ReferenceSettings reference;    ///< base height and reference sampling
  WholeBodySettings whole_body;   ///< leg and wheel gains
  /// Blind terrain (without boxes): move the terrain plane to the stance wheels' mean contact
  /// point at every MPC cycle (the normal stays the configured one). Off: the configured plane
  /// is used as is. With boxes the plane follows the mean box height under the wheels.
  bool estimate_terrain_height = true;
  /// With boxes: move a touchdown off the hip (by the leg's joint reference) when the wheel
  /// would land on a box's edge or roll into its face during the following stance.
  bool adapt_footholds = true;
  double max_foothold_offset_m = 0.15;       ///< largest touchdown shift along the heading [m]
  double foothold_edge_margin_m = 0.03;      ///< clearance of the wheel from a box edge [m]
  PostureIntegralSettings posture_integral;  ///< off by default (gains 0)
};

/// See the file comment.
class LocomotionController {
 public:
  /// Builds model, problem, solver and whole-body controller; throws std::invalid_argument on
  /// bad settings.
  LocomotionController(const model::RobotModel& robot, const LocomotionSettings& settings);

  /// Drops the solver's iterate: the next updateMpc() starts from the measured state (after a
  /// pause, e.g. a jump, the old iterate describes a state long gone). MPC thread.
  void restart() { solver_.reset(); }
  /// Speed command the reference follows from now on.
  void setSpeedCommand(const SpeedCommand& command) { command_ = command; }
  /// Runs `gait` from `t_start` on.
  void setGait(double t_start, Gait gait) { targets_.gait.setGait(t_start, gait); }
  /// The terrain plane (its normal is also the contact normal of the wheels).
  void setTerrain(const TerrainPlane& terrain) { terrain_ = terrain; }
  /// Raised blocks on the plane (perception's stand-in): the swings lift off from and land on
  /// their tops, and the reference height follows them. Empty: the plane only.
  void setTerrainBoxes(std::vector<TerrainBox> boxes) { boxes_ = std::move(boxes); }

  /// One MPC cycle at time t and measured state x: reference, one SQP solve (warm-started),
  /// policy published to the loop.
  SqpStatus updateMpc(double t, const State& x);
  /// One control period: drive commands at time t from the latest policy. No allocation.
  void calcCommands(double t, const State& x, const model::SensorData& sensors,
                    model::JointCommands& out);

  /// The centroidal model (immutable; safe from both threads).
  const CentroidalModel& model() const { return solver_.problem().model(); }
  /// The solver, with its last iterate and statistics (MPC thread).
  const SqpSolver& solver() const { return solver_; }
  /// The policy the control loop used last (loop thread).
  const Policy& policy() const { return policy_; }
  /// Gait, terrain, reference and swings of the last MPC cycle (MPC thread).
  const Targets& targets() const { return targets_; }
  /// Diagnostics of the last calcCommands().
  const WholeBodyOutput& lastOutput() const { return last_output_; }
  /// Adds the legs' integral forces times `scale` to the joint commands of the legs in `legs`
  /// (-J^T f, the measured joints and the attitude of x); what a jump's take-off and landing
  /// carry of what the integral learnt while rolling. Loop thread; no allocation.
  void addLegSupport(const State& x, const model::SensorData& sensors, const ContactFlags& legs,
                     double scale, model::JointCommands& out) const;
  /// The legs' integral forces, upward in the world, per leg [N] (loop thread).
  const std::array<double, kNumLegs>& postureIntegral() const { return posture_integral_; }

 private:
  // Terrain plane and heights of the swings for this cycle.
  void updateTerrain(double t, const State& x);
  // Highest box under a wheel whose contact point is at p.
  double calcFootprintHeight(const Eigen::Vector3d& p) const;
  // Shift along the heading of a touchdown planned at p that keeps the wheel off box edges
  // and box faces over a stance in which it rolls `stance_travel` [m].
  double calcFootholdShift(const Eigen::Vector3d& p, double stance_travel) const;
  // The legs' integral (PostureIntegralSettings): updated from the measured joints, added to
  // the commands of the legs planned on the ground.
  void addPostureIntegral(double t, const State& x, const ContactFlags& contact,
                          const model::SensorData& sensors, model::JointCommands& out);

  LocomotionSettings settings_;
  TerrainPlane terrain_;
  std::vector<TerrainBox> boxes_;
  std::array<double, kNumLegs> last_stance_height_{};  // box height under each stance wheel
  std::array<SwingHeights, kNumLegs> held_swing_{};    // last swing; its foothold held in stance
  std::array<Eigen::Vector2d, kNumLegs> nominal_wheel_xy_{};  // in B
  SqpSolver solver_;
  ReferenceGenerator reference_;
  WholeBodyController whole_body_;
  Targets targets_;
  SpeedCommand command_;
  PolicyExchange exchange_;
  Policy policy_;
  WholeBodyOutput last_output_;
  std::array<double, kNumLegs> nominal_wheel_z_{};   // wheel centre below the base, in B [m]
  std::array<double, kNumLegs> posture_integral_{};  // loop thread
  double posture_t_ = -1e300;                        // the last control period's time
};

}  // namespace wj::nmpc
