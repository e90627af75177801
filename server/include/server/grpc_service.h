#pragma once
/// @file The wheeljump.planner.v1.JumpPlanner service on gRPC's callback API. Thin: each
/// handler validates and converts the request, turns the call's deadline into the core's, hands
/// the work to the PlanningCore and returns its reactor at once; the answer is converted and the
/// call finished from the core's worker thread. Nothing here blocks or plans.

#include <google/protobuf/arena.h>
#include <grpcpp/support/message_allocator.h>

#include <atomic>
#include <chrono>

#include "server/config.h"
#include "server/hot_responses.h"
#include "server/planning_core.h"
#include "wheeljump/planner/v1/jump_planner.grpc.pb.h"

namespace wj::server {

/// The steady-clock deadline of a call whose gRPC deadline is `deadline` (system clock;
/// time_point::max() when the client set none): default_s without one, at most max_s.
Clock::time_point toCoreDeadline(std::chrono::system_clock::time_point deadline,
                                 const DeadlineConfig& config);

/// PlanJump's request and response on one protobuf arena per call: the dense response (a few
/// hundred CentroidalSample messages and three N x 16 arrays) is built with a handful of block
/// allocations instead of one malloc per sample, and freed at once with its arena.
class PlanJumpArenaAllocator final
    : public grpc::MessageAllocator<wheeljump::planner::v1::PlanJumpRequest,
                                    wheeljump::planner::v1::PlanJumpResponse> {
 public:
  grpc::MessageHolder<wheeljump::planner::v1::PlanJumpRequest,
                      wheeljump::planner::v1::PlanJumpResponse>*
  AllocateMessages() override;
};

class JumpPlannerService final : public wheeljump::planner::v1::JumpPlanner::CallbackService {
 public:
  JumpPlannerService(PlanningCore& core, const ServerConfig& config);

  grpc::ServerUnaryReactor* PlanJump(grpc::CallbackServerContext* context,
                                     const wheeljump::planner::v1::PlanJumpRequest* request,
                                     wheeljump::planner::v1::PlanJumpResponse* response) override;
  grpc::ServerUnaryReactor* GetStats(grpc::CallbackServerContext* context,
                                     const wheeljump::planner::v1::GetStatsRequest* request,
                                     wheeljump::planner::v1::GetStatsResponse* response) override;
  grpc::ServerWriteReactor<wheeljump::planner::v1::WarmCacheProgress>* WarmCache(
      grpc::CallbackServerContext* context,
      const wheeljump::planner::v1::WarmCacheRequest* request) override;

  /// Calls in progress (PlanJump and WarmCache).
  int inflight() const { return inflight_.load(); }

 private:
  friend class PlanJumpReactor;
  friend class WarmCacheReactor;
  /// Admits one more call, or returns false when limits.max_inflight_calls are in progress.
  bool admit();
  void release() { inflight_.fetch_sub(1); }

  PlanningCore& core_;
  ServerConfig config_;
  HotResponses hot_;  ///< ready responses of bins (cache.hot_responses_mb; 0 = off)
  std::atomic<int> inflight_{0};
  PlanJumpArenaAllocator allocator_;
};

}  // namespace wj::server
