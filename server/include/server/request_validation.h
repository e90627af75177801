#pragma once
/// @file Validation of the wheeljump.planner.v1 requests and their conversion to the service's
/// domain types. Every field is checked (finite, in range, right size, known enum value); a
/// failure throws ServiceError(InvalidArgument) whose message names the proto field and its
/// allowed range. The planner's own checks (JumpTask::validate, InitialState::validate) are
/// reused, their field names translated to the proto's.

#include <cstddef>
#include <cstdint>

#include "robot_model/robot_model.h"
#include "server/plan_types.h"
#include "server/service_error.h"
#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::server {

namespace v1 = wheeljump::planner::v1;

/// Bounds of the proto-level checks (the planner's ranges live in the planner).
struct RequestBounds {
  static constexpr double kMaxPositionM = 1.0e4;  ///< |base position| components
  static constexpr double kQuaternionNormTolerance = 1e-3;
  static constexpr double kMaxRollRad = 0.5;            ///< the planar model assumes level
  static constexpr double kMaxLinearSpeedMS = 20.0;     ///< |base velocity| components
  static constexpr double kMaxAngularSpeedRadS = 50.0;  ///< |base angular velocity| components
  static constexpr double kMaxJointSpeedRadS = 1000.0;  ///< |joint velocity|
  static constexpr std::uint32_t kMaxEvaluations = 10'000'000;
  static constexpr std::uint32_t kMaxVerifiedCandidates = 64;
  static constexpr std::size_t kMaxRequestIdBytes = 128;
  /// state.stamp_s is the robot's clock (not comparable with the server's): since boot or since
  /// the Unix epoch, both in [0, 1e10] s (1e10 s is the year 2286); 0 = not given.
  static constexpr double kMaxStampS = 1.0e10;
  static constexpr int kMaxWarmGridPoints = 1000;
};

/// The planar initial state of a measured robot state: v0 is the base velocity along the
/// heading (base x projected on the ground), pitch is nose-up, the pitch rate is -w_B.y.
planner::InitialState toInitialState(const v1::RobotState& state, const model::RobotModel& robot);
/// The task; `initial` is where the robot starts (its front wheels bound the obstacle).
planner::JumpTask toJumpTask(const v1::JumpTask& task, const model::RobotModel& robot,
                             const planner::InitialState& initial);
/// A complete PlanJump request.
PlanRequest toPlanRequest(const v1::PlanJumpRequest& request, const model::RobotModel& robot);
/// A complete WarmCache request; `nominal` gives the state of every grid point but v0.
WarmRequest toWarmRequest(const v1::WarmCacheRequest& request, const model::RobotModel& robot,
                          const planner::InitialState& nominal);

}  // namespace wj::server
