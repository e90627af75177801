#pragma once
/// @file The wheeljump.planner.v1.JumpPlanner service on gRPC's callback API. Thin: each
/// handler validates and converts the request, turns the call's deadline into the core's, hands
/// the work to the PlanningCore and returns its reactor at once; the answer is converted and the
/// call finished from the core's worker thread. Nothing here blocks or plans.

#include <google/protobuf/arena.h>
#include <grpcpp/support/byte_buffer.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

#include "server/config.h"
#include "server/hot_responses.h"
#include "server/planning_core.h"
#include "wheeljump/planner/v1/jump_planner.grpc.pb.h"

namespace wj::server {

/// The steady-clock deadline of a call whose gRPC deadline is `deadline` (system clock;
/// time_point::max() when the client set none): default_s without one, at most max_s.
Clock::time_point toCoreDeadline(std::chrono::system_clock::time_point deadline,
                                 const DeadlineConfig& config);

/// The service's base: GetStats and WarmCache on the typed callback API, PlanJump on the raw one
/// (ByteBuffer in and out, so that the hot tier can answer with ready bytes; the request is
/// parsed and the response serialized by the service, each on a protobuf arena per call).
using JumpPlannerBase = wheeljump::planner::v1::JumpPlanner::WithRawCallbackMethod_PlanJump<
    wheeljump::planner::v1::JumpPlanner::WithCallbackMethod_GetStats<
        wheeljump::planner::v1::JumpPlanner::WithCallbackMethod_WarmCache<
            wheeljump::planner::v1::JumpPlanner::Service>>>;

class JumpPlannerService final : public JumpPlannerBase {
 public:
  JumpPlannerService(PlanningCore& core, const ServerConfig& config);

  grpc::ServerUnaryReactor* PlanJump(grpc::CallbackServerContext* context,
                                     const grpc::ByteBuffer* request,
                                     grpc::ByteBuffer* response) override;
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
  /// The hot tier's slot of a request: its key and the cache entry it would be built from.
  struct HotSlot {
    std::string key;               ///< "" when the request is not a hit
    std::uint64_t generation = 0;  ///< the cache entry's (SolutionCache::find)
  };
  /// Answers `r` into `response_bytes` from the hot tier if its bin has ready bytes built from
  /// the entry the cache holds now (true); else fills `slot` for the hit's regeneration.
  bool answerHot(const PlanRequest& r, grpc::ByteBuffer* response_bytes, HotSlot* slot);
  /// Admits one more call, or returns false when limits.max_inflight_calls are in progress.
  bool admit();
  void release() { inflight_.fetch_sub(1); }

  PlanningCore& core_;
  ServerConfig config_;
  HotResponses hot_;  ///< ready responses of bins (cache.hot_responses_mb; 0 = off)
  std::atomic<int> inflight_{0};
};

}  // namespace wj::server
