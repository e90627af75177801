#include "server/planning_core.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace wj::server {

namespace {

double msBetween(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}
double secondsUntil(Clock::time_point t) {
  return std::chrono::duration<double>(t - Clock::now()).count();
}

PlanOutcome errorOutcome(ErrorCode code, const std::string& message) {
  PlanOutcome o;
  o.error = ServiceError(code, message);
  return o;
}

/// A stored solution rebuilt at another caller's state within its bins (a slightly different
/// v0 or posture) that no longer meets there what it met where it was computed: its target, or,
/// for a closest approach to a target out of reach, every constraint (a margin that was nearly
/// zero). The robot would refuse that plan, so the caller's state is planned for instead.
bool lostAtThisState(const CachedSolution& stored, const planner::Evaluation& here) {
  return (stored.feasible && !here.feasible) || (stored.constraints_ok && !here.constraints_ok);
}

}  // namespace

//==============================================================================================
PlanCall::PlanCall(Clock::time_point deadline, Done done)
    : deadline_(deadline), received_(Clock::now()), done_(std::move(done)) {}

void PlanCall::addCancelHook(std::function<void()> hook) {
  {
    std::lock_guard lock(mu_);
    if (!cancelled_.load()) {
      cancel_hooks_.push_back(std::move(hook));
      return;
    }
  }
  hook();
}

void PlanCall::cancel() {
  std::vector<std::function<void()>> hooks;
  {
    std::lock_guard lock(mu_);
    if (cancelled_.exchange(true)) return;
    hooks.swap(cancel_hooks_);
  }
  for (const auto& hook : hooks) hook();
  complete(errorOutcome(ErrorCode::Cancelled, "the call was cancelled"));
}

bool PlanCall::complete(PlanOutcome&& outcome) {
  Done done;
  {
    std::lock_guard lock(mu_);
    if (completed_) return false;
    completed_ = true;
    done = std::move(done_);
  }
  if (done) done(std::move(outcome));
  return true;
}

bool PlanCall::completed() const {
  std::lock_guard lock(mu_);
  return completed_;
}

WarmCall::WarmCall(Clock::time_point deadline, Progress progress, Done done)
    : deadline_(deadline), progress_(std::move(progress)), done_(std::move(done)) {}

void WarmCall::cancel() {
  cancelled_ = true;
  std::shared_ptr<PlanCall> current;
  {
    std::lock_guard lock(mu_);
    current = current_;
  }
  if (current) current->cancel();
}

//==============================================================================================
// A computation shared by every identical miss that arrives while it runs.
struct PlanningCore::Computation {
  struct Caller {
    std::shared_ptr<PlanCall> call;
    PlanRequest request;
    bool live = true;  ///< not cancelled (guarded by mu)
  };
  std::string id;  ///< key bytes + verification flag
  CacheKey key;
  bool want_verify = false;
  std::mutex mu;
  std::vector<Caller> callers;  ///< [0] is the leader
  int live = 0;
  std::atomic<bool> cancel{false};

  void attach(const std::shared_ptr<Computation>& self, std::shared_ptr<PlanCall> call,
              PlanRequest request) {
    std::size_t index = 0;
    {
      std::lock_guard lock(mu);
      index = callers.size();
      callers.push_back({call, std::move(request), true});
      ++live;
    }
    // Withdraws this caller's interest when it cancels; the last one cancels the work.
    call->addCancelHook([weak = std::weak_ptr<Computation>(self), index] {
      const auto c = weak.lock();
      if (!c) return;
      std::lock_guard lock(c->mu);
      auto& caller = c->callers[index];
      if (!caller.live) return;
      caller.live = false;
      if (--c->live == 0) c->cancel = true;
    });
  }
};

struct PlanningCore::WarmState {
  WarmRequest request;
  std::shared_ptr<WarmCall> call;
  std::size_t next = 0;
};

