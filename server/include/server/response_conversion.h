#pragma once
/// @file Conversion of the service's answers to the wheeljump.planner.v1 responses.

#include <string>

#include "robot_model/robot_model.h"
#include "server/plan_types.h"
#include "server/planning_core.h"
#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::server {

namespace v1 = wheeljump::planner::v1;

/// The response of an answer (the plan, what it predicts, feasibility, verification). The plan
/// goes out as it was built (dense samples, or knots), its knots in the compact form when
/// `format` is CompactKnots.
void toProto(const PlanAnswer& answer, const model::RobotModel& robot,
             const std::string& request_id, TrajectoryFormat format, v1::PlanJumpResponse* out);
void toProto(const StatsSnapshot& stats, v1::GetStatsResponse* out);
void toProto(const WarmProgress& progress, v1::WarmCacheProgress* out);
v1::PlanSource toProto(PlanSource source);

}  // namespace wj::server
