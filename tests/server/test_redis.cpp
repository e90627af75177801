// The shared Redis cache (cache.backend: redis): configuration, the store against a real
// redis-server on a free loopback port (values with checksums, the better solution kept, an
// outage answered as misses, reconnection, preload), two planner_server replicas sharing one
// Redis (a plan computed by one is a hit on the other; Redis killed and restarted mid-test; a
// corrupt value refused), and the client's round-robin over two replicas behind one target.
// Skipped only when redis-server is absent (CI installs it with deploy/install-deps.sh).
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <future>
#include <sstream>
#include <thread>

#include "error_of.h"
#include "planner_client/planner_client.h"
#include "redis_test_util.h"
#include "server/redis_store.h"
#include "server/solution_cache.h"
#include "server_test_util.h"

namespace wj::server {
namespace {

using namespace std::chrono_literals;
namespace v1 = wheeljump::planner::v1;
using test::RedisProcess;
using test::ServerProcess;
using test::standingRequest;
using test::TempDir;

std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string errorOf(const std::string& yaml) {
  return wj::test::errorOf([&] { return ServerConfig::fromYamlString(yaml, "test"); });
}

ServerConfig redisConfig(int port, const std::string& prefix) {
  ServerConfig c;
  c.cache.backend = CacheBackend::Redis;
  c.cache.path = "";
  c.cache.redis.host = "127.0.0.1";
  c.cache.redis.port = port;
  c.cache.redis.key_prefix = prefix;
  c.cache.redis.connect_timeout_ms = 200;
  c.cache.redis.command_timeout_ms = 200;
  c.cache.redis.reconnect_min_ms = 50;
  c.cache.redis.reconnect_max_ms = 400;
  return c;
}

// ---------------------------------------------------------------------------------------------
TEST(RedisConfig, BackendIsOptInAndTheSampleStaysSqlite) {
  const auto sample = ServerConfig::fromYamlFile(WJ_CONFIG_DIR "/planner_server.yaml");
  EXPECT_EQ(sample.cache.backend, CacheBackend::Sqlite);
  // A configuration written before the shared cache (no backend, no redis section) still reads.
  std::string old = readFile(WJ_CONFIG_DIR "/planner_server.yaml");
  const auto from = old.find("  redis:");
  const auto to = old.find("warm_cache:");
  ASSERT_NE(from, std::string::npos);
  old.erase(from, to - from);
  old.erase(old.find("  backend: "), old.find("  path: ") - old.find("  backend: "));
  const auto legacy = ServerConfig::fromYamlString(old, "legacy");
  EXPECT_EQ(legacy.cache.backend, CacheBackend::Sqlite);
  EXPECT_EQ(legacy.cache.path, sample.cache.path);
}

TEST(RedisConfig, RedisKeysRoundTripAndAreStrict) {
  ServerConfig c = redisConfig(6390, "fleet");
  c.cache.redis.db = 3;
  c.cache.redis.ttl_s = 86400;
  c.cache.redis.preload_entries = 7;
  const std::string yaml = c.toYaml();
  const auto back = ServerConfig::fromYamlString(yaml, "roundtrip");
  EXPECT_EQ(back.cache.backend, CacheBackend::Redis);
  EXPECT_EQ(back.cache.redis.port, 6390);
  EXPECT_EQ(back.cache.redis.db, 3);
  EXPECT_EQ(back.cache.redis.key_prefix, "fleet");
  EXPECT_EQ(back.cache.redis.ttl_s, 86400);
  EXPECT_EQ(back.cache.redis.preload_entries, 7);
  EXPECT_EQ(back.cache.redis.reconnect_max_ms, 400);
  EXPECT_EQ(back.toYaml(), yaml);

  const auto replaced = [&](const std::string& from, const std::string& to) {
    std::string y = yaml;
    const auto at = y.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return y.replace(at, from.size(), to);
  };
  EXPECT_THAT(errorOf(replaced("    db: 3\n", "    db: 3\n    bogus: 1\n")),
              wj::test::HasSubstr("unknown key 'cache.redis.bogus'"));
  EXPECT_THAT(errorOf(replaced("    db: 3\n", "")),
              wj::test::HasSubstr("missing key 'cache.redis.db'"));
  EXPECT_THAT(errorOf(replaced("  backend: redis", "  backend: memcached")),
              wj::test::HasSubstr("'memcached' is not one of sqlite, redis"));
  const std::string port = errorOf(replaced("    port: 6390", "    port: 0"));
  EXPECT_THAT(port, wj::test::HasSubstr("cache.redis.port must be in [1, 65535]")) << port;
  EXPECT_THAT(errorOf(replaced("    db: 3", "    db: 16")),
              wj::test::HasSubstr("cache.redis.db must be in [0, 15]"));
  EXPECT_THAT(errorOf(replaced("    command_timeout_ms: 200", "    command_timeout_ms: 0")),
              wj::test::HasSubstr("cache.redis.command_timeout_ms"));
  EXPECT_THAT(
      errorOf(replaced("    reconnect_max_ms: 400", "    reconnect_max_ms: 10")),
      wj::test::HasSubstr("cache.redis.reconnect_max_ms must be in [cache.redis.reconnect_min_ms"));
  EXPECT_THAT(errorOf(replaced("  path: \"\"", "  path: \"/tmp/x.sqlite\"")),
              wj::test::HasSubstr("cache.path must be \"\" with cache.backend redis"));
  // backend redis needs its section.
  std::string no_section = yaml;
  no_section.erase(no_section.find("  redis:\n"),
                   no_section.find("warm_cache:") - no_section.find("  redis:\n"));
  EXPECT_THAT(errorOf(no_section), wj::test::HasSubstr("missing key 'cache.redis'"));
}

// ---------------------------------------------------------------------------------------------
CachedSolution sampleSolution(double value, VerificationStatus status, double cost) {
  CachedSolution s;
  for (std::size_t i = 0; i < s.u.size(); ++i) s.u[i] = value + 0.01 * static_cast<double>(i);
  s.t1 = 0.3;
  s.t2 = 0.3;
  s.t3 = 0.9;
  s.feasible = true;
  s.constraints_ok = true;
  s.de_complete = true;
  s.final_cost = cost;
  s.verification.status = status;
  s.created_unix_ms = 1000 + static_cast<std::int64_t>(value * 10);
  return s;
}

CacheKey sampleKey(std::int32_t v0_bin) {
  CacheKey k;
  k.v0_bin = v0_bin;
  k.target_height_bin = 160;
  k.seed = 7;
  k.model_hash = 11;
  k.settings_hash = 22;
  return k;
}

class RedisStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto bin = test::findRedisServer();
    if (!bin)
      GTEST_SKIP() << "redis-server not found (PATH or WJ_REDIS_SERVER); install it with "
                      "deploy/install-deps.sh (Debian package redis-server)";
    dir_ = std::make_unique<TempDir>("wj-redis");
    redis_ = std::make_unique<RedisProcess>(*bin, dir_->path(), test::freeLoopbackPort());
    config_ = redisConfig(redis_->port(), "wjtest").cache.redis;
  }
  std::unique_ptr<TempDir> dir_;
  std::unique_ptr<RedisProcess> redis_;
  RedisConfig config_;
};

