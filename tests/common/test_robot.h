#pragma once
// The robot the tests run on: the source tree's models folder (WJ_MODELS_DIR, which
// wj_add_gtest defines for every test), so that no test depends on an installed copy.

#include <filesystem>
#include <string>

#include "robot_model/robot_model.h"

namespace wj::test {

/// A fresh robot from the source tree's models, with the given actuator file of that folder.
inline model::RobotModel loadRobot(const std::string& actuators_file = "actuators.yaml") {
  const std::filesystem::path dir = WJ_MODELS_DIR;
  return model::RobotModel::load(dir / "wheeljump.urdf", dir / actuators_file);
}

/// The default robot, loaded once per test binary (the model is immutable).
inline const model::RobotModel& robot() {
  static const model::RobotModel r = loadRobot();
  return r;
}

}  // namespace wj::test
