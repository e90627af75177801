#pragma once
/// @file The 3D replay: one self-contained HTML page (three.js and the data inlined) that plays
/// a run in the browser from a file URL, offline.

#include <filesystem>
#include <nlohmann/json.hpp>

#include "robot_model/robot_model.h"
#include "viz/recording.h"

namespace wj::viz {

/// How the page is written.
struct PageSettings {
  double rate_hz = 100.0;  ///< frames kept per second of the run (the rest are dropped)
  /// Folder with replay.html and node_modules/three ("" = findWebDir()).
  std::filesystem::path web_dir;
  /// Throws std::invalid_argument naming the field when out of range.
  void validate() const;
};

/// The folder of the page template and the npm packages: $WJ_VIZ_WEB_DIR if set, else the
/// source tree's viz/web. Throws std::runtime_error saying how to get three.js when the folder
/// or node_modules/three is missing (deploy/install-deps.sh runs npm ci there).
std::filesystem::path findWebDir();

/// The page's data: the robot (links, collision shapes, joints, actuator limits), the frames
/// (decimated to rate_hz; torque over the envelope at each instant), the boxes, the paths and
/// the jump's instants, plus `check`: C++ forward kinematics of the wheel centres at the apex
/// frame, which the browser test compares with the page's own.
nlohmann::json pageData(const model::RobotModel& robot, const Recording& rec,
                        const PageSettings& settings = {});

/// Writes the page. Throws std::runtime_error when the template or three.js is missing or the
/// file cannot be written.
void writeReplayPage(const model::RobotModel& robot, const Recording& rec,
                     const std::filesystem::path& html, const PageSettings& settings = {});

}  // namespace wj::viz