//==============================================================================================
PlanningCore::PlanningCore(const ServerConfig& config, model::RobotModel robot,
                           planner::PlannerSettings settings,
                           std::unique_ptr<PlanVerifier> verifier,
                           std::unique_ptr<SecondLevelStore> store)
    : config_(config),
      planner_(std::move(robot), std::move(settings)),
      verifier_(config.verification.enabled ? std::move(verifier) : nullptr),
      quantizer_(config.cache, planner_.robot().contentHash(),
                 fnv1a64(std::to_string(hashPlannerSettings(planner_)),
                         verifier_ ? verifier_->settingsHash() : 0)),
      cache_(config.cache.max_memory_entries, std::move(store)),
      hit_pool_("wj-hit", config.executor.hit_workers,
                static_cast<std::size_t>(config.executor.hit_queue)),
      plan_pool_("wj-plan", config.executor.plan_workers,
                 static_cast<std::size_t>(config.executor.plan_queue)),
      verify_pool_("wj-verify", config.executor.verify_workers,
                   static_cast<std::size_t>(64 * (config.executor.plan_workers + 1))),
      pipeline_(config_, planner_, verifier_.get(), verify_pool_),
      started_(Clock::now()) {}

PlanningCore::~PlanningCore() {
  shutdown();
}

planner::InitialState PlanningCore::nominalState(double v0) const {
  planner::InitialState s;
  s.v0 = v0;
  s.q = planner_.standPosture();
  return s;
}

bool PlanningCore::wantsVerification(const PlanRequest& r) const {
  return verifier_ != nullptr && !r.skip_verification;
}

std::uint64_t PlanningCore::effectiveSeed(const PlanRequest& r) const {
  return r.seed != 0 ? r.seed : planner_.settings().de.seed;
}

CacheKey PlanningCore::keyOf(const PlanRequest& request) const {
  return quantizer_.make(request.task, request.initial, effectiveSeed(request));
}

void PlanningCore::finish(const std::shared_ptr<PlanCall>& call, PlanOutcome&& outcome) {
  if (call->completed()) return;
  if (outcome.error) {
    if (outcome.error->code() == ErrorCode::DeadlineExceeded) deadline_exceeded_.fetch_add(1);
    if (outcome.error->code() == ErrorCode::ResourceExhausted) rejected_queue_full_.fetch_add(1);
  } else {
    const double ms = msBetween(call->received(), Clock::now());
    outcome.answer.stats.total_ms = ms;
    latency_[static_cast<std::size_t>(outcome.answer.source)].record(ms);
  }
  call->complete(std::move(outcome));
}

//==============================================================================================
void PlanningCore::plan(PlanRequest request, std::shared_ptr<PlanCall> call) {
  // A call cancelled after its deadline counts as a deadline miss.
  call->addCancelHook([this, weak = std::weak_ptr<PlanCall>(call)] {
    const auto c = weak.lock();
    if (c && !c->completed() && Clock::now() >= c->deadline()) deadline_exceeded_.fetch_add(1);
  });
  const CacheKey key = keyOf(request);
  bool stopping = false;
  {
    std::lock_guard lock(mu_);
    stopping = stopping_;
  }
  if (stopping) {
    finish(call, errorOutcome(ErrorCode::Unavailable, "the server is shutting down"));
    return;
  }
  std::optional<CachedSolution> hit = findHit(request, key);
  if (hit) {
    hits_.fetch_add(1);
    // A hit is about 0.1 ms of work (the plan rebuilt at the caller's state), less than what
    // the hand-off to the hit pool and back costs a caller: answered on the calling thread
    // (the RPC's reactor). A hit that turns out not to be valid here is handed to the plan
    // pool as before.
    answerHit(request, key, *hit, call);
    return;
  }
  startComputation(std::move(request), key, std::move(call), BoundedExecutor::Lane::Request);
}

std::optional<CachedSolution> PlanningCore::findHit(const PlanRequest& request, const CacheKey& key,
                                                    std::uint64_t* generation) {
  std::optional<CachedSolution> hit = cache_.find(key, generation);
  if (hit && wantsVerification(request) && hit->verification.status == VerificationStatus::NotRun)
    hit.reset();  // computed without verification; this caller wants it verified
  // An infeasible answer is not the last word for a caller who allows its search more
  // evaluations (docs/service.md, "Infeasible answers"): computed again, with that budget.
  else if (hit && !hit->feasible && pipeline_.maxEvaluations(request) > hit->max_evaluations)
    hit.reset();
  return hit;
}

void PlanningCore::recordHotHit(double ms) {
  hits_.fetch_add(1);
  latency_[static_cast<std::size_t>(PlanSource::CacheHit)].record(ms);
}

