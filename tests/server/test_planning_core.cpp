// The planning core without gRPC: hits regenerate for the caller's state, identical misses are
// coalesced, the best verified candidate is returned, verifications run in parallel, deadlines
// become budgets, cancellation stops the work, full queues refuse, warm starts and WarmCache.
// The pipeline of a miss is also tested alone (MissPipeline.*), without core, cache or gRPC.
// Verification uses a scripted test double (the real Simbody verifier is exercised by the
// integration tests): it lets a test decide verdicts, durations and when a verification ends.
#include <gtest/gtest.h>

#include <future>
#include <sstream>
#include <thread>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include "error_of.h"
#include "server/miss_pipeline.h"
#include "server/planning_core.h"
#include "server/solution_store.h"
#include "server_test_util.h"

namespace wj::server {
namespace {

using namespace std::chrono_literals;

class ScriptedVerifier final : public PlanVerifier {
 public:
  std::function<bool(const planner::JumpPlan&)> pass = [](const planner::JumpPlan&) {
    return true;
  };
  std::chrono::milliseconds delay{0};
  std::shared_future<void> gate;  // if valid, every verification waits for it
  std::atomic<int> calls{0}, running{0}, max_running{0};

  std::string name() const override { return "scripted test verifier"; }
  VerifierVerdict verify(const planner::JumpPlan& plan,
                         const planner::JumpTask& /*task*/) const override {
    auto* self = const_cast<ScriptedVerifier*>(this);
    ++self->calls;
    const int now = ++self->running;
    int prev = self->max_running.load();
    while (now > prev && !self->max_running.compare_exchange_weak(prev, now)) {
    }
    if (gate.valid()) gate.wait();
    std::this_thread::sleep_for(delay);
    --self->running;
    VerifierVerdict v;
    v.passed = pass(plan);
    v.simulated = plan.predicted;
    v.landed_upright = v.passed;
    v.max_envelope_ratio = 0.5;
    if (!v.passed) {
      v.failure_bits = 1;
      v.reasons.push_back("scripted failure");
    }
    return v;
  }
  std::vector<std::string> failureNames(std::uint32_t bits) const override {
    return bits ? std::vector<std::string>{"scripted_failure"} : std::vector<std::string>{};
  }
  std::uint64_t settingsHash() const override { return 42; }
};

struct Fixture {
  explicit Fixture(ServerConfig c = {}, ScriptedVerifier* v = nullptr,
                   const std::filesystem::path& store = {})
      : config(std::move(c)) {
    std::unique_ptr<PlanVerifier> owned;
    if (v) {
      owned.reset(v);
      verifier = v;
    }
    std::unique_ptr<SolutionStore> s;
    if (!store.empty()) s = std::make_unique<SolutionStore>(store, false, 1000);
    core = std::make_unique<PlanningCore>(
        config, model::RobotModel::loadDefault(),
        planner::PlannerSettings::fromYaml(config.planner.settings_file), std::move(owned),
        std::move(s));
  }
  ServerConfig config;
  ScriptedVerifier* verifier = nullptr;
  std::unique_ptr<PlanningCore> core;
};

ServerConfig coreConfig() {
  ServerConfig c = test::testConfig("/nonexistent");
  c.cache.path.clear();
  c.verification.enabled = true;
  c.verification.default_candidates = 2;
  return c;
}

PlanRequest request(double v0, double height = 0.8) {
  PlanRequest r;
  r.task.target = {0.0, height, 0.0, planner::TargetEvent::Apex};
  r.initial.v0 = v0;
  for (int leg = 0; leg < 4; ++leg) {
    r.initial.q[leg * 4 + 1] = 1.0;
    r.initial.q[leg * 4 + 2] = -2.0;
  }
  return r;
}

struct Pending {
  std::shared_ptr<PlanCall> call;
  std::future<PlanOutcome> outcome;
};

Pending start(PlanningCore& core, PlanRequest r, std::chrono::milliseconds deadline = 30s) {
  auto promise = std::make_shared<std::promise<PlanOutcome>>();
  Pending p;
  p.outcome = promise->get_future();
  p.call = std::make_shared<PlanCall>(
      Clock::now() + deadline, [promise](PlanOutcome&& o) { promise->set_value(std::move(o)); });
  core.plan(std::move(r), p.call);
  return p;
}

PlanOutcome get(Pending& p, std::chrono::seconds limit = 60s) {
  EXPECT_EQ(p.outcome.wait_for(limit), std::future_status::ready);
  return p.outcome.get();
}

PlanOutcome planSync(PlanningCore& core, PlanRequest r, std::chrono::milliseconds deadline = 30s) {
  auto p = start(core, std::move(r), deadline);
  return get(p);
}

void expectAnswer(const PlanOutcome& o) {
  ASSERT_FALSE(o.error.has_value()) << o.error->what();
  EXPECT_GT(o.answer.plan.numSamples(), 0);
}

template <typename Pred>
bool eventually(Pred pred, std::chrono::milliseconds limit = 20s) {
  const auto until = Clock::now() + limit;
  while (!pred()) {
    if (Clock::now() > until) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

TEST(PlanningCore, MissThenHitRegeneratedForTheCallersOwnState) {
  Fixture f(coreConfig(), new ScriptedVerifier);
  const PlanOutcome miss = planSync(*f.core, request(1.0));
  // K = 2 candidates, the second stopped once the best has passed (or never started).
  const int miss_calls = f.verifier->calls.load();
  EXPECT_GE(miss_calls, 1);
  EXPECT_LE(miss_calls, 2);
  expectAnswer(miss);
  EXPECT_EQ(miss.answer.source, PlanSource::CacheMiss);
  EXPECT_EQ(miss.answer.verification.status, VerificationStatus::Passed);
  EXPECT_DOUBLE_EQ(miss.answer.plan.initial.vx, 1.0);
  const PlanOutcome hit = planSync(*f.core, request(1.02));  // same 0.05 m/s bin
  expectAnswer(hit);
  EXPECT_EQ(hit.answer.source, PlanSource::CacheHit);
  EXPECT_DOUBLE_EQ(hit.answer.plan.initial.vx, 1.02);  // the trajectory is this caller's
  EXPECT_EQ(hit.answer.stats.cache_key, miss.answer.stats.cache_key);
  EXPECT_EQ(hit.answer.verification.status, VerificationStatus::Passed);
  EXPECT_EQ(hit.answer.stats.de_ms, 0.0);
  const auto s = f.core->stats();
  EXPECT_EQ(s.cache_hits, 1u);
  EXPECT_EQ(s.cache_misses, 1u);
  EXPECT_EQ(s.cache_entries, 1u);
  EXPECT_EQ(s.latencies[static_cast<int>(PlanSource::CacheHit)].count, 1u);
  EXPECT_EQ(f.verifier->calls.load(), miss_calls);  // only on the miss
}

TEST(PlanningCore, IdenticalConcurrentMissesAreCoalescedIntoOneComputation) {
  auto* v = new ScriptedVerifier;
  std::promise<void> release;
  v->gate = release.get_future().share();
  Fixture f(coreConfig(), v);
  std::vector<Pending> calls;
  calls.push_back(start(*f.core, request(2.0)));
  ASSERT_TRUE(eventually([&] { return v->calls.load() > 0; }));  // the leader is verifying
  for (const double v0 : {2.0, 2.01, 1.99}) calls.push_back(start(*f.core, request(v0)));
  EXPECT_EQ(f.core->stats().coalesced, 3u);
  release.set_value();
  std::vector<PlanOutcome> outcomes;
  for (auto& c : calls) outcomes.push_back(get(c));
  for (const auto& o : outcomes) expectAnswer(o);
  EXPECT_EQ(outcomes[0].answer.source, PlanSource::CacheMiss);
  for (std::size_t i = 1; i < outcomes.size(); ++i)
    EXPECT_EQ(outcomes[i].answer.source, PlanSource::Coalesced);
  EXPECT_DOUBLE_EQ(outcomes[3].answer.plan.initial.vx, 1.99);
  EXPECT_EQ(f.core->stats().cache_misses, 1u);
  EXPECT_LE(v->calls.load(), 2);  // one computation verified its (at most) two candidates
}

TEST(PlanningCore, ReturnsTheBestVerifiedCandidate) {
  ServerConfig c = coreConfig();
  c.verification.default_candidates = 3;
  std::vector<double> best_decision;
  {
    Fixture f(c, new ScriptedVerifier);
    const auto o = planSync(*f.core, request(0.5));
    expectAnswer(o);
    EXPECT_EQ(o.answer.verification.returned_candidate_rank, 0);
    // The best passed: if it is feasible the choice is final, the lower ranks do not count (nor
    // are they waited for); else a feasible lower rank that passes would win: all three.
    EXPECT_EQ(o.answer.verification.candidates_verified, o.answer.evaluation.feasible ? 1 : 3);
    const auto& d = o.answer.plan.decision;
    best_decision.assign(d.data(), d.data() + d.size());
  }
  {
    // Same seed, same search: now the best predicted candidate fails in "simulation".
    auto* v = new ScriptedVerifier;
    v->pass = [best_decision](const planner::JumpPlan& p) {
      return std::vector<double>(p.decision.data(), p.decision.data() + p.decision.size()) !=
             best_decision;
    };
    Fixture f(c, v);
    const auto o = planSync(*f.core, request(0.5));
    expectAnswer(o);
    EXPECT_EQ(o.answer.verification.status, VerificationStatus::Passed);
    EXPECT_GE(o.answer.verification.returned_candidate_rank, 1);
    // Ranks 0 to the chosen one decided the choice (if it is feasible).
    EXPECT_EQ(o.answer.verification.candidates_verified,
              o.answer.evaluation.feasible ? o.answer.verification.returned_candidate_rank + 1 : 3);
    EXPECT_NE(std::vector<double>(o.answer.plan.decision.data(),
                                  o.answer.plan.decision.data() + o.answer.plan.decision.size()),
              best_decision);
  }
  {
    auto* v = new ScriptedVerifier;
    v->pass = [](const planner::JumpPlan&) { return false; };
    Fixture f(c, v);
    // The refusal is logged with the request id and the reasons (docs/service.md).
    std::ostringstream log;
    const auto before = spdlog::default_logger();
    spdlog::set_default_logger(std::make_shared<spdlog::logger>(
        "test", std::make_shared<spdlog::sinks::ostream_sink_mt>(log)));
    PlanRequest refused = request(0.5);
    refused.request_id = "jump-refused";
    const auto o = planSync(*f.core, refused);
    spdlog::set_default_logger(before);
    EXPECT_THAT(log.str(), wj::test::HasSubstr("request jump-refused: plan "));
    EXPECT_THAT(log.str(),
                wj::test::HasSubstr("refused by the verifier (3 candidates): scripted failure\n"));
    expectAnswer(o);
    EXPECT_EQ(o.answer.verification.status, VerificationStatus::Failed);
    EXPECT_EQ(o.answer.verification.returned_candidate_rank, 0);
    ASSERT_FALSE(o.answer.verification.failure_reasons.empty());
    EXPECT_EQ(o.answer.verification.failure_reasons[0], "scripted failure");
    // The cached failure is served with the verifier's reason names.
    const auto hit = planSync(*f.core, request(0.5));
    EXPECT_EQ(hit.answer.source, PlanSource::CacheHit);
    EXPECT_EQ(hit.answer.verification.status, VerificationStatus::Failed);
    EXPECT_EQ(hit.answer.verification.failure_reasons,
              std::vector<std::string>{"scripted_failure"});
  }
}

// Both verifications wait at a gate that the test opens only once both are running: run in
// series, the second would never start while the first waits, and the gate would stay shut.
// No wall-clock comparison (two sleeps side by side against in series), so a loaded machine
// cannot tip the verdict.
TEST(PlanningCore, VerifiesCandidatesInParallel) {
  auto* v = new ScriptedVerifier;
  std::promise<void> release;
  v->gate = release.get_future().share();
  Fixture f(coreConfig(), v);
  auto p = start(*f.core, request(0.3));
  const bool side_by_side = eventually([&] { return v->running.load() == 2; });
  release.set_value();
  EXPECT_TRUE(side_by_side) << v->running.load() << " verification(s) running at once";
  expectAnswer(get(p));
  EXPECT_EQ(v->max_running.load(), 2);
}

// The verification never ends by itself (it waits at a gate the test opens only after the
// outcome): the deadline alone can end the call, so the outcome arriving at all proves that the
// core stopped waiting at the deadline, on a loaded machine as on an idle one. The search of
// planner_fast.yaml ends on its 640 evaluations, far inside the 60 % of the deadline it gets.
TEST(PlanningCore, DeadlineDuringVerificationIsDeadlineExceededNeverAHalfPlan) {
  auto* v = new ScriptedVerifier;
  std::promise<void> release;
  v->gate = release.get_future().share();
  Fixture f(coreConfig(), v);
  auto p = start(*f.core, request(0.7), 1500ms);
  const auto ready = p.outcome.wait_for(60s);
  const bool verifying = v->running.load() > 0;  // still inside the verification
  release.set_value();
  ASSERT_EQ(ready, std::future_status::ready);
  const auto o = p.outcome.get();
  EXPECT_TRUE(verifying);
  EXPECT_GE(v->calls.load(), 1);  // the verification was reached: its deadline ended the call
  ASSERT_TRUE(o.error.has_value());
  EXPECT_EQ(o.error->code(), ErrorCode::DeadlineExceeded) << o.error->what();
  EXPECT_EQ(o.answer.plan.numSamples(), 0);
  EXPECT_EQ(f.core->stats().deadline_exceeded, 1u);
  EXPECT_EQ(f.core->stats().cache_entries, 0u);
}

// A search of 10^7 evaluations (tens of seconds) with a 1 s deadline on the only plan worker,
// and behind it in the queue a small miss (200 evaluations) with a 5 s deadline. The small one
// gets its answer only if the deadline ended the long search: otherwise it waits in the queue
// past its own deadline. The long one's verdict does not depend on the machine's load either: an
// answer cut by the clock, or DEADLINE_EXCEEDED when a loaded machine finished it after its
// budget, never a half plan. (That the search uses the time it is given: MissPipeline.
// TheTimeLeftBoundsTheSearch, without the race of a whole call against its deadline.)
TEST(PlanningCore, TheDeadlineBoundsTheSearch) {
  ServerConfig c = coreConfig();
  c.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  c.verification.enabled = false;
  c.planner.max_evaluations_cap = 10'000'000;
  c.executor.plan_workers = 1;
  Fixture f(c);
  PlanRequest r = request(0.9);
  r.max_evaluations = 10'000'000;  // far more than fits in the deadline
  auto bounded = start(*f.core, r, 1000ms);
  ASSERT_TRUE(eventually([&] { return f.core->stats().cache_misses == 1; }));  // searching
  PlanRequest small = request(0.1);
  small.max_evaluations = 200;
  auto next = start(*f.core, small, 5000ms);
  const auto o = get(bounded);
  if (o.error) {
    EXPECT_EQ(o.error->code(), ErrorCode::DeadlineExceeded) << o.error->what();
    EXPECT_EQ(o.answer.plan.numSamples(), 0);
  } else {
    expectAnswer(o);
    EXPECT_LT(o.answer.stats.evaluations, 10'000'000);
    EXPECT_LT(o.answer.stats.de_ms, 1000.0);
    EXPECT_EQ(o.answer.verification.status, VerificationStatus::NotRun);
  }
  const auto after = get(next);
  expectAnswer(after);
  EXPECT_EQ(after.answer.source, PlanSource::CacheMiss);
}

// An infeasible answer whose search ran out of evaluations is served as a hit to callers who
// allow no more evaluations, and computed again (with the larger budget) for a caller who allows
// more; the larger search's answer then replaces it, also when it is no better, so that the next
// such caller gets a hit. The seed is part of the key: other seeds never see the entry.
TEST(PlanningCore, InfeasibleAnswerOfATooSmallBudgetIsRecomputedForALargerOne) {
  ServerConfig c = coreConfig();
  c.verification.enabled = false;
  Fixture f(c);
  PlanRequest small = request(0.0, 1.5);  // out of reach: infeasible with any budget
  small.max_evaluations = 200;            // a few generations
  const auto first = planSync(*f.core, small);
  expectAnswer(first);
  ASSERT_FALSE(first.answer.evaluation.feasible);
  ASSERT_EQ(first.answer.source, PlanSource::CacheMiss);
  ASSERT_LT(first.answer.stats.evaluations, 1000);
  // The same small budget, or a smaller one: the stored answer is what it would compute.
  EXPECT_EQ(planSync(*f.core, small).answer.source, PlanSource::CacheHit);
  PlanRequest smaller = small;
  smaller.max_evaluations = 150;
  EXPECT_EQ(planSync(*f.core, smaller).answer.source, PlanSource::CacheHit);
  // A larger budget: computed again, and stored.
  PlanRequest larger = small;
  larger.max_evaluations = 2000;
  const auto again = planSync(*f.core, larger);
  expectAnswer(again);
  EXPECT_EQ(again.answer.source, PlanSource::CacheMiss);
  EXPECT_GT(again.answer.stats.evaluations, first.answer.stats.evaluations);
  // The larger search's answer is stored (better, or as good with a larger budget): a hit for
  // both budgets from now on.
  EXPECT_EQ(planSync(*f.core, larger).answer.source, PlanSource::CacheHit);
  EXPECT_EQ(planSync(*f.core, small).answer.source, PlanSource::CacheHit);
  EXPECT_EQ(f.core->stats().cache_misses, 2u);
}

// A closest approach (a target out of reach, every constraint met) rebuilt at another state of
// its bins can lose a constraint whose margin was nearly zero; the robot client refuses such a
// plan and asks again. The service plans that caller's state instead, as it does for a feasible
// hit that is no longer feasible there, and the better answer replaces the entry.
// The shipped settings and their polish, which puts a closest approach on its constraints (the
// test settings' short unpolished search leaves it inside them).
ServerConfig shippedPlannerConfig() {
  ServerConfig c = coreConfig();
  c.verification.enabled = false;
  c.planner.settings_file = WJ_CONFIG_DIR "/planner_settings.yaml";
  c.planner.polish_min_budget_s = ServerConfig{}.planner.polish_min_budget_s;
  return c;
}

TEST(PlanningCore, AClosestApproachThatLosesAConstraintAtTheCallersStateIsPlannedForIt) {
  Fixture f(shippedPlannerConfig());
  const PlanRequest first_state = request(0.0, 0.605);
  const auto first = planSync(*f.core, first_state);
  expectAnswer(first);
  ASSERT_EQ(first.answer.source, PlanSource::CacheMiss);
  ASSERT_FALSE(first.answer.evaluation.feasible);
  ASSERT_TRUE(first.answer.evaluation.constraints_ok) << first.answer.summary;
  // Pitched by 9 mrad (in the same bin), the stored plan violates a constraint (checked here, so
  // that this test notices if the planner's closest approach stops being this close to them).
  PlanRequest other = request(0.012, 0.605);
  other.initial.pitch = 0.009;
  const planner::JumpModel model(f.core->planner().robot(), f.core->planner().settings(),
                                 other.task, other.initial);
  const auto stored = f.core->findHit(other, f.core->keyOf(other));
  ASSERT_TRUE(stored.has_value());
  EXPECT_TRUE(stored->constraints_ok);
  EXPECT_FALSE(stored->feasible);
  planner::Evaluation there;
  model.evaluate(Eigen::Map<const Eigen::VectorXd>(stored->u.data(), planner::kNumDecision), there);
  ASSERT_TRUE(there.valid);
  ASSERT_FALSE(there.constraints_ok);
  const auto second = planSync(*f.core, other);
  expectAnswer(second);
  EXPECT_NE(second.answer.source, PlanSource::CacheHit);
  EXPECT_DOUBLE_EQ(second.answer.plan.initial.vx, 0.012);
  EXPECT_TRUE(second.answer.evaluation.constraints_ok) << second.answer.summary;
  EXPECT_EQ(second.answer.stats.cache_key, first.answer.stats.cache_key);
  auto s = f.core->stats();
  EXPECT_EQ(s.cache_misses, 2u);
  EXPECT_EQ(s.cache_hits, 0u);
  EXPECT_EQ(s.cache_entries, 1u);
  // A state where the entry's plan holds its constraints is a hit, as ever.
  const auto third = planSync(*f.core, other);
  EXPECT_EQ(third.answer.source, PlanSource::CacheHit);
  EXPECT_TRUE(third.answer.evaluation.constraints_ok) << third.answer.summary;
}

// The same rule when the entry is read back from SQLite (evicted from memory).
TEST(PlanningCore, APersistedClosestApproachThatLosesAConstraintIsPlannedForTheCaller) {
  test::TempDir dir("wj-core");
  ServerConfig c = shippedPlannerConfig();
  c.cache.max_memory_entries = 1;
  Fixture f(c, nullptr, dir / "c.sqlite");
  const auto first = planSync(*f.core, request(0.0, 0.605));
  ASSERT_EQ(first.answer.source, PlanSource::CacheMiss);
  ASSERT_FALSE(first.answer.evaluation.feasible);
  ASSERT_TRUE(first.answer.evaluation.constraints_ok) << first.answer.summary;
  expectAnswer(planSync(*f.core, request(1.0, 0.605)));  // evicts the first from memory
  ASSERT_EQ(f.core->stats().evictions, 1u);
  PlanRequest other = request(0.012, 0.605);
  other.initial.pitch = 0.009;  // the previous test's state, where a constraint is lost
  const auto second = planSync(*f.core, other);
  expectAnswer(second);
  EXPECT_NE(second.answer.source, PlanSource::CacheHit);
  EXPECT_TRUE(second.answer.evaluation.constraints_ok) << second.answer.summary;
  const auto s = f.core->stats();
  EXPECT_EQ(s.cache.persisted_hits, 1);  // the row was read back, and not served
  EXPECT_EQ(s.cache_hits, 0u);
  EXPECT_EQ(s.cache_misses, 3u);
}

TEST(PlanningCore, CancellationStopsTheSearch) {
  ServerConfig c = coreConfig();
  c.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  c.verification.enabled = false;
  c.planner.max_evaluations_cap = 10'000'000;
  c.executor.plan_workers = 1;
  Fixture f(c);
  PlanRequest r = request(1.5);
  r.max_evaluations = 10'000'000;
  r.seed = 5;
  auto slow = start(*f.core, r, 60s);
  ASSERT_TRUE(eventually([&] { return f.core->stats().cache_misses == 1; }));  // searching
  slow.call->cancel();
  const auto cancelled = get(slow, 5s);
  ASSERT_TRUE(cancelled.error.has_value());
  EXPECT_EQ(cancelled.error->code(), ErrorCode::Cancelled);
  // The only plan worker is free again: a new miss with a 5 s deadline gets an answer. Had the
  // cancelled search of 10^7 evaluations (tens of seconds) kept the worker, the miss would have
  // waited in the queue past its deadline and been refused (DEADLINE_EXCEEDED: a search does
  // not start with less than deadlines.min_budget_s left). The new miss ends on its 200
  // evaluations, not on its deadline, so no race with the clock: the answer itself is the proof,
  // on a loaded machine too.
  PlanRequest small = request(0.1);
  small.max_evaluations = 200;
  const auto next = planSync(*f.core, small, 5000ms);
  expectAnswer(next);
  EXPECT_EQ(next.answer.source, PlanSource::CacheMiss);
  EXPECT_EQ(f.core->stats().deadline_exceeded, 0u);
}

TEST(PlanningCore, FullQueueIsResourceExhaustedAndShutdownAbandonsQueuedWork) {
  ServerConfig c = coreConfig();
  c.executor.plan_workers = 1;
  c.executor.plan_queue = 1;
  auto* v = new ScriptedVerifier;
  std::promise<void> release;
  v->gate = release.get_future().share();
  Fixture f(c, v);
  auto running = start(*f.core, request(0.2));
  ASSERT_TRUE(eventually([&] { return v->calls.load() > 0; }));  // holds the only worker
  auto queued = start(*f.core, request(0.4));
  // Refused at once: completed on the calling thread, before plan() returns.
  auto third = start(*f.core, request(0.6));
  ASSERT_EQ(third.outcome.wait_for(0s), std::future_status::ready);
  const auto refused = third.outcome.get();
  ASSERT_TRUE(refused.error.has_value());
  EXPECT_EQ(refused.error->code(), ErrorCode::ResourceExhausted);
  EXPECT_NE(std::string(refused.error->what()).find("executor.plan_queue"), std::string::npos);
  EXPECT_EQ(f.core->stats().rejected_queue_full, 1u);
  std::thread stopper([&] { f.core->shutdown(); });
  const auto abandoned = get(queued, 10s);
  ASSERT_TRUE(abandoned.error.has_value());
  EXPECT_EQ(abandoned.error->code(), ErrorCode::Unavailable);
  release.set_value();
  stopper.join();
  const auto first = get(running, 10s);
  ASSERT_TRUE(first.error.has_value());  // cancelled by the shutdown while verifying
  const auto after = planSync(*f.core, request(0.2));
  ASSERT_TRUE(after.error.has_value());
  EXPECT_EQ(after.error->code(), ErrorCode::Unavailable);
}

TEST(PlanningCore, MissIsWarmStartedFromCachedNeighbours) {
  ServerConfig c = coreConfig();
  c.verification.enabled = false;
  Fixture f(c);
  expectAnswer(planSync(*f.core, request(1.0)));
  expectAnswer(planSync(*f.core, request(1.2)));
  EXPECT_EQ(f.core->stats().warm_starts, 1u);  // 1.2 started from 1.0
  const auto o = planSync(*f.core, request(1.1));
  expectAnswer(o);
  EXPECT_EQ(o.answer.source, PlanSource::WarmStart);
  EXPECT_EQ(f.core->stats().warm_starts, 2u);
  const auto far = planSync(*f.core, request(2.5));  // nothing within 0.5 m/s
  EXPECT_EQ(far.answer.source, PlanSource::CacheMiss);
}

TEST(PlanningCore, UnverifiedEntryIsRecomputedWhenVerificationIsWanted) {
  auto* v = new ScriptedVerifier;
  Fixture f(coreConfig(), v);
  PlanRequest skip = request(0.8);
  skip.skip_verification = true;
  const auto a = planSync(*f.core, skip);
  expectAnswer(a);
  EXPECT_EQ(a.answer.verification.status, VerificationStatus::NotRun);
  EXPECT_EQ(v->calls.load(), 0);
  const auto b = planSync(*f.core, request(0.8));
  expectAnswer(b);
  EXPECT_NE(b.answer.source, PlanSource::CacheHit);
  EXPECT_EQ(b.answer.verification.status, VerificationStatus::Passed);
  const auto c = planSync(*f.core, skip);  // a verified entry serves everyone
  EXPECT_EQ(c.answer.source, PlanSource::CacheHit);
  EXPECT_EQ(c.answer.verification.status, VerificationStatus::Passed);
}

TEST(PlanningCore, PersistedEntriesSurviveARestartAndAnEviction) {
  test::TempDir dir("wj-core");
  const auto path = dir / "c.sqlite";
  ServerConfig c = coreConfig();
  c.verification.enabled = false;
  std::vector<double> u;
  {
    Fixture f(c, nullptr, path);
    const auto o = planSync(*f.core, request(0.5));
    expectAnswer(o);
    EXPECT_EQ(o.answer.source, PlanSource::CacheMiss);
  }
  c.cache.max_memory_entries = 1;
  Fixture f(c, nullptr, path);
  EXPECT_EQ(f.core->stats().cache_entries, 1u);  // loaded at start
  EXPECT_EQ(planSync(*f.core, request(0.5)).answer.source, PlanSource::CacheHit);
  expectAnswer(planSync(*f.core, request(0.7)));  // evicts 0.5 from memory
  EXPECT_EQ(f.core->stats().evictions, 1u);
  const auto o = planSync(*f.core, request(0.5));
  EXPECT_EQ(o.answer.source, PlanSource::CacheHit);  // read back from SQLite
  EXPECT_EQ(f.core->stats().cache.persisted_hits, 1);
}

TEST(PlanningCore, WarmCacheStreamsProgressAndFillsTheCache) {
  ServerConfig c = coreConfig();
  c.verification.enabled = false;
  Fixture f(c);
  WarmRequest w;
  w.task = request(0.0).task;
  w.v0_grid = {0.0, 0.1, 0.2};
  std::vector<WarmProgress> progress;
  std::promise<std::optional<ServiceError>> done;
  auto call = std::make_shared<WarmCall>(
      Clock::now() + 60s, [&](const WarmProgress& p) { progress.push_back(p); },
      [&](std::optional<ServiceError> e) { done.set_value(std::move(e)); });
  f.core->warm(w, call);
  // A second stream is refused while the first runs (warm_cache.max_streams = 1).
  std::promise<std::optional<ServiceError>> second;
  f.core->warm(w, std::make_shared<WarmCall>(
                      Clock::now() + 60s, [](const WarmProgress&) {},
                      [&](std::optional<ServiceError> e) { second.set_value(std::move(e)); }));
  const auto refused = second.get_future().get();
  ASSERT_TRUE(refused.has_value());
  EXPECT_EQ(refused->code(), ErrorCode::ResourceExhausted);
  auto finished = done.get_future();
  ASSERT_EQ(finished.wait_for(60s), std::future_status::ready);
  EXPECT_FALSE(finished.get().has_value());
  ASSERT_EQ(progress.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(progress[static_cast<std::size_t>(i)].done, i + 1);
    EXPECT_EQ(progress[static_cast<std::size_t>(i)].total, 3);
  }
  EXPECT_DOUBLE_EQ(progress[2].v0, 0.2);
  EXPECT_EQ(progress[1].source, PlanSource::WarmStart);  // seeded by 0.0
  EXPECT_EQ(planSync(*f.core, request(0.1)).answer.source, PlanSource::CacheHit);
}

//==============================================================================================
// The pipeline of a miss on its own: no core, no cache, no coalescing, no gRPC.
struct PipelineFixture {
  explicit PipelineFixture(ServerConfig c, ScriptedVerifier* v = nullptr)
      : config(std::move(c)),
        planner(model::RobotModel::loadDefault(),
                planner::PlannerSettings::fromYaml(config.planner.settings_file)),
        verifier(v),
        pool("wj-test-verify", 2, 64),
        pipeline(config, planner, v, pool) {}
  MissInputs inputs(PlanRequest r, bool verify, std::chrono::milliseconds budget = 30s) const {
    MissInputs in;
    in.request = std::move(r);
    in.cache_key_hex = "test-key";
    in.verify = verify;
    in.budget_end = Clock::now() + budget;
    in.remaining_s = std::chrono::duration<double>(budget).count();
    in.cancel = &cancel;
    return in;
  }
  ServerConfig config;
  planner::JumpPlanner planner;
  std::unique_ptr<ScriptedVerifier> verifier;
  BoundedExecutor pool;
  MissPipeline pipeline;
  std::atomic<bool> cancel{false};
};

TEST(MissPipeline, ChoosesPassedAndFeasibleThenPassedThenTheBestRankedSimulated) {
  const auto verdict = [](bool passed) {
    VerifierVerdict v;
    v.passed = passed;
    return std::optional<VerifierVerdict>(v);
  };
  const std::optional<VerifierVerdict> none;
  EXPECT_EQ(chooseVerified({verdict(true), verdict(true)}, {false, true}), 1u);
  EXPECT_EQ(chooseVerified({verdict(false), verdict(true)}, {true, false}), 1u);
  EXPECT_EQ(chooseVerified({none, verdict(false), verdict(false)}, {true, true, true}), 1u);
  EXPECT_EQ(chooseVerified({none, none}, {true, true}), std::nullopt);
  EXPECT_EQ(chooseVerified({}, {}), std::nullopt);
}

// The choice is final once a verdict passed on a feasible candidate and every higher rank has
// its verdict: whatever the missing ones say, chooseVerified() takes that rank.
TEST(MissPipeline, TheChoiceIsFinalOnceTheFirstPassedAndFeasibleRankIsKnown) {
  const auto verdict = [](bool passed) {
    VerifierVerdict v;
    v.passed = passed;
    return std::optional<VerifierVerdict>(v);
  };
  const std::optional<VerifierVerdict> none;
  EXPECT_EQ(choiceIsFinal({verdict(true), none, none}, {true, true, true}), 0u);
  EXPECT_EQ(choiceIsFinal({verdict(false), verdict(true), none}, {true, true, true}), 1u);
  // Rank 0 still running: a pass there would win.
  EXPECT_EQ(choiceIsFinal({none, verdict(true)}, {true, true}), std::nullopt);
  // Passed but infeasible: a feasible lower rank that passes would win.
  EXPECT_EQ(choiceIsFinal({verdict(true), none}, {false, true}), std::nullopt);
  EXPECT_EQ(choiceIsFinal({verdict(false), verdict(false)}, {true, true}), std::nullopt);
  // Wherever it says final, chooseVerified agrees for every outcome of the missing verdicts.
  for (const bool a : {false, true})
    for (const bool b : {false, true}) {
      const std::vector<std::optional<VerifierVerdict>> partial = {verdict(false), verdict(true),
                                                                   none, none};
      const std::vector<std::optional<VerifierVerdict>> full = {verdict(false), verdict(true),
                                                                verdict(a), verdict(b)};
      EXPECT_EQ(choiceIsFinal(partial, {true, true, true, true}),
                chooseVerified(full, {true, true, true, true}));
    }
}

TEST(MissPipeline, WithoutVerificationAnswersTheBestCandidateAndSaysWhy) {
  ServerConfig c = coreConfig();
  c.verification.enabled = false;
  PipelineFixture f(c);
  MissResult r = f.pipeline.run(f.inputs(request(1.0), false));
  ASSERT_FALSE(r.error.has_value()) << r.error->what();
  ASSERT_TRUE(r.answer.has_value());
  ASSERT_TRUE(r.solution.has_value());
  EXPECT_GT(r.answer->plan.numSamples(), 0);
  EXPECT_EQ(r.answer->verification.status, VerificationStatus::NotRun);
  ASSERT_EQ(r.answer->verification.failure_reasons.size(), 1u);
  EXPECT_NE(r.answer->verification.failure_reasons[0].find("verification.enabled"),
            std::string::npos);
  EXPECT_EQ(r.answer->stats.cache_key, "test-key");
  // The compact solution is the answer's: its u rebuilds the answer's plan.
  const PlanRequest asked = request(1.0);
  const planner::JumpModel model(f.planner.robot(), f.planner.settings(), asked.task,
                                 asked.initial);
  const Eigen::Map<const Eigen::VectorXd> u(r.solution->u.data(), planner::kNumDecision);
  const planner::JumpPlan rebuilt = model.buildPlan(u);
  EXPECT_EQ(rebuilt.decision, r.answer->plan.decision);
  EXPECT_EQ(rebuilt.q, r.answer->plan.q);
  EXPECT_EQ(r.solution->t3, r.answer->plan.t3);
  EXPECT_EQ(r.solution->feasible, r.answer->evaluation.feasible);
  EXPECT_EQ(r.cacheable, r.solution->de_complete || r.solution->feasible);
  EXPECT_EQ(r.solution->verification.status, VerificationStatus::NotRun);
}

TEST(MissPipeline, VerifiesTheTopKAndReturnsTheBestThatPasses) {
  ServerConfig c = coreConfig();
  c.verification.default_candidates = 3;
  auto* v = new ScriptedVerifier;
  std::vector<double> rejected;  // the best-predicted candidate's decision vector
  std::mutex mu;
  v->pass = [&](const planner::JumpPlan& p) {
    std::lock_guard lock(mu);
    const std::vector<double> d(p.decision.data(), p.decision.data() + p.decision.size());
    if (rejected.empty()) return true;
    return d != rejected;
  };
  PipelineFixture f(c, v);
  const MissResult first = f.pipeline.run(f.inputs(request(0.5), true));
  ASSERT_TRUE(first.answer.has_value());
  EXPECT_EQ(first.answer->verification.returned_candidate_rank, 0);
  EXPECT_EQ(first.answer->verification.candidates_verified,
            first.answer->evaluation.feasible ? 1 : 3);
  const int first_calls = v->calls.load();
  {
    std::lock_guard lock(mu);
    const auto& d = first.answer->plan.decision;
    rejected.assign(d.data(), d.data() + d.size());
  }
  const MissResult second = f.pipeline.run(f.inputs(request(0.5), true));
  ASSERT_TRUE(second.answer.has_value());
  EXPECT_EQ(second.answer->verification.status, VerificationStatus::Passed);
  EXPECT_GE(second.answer->verification.returned_candidate_rank, 1);
  EXPECT_EQ(second.solution->verification.status, VerificationStatus::Passed);
  EXPECT_EQ(second.solution->verification.returned_candidate_rank,
            second.answer->verification.returned_candidate_rank);
  // A lower rank's plan is built on its verify worker: the answer is that rank's plan, the
  // one its verdict is of (the compact solution's u rebuilds it).
  const PlanRequest asked = request(0.5);
  const planner::JumpModel model(f.planner.robot(), f.planner.settings(), asked.task,
                                 asked.initial);
  const Eigen::Map<const Eigen::VectorXd> u(second.solution->u.data(), planner::kNumDecision);
  const planner::JumpPlan rebuilt = model.buildPlan(u);
  EXPECT_EQ(second.answer->plan.decision, rebuilt.decision);
  EXPECT_EQ(second.answer->plan.q, rebuilt.q);
  EXPECT_NE(second.answer->plan.decision, first.answer->plan.decision);
  // The second miss verified at least ranks 0 to the chosen one, at most all three.
  EXPECT_GE(v->calls.load() - first_calls,
            static_cast<int>(second.answer->verification.returned_candidate_rank) + 1);
  EXPECT_LE(v->calls.load() - first_calls, 3);
}

// The time left becomes the search's budget: a search allowed 10^7 evaluations is stopped by the
// clock (not complete, far fewer evaluations) after at least that budget less the margins kept
// back (two generations and 5 ms, docs/service.md). The hard end of the call (budget_end) is a
// minute away, so that the verdict does not depend on how fast a loaded machine builds the
// answer after the search: only on what the search was given and used.
TEST(MissPipeline, TheTimeLeftBoundsTheSearch) {
  ServerConfig c = coreConfig();
  c.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  c.verification.enabled = false;
  c.planner.max_evaluations_cap = 10'000'000;
  PipelineFixture f(c);
  PlanRequest r = request(0.9);
  r.max_evaluations = 10'000'000;
  MissInputs in = f.inputs(r, false, 60s);
  in.remaining_s = 0.4;
  const double generation_ms = f.pipeline.generationMs();
  const MissResult m = f.pipeline.run(in);
  ASSERT_FALSE(m.error.has_value()) << m.error->what();
  ASSERT_TRUE(m.answer.has_value());
  ASSERT_TRUE(m.solution.has_value());
  EXPECT_FALSE(m.solution->de_complete);  // stopped by its time budget
  EXPECT_LT(m.answer->stats.evaluations, 10'000'000);
  EXPECT_GE(m.answer->stats.de_ms, 400.0 - 2.0 * generation_ms - 5.0);
}

TEST(MissPipeline, CancelledOrOutOfTimeIsAnErrorNeverAnAnswer) {
  auto* v = new ScriptedVerifier;
  PipelineFixture f(coreConfig(), v);
  f.cancel = true;
  const MissResult cancelled = f.pipeline.run(f.inputs(request(0.7), true));
  ASSERT_TRUE(cancelled.error.has_value());
  EXPECT_EQ(cancelled.error->code(), ErrorCode::Cancelled);
  EXPECT_FALSE(cancelled.answer.has_value());
  f.cancel = false;
  // The verifications never end before the budget does (they wait at a gate opened after the
  // result).
  std::promise<void> release;
  v->gate = release.get_future().share();
  const MissResult late = f.pipeline.run(f.inputs(request(0.7), true, 1500ms));
  release.set_value();
  ASSERT_TRUE(late.error.has_value());
  EXPECT_EQ(late.error->code(), ErrorCode::DeadlineExceeded);
  EXPECT_FALSE(late.answer.has_value());
}

}  // namespace
}  // namespace wj::server