TEST_F(RedisStoreTest, ValuesRoundTripUnderANamespacedKey) {
  RedisStore store(config_);
  const CacheKey key = sampleKey(20);
  const CachedSolution s = sampleSolution(1.0, VerificationStatus::Passed, 2.0);
  EXPECT_FALSE(store.get(key));
  store.put(key, s);
  const auto back = store.get(key);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->u, s.u);
  EXPECT_EQ(back->final_cost, 2.0);
  const std::string rkey = "wjtest:plan:v1:" + key.hex();
  EXPECT_EQ(redisKeyOf("wjtest", key), rkey);
  EXPECT_EQ(redis_->command({"EXISTS", rkey}), "1");
  EXPECT_EQ(redis_->command({"TTL", rkey}), "-1");  // ttl_s 0: no expiry
  // Another prefix is another namespace.
  RedisConfig other = config_;
  other.key_prefix = "other";
  other.ttl_s = 60;
  RedisStore second(other);
  EXPECT_FALSE(second.get(key));
  second.put(key, s);
  const int ttl = std::stoi(redis_->command({"TTL", redisKeyOf("other", key)}));
  EXPECT_GT(ttl, 50);
  EXPECT_LE(ttl, 60);
  const auto c = store.counters();
  EXPECT_EQ(c.writes, 1);
  EXPECT_EQ(c.read_errors, 0);
  EXPECT_TRUE(c.available);
  EXPECT_EQ(store.backend(), "redis");
}

