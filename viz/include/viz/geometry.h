#pragma once
/// @file The robot's drawn geometry: the URDF's collision boxes and cylinders posed in the
/// world by forward kinematics (RobotModel::calcLinkPoses), and their side-view outlines.

#include <Eigen/Geometry>
#include <vector>

#include "robot_model/robot_model.h"
#include "viz/recording.h"

namespace wj::viz {

/// One collision shape of the URDF, posed in the world.
struct PosedShape {
  int link = 0;                                            ///< index into RobotModel::links()
  model::LinkShape shape;                                  ///< kind and size (URDF)
  Eigen::Isometry3d X_WS = Eigen::Isometry3d::Identity();  ///< shape frame in the world
};

/// Base pose of a frame as an isometry.
Eigen::Isometry3d basePose(const Frame& frame);
/// World pose of every link at `frame` (index as RobotModel::links()).
std::vector<Eigen::Isometry3d> calcLinkPosesW(const model::RobotModel& robot, const Frame& frame);
/// Every collision shape of every link, posed at `frame`.
std::vector<PosedShape> calcPosedShapes(const model::RobotModel& robot, const Frame& frame);
/// World position of the four wheel centres (leg order LF, RF, LH, RH).
std::array<Eigen::Vector3d, model::kNumLegs> calcWheelCentersW(const model::RobotModel& robot,
                                                               const Frame& frame);

/// Outline of a shape seen from the side (projected along y onto the x-z plane): the convex
/// hull of its projected corners (box) or rim points (cylinder, `segments` per rim; sphere: a
/// circle of `segments` points), counter-clockwise, as (x, z) pairs [m].
std::vector<Eigen::Vector2d> sideOutline(const PosedShape& shape, int segments = 32);

/// Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, no repeated point.
std::vector<Eigen::Vector2d> convexHull(std::vector<Eigen::Vector2d> points);

}  // namespace wj::viz
