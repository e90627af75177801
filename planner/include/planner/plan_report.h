#pragma once
/// @file Human- and machine-readable reports of a planner result (plan_jump, benchmarks).

#include <nlohmann/json.hpp>
#include <string>

#include "planner/jump_planner.h"
#include "planner/presets.h"

namespace wj::planner {

/// The JSON report: feasible, solve_ms, evaluations, generations, target, predicted,
/// phase_times, max_abs_torque_nm / max_abs_speed_rad_s per joint kind, worst_margin per
/// constraint class, violations, binding, polish, summary.
nlohmann::json reportJson(const Scenario& scenario, const PlannerResult& result);
/// A short text report of the same.
std::string reportText(const Scenario& scenario, const PlannerResult& result);

}  // namespace wj::planner