void PlanningCore::answerHit(const PlanRequest& request, const CacheKey& key,
                             const CachedSolution& solution,
                             const std::shared_ptr<PlanCall>& call) {
  if (call->completed()) return;
  PlanOutcome o;
  try {
    o.answer = answerFromSolution(solution, request, key, PlanSource::CacheHit);
  } catch (const std::exception& e) {
    // The stored u is not valid at this caller's state (rare, at a bin edge): compute.
    spdlog::debug("cache hit {} not valid at the request's state ({}); planning", key.hex(),
                  e.what());
    hits_.fetch_sub(1);
    startComputation(request, key, call, BoundedExecutor::Lane::Internal);
    return;
  }
  if (lostAtThisState(solution, o.answer.evaluation)) {
    spdlog::debug(
        "cache hit {} no longer meets its constraints or target at the request's "
        "state ({}); planning",
        key.hex(), o.answer.summary);
    hits_.fetch_sub(1);  // counted as a hit on arrival; the computation counts its miss
    startComputation(request, key, call, BoundedExecutor::Lane::Internal);
    return;
  }
  finish(call, std::move(o));
}

void PlanningCore::submitHit(PlanRequest request, CacheKey key, CachedSolution solution,
                             std::shared_ptr<PlanCall> call, BoundedExecutor::Lane lane) {
  Task task;
  task.run = [this, request, key, solution, call] { answerHit(request, key, solution, call); };
  task.abandon = [this, call] {
    finish(call, errorOutcome(ErrorCode::Unavailable, "the server is shutting down"));
  };
  if (!hit_pool_.trySubmit(std::move(task), lane))
    finish(call, errorOutcome(ErrorCode::ResourceExhausted,
                              "the cache-hit queue is full (executor.hit_queue = " +
                                  std::to_string(config_.executor.hit_queue) + "); retry later"));
}

void PlanningCore::startComputation(PlanRequest request, CacheKey key,
                                    std::shared_ptr<PlanCall> call, BoundedExecutor::Lane lane) {
  const bool want_verify = wantsVerification(request);
  const std::string id = key.bytes() + (want_verify ? "V" : "N");
  std::optional<ServiceError> refusal;
  {
    // Callers are completed only after the lock is released: their callbacks may call back.
    std::lock_guard lock(mu_);
    if (stopping_) {
      refusal = ServiceError(ErrorCode::Unavailable, "the server is shutting down");
    } else if (const auto it = inflight_.find(id); it != inflight_.end()) {
      coalesced_.fetch_add(1);
      it->second->attach(it->second, call, std::move(request));
      return;
    } else {
      auto c = std::make_shared<Computation>();
      c->id = id;
      c->key = key;
      c->want_verify = want_verify;
      c->attach(c, call, std::move(request));
      Task task;
      task.run = [this, c] { runComputation(c); };
      task.abandon = [this, c] {
        finishComputation(c, ServiceError(ErrorCode::Unavailable, "the server is shutting down"),
                          std::nullopt, std::nullopt, PlanSource::Coalesced);
      };
      // In the map before the task can run: finishComputation removes it under this lock.
      inflight_.emplace(id, c);
      if (!plan_pool_.trySubmit(std::move(task), lane)) {
        inflight_.erase(id);
        refusal = ServiceError(ErrorCode::ResourceExhausted,
                               "the planning queue is full (executor.plan_queue = " +
                                   std::to_string(config_.executor.plan_queue) + "); retry later");
      }
    }
  }
  if (refusal) {
    PlanOutcome o;
    o.error = *refusal;
    finish(call, std::move(o));
  }
}