TEST_F(RedisStoreTest, ACorruptValueIsRefusedCountedAndReplaced) {
  RedisStore store(config_);
  const CacheKey key = sampleKey(21);
  store.put(key, sampleSolution(1.0, VerificationStatus::Passed, 2.0));
  const std::string rkey = redisKeyOf("wjtest", key);
  // One payload byte flipped behind the store's back.
  const std::string length = redis_->command({"STRLEN", rkey});
  const std::string was = redis_->command({"GETRANGE", rkey, "30", "30"});
  ASSERT_EQ(redis_->command({"SETRANGE", rkey, "30", was == "Z" ? "Y" : "Z"}), length);
  EXPECT_FALSE(store.get(key));
  EXPECT_EQ(store.counters().corrupt_rows, 1);
  // A value stored under another key (a copy) fails its checksum too: the key is covered.
  const CacheKey other = sampleKey(22);
  store.put(other, sampleSolution(3.0, VerificationStatus::Passed, 2.0));
  ASSERT_EQ(redis_->command({"COPY", redisKeyOf("wjtest", other), rkey, "REPLACE"}), "1");
  EXPECT_FALSE(store.get(key));
  EXPECT_EQ(store.counters().corrupt_rows, 2);
  // Garbage of any length is refused, never thrown.
  ASSERT_EQ(redis_->command({"SET", rkey, "xy"}), "OK");
  EXPECT_FALSE(store.get(key));
  EXPECT_EQ(store.counters().corrupt_rows, 3);
  // The next put replaces it even though nothing better is known.
  store.put(key, sampleSolution(1.0, VerificationStatus::NotRun, 9.0));
  ASSERT_TRUE(store.get(key));
}

TEST_F(RedisStoreTest, APutKeepsTheBetterSolutionAcrossReplicas) {
  RedisStore a(config_), b(config_);
  const CacheKey key = sampleKey(23);
  a.put(key, sampleSolution(1.0, VerificationStatus::Passed, 2.0));
  // An unverified, costlier solution from another replica does not replace it.
  b.put(key, sampleSolution(5.0, VerificationStatus::NotRun, 1.0));
  EXPECT_EQ(b.counters().writes_skipped, 1);
  EXPECT_EQ(b.counters().writes, 0);
  EXPECT_DOUBLE_EQ(a.get(key)->u[0], 1.0);
  // A verified, cheaper one does.
  b.put(key, sampleSolution(6.0, VerificationStatus::Passed, 1.0));
  EXPECT_EQ(b.counters().writes, 1);
  EXPECT_DOUBLE_EQ(a.get(key)->u[0], 6.0);
}

TEST_F(RedisStoreTest, AnOutageIsAMissThenTheStoreReconnects) {
  RedisStore store(config_);
  const CacheKey key = sampleKey(24);
  store.put(key, sampleSolution(1.0, VerificationStatus::Passed, 2.0));
  redis_->kill();
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(store.get(key));  // the connection is gone: a miss, not an exception
  const auto first = std::chrono::steady_clock::now() - t0;
  EXPECT_LT(first,
            2 * std::chrono::milliseconds(config_.connect_timeout_ms + config_.command_timeout_ms));
  EXPECT_THROW(store.put(sampleKey(25), sampleSolution(2.0, VerificationStatus::Passed, 1.0)),
               std::runtime_error);
  // Inside the backoff, calls fail at once without touching the network.
  const auto t1 = std::chrono::steady_clock::now();
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(store.get(key));
  EXPECT_LT(std::chrono::steady_clock::now() - t1, 100ms);
  auto c = store.counters();
  EXPECT_GE(c.read_errors, 101);
  EXPECT_EQ(c.write_errors, 1);
  EXPECT_FALSE(c.available);

  redis_->restart();  // empty: nothing was persisted
  std::this_thread::sleep_for(std::chrono::milliseconds(config_.reconnect_max_ms + 50));
  EXPECT_FALSE(store.get(key));
  store.put(key, sampleSolution(3.0, VerificationStatus::Passed, 2.0));
  ASSERT_TRUE(store.get(key));
  c = store.counters();
  EXPECT_GE(c.reconnects, 1);
  EXPECT_TRUE(c.available);
  EXPECT_EQ(c.writes, 2);
}

