// Integration tests against real planner_server processes on 127.0.0.1 with ephemeral ports:
// plans and hits, invalid requests, concurrent clients, full queues, deadlines, cancellation,
// WarmCache, SIGTERM, kill -9 in the middle of cache writes, corrupted rows, TLS and mutual TLS,
// plaintext off loopback, configuration errors, message size bounds, verification in the loop.
#include <grpcpp/create_channel.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/security/credentials.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <future>
#include <mutex>
#include <set>
#include <thread>

#include "planner/plan_knots.h"
#include "planner_client/compact_knots.h"
#include "planner_client/planner_client.h"
#include "server/plan_verifier.h"
#include "server/solution_store.h"
#include "server_test_util.h"

namespace wj::server {
namespace {

using namespace std::chrono_literals;
namespace v1 = wheeljump::planner::v1;
using test::ServerProcess;
using test::standingRequest;
using test::TempDir;

client::ClientOptions clientFor(const std::string& target, int max_attempts = 5) {
  client::ClientOptions o;
  o.target = target;
  o.max_attempts = max_attempts;
  o.initial_backoff = 100ms;
  return o;
}

client::PlanResult plan(client::PlannerClient& c, const v1::PlanJumpRequest& r,
                        std::chrono::milliseconds deadline = 20s) {
  auto f = c.planJump(r, deadline);
  EXPECT_EQ(f.wait_for(deadline + 10s), std::future_status::ready);
  return f.get();
}

v1::GetStatsResponse stats(client::PlannerClient& c) {
  const auto r = c.getStats(5s).get();
  EXPECT_TRUE(r.ok()) << r.status.error_message();
  return r.response;
}

// Polls the server's statistics until `pred` holds (false after 30 s): how a test learns that
// the server has received a call, or started its search, instead of sleeping and hoping.
template <typename Pred>
bool serverReaches(client::PlannerClient& c, Pred pred) {
  const auto until = std::chrono::steady_clock::now() + 30s;
  while (!pred(stats(c))) {
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

// A request whose search ends on its 200 evaluations (a few generations), never on its
// deadline, whatever the planner settings: its answer does not race the clock.
v1::PlanJumpRequest smallRequest(double v0) {
  v1::PlanJumpRequest r = standingRequest(v0);
  r.mutable_budget()->set_max_evaluations(200);
  return r;
}

// Waits until `n` of `calls` have their result (false after 30 s).
bool resultsArrive(std::vector<std::future<client::PlanResult>>& calls, int n) {
  const auto until = std::chrono::steady_clock::now() + 30s;
  while (true) {
    int ready = 0;
    for (auto& f : calls) ready += f.wait_for(0s) == std::future_status::ready ? 1 : 0;
    if (ready >= n) return true;
    if (std::chrono::steady_clock::now() > until) return false;
    std::this_thread::sleep_for(5ms);
  }
}

// The response is a whole plan: sizes consistent with each other and with the phase times.
void expectWholePlan(const v1::PlanJumpResponse& r) {
  const auto& p = r.plan();
  const auto& j = p.joints();
  ASSERT_GT(j.num_samples(), 10u);
  EXPECT_EQ(j.joint_names_size(), 16);
  EXPECT_EQ(static_cast<std::uint32_t>(j.positions_rad_size()), 16 * j.num_samples());
  EXPECT_EQ(static_cast<std::uint32_t>(j.velocities_rad_s_size()), 16 * j.num_samples());
  EXPECT_EQ(static_cast<std::uint32_t>(j.torques_nm_size()), 16 * j.num_samples());
  EXPECT_EQ(static_cast<std::uint32_t>(p.centroidal_trajectory_size()), j.num_samples());
  EXPECT_DOUBLE_EQ(p.centroidal_trajectory(p.centroidal_trajectory_size() - 1).t_s(),
                   p.phase_times().t3_s());
  EXPECT_EQ(p.decision_vector_size(), 12);
  EXPECT_GE(p.force_phases_size(), 1);
  EXPECT_EQ(r.feasibility().margins_size(), 10);
}

std::string planSourceName(const v1::PlanJumpResponse& r) {
  return v1::PlanSource_Name(r.source());
}

// Flips one payload byte of the row of `key_hex` behind the server's back.
void corruptRow(const std::filesystem::path& db_path, const std::string& key_hex) {
  std::string key;
  for (std::size_t i = 0; i + 1 < key_hex.size(); i += 2)
    key.push_back(static_cast<char>(std::stoi(key_hex.substr(i, 2), nullptr, 16)));
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db_path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "UPDATE solutions SET payload = substr(payload, 1, 30) || "
                               "x'5a' || substr(payload, 32) WHERE key = ?1",
                               -1, &st, nullptr),
            SQLITE_OK);
  sqlite3_bind_blob(st, 1, key.data(), static_cast<int>(key.size()), SQLITE_TRANSIENT);
  ASSERT_EQ(sqlite3_step(st), SQLITE_DONE);
  EXPECT_EQ(sqlite3_changes(db), 1);
  sqlite3_finalize(st);
  sqlite3_close(db);
}

// With the hot tier off, every hit is regenerated at its caller's state (v0 = 1.01 here, in the
// bin of the miss's 1.0).
TEST(Integration, PlanMissThenHitWithStatsAndRequestId) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.cache.hot_responses_mb = 0.0;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  v1::PlanJumpRequest r = standingRequest(1.0);
  r.set_request_id("robot-42");
  const auto miss = plan(c, r);
  ASSERT_TRUE(miss.ok()) << miss.status.error_message();
  EXPECT_EQ(miss.response.source(), v1::PLAN_SOURCE_CACHE_MISS);
  EXPECT_EQ(miss.response.request_id(), "robot-42");
  expectWholePlan(miss.response);
  EXPECT_EQ(miss.response.verification().status(), v1::VERIFICATION_STATUS_NOT_RUN);
  ASSERT_EQ(miss.response.verification().failure_reasons_size(), 1);
  EXPECT_NE(miss.response.verification().failure_reasons(0).find("verification.enabled"),
            std::string::npos);
  EXPECT_GT(miss.response.stats().evaluations(), 0u);
  EXPECT_EQ(miss.response.stats().cache_key().size(), 2 * CacheKey::kBytes);
  const auto hit = plan(c, standingRequest(1.01));
  ASSERT_TRUE(hit.ok());
  EXPECT_EQ(hit.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  expectWholePlan(hit.response);
  EXPECT_EQ(hit.response.stats().cache_key(), miss.response.stats().cache_key());
  EXPECT_NEAR(hit.response.plan().centroidal_trajectory(0).com_vx_m_s(), 1.01, 1e-9);
  EXPECT_NEAR(hit.response.planned_for().v0_m_s(), 1.01, 1e-9);
  EXPECT_FALSE(hit.response.ready_response());
  const auto again = plan(c, standingRequest(1.02));  // regenerated again, not a ready response
  ASSERT_TRUE(again.ok());
  EXPECT_NEAR(again.response.planned_for().v0_m_s(), 1.02, 1e-9);
  EXPECT_FALSE(again.response.ready_response());
  const auto s = stats(c);
  EXPECT_EQ(s.requests(), 3u);
  EXPECT_EQ(s.cache_hits(), 2u);
  EXPECT_EQ(s.cache_misses(), 1u);
  EXPECT_EQ(s.cache_entries(), 1u);
  ASSERT_EQ(s.latencies_size(), 4);
  EXPECT_EQ(s.latencies(0).path(), "cache_hit");
  EXPECT_EQ(s.latencies(0).count(), 2u);
  EXPECT_GT(s.latencies(0).p99_ms(), 0.0);
  EXPECT_GT(s.uptime_s(), 0.0);
}

// The hot tier (cache.hot_responses_mb > 0, the default): the first hit of a bin is regenerated
// at its caller's state and becomes the bin's ready response; later hits of the bin get that
// response (its trajectory starts at the first caller's v0, which planned_for says, and
// ready_response is set) as ready bytes with their own request id and total_ms appended, which
// the client parses as one message; counted as hits. Off, every hit is regenerated (the test
// above).
TEST(Integration, HotTierAnswersLaterHitsOfABinWithItsFirstHit) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  ASSERT_GT(config.cache.hot_responses_mb, 0.0);  // the default
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  const auto miss = plan(c, standingRequest(1.0));
  ASSERT_TRUE(miss.ok()) << miss.status.error_message();
  EXPECT_EQ(miss.response.source(), v1::PLAN_SOURCE_CACHE_MISS);
  const auto first = plan(c, standingRequest(1.01));
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  EXPECT_NEAR(first.response.plan().centroidal_trajectory(0).com_vx_m_s(), 1.01, 1e-9);
  EXPECT_NEAR(first.response.planned_for().v0_m_s(), 1.01, 1e-9);
  EXPECT_FALSE(first.response.ready_response());
  v1::PlanJumpRequest later_request = standingRequest(1.02);
  later_request.set_request_id("later");
  const auto later = plan(c, later_request);
  ASSERT_TRUE(later.ok());
  EXPECT_EQ(later.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  EXPECT_EQ(later.response.request_id(), "later");
  EXPECT_GT(later.response.stats().total_ms(), 0.0);  // its own, merged into the ready stats
  EXPECT_NEAR(later.response.plan().centroidal_trajectory(0).com_vx_m_s(), 1.01, 1e-9);
  EXPECT_NEAR(later.response.planned_for().v0_m_s(), 1.01, 1e-9);  // not the caller's 1.02
  EXPECT_EQ(later.response.planned_for().joint_positions_rad_size(), 16);
  EXPECT_TRUE(later.response.ready_response());
  v1::PlanJumpResponse a = first.response, b = later.response;
  for (auto* m : {&a, &b}) {
    m->clear_request_id();
    m->mutable_stats()->clear_total_ms();
    m->clear_ready_response();
  }
  EXPECT_EQ(a.SerializeAsString(), b.SerializeAsString())
      << a.ShortDebugString().substr(0, 300) << "\n"
      << b.ShortDebugString().substr(0, 300);
  // Another trajectory format is another ready response.
  later_request.set_trajectory_format(v1::TRAJECTORY_FORMAT_KNOTS);
  const auto knots = plan(c, later_request);
  ASSERT_TRUE(knots.ok());
  EXPECT_GT(knots.response.plan().knots().t_s_size(), 0);
  const auto s = stats(c);
  EXPECT_EQ(s.cache_hits(), 3u);
  EXPECT_EQ(s.cache_misses(), 1u);
  EXPECT_EQ(s.latencies(0).count(), 3u);
}

// A plan sent as knots, on a miss and on a hit: no dense arrays, consistent knot arrays, and
// densified at the same period it matches the dense answer of the same cached solution.
TEST(Integration, PlansTravelAsKnotsWhenAsked) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.output_dt_s = 0.001;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  v1::PlanJumpRequest r = standingRequest(1.0);
  r.set_trajectory_format(v1::TRAJECTORY_FORMAT_KNOTS);
  const auto miss = plan(c, r);
  ASSERT_TRUE(miss.ok()) << miss.status.error_message();
  EXPECT_EQ(miss.response.source(), v1::PLAN_SOURCE_CACHE_MISS);
  r.set_trajectory_format(v1::TRAJECTORY_FORMAT_DENSE);
  const auto dense = plan(c, r);
  ASSERT_TRUE(dense.ok()) << dense.status.error_message();
  EXPECT_EQ(dense.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  expectWholePlan(dense.response);
  r.set_trajectory_format(v1::TRAJECTORY_FORMAT_KNOTS);
  const auto hit = plan(c, r);
  ASSERT_TRUE(hit.ok()) << hit.status.error_message();
  EXPECT_EQ(hit.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  for (const auto* resp : {&miss.response, &hit.response}) {
    const v1::Plan& p = resp->plan();
    EXPECT_EQ(p.joints().num_samples(), 0u);
    EXPECT_EQ(p.centroidal_trajectory_size(), 0);
    EXPECT_EQ(p.decision_vector_size(), 12);
    const v1::TrajectoryKnots& k = p.knots();
    const int n = k.t_s_size();
    ASSERT_GE(n, 4);
    EXPECT_EQ(k.positions_rad_size(), 16 * n);
    EXPECT_EQ(k.velocities_rad_s_size(), 16 * n);
    EXPECT_EQ(k.torques_nm_size(), 16 * n);
    EXPECT_EQ(k.centroidal_size(), 6 * n);
    EXPECT_EQ(k.t_s(0), 0.0);
    EXPECT_DOUBLE_EQ(k.t_s(n - 1), p.phase_times().t3_s());
    EXPECT_LT(resp->ByteSizeLong() * 3, dense.response.ByteSizeLong());
  }
  // Densified at the dense answer's period, the knots give the dense answer's references.
  const v1::Plan& d = dense.response.plan();
  const v1::TrajectoryKnots& k = hit.response.plan().knots();
  planner::JumpPlan jp;
  jp.t3 = hit.response.plan().phase_times().t3_s();
  const int n = k.t_s_size();
  jp.knots.t.assign(k.t_s().begin(), k.t_s().end());
  jp.knots.q.resize(n, 16);
  jp.knots.qd.resize(n, 16);
  jp.knots.tau.resize(n, 16);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < 16; ++j) {
      jp.knots.q(i, j) = k.positions_rad(16 * i + j);
      jp.knots.qd(i, j) = k.velocities_rad_s(16 * i + j);
      jp.knots.tau(i, j) = k.torques_nm(16 * i + j);
    }
    const float* cen = k.centroidal().data() + 6 * i;
    jp.knots.centroidal.push_back({cen[0], cen[1], cen[2], cen[3], cen[4], cen[5]});
  }
  planner::densify(jp, d.joints().sample_period_s());
  ASSERT_EQ(static_cast<std::uint32_t>(jp.numSamples()), d.joints().num_samples());
  double q_err = 0.0, tau_err = 0.0, x_err = 0.0;
  for (int row = 0; row < jp.numSamples(); ++row) {
    for (int j = 0; j < 16; ++j) {
      if (j % 4 == 3) continue;  // wheel angles: integrated differently (Simpson, trapezoid)
      q_err = std::max(q_err, std::abs(jp.q(row, j) - d.joints().positions_rad(16 * row + j)));
      tau_err = std::max(tau_err, std::abs(jp.tau(row, j) - d.joints().torques_nm(16 * row + j)));
    }
    x_err =
        std::max(x_err, std::abs(jp.centroidal[row].z - d.centroidal_trajectory(row).com_z_m()));
  }
  EXPECT_LT(q_err, 1e-3);
  EXPECT_LT(tau_err, 0.25);
  EXPECT_LT(x_err, 1e-5);

