#pragma once
// The robot's collision spheres: those that meet the ground half-space and the groups that meet
// the terrain boxes, built once from the RobotModel. Internal to wj_sim_simbody (C++17).

#include <Simbody.h>

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "robot_model/robot_model.h"
#include "sim/settings.h"

namespace wj::sim::detail {

// Which part of the robot a collision sphere belongs to.
enum class Part : std::uint8_t { Wheel, Base, Leg };

// Spheres fixed to one link, for contact with boxes and for the clearance metric.
struct SphereGroup {
  int link = 0;  // index into RobotModel::links()
  Part part = Part::Base;
  int leg = -1;                                            // 0..3 for wheels and legs
  std::vector<Eigen::Vector3d> centers;                    // in the link frame
  double radius = 0.0;                                     // of each sphere
  Eigen::Vector3d bound_center = Eigen::Vector3d::Zero();  // bounding sphere, link frame
  double bound_radius = 0.0;
  double weight = 1.0;  // groups it stands for: 2 for a left one and its mirror image
};

// A sphere fixed to a link, against the ground half-space.
struct GroundSphere {
  int link = 0;  // index into RobotModel::links()
  Part part = Part::Base;
  int leg = -1;             // 0..3 for wheels and knees
  SimTK::Vec3 center{0.0};  // in the link frame
  double radius = 0.0;
  double weight = 1.0;  // spheres it stands for: 2 for a left one and its mirror image
};

/// The spheres against the ground: per leg the wheel (unless an ellipsoid, which Simbody's
/// contact subsystem handles) and the knee, then the eight base corners; sorted by link, so
/// that a pass over them fetches each link's pose once.
std::vector<GroundSphere> makeGroundSpheres(const model::RobotModel& model,
                                            const ContactSettings& cs, bool ellipsoid_wheels);
/// The sphere groups against the terrain boxes: the base surface, then per leg the wheel, the
/// thigh and the shank.
std::vector<SphereGroup> makeBoxSphereGroups(const model::RobotModel& model,
                                             const ContactSettings& cs);

/// The spheres of a sagittal model (SimModel::Sagittal): the right legs' dropped (their left
/// mirror images count twice), the base's on y > 0 counting twice, those on y = 0 once, those
/// on y < 0 dropped.
void keepSagittal(std::vector<GroundSphere>& ground_spheres, std::vector<SphereGroup>& groups);

}  // namespace wj::sim::detail