TEST_F(RedisStoreTest, AnUnreachableRedisAtStartIsNotAnError) {
  RedisConfig nowhere = config_;
  nowhere.port = test::freeLoopbackPort();
  RedisStore store(nowhere);
  EXPECT_FALSE(store.counters().available);
  EXPECT_FALSE(store.get(sampleKey(1)));
  SolutionCache cache(10, std::make_unique<RedisStore>(nowhere));
  EXPECT_EQ(cache.counters().entries, 0);
  EXPECT_THROW(cache.put(sampleKey(1), sampleSolution(1.0, VerificationStatus::Passed, 1.0)),
               std::runtime_error);
  // The failed write kept the solution in memory.
  EXPECT_TRUE(cache.find(sampleKey(1)));
  EXPECT_EQ(cache.counters().store.write_errors, 1);
  EXPECT_EQ(cache.counters().backend, "redis");
}

TEST_F(RedisStoreTest, AReplicaPreloadsTheNewestSharedEntries) {
  {
    RedisStore writer(config_);
    for (int i = 0; i < 5; ++i)
      writer.put(sampleKey(30 + i), sampleSolution(i, VerificationStatus::Passed, 1.0));
  }
  redis_->command({"SET", "wjtest:plan:v1:zz", "not a key"});
  RedisConfig preload = config_;
  preload.preload_entries = 3;
  SolutionCache cache(100, std::make_unique<RedisStore>(preload));
  EXPECT_EQ(cache.counters().entries, 3);
  EXPECT_EQ(cache.counters().store.rows_loaded, 3);
  // Newest first (created_unix_ms grows with i).
  EXPECT_TRUE(cache.find(sampleKey(34)));
  EXPECT_TRUE(cache.find(sampleKey(32)));
  EXPECT_FALSE(cache.find(sampleKey(30)));
  // A miss in memory is found in Redis.
  EXPECT_TRUE(cache.findPersisted(sampleKey(30)));
  EXPECT_EQ(cache.counters().persisted_hits, 1);
}

// ---------------------------------------------------------------------------------------------
// Two planner_server replicas against one Redis.

client::PlanResult plan(client::PlannerClient& c, const v1::PlanJumpRequest& r) {
  auto f = c.planJump(r, 20s);
  EXPECT_EQ(f.wait_for(30s), std::future_status::ready);
  return f.get();
}

v1::GetStatsResponse stats(client::PlannerClient& c) {
  const auto r = c.getStats(5s).get();
  EXPECT_TRUE(r.ok()) << r.status.error_message();
  return r.response;
}

client::ClientOptions clientFor(const std::string& target) {
  client::ClientOptions o;
  o.target = target;
  o.initial_backoff = 100ms;
  return o;
}

// Planned here (from scratch or warm-started from a cached neighbouring speed), not served.
bool plannedLocally(const v1::PlanJumpResponse& r) {
  return r.source() == v1::PLAN_SOURCE_CACHE_MISS || r.source() == v1::PLAN_SOURCE_WARM_START;
}

void expectSamePlan(const v1::PlanJumpResponse& a, const v1::PlanJumpResponse& b) {
  EXPECT_EQ(a.stats().cache_key(), b.stats().cache_key());
  ASSERT_EQ(a.plan().decision_vector_size(), b.plan().decision_vector_size());
  for (int i = 0; i < a.plan().decision_vector_size(); ++i)
    EXPECT_EQ(a.plan().decision_vector(i), b.plan().decision_vector(i)) << i;
  EXPECT_EQ(a.plan().phase_times().t3_s(), b.plan().phase_times().t3_s());
  EXPECT_EQ(a.plan().joints().num_samples(), b.plan().joints().num_samples());
  ASSERT_EQ(a.plan().joints().positions_rad_size(), b.plan().joints().positions_rad_size());
  for (int i = 0; i < a.plan().joints().positions_rad_size(); i += 97)
    EXPECT_EQ(a.plan().joints().positions_rad(i), b.plan().joints().positions_rad(i)) << i;
  EXPECT_EQ(a.feasibility().feasible(), b.feasibility().feasible());
}

class SharedCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto bin = test::findRedisServer();
    if (!bin)
      GTEST_SKIP() << "redis-server not found (PATH or WJ_REDIS_SERVER); install it with "
                      "deploy/install-deps.sh (Debian package redis-server)";
    dir_ = std::make_unique<TempDir>("wj-shared");
    redis_ = std::make_unique<RedisProcess>(*bin, dir_->path(), test::freeLoopbackPort());
    a_ = std::make_unique<ServerProcess>(replicaConfig(), dir_->path() / "a.yaml");
    b_ = std::make_unique<ServerProcess>(replicaConfig(), dir_->path() / "b.yaml");
    ca_ = std::make_unique<client::PlannerClient>(clientFor(a_->target()));
    cb_ = std::make_unique<client::PlannerClient>(clientFor(b_->target()));
  }
  ServerConfig replicaConfig() const {
    ServerConfig c = test::testConfig(dir_->path());
    const ServerConfig r = redisConfig(redis_->port(), "wjit");
    c.cache.backend = r.cache.backend;
    c.cache.path = "";
    c.cache.redis = r.cache.redis;
    return c;
  }
  std::unique_ptr<TempDir> dir_;
  std::unique_ptr<RedisProcess> redis_;
  std::unique_ptr<ServerProcess> a_, b_;
  std::unique_ptr<client::PlannerClient> ca_, cb_;
};

