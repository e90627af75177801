#pragma once
/// @file Mirror symmetry about the robot's sagittal plane (y = 0 of the base): which joint is
/// whose mirror image, and whether a robot, a simulation or a plan is symmetric, which the
/// sagittal verification model (SimModel::Sagittal, docs/sim.md) needs to be exact.
/// Simbody-free and C++17 (included by the Simbody translation units).

#include <string>

#include "robot_model/robot_model.h"
#include "sim/settings.h"

namespace wj::sim {

/// The joint on the other side of the robot: LF <-> RF, LH <-> RH, same kind.
constexpr int mirrorJoint(int joint) {
  const int leg = joint / model::kJointsPerLeg;
  const int other = leg ^ 1;  // LF = 0 <-> RF = 1, LH = 2 <-> RH = 3
  return other * model::kJointsPerLeg + joint % model::kJointsPerLeg;
}

/// Sign that turns a joint's position into its mirror joint's under the reflection y -> -y:
/// -1 for the abduction (HAA, axis x of both legs), +1 for the joints turning about y.
constexpr double mirrorSign(int joint) {
  return joint % model::kJointsPerLeg == static_cast<int>(model::JointKind::HAA) ? -1.0 : 1.0;
}

/// True for the left legs' joints: the ones a sagittal model keeps.
constexpr bool isLeftJoint(int joint) {
  const int leg = joint / model::kJointsPerLeg;
  return leg == static_cast<int>(model::Leg::LF) || leg == static_cast<int>(model::Leg::LH);
}

/// Why `model` is not mirror-symmetric about y = 0 of its base (a sentence naming the first
/// link or joint that breaks it), or "" when it is: base centre of mass and products of
/// inertia, each right joint's frame, axis, limits and drive, each right link's inertia.
std::string findAsymmetry(const model::RobotModel& model);
/// Why a simulation with `settings` does not keep a symmetric robot symmetric, or "": noise,
/// a non-nominal plant, ellipsoid wheels (Simbody's contact subsystem) or a terrain box that
/// does not span y symmetrically.
std::string findAsymmetry(const SimSettings& settings);

}  // namespace wj::sim