//==============================================================================================
void PlanningCore::runComputation(const std::shared_ptr<Computation>& c) {
  const auto t_start = Clock::now();
  PlanRequest request;
  Clock::time_point deadline = t_start;
  {
    std::lock_guard lock(c->mu);
    request = c->callers.front().request;
    for (const auto& caller : c->callers)
      if (caller.live) deadline = std::max(deadline, caller.call->deadline());
  }
  if (c->cancel) {
    finishComputation(c, ServiceError(ErrorCode::Cancelled, "the call was cancelled"), std::nullopt,
                      std::nullopt, PlanSource::Coalesced);
    return;
  }
  if (answerFromPersisted(c, request)) return;
  misses_.fetch_add(1);

  // The deadline becomes the budget: what is left after the reply margin, which the pipeline
  // splits between the search (DE, polish) and the verification.
  MissInputs in;
  in.budget_end = deadline - std::chrono::duration_cast<Clock::duration>(
                                 std::chrono::duration<double>(config_.deadlines.reply_margin_s));
  in.remaining_s = secondsUntil(in.budget_end);
  if (in.remaining_s < config_.deadlines.min_budget_s) {
    finishComputation(c,
                      ServiceError(ErrorCode::DeadlineExceeded,
                                   "the deadline left no time to plan (waited in the queue)"),
                      std::nullopt, std::nullopt, PlanSource::Coalesced);
    return;
  }
  in.cache_key_hex = c->key.hex();
  in.seed = effectiveSeed(request);
  in.verify = c->want_verify;
  in.cancel = &c->cancel;
  PlanSource source = PlanSource::CacheMiss;
  const auto neighbours = cache_.nearestByV0(
      c->key, config_.cache.warm_start_neighbors,
      static_cast<int>(
          std::floor(config_.cache.warm_start_max_distance_m_s / config_.cache.v0_bin_m_s + 1e-9)));
  if (!neighbours.empty()) {
    in.warm_start.resize(planner::kNumDecision, static_cast<Eigen::Index>(neighbours.size()));
    for (std::size_t j = 0; j < neighbours.size(); ++j)
      for (int i = 0; i < planner::kNumDecision; ++i)
        in.warm_start(i, static_cast<Eigen::Index>(j)) =
            neighbours[j].second.u[static_cast<std::size_t>(i)];
    source = PlanSource::WarmStart;
    warm_starts_.fetch_add(1);
  }
  in.request = std::move(request);

  MissResult result = pipeline_.run(in);
  if (result.error) {
    finishComputation(c, result.error, std::nullopt, std::nullopt, PlanSource::Coalesced);
    return;
  }
  result.answer->source = source;
  if (result.solution && result.cacheable) {
    try {
      cache_.put(c->key, *result.solution);
    } catch (const std::exception& e) {
      spdlog::error("cache write failed (the entry stays in memory only): {}", e.what());
    }
  }
  // A plan the verifier refused is returned, but the robot should not fly it: say why, so
  // that an operator sees it without replaying the request (docs/service.md, "Verification
  // in the loop").
  if (result.answer->verification.status == VerificationStatus::Failed) {
    std::string why;
    for (const std::string& r : result.answer->verification.failure_reasons)
      why += (why.empty() ? "" : "; ") + r;
    spdlog::info("request {}: plan {} refused by the verifier ({} candidates): {}",
                 in.request.request_id, c->key.hex().substr(0, 16),
                 result.answer->verification.candidates_verified, why);
  }
  if (result.solution)
    spdlog::debug("planned {} in {:.1f} ms ({} evaluations, feasible {}, verification {})",
                  c->key.hex().substr(0, 16), msBetween(t_start, Clock::now()),
                  result.solution->evaluations, result.solution->feasible,
                  static_cast<int>(result.answer->verification.status));
  finishComputation(c, std::nullopt, std::move(result.answer), result.solution,
                    PlanSource::Coalesced);
}

bool PlanningCore::answerFromPersisted(const std::shared_ptr<Computation>& c,
                                       const PlanRequest& request) {
  // Slow path of the cache: a row in SQLite that is no longer (or not yet) in memory.
  auto stored = cache_.findPersisted(c->key);
  if (!stored || (c->want_verify && stored->verification.status == VerificationStatus::NotRun))
    return false;
  try {
    PlanAnswer a = answerFromSolution(*stored, request, c->key, PlanSource::CacheHit);
    if (lostAtThisState(*stored, a.evaluation)) return false;  // plan instead (answerHit)
    hits_.fetch_add(1);
    finishComputation(c, std::nullopt, std::move(a), stored, PlanSource::Coalesced);
    return true;
  } catch (const std::exception&) {
    return false;  // not valid at this state: plan instead
  }
}

