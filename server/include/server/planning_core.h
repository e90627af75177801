#pragma once
/// @file The core of the service, free of gRPC: cache lookup, coalescing of identical misses,
/// the deadline turned into a budget, the pools and their lanes, WarmCache, and the statistics.
/// What one miss does (search, verification of the best candidates, choice) is MissPipeline's. The
/// RPC layer validates and converts requests, hands them here with a completion callback, and
/// returns at once.

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "planner/jump_planner.h"
#include "robot_model/robot_model.h"
#include "server/cache_key.h"
#include "server/config.h"
#include "server/executor.h"
#include "server/latency_histogram.h"
#include "server/miss_pipeline.h"
#include "server/plan_types.h"
#include "server/plan_verifier.h"
#include "server/service_error.h"
#include "server/solution_cache.h"

namespace wj::server {

/// An answer, or the error that replaced it.
struct PlanOutcome {
  std::optional<ServiceError> error;  ///< set when there is no answer
  PlanAnswer answer;
};

/// The completion of one plan request (a PlanJump call, or a WarmCache grid point). Completed
/// exactly once: by the core with an outcome, or by cancel().
class PlanCall {
 public:
  using Done = std::function<void(PlanOutcome&&)>;
  /// `deadline` bounds all the work done for this call.
  PlanCall(Clock::time_point deadline, Done done);

  /// The caller gave up (gRPC OnCancel, or its deadline passed): completes the call with
  /// Cancelled at once if it is still open, and withdraws its interest in shared work.
  void cancel();
  bool cancelled() const { return cancelled_.load(); }
  /// Completes the call; false if it was already completed.
  bool complete(PlanOutcome&& outcome);
  bool completed() const;
  Clock::time_point deadline() const { return deadline_; }
  Clock::time_point received() const { return received_; }

 private:
  friend class PlanningCore;
  /// Adds `hook` to run on cancel() (runs it at once if already cancelled).
  void addCancelHook(std::function<void()> hook);

  const Clock::time_point deadline_;
  const Clock::time_point received_;
  mutable std::mutex mu_;
  Done done_;
  bool completed_ = false;
  std::vector<std::function<void()>> cancel_hooks_;
  std::atomic<bool> cancelled_{false};
};

/// Progress of a WarmCache call after one grid point.
struct WarmProgress {
  int done = 0;
  int total = 0;
  double v0 = 0.0;
  bool feasible = false;
  PlanSource source = PlanSource::CacheMiss;
};

/// The completion of one WarmCache call: progress once per grid point, then done once.
class WarmCall {
 public:
  using Progress = std::function<void(const WarmProgress&)>;
  using Done = std::function<void(std::optional<ServiceError>)>;
  WarmCall(Clock::time_point deadline, Progress progress, Done done);

  /// The caller gave up: the grid point in progress is cancelled, no further point starts.
  void cancel();
  bool cancelled() const { return cancelled_.load(); }
  Clock::time_point deadline() const { return deadline_; }

 private:
  friend class PlanningCore;
  const Clock::time_point deadline_;
  Progress progress_;
  Done done_;
  std::atomic<bool> cancelled_{false};
  std::mutex mu_;
  std::shared_ptr<PlanCall> current_;  ///< the grid point in progress
};

/// Latency percentiles of one path [ms].
struct PathLatency {
  PlanSource path = PlanSource::CacheHit;
  std::uint64_t count = 0;
  double p50_ms = 0.0, p90_ms = 0.0, p99_ms = 0.0;
};

/// Counters since the core was built (the proto's GetStatsResponse).
struct StatsSnapshot {
  std::uint64_t requests = 0;
  std::uint64_t cache_hits = 0, cache_misses = 0, coalesced = 0, warm_starts = 0;
  std::uint64_t evictions = 0, cache_entries = 0;
  std::uint64_t rejected_invalid = 0, rejected_queue_full = 0, deadline_exceeded = 0;
  std::array<PathLatency, kNumPlanSources> latencies{};
  double uptime_s = 0.0;
  CacheCounters cache;
};

class PlanningCore {
 public:
  /// Builds the planner, the pools and the cache. `verifier` may be null (verification is then
  /// reported NOT_RUN), `store` may be null (memory-only cache).
  PlanningCore(const ServerConfig& config, model::RobotModel robot,
               planner::PlannerSettings settings, std::unique_ptr<PlanVerifier> verifier,
               std::unique_ptr<SecondLevelStore> store);
  /// Calls shutdown().
  ~PlanningCore();
  PlanningCore(const PlanningCore&) = delete;
  PlanningCore& operator=(const PlanningCore&) = delete;

  /// Starts answering `request`. Never blocks and never plans on the calling thread: a cache hit
  /// is regenerated on the hit pool, a miss joins an identical computation in flight or is
  /// queued on the plan pool. `call` is completed exactly once, with RESOURCE_EXHAUSTED at once
  /// if the pool's queue is full, with UNAVAILABLE after shutdown().
  void plan(PlanRequest request, std::shared_ptr<PlanCall> call);
  /// Precomputes the grid of `request` one point after the other on the plan pool, reporting
  /// progress through `call`. RESOURCE_EXHAUSTED at once when max_streams calls are running.
  void warm(WarmRequest request, std::shared_ptr<WarmCall> call);