  // Compact knots: the same knots bit for bit, in two thirds of the bytes or less.
  r.set_trajectory_format(v1::TRAJECTORY_FORMAT_COMPACT_KNOTS);
  const auto compact = plan(c, r);
  ASSERT_TRUE(compact.ok()) << compact.status.error_message();
  EXPECT_EQ(compact.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  const v1::Plan& cp = compact.response.plan();
  EXPECT_EQ(cp.knots().t_s_size(), 0);
  EXPECT_EQ(cp.joints().num_samples(), 0u);
  EXPECT_EQ(cp.decision_vector_size(), 12);
  EXPECT_LT(compact.response.ByteSizeLong() * 3, hit.response.ByteSizeLong() * 2);
  v1::TrajectoryKnots expanded;
  ASSERT_EQ(client::expandKnots(cp.compact_knots(), &expanded), "");
  EXPECT_EQ(expanded.SerializeAsString(), k.SerializeAsString());
}

TEST(Integration, OutputSamplePeriodComesFromTheConfiguration) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.output_dt_s = 0.002;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  const auto miss = plan(c, standingRequest(0.5));
  ASSERT_TRUE(miss.ok()) << miss.status.error_message();
  const auto hit = plan(c, standingRequest(0.51));
  ASSERT_TRUE(hit.ok()) << hit.status.error_message();
  EXPECT_EQ(hit.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  for (const auto* r : {&miss.response, &hit.response}) {
    expectWholePlan(*r);
    const auto& p = r->plan();
    EXPECT_DOUBLE_EQ(p.joints().sample_period_s(), 0.002);
    EXPECT_EQ(p.joints().num_samples(),
              static_cast<std::uint32_t>(std::ceil(p.phase_times().t3_s() / 0.002 - 1e-9)) + 1);
  }
}

TEST(Integration, InvalidRequestsNameTheFieldAndItsRange) {
  TempDir dir("wj-it");
  ServerProcess server(test::testConfig(dir.path()), dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  v1::PlanJumpRequest nan = standingRequest(1.0);
  nan.mutable_task()->set_target_height_m(std::numeric_limits<double>::quiet_NaN());
  const auto a = plan(c, nan);
  EXPECT_EQ(a.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(a.status.error_message().find("task.target_height_m"), std::string::npos);
  EXPECT_NE(a.status.error_message().find("[0.1, 1.5]"), std::string::npos);
  v1::PlanJumpRequest short_joints = standingRequest(1.0);
  short_joints.mutable_state()->mutable_joint_positions_rad()->RemoveLast();
  const auto b = plan(c, short_joints);
  EXPECT_EQ(b.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(b.status.error_message().find("16 entries"), std::string::npos);
  const auto empty = plan(c, v1::PlanJumpRequest{});
  EXPECT_EQ(empty.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(empty.attempts, 1);  // not retried
  // Bytes that are no PlanJumpRequest at all (PlanJump parses its request itself, on the raw
  // method): refused as invalid, and the server stays up.
  {
    auto channel = grpc::CreateChannel(server.target(), grpc::InsecureChannelCredentials());
    grpc::GenericStub stub(channel);
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + 10s);
    const char garbage[] = {'\x0a', '\x7f', 'x'};  // field 1, length 127, 1 byte
    grpc::Slice slice(garbage, sizeof garbage);
    const grpc::ByteBuffer request(&slice, 1);
    grpc::ByteBuffer response;
    std::promise<grpc::Status> done;
    stub.UnaryCall(&ctx, "/wheeljump.planner.v1.JumpPlanner/PlanJump", grpc::StubOptions(),
                   &request, &response, [&](grpc::Status st) { done.set_value(st); });
    const grpc::Status st = done.get_future().get();
    EXPECT_EQ(st.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << st.error_message();
    EXPECT_NE(st.error_message().find("PlanJumpRequest"), std::string::npos);
  }
  const auto s = stats(c);
  EXPECT_EQ(s.rejected_invalid(), 4u);
  EXPECT_EQ(s.requests(), 4u);
}

TEST(Integration, ConcurrentClientsMixHitsAndMisses) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.executor.plan_queue = 64;
  ServerProcess server(config, dir / "server.yaml");
  {
    client::PlannerClient warm(clientFor(server.target()));
    for (const double v0 : {0.0, 0.5, 1.0}) ASSERT_TRUE(plan(warm, standingRequest(v0)).ok());
  }
  constexpr int kThreads = 8, kPerThread = 12;
  std::vector<std::unique_ptr<client::PlannerClient>> clients;
  for (int i = 0; i < 4; ++i)
    clients.push_back(std::make_unique<client::PlannerClient>(clientFor(server.target())));
  std::mutex mu;
  std::map<std::string, int> sources;
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      auto& c = *clients[static_cast<std::size_t>(t % 4)];
      for (int i = 0; i < kPerThread; ++i) {
        // Even requests hit the three warm speeds; odd ones ask for six new speeds that
        // several threads request at about the same time (misses, some coalesced).
        const double v0 = i % 2 == 0 ? 0.5 * (i / 2 % 3) : 1.5 + 0.1 * ((i / 2 + t) % 6);
        const auto r = plan(c, standingRequest(v0, 0.8), 60s);
        if (!r.ok()) {
          ++failures;
          continue;
        }
        expectWholePlan(r.response);
        std::lock_guard lock(mu);
        ++sources[planSourceName(r.response)];
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(failures.load(), 0);
  const auto s = stats(*clients[0]);
  const int total = kThreads * kPerThread;
  EXPECT_GE(sources["PLAN_SOURCE_CACHE_HIT"], total / 2);
  EXPECT_EQ(s.cache_hits() + s.cache_misses() + s.coalesced(), 3u + total);
  EXPECT_EQ(s.cache_misses(), 3u + 6u);  // each new speed computed once
  EXPECT_EQ(s.cache_entries(), 9u);
  EXPECT_EQ(static_cast<std::uint64_t>(sources["PLAN_SOURCE_COALESCED"]), s.coalesced());
}

// One search holds the only worker (10^7 evaluations, until the test cancels it), one small
// miss waits in the queue of one, three more are refused at once; once the holder is cancelled
// the queued one gets its answer. Nothing here races the clock: the holder lasts as long as the
// test wants, the others end on their evaluation budget.
TEST(Integration, FullQueueIsResourceExhausted) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  config.planner.max_evaluations_cap = 10'000'000;
  config.executor.plan_workers = 1;
  config.executor.plan_queue = 1;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient holder(clientFor(server.target(), 1));
  client::PlannerClient c(clientFor(server.target(), 1));
  auto held = holder.planJump(standingRequest(1.5), 60s);
  ASSERT_TRUE(serverReaches(c, [](const auto& s) { return s.cache_misses() == 1; }));
  std::vector<std::future<client::PlanResult>> calls;
  for (int i = 0; i < 4; ++i) calls.push_back(c.planJump(smallRequest(0.2 * i), 60s));
  ASSERT_TRUE(resultsArrive(calls, 3));  // the refusals, while the holder still runs
  holder.cancelAll();
  EXPECT_EQ(held.get().status.error_code(), grpc::StatusCode::CANCELLED);
  int exhausted = 0, ok = 0;
  for (auto& f : calls) {
    const auto r = f.get();
    if (r.status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++exhausted;
      EXPECT_NE(r.status.error_message().find("queue is full"), std::string::npos);
    }
    ok += r.ok() ? 1 : 0;
  }
  EXPECT_EQ(exhausted, 3);  // one running, one queued, the rest refused
  EXPECT_EQ(ok, 1);         // the queued one, once the worker was free
  EXPECT_EQ(stats(c).rejected_queue_full(), 3u);
}

// Two calls that last until the test cancels them hold both places; three more are refused at
// once. (Should a held call lose the race for a place to a later one, the count is the same.)
TEST(Integration, CallsInFlightAreBounded) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  config.planner.max_evaluations_cap = 10'000'000;
  config.executor.plan_queue = 64;
  config.limits.max_inflight_calls = 2;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient holder(clientFor(server.target(), 1));
  client::PlannerClient c(clientFor(server.target(), 1));
  std::vector<std::future<client::PlanResult>> calls;
  for (int i = 0; i < 2; ++i) calls.push_back(holder.planJump(standingRequest(1.4 + 0.2 * i), 60s));
  ASSERT_TRUE(serverReaches(c, [](const auto& s) { return s.requests() == 2; }));
  for (int i = 0; i < 3; ++i) calls.push_back(c.planJump(smallRequest(0.2 * i), 60s));
  ASSERT_TRUE(resultsArrive(calls, 3));
  holder.cancelAll();
  int refused = 0;
  for (auto& f : calls) {
    const auto r = f.get();
    if (r.status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++refused;
      EXPECT_NE(r.status.error_message().find("limits.max_inflight_calls"), std::string::npos);
    }
  }
  EXPECT_EQ(refused, 3);
  EXPECT_EQ(stats(c).rejected_queue_full(), 3u);
}

TEST(Integration, TheDeadlineBecomesTheBudget) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  // Nor may the service's evaluation cap end it: 200,000 mostly invalid (cheap) candidates take
  // ~0.6 s since the evaluation got faster, and the search stopped there, before the deadline.
  config.planner.max_evaluations_cap = 10'000'000;
  config.executor.plan_workers = 1;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  // A search that would take minutes (10^7 evaluations) is cut to fit the client's 1.5 s; behind
  // it on the only worker, a small miss (200 evaluations) with a 5 s deadline gets its answer
  // only if the deadline ended the long search (else it would wait in the queue past its own).
  // The verdict does not race the clock: the long call may end OK or, on a machine too loaded
  // to deliver the answer within the 1.5 s, DEADLINE_EXCEEDED; never a half-written plan. When
  // OK, the answer says what the server did with the deadline: its search stopped on the clock
  // (far fewer evaluations than allowed) within the 1.5 s. (That the search uses the time it is
  // given: MissPipeline.TheTimeLeftBoundsTheSearch.)
  auto bounded = c.planJump(standingRequest(0.6), 1500ms);
  ASSERT_TRUE(serverReaches(c, [&](const auto& s) {
    return s.cache_misses() == 1 || bounded.wait_for(0s) == std::future_status::ready;
  }));
  auto next = c.planJump(smallRequest(1.1), 5000ms);
  const auto r = bounded.get();
  if (r.ok()) {
    expectWholePlan(r.response);
    EXPECT_LT(r.response.stats().evaluations(), 10'000'000u);
    EXPECT_LT(r.response.stats().de_ms(), 1500.0);
  } else {
    EXPECT_EQ(r.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED)
        << r.status.error_message();
    EXPECT_FALSE(r.response.has_plan());
  }
  const auto after = next.get();
  ASSERT_TRUE(after.ok()) << after.status.error_message();
  expectWholePlan(after.response);
  // No time at all: DEADLINE_EXCEEDED, never a half-written plan.
  const auto none = plan(c, standingRequest(2.2), 5ms);
  EXPECT_EQ(none.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_FALSE(none.response.has_plan());
}

TEST(Integration, CancellationStopsTheWork) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  config.planner.max_evaluations_cap = 10'000'000;  // the search must outlast the 0.5 s wait
  config.executor.plan_workers = 1;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  client::PlannerClient observer(clientFor(server.target()));
  auto slow = c.planJump(standingRequest(0.3), 60s);
  // Cancelled once its search runs (not before it starts, which a fixed sleep cannot tell).
  ASSERT_TRUE(serverReaches(observer, [](const auto& s) { return s.cache_misses() == 1; }));
  c.cancelAll();
  ASSERT_EQ(slow.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(slow.get().status.error_code(), grpc::StatusCode::CANCELLED);
  // The only plan worker is free: a 5 s call gets its answer within its deadline (an uncancelled
  // search of 10^7 evaluations would hold the worker for tens of seconds). Its own search ends
  // on its 200 evaluations, not on its deadline, so its answer does not race the clock.
  const auto next = plan(observer, smallRequest(1.7), 5000ms);
  EXPECT_TRUE(next.ok()) << next.status.error_message();
}

TEST(Integration, WarmCacheStreamsProgressAndWarmStarts) {
  TempDir dir("wj-it");
  ServerProcess server(test::testConfig(dir.path()), dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  v1::WarmCacheRequest w;
  *w.mutable_task() = standingRequest(0.0).task();
  w.set_v0_min_m_s(0.0);
  w.set_v0_max_m_s(0.3);
  w.set_v0_step_m_s(0.1);
  std::vector<v1::WarmCacheProgress> progress;
  std::promise<client::WarmResult> done;
  c.warmCache(
      w, [&](const v1::WarmCacheProgress& p) { progress.push_back(p); },
      [&](client::WarmResult r) { done.set_value(std::move(r)); }, 60s);
  const auto result = done.get_future().get();
  ASSERT_TRUE(result.ok()) << result.status.error_message();
  ASSERT_EQ(progress.size(), 4u);
  for (std::size_t i = 0; i < progress.size(); ++i) {
    EXPECT_EQ(progress[i].done(), i + 1);
    EXPECT_EQ(progress[i].total(), 4u);
    EXPECT_NEAR(progress[i].v0_m_s(), 0.1 * static_cast<double>(i), 1e-12);
  }
  EXPECT_EQ(progress[1].source(), v1::PLAN_SOURCE_WARM_START);
  EXPECT_GE(stats(c).warm_starts(), 3u);
  EXPECT_EQ(plan(c, standingRequest(0.2)).response.source(), v1::PLAN_SOURCE_CACHE_HIT);
}

TEST(Integration, SigtermFinishesInFlightCallsAndFlushesTheCache) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.planner.settings_file = WJ_SERVER_TEST_DATA_DIR "/planner_long.yaml";
  config.shutdown_grace_s = 60.0;  // the call in flight ends on its evaluations, not the grace
  std::string key;
  {
    ServerProcess server(config, dir / "server.yaml");
    client::PlannerClient c(clientFor(server.target(), 1));
    // An entry whose search ends on its evaluation budget (so it is cached) ...
    v1::PlanJumpRequest bounded = standingRequest(1.2);
    bounded.mutable_budget()->set_max_evaluations(200);
    const auto first = plan(c, bounded, 10s);
    ASSERT_TRUE(first.ok()) << first.status.error_message();
    key = first.response.stats().cache_key();
    // ... and a call in flight when SIGTERM arrives: its search (10^5 evaluations, a fraction
    // of a second on an idle machine) has started and not ended. It ends on its evaluations, not
    // on its deadline, so that its answer does not race the clock.
    v1::PlanJumpRequest longer = standingRequest(0.8);
    longer.mutable_budget()->set_max_evaluations(100'000);
    auto in_flight = c.planJump(longer, 60s);
    client::PlannerClient observer(clientFor(server.target(), 1));
    ASSERT_TRUE(serverReaches(observer, [](const auto& s) { return s.cache_misses() == 2; }));
    ASSERT_NE(in_flight.wait_for(0s), std::future_status::ready);
    server.signal(SIGTERM);
    const auto r = in_flight.get();
    ASSERT_TRUE(r.ok()) << r.status.error_message();  // finished, not dropped
    expectWholePlan(r.response);
    const auto code = server.waitExit(15s);
    ASSERT_TRUE(code.has_value());
    EXPECT_EQ(*code, 0) << server.output();
    EXPECT_NE(server.output().find("planner_server stopped"), std::string::npos);
    // New calls after the signal are refused.
    const auto late = plan(c, standingRequest(1.9), 1000ms);
    EXPECT_EQ(late.status.error_code(), grpc::StatusCode::UNAVAILABLE);
  }
  // Flushed: the WAL was folded into the database file.
  const auto wal = std::filesystem::path(config.cache.path + "-wal");
  EXPECT_TRUE(!std::filesystem::exists(wal) || std::filesystem::file_size(wal) == 0);
  ServerProcess again(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(again.target()));
  const auto hit = plan(c, standingRequest(1.2), 3s);
  ASSERT_TRUE(hit.ok()) << hit.status.error_message();
  EXPECT_EQ(hit.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  EXPECT_EQ(hit.response.stats().cache_key(), key);
}

// kill -9 while WarmCache writes the cache, three times: every grid point reported done
// before the kill is served from the cache after the restart, no row is corrupted, and
// clients see UNAVAILABLE while the server is down, then recover by themselves.
TEST(Integration, KillNineMidWriteLosesNoCommittedEntryAndClientsRecover) {
  TempDir dir("wj-it");
  const ServerConfig config = test::testConfig(dir.path());
  std::set<long> committed;  // v0 in mm/s
  v1::WarmCacheRequest w;
  *w.mutable_task() = standingRequest(0.0).task();
  w.set_v0_step_m_s(0.05);
  for (int round = 0; round < 3; ++round) {
    auto server = std::make_unique<ServerProcess>(config, dir / "server.yaml");
    {
      client::PlannerClient c(clientFor(server->target(), 1));
      w.set_v0_min_m_s(-1.0 + 1.45 * round);
      w.set_v0_max_m_s(w.v0_min_m_s() + 1.4);  // up to 3.3 m/s, within the wheels' reach
      std::mutex mu;
      std::condition_variable cv;
      int received = 0;
      std::promise<client::WarmResult> done;
      c.warmCache(
          w,
          [&](const v1::WarmCacheProgress& p) {
            std::lock_guard lock(mu);
            committed.insert(std::lround(p.v0_m_s() * 1000));
            ++received;
            cv.notify_all();
          },
          [&](client::WarmResult r) { done.set_value(std::move(r)); }, 120s);
      auto finished = done.get_future();
      {
        std::unique_lock lock(mu);
        const bool enough = cv.wait_for(lock, 60s, [&] { return received >= 3 + round; });
        ASSERT_TRUE(enough) << received << " points; stream "
                            << (finished.wait_for(0s) == std::future_status::ready
                                    ? finished.get().status.error_message()
                                    : std::string("still open"))
                            << "\n"
                            << server->output();
      }
      server->signal(SIGKILL);  // in the middle of the stream: a point is being planned/written
      ASSERT_EQ(server->waitExit(10s), 128 + SIGKILL);
      const auto end = finished.get();
      EXPECT_EQ(end.status.error_code(), grpc::StatusCode::UNAVAILABLE);
    }
    const std::string dead = server->target();
    server.reset();
    // Down: a client without retries sees UNAVAILABLE ...
    {
      client::PlannerClient once(clientFor(dead, 1));
      EXPECT_EQ(plan(once, standingRequest(0.0), 2000ms).status.error_code(),
                grpc::StatusCode::UNAVAILABLE);
    }
  }
  // ... and one with retries recovers once the server is back on its port.
  ServerConfig fixed = config;
  {
    ServerConfig probe_config = config;
    probe_config.cache.path.clear();
    ServerProcess probe(probe_config, dir / "probe.yaml");  // finds a free port
    fixed.listen = probe.target();
  }
  client::PlannerClient retrying(clientFor(fixed.listen, 20));
  auto pending = retrying.planJump(standingRequest(0.0), 30s);
  std::this_thread::sleep_for(700ms);  // a few attempts fail with UNAVAILABLE meanwhile
  ServerProcess server(fixed, dir / "server.yaml");
  const auto recovered = pending.get();
  ASSERT_TRUE(recovered.ok()) << recovered.status.error_message();
  EXPECT_GE(recovered.attempts, 2);
  ASSERT_GE(committed.size(), 9u);
  int lost = 0;
  for (const long mm : committed) {
    const auto r = plan(retrying, standingRequest(static_cast<double>(mm) / 1000.0));
    ASSERT_TRUE(r.ok()) << r.status.error_message();
    if (r.response.source() != v1::PLAN_SOURCE_CACHE_HIT) ++lost;
  }
  EXPECT_EQ(lost, 0) << "of " << committed.size() << " committed grid points";
  server.signal(SIGTERM);
  ASSERT_EQ(server.waitExit(15s), 0);
  SolutionStore store(config.cache.path, true, 1000000);
  EXPECT_GE(store.count(), static_cast<std::int64_t>(committed.size()));
  std::int64_t rows = 0;
  store.forEachNewest(1000000, [&](const CacheKey&, const CachedSolution&) { ++rows; });
  EXPECT_EQ(rows, store.count());
  EXPECT_EQ(store.counters().corrupt_rows, 0);
  EXPECT_FALSE(store.counters().recreated);
}

TEST(Integration, CorruptedRowIsNeverServed) {
  TempDir dir("wj-it");
  const ServerConfig config = test::testConfig(dir.path());
  std::string damaged_key;
  {
    ServerProcess server(config, dir / "server.yaml");
    client::PlannerClient c(clientFor(server.target()));
    const auto a = plan(c, standingRequest(0.5));
    ASSERT_TRUE(a.ok());
    damaged_key = a.response.stats().cache_key();
    ASSERT_TRUE(plan(c, standingRequest(1.0)).ok());
    server.signal(SIGTERM);
    ASSERT_EQ(server.waitExit(15s), 0);
  }
  corruptRow(config.cache.path, damaged_key);
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  EXPECT_EQ(stats(c).cache_entries(), 1u);  // the damaged row was refused at load
  const auto a = plan(c, standingRequest(0.5));
  ASSERT_TRUE(a.ok());
  EXPECT_NE(a.response.source(), v1::PLAN_SOURCE_CACHE_HIT);  // recomputed, not served
  EXPECT_EQ(stats(c).cache_misses(), 1u);
  EXPECT_EQ(plan(c, standingRequest(1.0)).response.source(), v1::PLAN_SOURCE_CACHE_HIT);
}

// Creates a CA, a server certificate for 127.0.0.1 and a client certificate with openssl.
void makeCertificates(const std::filesystem::path& d) {
  const std::string q = "cd '" + d.string() + "' && ";
  const std::string ec = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes";
  const std::vector<std::string> steps = {
      "openssl req -x509" + ec + " -keyout ca.key -out ca.pem -days 2 -subj /CN=wj-test-ca",
      "openssl req" + ec + " -keyout server.key -out server.csr -subj /CN=localhost",
      "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost' > san.ext",
      "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out "
      "server.pem -days 2 -extfile san.ext",
      "openssl req" + ec + " -keyout client.key -out client.csr -subj /CN=wj-robot",
      "openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -out "
      "client.pem -days 2"};
  for (const auto& s : steps) ASSERT_EQ(std::system((q + s + " > /dev/null 2>&1").c_str()), 0) << s;
}

TEST(Integration, TlsAndMutualTls) {
  TempDir dir("wj-it");
  makeCertificates(dir.path());
  ServerConfig config = test::testConfig(dir.path());
  config.cache.path.clear();
  config.tls.mode = TlsMode::Tls;
  config.tls.server_cert_file = (dir / "server.pem").string();
  config.tls.server_key_file = (dir / "server.key").string();
  const auto tlsClient = [&](const std::string& target, bool with_cert) {
    client::ClientOptions o = clientFor(target, 1);
    o.use_tls = true;
    o.tls.root_ca_file = (dir / "ca.pem").string();
    // With gRPC 1.51 the IP target was refused against the IP SAN ("Peer name 127.0.0.1 is not
    // in peer certificate"); the DNS name of the certificate is checked instead.
    o.tls.target_name_override = "localhost";
    if (with_cert) {
      o.tls.cert_chain_file = (dir / "client.pem").string();
      o.tls.private_key_file = (dir / "client.key").string();
    }
    return o;
  };
  {
    ServerProcess server(config, dir / "tls.yaml");
    client::PlannerClient secure(tlsClient(server.target(), false));
    EXPECT_TRUE(secure.getStats(5s).get().ok());
    client::PlannerClient plaintext(clientFor(server.target(), 1));
    EXPECT_EQ(plaintext.getStats(3s).get().status.error_code(), grpc::StatusCode::UNAVAILABLE);
  }
  config.tls.mode = TlsMode::MutualTls;
  config.tls.client_ca_file = (dir / "ca.pem").string();
  ServerProcess server(config, dir / "mtls.yaml");
  client::PlannerClient anonymous(tlsClient(server.target(), false));
  EXPECT_EQ(anonymous.getStats(3s).get().status.error_code(), grpc::StatusCode::UNAVAILABLE);
  client::PlannerClient robot(tlsClient(server.target(), true));
  const auto r = plan(robot, standingRequest(0.4));
  EXPECT_TRUE(r.ok()) << r.status.error_message();
}

TEST(Integration, PlaintextIsRefusedOffLoopbackUnlessAllowed) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.cache.path.clear();
  const auto path = dir / "open.yaml";
  { std::ofstream(path) << config.toYaml(); }
  const auto [code, out] =
      test::runServerToExit({"--config", path.string(), "--listen", "0.0.0.0:0"});
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("not a loopback address"), std::string::npos) << out;
  config.listen = "0.0.0.0:0";
  config.tls.allow_insecure_non_loopback = true;
  ServerProcess allowed(config, dir / "allowed.yaml");
  client::PlannerClient c(clientFor(allowed.target()));
  EXPECT_TRUE(c.getStats(5s).get().ok());
}

TEST(Integration, ConfigurationErrorsNameTheKeyAndTheEffectiveConfigIsPrinted) {
  TempDir dir("wj-it");
  std::string yaml = test::testConfig(dir.path()).toYaml();
  { std::ofstream(dir / "typo.yaml") << yaml << "cache_size: 5\n"; }
  const auto [code, out] = test::runServerToExit({"--config", (dir / "typo.yaml").string()});
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("unknown key 'cache_size'"), std::string::npos) << out;
  const auto at = yaml.find("  hit_workers:");
  const std::string missing = yaml.substr(0, at) + yaml.substr(yaml.find('\n', at) + 1);
  { std::ofstream(dir / "missing.yaml") << missing; }
  const auto [code2, out2] = test::runServerToExit({"--config", (dir / "missing.yaml").string()});
  EXPECT_EQ(code2, 2);
  EXPECT_NE(out2.find("missing key 'executor.hit_workers'"), std::string::npos) << out2;
  { std::ofstream(dir / "good.yaml") << yaml; }
  const auto [code3, out3] =
      test::runServerToExit({"--config", (dir / "good.yaml").string(), "--print-config"});
  EXPECT_EQ(code3, 0);
  const auto printed = ServerConfig::fromYamlString(out3, "printed");
  EXPECT_EQ(printed.toYaml(), yaml);
}

TEST(Integration, OversizedRequestIsRefusedAndTheServerStaysUp) {
  TempDir dir("wj-it");
  ServerProcess server(test::testConfig(dir.path()), dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target(), 1));
  v1::PlanJumpRequest big = standingRequest(0.5);
  big.set_request_id(std::string(200 * 1024, 'x'));
  const auto r = plan(c, big);
  EXPECT_EQ(r.status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED)
      << r.status.error_message();
  EXPECT_TRUE(plan(c, standingRequest(0.5)).ok());
}

TEST(Integration, VerificationInTheLoop) {
  TempDir dir("wj-it");
  ServerConfig config = test::testConfig(dir.path());
  config.verification.enabled = true;
  ServerProcess server(config, dir / "server.yaml");
  client::PlannerClient c(clientFor(server.target()));
  v1::PlanJumpRequest r = standingRequest(0.5);
  r.mutable_budget()->set_max_verified_candidates(2);
  const auto a = plan(c, r, 60s);
  ASSERT_TRUE(a.ok()) << a.status.error_message();
  expectWholePlan(a.response);
  const auto& v = a.response.verification();
  if (!simVerifierAvailable()) {
    // Built without the sim component: said plainly, never faked.
    EXPECT_EQ(v.status(), v1::VERIFICATION_STATUS_NOT_RUN);
    ASSERT_GT(v.failure_reasons_size(), 0);
    EXPECT_NE(v.failure_reasons(0).find("without the sim component"), std::string::npos);
    return;
  }
  EXPECT_NE(v.status(), v1::VERIFICATION_STATUS_NOT_RUN);
  // Ranks 0 to the chosen one (the lower ones are not waited for once one has passed), or
  // both when none passed.
  EXPECT_GE(v.candidates_verified(), v.returned_candidate_rank() + 1);
  EXPECT_LE(v.candidates_verified(), 2u);
  EXPECT_LT(v.returned_candidate_rank(), 2u);
  EXPECT_GT(v.simulated().takeoff().t_s(), 0.0);  // measured in the simulation
  EXPECT_GT(v.max_envelope_ratio(), 0.0);
  EXPECT_GT(a.response.stats().verify_ms(), 0.0);
  // Predicted by the planar model, measured in the simulation: both reported.
  EXPECT_GT(a.response.predicted().takeoff().t_s(), 0.0);
  EXPECT_GT(a.response.predicted().apex().com_z_m(), 0.0);
  if (v.status() == v1::VERIFICATION_STATUS_FAILED) {
    EXPECT_GT(v.failure_reasons_size(), 0);
  }
  // The verified plan is cached with its verification summary.
  const auto hit = plan(c, r, 60s);
  ASSERT_TRUE(hit.ok());
  EXPECT_EQ(hit.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  EXPECT_EQ(hit.response.verification().status(), v.status());
  EXPECT_EQ(hit.response.verification().candidates_verified(), v.candidates_verified());
}

}  // namespace
}  // namespace wj::server
