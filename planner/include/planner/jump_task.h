#pragma once
/// @file What a jump must achieve, and the state it starts from.

#include <Eigen/Core>
#include <optional>
#include <string>

#include "planner/jump_plan.h"

namespace wj::planner {

/// An axis-aligned box standing on the ground, in the jump frame J [m].
struct BoxObstacle {
  double x_min = 0.0;   ///< near face
  double x_max = 0.0;   ///< far face, > x_min
  double height = 0.0;  ///< top above the ground, in (0, 1]
};

/// The target of the jump: CoM displacement, CoM height and pitch change at the event.
struct JumpTarget {
  double dx = 0.0;            ///< CoM x displacement from t = 0 [m], in [-3, 5]
  double height = 0.0;        ///< CoM height at the event [m], in [0.1, 1.5]
  double pitch_change = 0.0;  ///< nose-up positive [rad], in [-7, 7]
  TargetEvent event = TargetEvent::Apex;
};

/// A jump request in the planner's terms.
struct JumpTask {
  JumpTarget target;
  std::optional<BoxObstacle> obstacle;
  TakeoffMode mode = TakeoffMode::Simultaneous;

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate() const;
  /// True when the jump lands on top of the obstacle (a platform, a kerb): a touchdown target
  /// whose CoM x lies over the box. Its wheels must then touch down on the top, inside both
  /// faces, instead of beyond the far face, and target.height is the CoM height above the
  /// take-off ground at touchdown (the box's height plus the standing height).
  bool landsOnObstacle() const;
  /// A backflip: a two-step take-off whose target pitch change is more than half a turn
  /// nose-up. Its search uses the flip box of the settings (`flip.*`, docs/backflip.md).
  bool isBackflip() const;
};

/// The measured state at the start of the take-off. The wheels are on flat ground; the CoM
/// height follows from the posture.
struct InitialState {
  /// Forward CoM speed, the run-up [m/s], in [-1, maxRunUpSpeed(robot)].
  double v0 = 0.0;
  double pitch = 0.0;       ///< base pitch, nose-up positive [rad], in [-0.5, 0.5]
  double pitch_rate = 0.0;  ///< [rad/s], in [-3, 3]
  /// Joint positions [rad], jointIndex order; the sagittal joints must be within limits.
  Eigen::Matrix<double, model::kNumJoints, 1> q =
      Eigen::Matrix<double, model::kNumJoints, 1>::Zero();

  /// Throws std::invalid_argument naming the field and its allowed range.
  void validate(const model::RobotModel& robot) const;
};

/// The fastest run-up the robot can roll at [m/s]: the wheel radius times the wheels' no-load
/// speed (the slowest wheel's), where their drives have no torque left (40 rad/s x 0.085 m = 3.4
/// m/s on the default robot), capped at 4 m/s. A faster v0 is no state the robot can be in.
[[nodiscard]] double maxRunUpSpeed(const model::RobotModel& robot);

/// The slowest run-up [m/s]: a backward roll of 1 m/s (the backflip's).
inline constexpr double kMinRunUpSpeed = -1.0;

}  // namespace wj::planner