  /// The memory cache's entry that would answer `request` (key `key`) as a hit now: none on a
  /// miss, or when the request wants verification and the entry was computed without it. Cheap
  /// (one lock, one lookup): the RPC layer's hot tier checks its responses against it.
  /// `generation`, if given, receives the entry's generation (SolutionCache::find).
  std::optional<CachedSolution> findHit(const PlanRequest& request, const CacheKey& key,
                                        std::uint64_t* generation = nullptr);
  /// Counts a hit answered by the RPC layer's hot tier, `ms` after it was received.
  void recordHotHit(double ms);
  /// Counts a PlanJump call received (valid or not) / refused as invalid.
  void recordRequest() { requests_.fetch_add(1); }
  void recordInvalid() { rejected_invalid_.fetch_add(1); }
  /// Counts a call refused because limits.max_inflight_calls were in progress.
  void recordBusy() { rejected_queue_full_.fetch_add(1); }
  StatsSnapshot stats() const;

  /// Refuses new work (UNAVAILABLE), abandons queued work, waits for running work, flushes the
  /// cache. Idempotent.
  void shutdown();

  /// The state the presets and WarmCache plan from: standing posture, level, rolling at v0.
  planner::InitialState nominalState(double v0) const;
  const planner::JumpPlanner& planner() const { return planner_; }
  const model::RobotModel& robot() const { return planner_.robot(); }
  const PlanVerifier* verifier() const { return verifier_.get(); }
  const KeyQuantizer& quantizer() const { return quantizer_; }
  /// The key of a request (after the seed is made effective).
  CacheKey keyOf(const PlanRequest& request) const;

 private:
  struct Computation;
  struct WarmState;

  bool wantsVerification(const PlanRequest& r) const;
  std::uint64_t effectiveSeed(const PlanRequest& r) const;
  /// Records the outcome's statistics and completes the call.
  void finish(const std::shared_ptr<PlanCall>& call, PlanOutcome&& outcome);
  /// Answers a hit on the calling thread: the plan rebuilt at the caller's state, or a
  /// computation started when the stored solution is not valid there or no longer meets there
  /// its target or (a closest approach) its constraints.
  void answerHit(const PlanRequest& request, const CacheKey& key, const CachedSolution& solution,
                 const std::shared_ptr<PlanCall>& call);
  /// answerHit() on the hit pool (the warm-up's hits).
  void submitHit(PlanRequest request, CacheKey key, CachedSolution solution,
                 std::shared_ptr<PlanCall> call, BoundedExecutor::Lane lane);
  void startComputation(PlanRequest request, CacheKey key, std::shared_ptr<PlanCall> call,
                        BoundedExecutor::Lane lane);
  /// The leader's miss: the second level, then the pipeline; completes every caller.
  void runComputation(const std::shared_ptr<Computation>& c);
  /// Answers `c` from the second-level store if it holds a usable entry; false otherwise.
  bool answerFromPersisted(const std::shared_ptr<Computation>& c, const PlanRequest& request);
  /// Completes every live caller of `c` (the leader with `leader_answer` if given, the others
  /// from `solution`), or all with `error`.
  void finishComputation(const std::shared_ptr<Computation>& c,
                         const std::optional<ServiceError>& error,
                         std::optional<PlanAnswer> leader_answer,
                         const std::optional<CachedSolution>& solution, PlanSource waiter_source);
  /// The answer for `request` regenerated from a stored solution (throws if u is invalid at the
  /// request's state).
  PlanAnswer answerFromSolution(const CachedSolution& s, const PlanRequest& request,
                                const CacheKey& key, PlanSource source) const;
  VerificationSummary summaryOf(const StoredVerification& v) const;
  void startWarmPoint(const std::shared_ptr<WarmState>& state);

  ServerConfig config_;
  planner::JumpPlanner planner_;
  std::unique_ptr<PlanVerifier> verifier_;
  KeyQuantizer quantizer_;
  SolutionCache cache_;
  BoundedExecutor hit_pool_;
  BoundedExecutor plan_pool_;
  BoundedExecutor verify_pool_;
  MissPipeline pipeline_;  ///< after the planner, verifier and verify pool it refers to
  const Clock::time_point started_;

  std::mutex mu_;  ///< guards inflight_, stopping_, warm_streams_
  std::unordered_map<std::string, std::shared_ptr<Computation>> inflight_;
  bool stopping_ = false;
  int warm_streams_ = 0;
  std::once_flag shutdown_once_;

  std::atomic<std::uint64_t> requests_{0}, hits_{0}, misses_{0}, coalesced_{0}, warm_starts_{0};
  std::atomic<std::uint64_t> rejected_invalid_{0}, rejected_queue_full_{0}, deadline_exceeded_{0};
  std::array<LatencyHistogram, kNumPlanSources> latency_;
};

}  // namespace wj::server
