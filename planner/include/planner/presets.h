#pragma once
/// @file The paper's jump tasks as presets (paper Sec. IV-B and V; docs/planner.md).

#include <string>
#include <vector>

#include "planner/jump_planner.h"

namespace wj::planner {

/// A task and the state it starts from.
struct Scenario {
  std::string name;
  JumpTask task;
  InitialState initial;
};

/// The platform preset's box: height and length along x [m].
inline constexpr double kPlatformHeight = 0.25;
inline constexpr double kPlatformLength = 4.0;

/// Names accepted by makePreset: "forward", "forward_hw", "vertical", "backflip", "platform".
std::vector<std::string> presetNames();

/// Builds a preset for `planner`'s robot and settings. `v0` overrides the run-up speed.
///  - forward: v0 = 3.0 m/s, a 0.25 m wall, landing upright 1.9 m ahead, beyond the wall.
///  - forward_hw: the same over the 0.12 m obstacle of the paper's hardware experiment.
///  - vertical: v0 = 0, base apex 0.7 m straight up (apex target).
///  - backflip: two-step take-off, a full backward rotation (+2 pi), landing 0.55 m behind.
///  - platform: v0 = 3.0 m/s onto a 0.25 m platform 4 m long, its near face 1.6 m ahead, all
///    four wheels landing on its top, the CoM 2.0 m ahead, 0.2 rad nose-up.
/// Throws std::invalid_argument for an unknown name.
Scenario makePreset(const JumpPlanner& planner, const std::string& name,
                    std::optional<double> v0 = std::nullopt);

/// CoM height at which the base origin is at `base_height` in the posture `q`, pitch 0 [m].
double comHeightForBaseHeight(const model::RobotModel& robot, const Eigen::VectorXd& q,
                              double base_height);

}  // namespace wj::planner