TEST_F(SharedCacheTest, APlanComputedByOneReplicaIsAHitOnTheOther) {
  const auto miss = plan(*ca_, standingRequest(1.0));
  ASSERT_TRUE(miss.ok()) << miss.status.error_message();
  EXPECT_EQ(miss.response.source(), v1::PLAN_SOURCE_CACHE_MISS);
  const auto hit = plan(*cb_, standingRequest(1.0));
  ASSERT_TRUE(hit.ok()) << hit.status.error_message();
  EXPECT_EQ(hit.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  expectSamePlan(miss.response, hit.response);
  const auto sa = stats(*ca_), sb = stats(*cb_);
  EXPECT_EQ(sa.store().backend(), "redis");
  EXPECT_TRUE(sa.store().available());
  EXPECT_EQ(sa.store().writes(), 1u);
  EXPECT_EQ(sa.cache_misses(), 1u);
  EXPECT_EQ(sb.cache_misses(), 0u);
  EXPECT_EQ(sb.cache_hits(), 1u);
  EXPECT_EQ(sb.store().hits(), 1u);
  EXPECT_EQ(sb.store().writes(), 0u);
  EXPECT_EQ(sb.store().read_errors(), 0u);
  // The entry is in memory on B now: the next call there does not ask Redis.
  const auto again = plan(*cb_, standingRequest(1.0));
  EXPECT_EQ(again.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  EXPECT_EQ(stats(*cb_).store().hits(), 1u);
}

TEST_F(SharedCacheTest, BothReplicasKeepAnsweringThroughARedisOutage) {
  ASSERT_TRUE(plan(*ca_, standingRequest(1.0)).ok());
  ASSERT_EQ(plan(*cb_, standingRequest(1.0)).response.source(), v1::PLAN_SOURCE_CACHE_HIT);

  redis_->kill();
  // Hits in local memory still answer; misses are planned locally.
  for (auto* c : {ca_.get(), cb_.get()}) {
    const auto local = plan(*c, standingRequest(1.0));
    ASSERT_TRUE(local.ok()) << local.status.error_message();
    EXPECT_EQ(local.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  }
  const auto miss_a = plan(*ca_, standingRequest(1.5));
  ASSERT_TRUE(miss_a.ok()) << miss_a.status.error_message();
  EXPECT_TRUE(plannedLocally(miss_a.response)) << miss_a.response.source();
  const auto miss_b = plan(*cb_, standingRequest(1.5));
  ASSERT_TRUE(miss_b.ok()) << miss_b.status.error_message();
  EXPECT_TRUE(plannedLocally(miss_b.response)) << "A's plan is not shared";
  // ... but A keeps its own locally.
  EXPECT_EQ(plan(*ca_, standingRequest(1.5)).response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  for (auto* c : {ca_.get(), cb_.get()}) {
    const auto s = stats(*c);
    EXPECT_FALSE(s.store().available());
    EXPECT_GE(s.store().read_errors(), 1u);
    EXPECT_GE(s.store().write_errors(), 1u);
  }

  redis_->restart();  // empty: nothing was persisted
  // Past the longest backoff (reconnect_max_ms) the next call reconnects.
  std::this_thread::sleep_for(500ms);
  const auto fresh = plan(*ca_, standingRequest(2.0));
  ASSERT_TRUE(fresh.ok()) << fresh.status.error_message();
  EXPECT_TRUE(plannedLocally(fresh.response)) << fresh.response.source();
  const auto shared = plan(*cb_, standingRequest(2.0));
  ASSERT_TRUE(shared.ok()) << shared.status.error_message();
  EXPECT_EQ(shared.response.source(), v1::PLAN_SOURCE_CACHE_HIT);
  expectSamePlan(fresh.response, shared.response);
  const auto sa = stats(*ca_);
  EXPECT_TRUE(sa.store().available());
  EXPECT_GE(sa.store().reconnects(), 1u);
  EXPECT_TRUE(stats(*cb_).store().available());
}

TEST_F(SharedCacheTest, ACorruptValueInRedisIsRefusedAndCounted) {
  const auto first = plan(*ca_, standingRequest(1.2));
  ASSERT_TRUE(first.ok()) << first.status.error_message();
  const std::string rkey = "wjit:plan:v1:" + first.response.stats().cache_key();
  const std::string length = redis_->command({"STRLEN", rkey});
  ASSERT_NE(length, "0") << "A did not write " << rkey;
  const std::string was = redis_->command({"GETRANGE", rkey, "40", "40"});
  ASSERT_EQ(redis_->command({"SETRANGE", rkey, "40", was == "Z" ? "Y" : "Z"}), length);

  const auto refused = plan(*cb_, standingRequest(1.2));
  ASSERT_TRUE(refused.ok()) << refused.status.error_message();
  EXPECT_TRUE(plannedLocally(refused.response)) << "served a corrupt value";
  const auto sb = stats(*cb_);
  EXPECT_EQ(sb.store().corrupt_values(), 1u);
  EXPECT_EQ(sb.store().hits(), 0u);
  // B's own plan replaced the corrupt value: it decodes again.
  std::string key_bytes;
  const std::string hex = first.response.stats().cache_key();
  for (std::size_t i = 0; i + 1 < hex.size(); i += 2)
    key_bytes.push_back(static_cast<char>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  const auto key = CacheKey::fromBytes(key_bytes);
  ASSERT_TRUE(key);
  EXPECT_TRUE(decodeRedisValue(*key, redis_->command({"GET", rkey})));
}

// ---------------------------------------------------------------------------------------------
// Client-side load balancing over two replicas behind one target.

int planRequestsOn(const ServerProcess& server) {
  client::PlannerClient c(clientFor(server.target()));
  return static_cast<int>(stats(c).requests());
}

TEST(RoundRobin, TheClientSpreadsCallsOverTheResolvedReplicas) {
  TempDir dir("wj-rr");
  ServerConfig config = test::testConfig(dir.path());
  config.cache.path = "";
  ServerProcess s1(config, dir / "s1.yaml"), s2(config, dir / "s2.yaml");
  const std::string target =
      "ipv4:127.0.0.1:" + std::to_string(s1.port()) + ",127.0.0.1:" + std::to_string(s2.port());
  constexpr int kCalls = 12;
  {
    client::ClientOptions o = clientFor(target);
    o.load_balancing = client::LoadBalancing::RoundRobin;
    client::PlannerClient c(o);
    for (int i = 0; i < kCalls; ++i) ASSERT_TRUE(plan(c, standingRequest(1.0)).ok());
  }
  const int n1 = planRequestsOn(s1), n2 = planRequestsOn(s2);
  EXPECT_EQ(n1 + n2, kCalls);
  EXPECT_GE(n1, kCalls / 3) << n1 << " vs " << n2;
  EXPECT_GE(n2, kCalls / 3) << n1 << " vs " << n2;
  // The default, pick_first, sends everything to one of them.
  {
    client::PlannerClient c(clientFor(target));
    for (int i = 0; i < kCalls; ++i) ASSERT_TRUE(plan(c, standingRequest(1.0)).ok());
  }
  const int d1 = planRequestsOn(s1) - n1, d2 = planRequestsOn(s2) - n2;
  EXPECT_EQ(d1 + d2, kCalls);
  EXPECT_TRUE(d1 == 0 || d2 == 0) << d1 << " vs " << d2;
}

}  // namespace
}  // namespace wj::server
