#pragma once
/// \file
/// The jump executor's gains as a file: config/jump_executor.yaml, read by the robot client
/// (the executor it flies plans with) and by the planning service's verifier (the executor it
/// simulates them with), so that a plan is verified with the controller that will run it.

#include <filesystem>
#include <string>
#include <string_view>

#include "sim/plan_executor.h"

namespace wj::sim {

/// Reads ExecutorSettings from YAML text whose root map holds every field of ExecutorSettings
/// (layout: config/jump_executor.yaml). Every key is required and unknown keys are errors
/// (std::runtime_error naming `origin` and the key); the values are then validated
/// (std::invalid_argument naming the field and its range).
ExecutorSettings parseExecutorSettings(std::string_view yaml_text, const std::string& origin);
/// Same, from a file.
ExecutorSettings loadExecutorSettings(const std::filesystem::path& yaml_file);

}  // namespace wj::sim