void PlanningCore::finishComputation(const std::shared_ptr<Computation>& c,
                                     const std::optional<ServiceError>& error,
                                     std::optional<PlanAnswer> leader_answer,
                                     const std::optional<CachedSolution>& solution,
                                     PlanSource waiter_source) {
  {
    std::lock_guard lock(mu_);
    const auto it = inflight_.find(c->id);
    if (it != inflight_.end() && it->second == c) inflight_.erase(it);
  }
  // No caller can attach any more: the computation has left the in-flight map.
  std::vector<Computation::Caller> callers;
  {
    std::lock_guard lock(c->mu);
    callers = c->callers;
  }
  for (std::size_t i = 0; i < callers.size(); ++i) {
    const auto& caller = callers[i];
    if (caller.call->completed()) continue;
    if (error) {
      PlanOutcome o;
      o.error = *error;
      finish(caller.call, std::move(o));
      continue;
    }
    if (i == 0 && leader_answer) {
      PlanOutcome o;
      o.answer = std::move(*leader_answer);
      finish(caller.call, std::move(o));
      continue;
    }
    std::optional<PlanOutcome> o;
    if (solution) {
      try {
        o.emplace();
        o->answer = answerFromSolution(*solution, caller.request, c->key, waiter_source);
        if (lostAtThisState(*solution, o->answer.evaluation)) o.reset();  // as answerHit
      } catch (const std::exception&) {
        o.reset();  // no valid trajectory at this waiter's state
      }
    }
    if (o) {
      finish(caller.call, std::move(*o));
      continue;
    }
    // Nothing to share, or not usable at this waiter's state: answered the leader's way.
    startComputation(caller.request, keyOf(caller.request), caller.call,
                     BoundedExecutor::Lane::Internal);
  }
}

PlanAnswer PlanningCore::answerFromSolution(const CachedSolution& s, const PlanRequest& request,
                                            const CacheKey& key, PlanSource source) const {
  const planner::JumpModel model(planner_.robot(), planner_.settings(), request.task,
                                 request.initial, s.liftoff_correction);
  const Eigen::Map<const Eigen::VectorXd> u(s.u.data(), planner::kNumDecision);
  PlanAnswer a;
  model.evaluate(u, a.evaluation);
  if (!a.evaluation.valid)
    throw std::runtime_error("the cached solution has no valid trajectory at this state");
  a.plan = asKnots(request.trajectory) ? model.buildKnots(u, &a.evaluation)
                                       : model.buildPlan(u, &a.evaluation);
  describeEvaluation(a.evaluation, planner_.settings().polish_backoff, a.binding, a.summary);
  a.verification = summaryOf(s.verification);
  a.source = source;
  a.stats.evaluations = s.evaluations;
  a.stats.generations = s.generations;
  a.stats.de_cost = s.de_cost;
  a.stats.polished_cost = s.final_cost;
  a.stats.seed = s.seed;
  a.stats.cache_key = key.hex();
  return a;
}

VerificationSummary PlanningCore::summaryOf(const StoredVerification& v) const {
  VerificationSummary out;
  out.status = v.status;
  if (v.status == VerificationStatus::Failed && verifier_)
    out.failure_reasons = verifier_->failureNames(v.failure_bits);
  out.simulated = v.simulated;
  out.max_envelope_ratio = v.max_envelope_ratio;
  out.landed_upright = v.landed_upright;
  out.candidates_verified = v.candidates_verified;
  out.returned_candidate_rank = v.returned_candidate_rank;
  return out;
}

//==============================================================================================
void PlanningCore::warm(WarmRequest request, std::shared_ptr<WarmCall> call) {
  std::optional<ServiceError> refusal;
  {
    std::lock_guard lock(mu_);
    if (stopping_) {
      refusal = ServiceError(ErrorCode::Unavailable, "the server is shutting down");
    } else if (warm_streams_ >= config_.warm_cache.max_streams) {
      rejected_queue_full_.fetch_add(1);
      refusal = ServiceError(ErrorCode::ResourceExhausted,
                             "WarmCache is already running on " + std::to_string(warm_streams_) +
                                 " stream(s) (warm_cache.max_streams); retry later");
    } else {
      ++warm_streams_;
    }
  }
  if (refusal) {
    call->done_(std::move(refusal));
    return;
  }
  auto state = std::make_shared<WarmState>();
  state->request = std::move(request);
  state->call = std::move(call);
  startWarmPoint(state);
}

