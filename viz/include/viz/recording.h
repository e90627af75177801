#pragma once
/// @file What the viewers draw: a run as plain frames (time, base pose, 16 joint angles,
/// torques, the state machine's phase, the centre of mass) plus the scene (boxes) and the
/// planned CoM path. Filled by sim_jump (Simbody ground truth), robot_client (ground truth in
/// simulation, the estimate on hardware) and planner_cli (a plan alone); no Simbody here.

#include <Eigen/Geometry>
#include <array>
#include <limits>
#include <string>
#include <vector>

#include "robot_model/robot_model.h"

namespace wj::viz {

/// One instant of a run, in the world frame W (x forward, z up, ground at z = 0).
struct Frame {
  double t = 0.0;                                            ///< [s]
  Eigen::Vector3d p_WB = Eigen::Vector3d::Zero();            ///< base origin [m]
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();  ///< base orientation
  std::array<double, model::kNumJoints> q{};                 ///< joint positions [rad]
  std::array<double, model::kNumJoints> qd{};                ///< joint velocities [rad/s]
  std::array<double, model::kNumJoints> tau{};               ///< applied torques [Nm]
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();            ///< whole-robot centre of mass [m]
  std::string phase;  ///< state-machine mode or executor phase, e.g. "flight"
};

/// An axis-aligned box of the terrain (a wall, a platform) [m].
struct SceneBox {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
};

/// One point of a CoM path.
struct PathPoint {
  double t = 0.0;                               ///< on the frames' clock [s]
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  ///< [m], world frame
};

/// The plan's joint speeds and torques at one instant, on the frames' clock.
struct PlannedJoints {
  double t = 0.0;                               ///< [s]
  std::array<double, model::kNumJoints> qd{};   ///< [rad/s]
  std::array<double, model::kNumJoints> tau{};  ///< [Nm]
};

/// One jump of a run that has several (the course).
struct JumpSpan {
  double start_t = std::numeric_limits<double>::quiet_NaN();      ///< start of the take-off [s]
  double touchdown_t = std::numeric_limits<double>::quiet_NaN();  ///< first contact after it
  std::vector<PathPoint> planned_com;  ///< this jump's plan, world frame (empty: none)
};

/// A run to draw. The ground plane z = 0 is always drawn.
struct Recording {
  std::string title;                   ///< shown on every picture
  std::vector<Frame> frames;           ///< in time order
  std::vector<SceneBox> boxes;         ///< walls and platforms
  std::vector<PathPoint> planned_com;  ///< the plan's CoM path (empty: none)
  /// Start of the jump (take-off phase) and first wheel contact after the flight [s]; NaN:
  /// unknown (the strip then spans the whole run).
  double jump_start_t = std::numeric_limits<double>::quiet_NaN();
  double touchdown_t = std::numeric_limits<double>::quiet_NaN();
  /// The plan's lift-off (t2) and, for a two-step take-off, the front pair's (t1) [s]; NaN:
  /// unknown or not a two-step take-off.
  double liftoff_t = std::numeric_limits<double>::quiet_NaN();
  double front_liftoff_t = std::numeric_limits<double>::quiet_NaN();
  /// The plan's joint speeds and torques over the take-off (empty: none; the knee figure).
  std::vector<PlannedJoints> planned_joints;
  /// Every jump of a run with several (the course), in time order: the snapshot strip draws
  /// one row each. Empty for a run with one jump, which the fields above describe (they
  /// describe the last jump of a run with several).
  std::vector<JumpSpan> jumps;
  /// What the frames are: "simulated" (ground truth), "estimated" (hardware) or "planned".
  std::string source = "simulated";

  /// Throws std::invalid_argument naming the field when the recording cannot be drawn: no
  /// frames, times not increasing, a non-finite pose or angle.
  void validate() const;
  /// Index of the frame at or just before time t (clamped to the ends).
  int frameAt(double t) const;
  /// Index of the highest CoM between jump_start_t and touchdown_t (the whole run if unknown).
  int apexFrame() const;
  /// Index of the highest CoM between times from_t and to_t, one jump of the run (from the
  /// first frame if from_t is not finite, to the last if to_t is not).
  int apexFrame(double from_t, double to_t) const;
};

/// The frame of a planar pose: CoM at (x, z) in the sagittal plane, pitch nose-up positive
/// (a rotation about -y), joint positions q. The base is placed so that the whole-robot CoM
/// at q (RobotModel::calcCompositeInertia) is at (x, 0, z), as the planner's model does.
Frame makePlanarFrame(const model::RobotModel& robot, double t, double com_x, double com_z,
                      double pitch, const Eigen::Ref<const Eigen::VectorXd>& q);

}  // namespace wj::viz
