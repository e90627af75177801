#pragma once
/// @file The whole robot's angular momentum about its CoM from its configuration and rates
/// (sim_jump --momentum-csv compares Simbody's with the plan's; docs/backflip.md).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "robot_model/robot_model.h"

namespace wj::model {

/// Whether the wheels' own rotation counts. A free wheel keeps its spin about its axle in
/// flight, so the momentum the body and legs exchange is the rest, the wheels taken as point
/// masses on their axles: the planner's flight model (planner::JumpEvent::momentum).
enum class WheelSpin { Included, Excluded };

/// Angular momentum of the whole robot about its CoM, in the world frame [kg m^2/s], for the
/// base orientation R_WB, its angular velocity w_WB (world frame) and the joints' q and qd
/// (jointIndex order). Independent of the base's position and linear velocity. The links'
/// velocities relative to the base are central differences of calcLinkPoses along qd.
Eigen::Vector3d calcCentralAngularMomentum(const RobotModel& robot, const Eigen::Matrix3d& R_WB,
                                           const Eigen::Vector3d& w_WB, const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& qd,
                                           WheelSpin wheels = WheelSpin::Included);

/// calcCentralAngularMomentum without allocation, for a control loop: the buffers are sized
/// once, at construction. Keeps a reference to `robot`. One per thread.
class CentralMomentum {
 public:
  explicit CentralMomentum(const RobotModel& robot);

  /// As calcCentralAngularMomentum (the same arithmetic); q and qd have 16 entries.
  Eigen::Vector3d calc(const Eigen::Matrix3d& R_WB, const Eigen::Vector3d& w_WB,
                       const Eigen::VectorXd& q, const Eigen::VectorXd& qd,
                       WheelSpin wheels = WheelSpin::Included);
  /// Every link's pose in the base frame at the last calc()'s q (calcLinkPoses).
  const std::vector<Eigen::Isometry3d>& linkPoses() const { return X_; }

 private:
  const RobotModel& robot_;
  std::vector<Eigen::Isometry3d> X_, X_plus_, X_minus_;
  std::vector<Eigen::Vector3d> p_, v_, w_;
  Eigen::VectorXd q_step_;
  std::vector<bool> is_wheel_;  ///< per link
};

}  // namespace wj::model