void PlanningCore::startWarmPoint(const std::shared_ptr<WarmState>& state) {
  const auto& grid = state->request.v0_grid;
  const auto end = [this, state](std::optional<ServiceError> error) {
    {
      std::lock_guard lock(mu_);
      --warm_streams_;
    }
    state->call->done_(std::move(error));
  };
  if (state->call->cancelled()) {
    end(ServiceError(ErrorCode::Cancelled, "the call was cancelled"));
    return;
  }
  if (state->next >= grid.size()) {
    end(std::nullopt);
    return;
  }
  if (Clock::now() >= state->call->deadline()) {
    end(ServiceError(ErrorCode::DeadlineExceeded, "WarmCache reached its deadline after " +
                                                      std::to_string(state->next) + " of " +
                                                      std::to_string(grid.size()) + " points"));
    return;
  }
  const std::size_t index = state->next;
  PlanRequest r;
  r.task = state->request.task;
  r.initial = nominalState(grid[index]);
  r.request_id = "warm-cache";
  const auto point_deadline = std::min(
      state->call->deadline(),
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(config_.warm_cache.point_budget_s)));
  auto point = std::make_shared<PlanCall>(point_deadline, [this, state, index,
                                                           end](PlanOutcome&& o) {
    if (o.error && o.error->code() != ErrorCode::DeadlineExceeded) {
      end(*o.error);
      return;
    }
    WarmProgress p;
    p.done = static_cast<int>(index + 1);
    p.total = static_cast<int>(state->request.v0_grid.size());
    p.v0 = state->request.v0_grid[index];
    p.feasible = !o.error && o.answer.evaluation.feasible;
    p.source = o.error ? PlanSource::CacheMiss : o.answer.source;
    state->call->progress_(p);
    state->next = index + 1;
    // The next point goes to the back of the queue, so PlanJump calls interleave with it.
    Task t;
    t.run = [this, state] { startWarmPoint(state); };
    t.abandon = [end] { end(ServiceError(ErrorCode::Unavailable, "the server is shutting down")); };
    if (!plan_pool_.trySubmit(std::move(t), BoundedExecutor::Lane::Internal))
      end(ServiceError(ErrorCode::Unavailable, "the server is shutting down"));
  });
  {
    std::lock_guard lock(state->call->mu_);
    state->call->current_ = point;
  }
  if (state->call->cancelled()) point->cancel();
  // Grid points are admitted work of an admitted stream: they do not count against the queue.
  const CacheKey key = keyOf(r);
  std::optional<CachedSolution> hit = findHit(r, key);
  if (hit) {
    hits_.fetch_add(1);
    submitHit(std::move(r), key, *hit, std::move(point), BoundedExecutor::Lane::Internal);
  } else {
    startComputation(std::move(r), key, std::move(point), BoundedExecutor::Lane::Internal);
  }
}

//==============================================================================================
StatsSnapshot PlanningCore::stats() const {
  StatsSnapshot s;
  s.requests = requests_.load();
  s.cache_hits = hits_.load();
  s.cache_misses = misses_.load();
  s.coalesced = coalesced_.load();
  s.warm_starts = warm_starts_.load();
  s.rejected_invalid = rejected_invalid_.load();
  s.rejected_queue_full = rejected_queue_full_.load();
  s.deadline_exceeded = deadline_exceeded_.load();
  s.cache = cache_.counters();
  s.evictions = static_cast<std::uint64_t>(s.cache.evictions);
  s.cache_entries = static_cast<std::uint64_t>(s.cache.entries);
  for (int i = 0; i < kNumPlanSources; ++i) {
    const auto& h = latency_[static_cast<std::size_t>(i)];
    auto& p = s.latencies[static_cast<std::size_t>(i)];
    p.path = static_cast<PlanSource>(i);
    p.count = h.count();
    p.p50_ms = h.quantile(0.50);
    p.p90_ms = h.quantile(0.90);
    p.p99_ms = h.quantile(0.99);
  }
  s.uptime_s = std::chrono::duration<double>(Clock::now() - started_).count();
  return s;
}

void PlanningCore::shutdown() {
  std::call_once(shutdown_once_, [this] {
    std::vector<std::shared_ptr<Computation>> running;
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
      for (const auto& [id, c] : inflight_) running.push_back(c);
    }
    for (const auto& c : running) c->cancel = true;
    // Plan workers may wait for verifications: stop them first, the verify pool after.
    plan_pool_.shutdown();
    verify_pool_.shutdown();
    hit_pool_.shutdown();
    try {
      cache_.flush();
    } catch (const std::exception& e) {
      spdlog::error("cache flush at shutdown failed: {}", e.what());
    }
  });
}

}  // namespace wj::server
