// Small parts of the service: the bounded executor, the latency histogram, the status mapping,
// the binding-constraint description against the planner's own.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <random>
#include <thread>

#include "planner/jump_planner.h"
#include "planner/presets.h"
#include "server/executor.h"
#include "server/latency_histogram.h"
#include "server/plan_types.h"
#include "server/status_mapping.h"

namespace wj::server {
namespace {

TEST(BoundedExecutor, RefusesWhenTheQueueIsFullAndNeverBlocks) {
  BoundedExecutor pool("test", 1, 2);
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::atomic<int> ran{0};
  const auto blocker = [&] {
    gate.wait();
    ++ran;
  };
  ASSERT_TRUE(pool.trySubmit({blocker, {}}));
  // Wait until the worker holds the first task, then fill the queue.
  while (pool.running() == 0) std::this_thread::yield();
  EXPECT_TRUE(pool.trySubmit({blocker, {}}));
  EXPECT_TRUE(pool.trySubmit({blocker, {}}));
  // Full: refused at once. Had trySubmit waited for room, it would wait forever: the worker
  // holds its task until this thread opens the gate below (no wall-clock bound to race).
  EXPECT_FALSE(pool.trySubmit({blocker, {}}));
  EXPECT_TRUE(pool.trySubmit({blocker, {}}, BoundedExecutor::Lane::Internal));
  EXPECT_EQ(pool.queued(), 3u);
  release.set_value();
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (ran.load() < 4 && std::chrono::steady_clock::now() < until) std::this_thread::yield();
  pool.shutdown();
  EXPECT_EQ(ran.load(), 4);
}

TEST(BoundedExecutor, ShutdownAbandonsQueuedTasks) {
  BoundedExecutor pool("test", 1, 10);
  std::promise<void> release;
  std::shared_future<void> gate = release.get_future().share();
  std::atomic<int> ran{0}, abandoned{0};
  ASSERT_TRUE(pool.trySubmit({[&] { gate.wait(); }, {}}));
  while (pool.running() == 0) std::this_thread::yield();
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(pool.trySubmit({[&] { ++ran; }, [&] { ++abandoned; }}));
  std::thread stopper([&] { pool.shutdown(); });
  while (abandoned.load() < 3) std::this_thread::yield();
  release.set_value();
  stopper.join();
  EXPECT_EQ(ran.load(), 0);
  EXPECT_EQ(abandoned.load(), 3);
  EXPECT_FALSE(pool.trySubmit({[&] { ++ran; }, {}}));
}

TEST(LatencyHistogram, PercentilesWithinABucket) {
  LatencyHistogram h;
  EXPECT_EQ(h.quantile(0.5), 0.0);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> xs;
  for (int i = 0; i < 20000; ++i) {
    const double ms = 0.1 + 99.9 * u(rng);  // 0.1 .. 100 ms
    xs.push_back(ms);
    h.record(ms);
  }
  std::sort(xs.begin(), xs.end());
  EXPECT_EQ(h.count(), 20000u);
  for (const double q : {0.5, 0.9, 0.99}) {
    const double exact = xs[static_cast<std::size_t>(q * xs.size()) - 1];
    EXPECT_NEAR(h.quantile(q), exact, 0.05 * exact) << q;
    EXPECT_GE(h.quantile(q), exact * 0.999) << "upper edge of the bucket";
  }
  h.record(std::numeric_limits<double>::quiet_NaN());  // no crash, smallest bucket
  h.record(1e12);
  EXPECT_EQ(h.count(), 20002u);
}

TEST(StatusMapping, OneCodePerDomainError) {
  const std::vector<std::pair<ErrorCode, grpc::StatusCode>> expected = {
      {ErrorCode::InvalidArgument, grpc::StatusCode::INVALID_ARGUMENT},
      {ErrorCode::ResourceExhausted, grpc::StatusCode::RESOURCE_EXHAUSTED},
      {ErrorCode::DeadlineExceeded, grpc::StatusCode::DEADLINE_EXCEEDED},
      {ErrorCode::Cancelled, grpc::StatusCode::CANCELLED},
      {ErrorCode::Unavailable, grpc::StatusCode::UNAVAILABLE},
      {ErrorCode::Internal, grpc::StatusCode::INTERNAL}};
  for (const auto& [domain, code] : expected) {
    const grpc::Status s = toGrpcStatus(ServiceError(domain, "why"));
    EXPECT_EQ(s.error_code(), code);
    EXPECT_EQ(s.error_message(), "why");
  }
  const auto classify = [](auto thrower) {
    try {
      thrower();
    } catch (...) {
      return classifyException(std::current_exception());
    }
    return ServiceError(ErrorCode::Internal, "not thrown");
  };
  EXPECT_EQ(classify([] { throw std::invalid_argument("task.x must be"); }).code(),
            ErrorCode::InvalidArgument);
  EXPECT_EQ(classify([] { throw std::runtime_error("disk"); }).code(), ErrorCode::Internal);
  EXPECT_EQ(classify([] { throw ServiceError(ErrorCode::Unavailable, "bye"); }).code(),
            ErrorCode::Unavailable);
  EXPECT_EQ(classify([] { throw 42; }).code(), ErrorCode::Internal);
}

// describeEvaluation() re-derives binding classes and the summary of a cached solution; it
// must agree with what the planner itself reports for the same evaluation.
TEST(DescribeEvaluation, AgreesWithThePlanner) {
  const planner::JumpPlanner jp(model::RobotModel::loadDefault(), planner::PlannerSettings{});
  int infeasible = 0;
  for (const auto& [name, evaluations] : std::vector<std::pair<std::string, int>>{
           {"vertical", 320}, {"forward", 64}, {"backflip", 64}}) {
    const planner::Scenario sc = planner::makePreset(jp, name);
    planner::PlanOptions o;
    o.max_evaluations = evaluations;  // small budgets give infeasible results too
    o.polish = false;
    o.threads = 1;
    const auto r = jp.plan(sc.task, sc.initial, o);
    std::vector<planner::ConstraintClass> binding;
    std::string summary;
    describeEvaluation(r.evaluation, jp.settings().polish_backoff, binding, summary);
    EXPECT_EQ(binding, r.binding) << name;
    EXPECT_EQ(summary, r.summary) << name;
    infeasible += r.evaluation.feasible ? 0 : 1;
  }
  EXPECT_GE(infeasible, 1) << "the comparison should cover an infeasible case";
}

}  // namespace
}  // namespace wj::server
