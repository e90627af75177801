#pragma once
/// @file The whole robot's angular momentum about its CoM from its configuration and rates
/// (sim_jump --momentum-csv compares Simbody's with the plan's; docs/backflip.md).

#include <Eigen/Core>

#include "robot_model/robot_model.h"

namespace wj::model {

/// Angular momentum of the whole robot about its CoM, in the world frame [kg m^2/s], for the
/// base orientation R_WB, its angular velocity w_WB (world frame) and the joints' q and qd
/// (jointIndex order). Independent of the base's position and linear velocity. The links'
/// velocities relative to the base are central differences of calcLinkPoses along qd.
Eigen::Vector3d calcCentralAngularMomentum(const RobotModel& robot, const Eigen::Matrix3d& R_WB,
                                           const Eigen::Vector3d& w_WB, const Eigen::VectorXd& q,
                                           const Eigen::VectorXd& qd);

}  // namespace wj::model
