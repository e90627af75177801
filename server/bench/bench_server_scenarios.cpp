// bench_server, parts 2-4: cold plans with verification and deadlines, kill -9 during cache
// writes, resident memory with many cached entries, and the Redis lookups
// (bench_server_common.h).
#include "bench_server_common.h"

#include <fcntl.h>
#include <google/protobuf/arena.h>
#include <grpcpp/grpcpp.h>
#include <malloc.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <iostream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include "planner/jump_model.h"
#include "planner/jump_planner.h"
#include "planner_client/compact_knots.h"
#include "planner_client/planner_client.h"
#include "server/cached_solution.h"
#include "server/config.h"
#include "server/hot_responses.h"
#include "server/plan_types.h"
#include "server/redis_store.h"
#include "server/request_validation.h"
#include "server/response_conversion.h"
#include "server/solution_cache.h"
#include "server/solution_store.h"
#include "wheeljump/planner/v1/jump_planner.grpc.pb.h"

namespace wj::server_bench {

using namespace std::chrono_literals;

// --- 2. cold plans with verification -------------------------------------------------------
json benchCold(const std::filesystem::path& dir, int plans, std::chrono::milliseconds deadline,
               const std::string& name, bool verification, bool sagittal) {
  auto config = baseConfig(dir);
  config.cache.path.clear();  // every request cold
  config.deadlines.max_s = 120.0;
  config.verification.enabled = verification;
  config.verification.sagittal_model = sagittal;
  Server server(config, dir, name);
  wj::client::ClientOptions o;
  o.target = server.target();
  wj::client::PlannerClient c(o);
  std::vector<double> ms, verify_ms, de_ms, polish_ms, server_ms;
  int ok = 0, feasible = 0, passed = 0, verified = 0;
  std::map<std::string, int> errors;
  for (int i = 0; i < plans; ++i) {
    // A different target height per request: no neighbour can warm-start it.
    const auto t0 = Clock::now();
    const auto r = c.planJump(standing(0.0, 0.40 + 0.015 * i), deadline).get();
    ms.push_back(msSince(t0));
    if (!r.ok()) {
      ++errors[grpc::Status(r.status).error_message().substr(0, 60) + " (" +
               std::to_string(static_cast<int>(r.status.error_code())) + ")"];
      continue;
    }
    ++ok;
    feasible += r.response.feasibility().feasible() ? 1 : 0;
    const auto status = r.response.verification().status();
    verified += status != v1::VERIFICATION_STATUS_NOT_RUN ? 1 : 0;
    passed += status == v1::VERIFICATION_STATUS_PASSED ? 1 : 0;
    verify_ms.push_back(r.response.stats().verify_ms());
    de_ms.push_back(r.response.stats().de_ms());
    polish_ms.push_back(r.response.stats().polish_ms());
    server_ms.push_back(r.response.stats().total_ms());
  }
  json j = latencyJson(ms);
  j["deadline_ms"] = deadline.count();
  j["verification_enabled"] = verification;
  j["sagittal_model"] = sagittal;
  j["answered"] = ok;
  j["feasible"] = feasible;
  j["verified"] = verified;
  j["verification_passed"] = passed;
  j["de_p50_ms"] = percentile(de_ms, 0.5);
  j["verify_p50_ms"] = percentile(verify_ms, 0.5);
  j["polish_p50_ms"] = percentile(polish_ms, 0.5);
  j["server_total_p50_ms"] = percentile(server_ms, 0.5);
  j["per_request_ms"] = {{"total", ms},
                         {"de", de_ms},
                         {"polish", polish_ms},
                         {"verify", verify_ms},
                         {"server_total", server_ms}};
  j["errors"] = errors;
  j["target_p50_ms"] = 150.0;
  j["meets_p50_target"] = percentile(ms, 0.5) <= 150.0 && ok == plans;
  return j;
}

// --- 3. kill -9 during cache writes --------------------------------------------------------
json benchKill(const std::filesystem::path& dir, int rounds, std::uint32_t seed) {
  auto config = baseConfig(dir);
  config.planner.settings_file = writeFastPlannerSettings(dir).string();
  config.verification.enabled = false;
  std::mt19937 rng(seed);
  std::set<long> committed;  // v0 in mm/s of every grid point reported done before a kill
  std::vector<int> per_round;
  for (int round = 0; round < rounds; ++round) {
    Server server(config, dir, "kill");
    wj::client::ClientOptions o;
    o.target = server.target();
    o.max_attempts = 1;
    std::mutex mu;
    int received = 0;
    {
      wj::client::PlannerClient c(o);
      v1::WarmCacheRequest w;
      *w.mutable_task() = standing(0.0, 0.8).task();
      // Disjoint grids per round, in 0.05 m/s steps over [-1, 3.4] (3.4 m/s: the default
      // robot's wheels' reach, planner::maxRunUpSpeed).
      const double lo = -1.0 + 0.05 * ((round * 13) % 88);
      w.set_v0_min_m_s(lo);
      w.set_v0_max_m_s(std::min(3.4, lo + 1.0));
      w.set_v0_step_m_s(0.05);
      std::promise<void> done;
      c.warmCache(
          w,
          [&](const v1::WarmCacheProgress& p) {
            std::lock_guard lock(mu);
            committed.insert(std::lround(p.v0_m_s() * 1000));
            ++received;
          },
          [&](wj::client::WarmResult) { done.set_value(); }, 120s);
      std::this_thread::sleep_for(std::chrono::milliseconds(300 + rng() % 1200));
      server.kill(SIGKILL);
      done.get_future().wait();
    }
    per_round.push_back(received);
  }
  // Restart once more: every committed point must be a hit.
  Server server(config, dir, "kill");
  wj::client::ClientOptions o;
  o.target = server.target();
  wj::client::PlannerClient c(o);
  int lost = 0;
  for (const long mm : committed) {
    const auto r = c.planJump(standing(static_cast<double>(mm) / 1000.0, 0.8), 30s).get();
    if (!r.ok() || r.response.source() != v1::PLAN_SOURCE_CACHE_HIT) ++lost;
  }
  server.kill(SIGTERM);
  wj::server::SolutionStore store(config.cache.path, true, 100000000);
  std::int64_t rows = 0;
  store.forEachNewest(100000000, [&](const auto&, const auto&) { ++rows; });
  return {{"rounds", rounds},
          {"committed_entries", committed.size()},
          {"committed_per_round", per_round},
          {"lost", lost},
          {"corrupted_rows", store.counters().corrupt_rows},
          {"rows_after", rows},
          {"database_recreated", store.counters().recreated},
          {"meets_target", lost == 0 && store.counters().corrupt_rows == 0}};
}

// --- 4. memory with N cached entries -------------------------------------------------------
json benchMemory(const std::filesystem::path& dir, int entries) {
  auto empty_config = baseConfig(dir);
  empty_config.cache.path.clear();
  empty_config.verification.enabled = false;
  double empty_rss = 0.0;
  {
    Server server(empty_config, dir, "mem-empty");
    std::this_thread::sleep_for(500ms);
    empty_rss = server.rssMb();
  }
  const auto path = dir / "memory.sqlite";
  {
    wj::server::SolutionStore store(path, false, 100000000);
    std::vector<std::pair<wj::server::CacheKey, wj::server::CachedSolution>> batch;
    for (int i = 0; i < entries; ++i) {
      wj::server::CacheKey k;
      k.v0_bin = i % 100 - 20;
      k.target_height_bin = i / 100;
      k.seed = 1;
      wj::server::CachedSolution s;
      for (std::size_t d = 0; d < s.u.size(); ++d) s.u[d] = 0.01 * static_cast<double>(d + i % 7);
      s.t1 = 0.3;
      s.t2 = 0.3;
      s.t3 = 0.9;
      s.verification.status = wj::server::VerificationStatus::Passed;
      batch.emplace_back(k, s);
      if (batch.size() == 10000) {
        store.putMany(batch);
        batch.clear();
      }
    }
    if (!batch.empty()) store.putMany(batch);
  }
  auto config = empty_config;
  config.cache.path = path.string();
  config.cache.max_memory_entries = entries;
  Server server(config, dir, "mem-full");
  wj::client::ClientOptions o;
  o.target = server.target();
  wj::client::PlannerClient c(o);
  const auto stats = c.getStats(10s).get();
  std::this_thread::sleep_for(500ms);
  const double rss = server.rssMb();
  return {{"entries_loaded", stats.response.cache_entries()},
          {"rss_mb", rss},
          {"rss_empty_mb", empty_rss},
          {"bytes_per_entry", (rss - empty_rss) * 1024.0 * 1024.0 / entries},
          {"target_rss_mb", 300.0},
          {"meets_target",
           rss <= 300.0 && stats.response.cache_entries() == static_cast<std::uint64_t>(entries)}};
}

// The second-level lookups against a running Redis at `host:port`, in process: a memory hit of
// the LRU, a Redis hit, a Redis miss, a put (WATCH/GET/MULTI/SET/EXEC), and a get during an
// outage (a closed port: the backoff answers without touching the network).
json benchRedis(const std::string& address, int ops) {
  using namespace wj::server;
  RedisConfig rc;
  rc.host = address.substr(0, address.rfind(':'));
  rc.port = std::stoi(address.substr(address.rfind(':') + 1));
  rc.key_prefix = "wj-bench-" + std::to_string(::getpid());
  rc.ttl_s = 600;  // the benchmark's keys expire on their own
  CachedSolution s;
  for (std::size_t i = 0; i < s.u.size(); ++i) s.u[i] = 0.1 * static_cast<double>(i);
  s.t1 = s.t2 = 0.3;
  s.t3 = 0.9;
  s.feasible = true;
  s.verification.status = VerificationStatus::Passed;
  const int keys = 1000;
  const auto key = [](int i) {
    CacheKey k;
    k.v0_bin = i;
    k.seed = 1;
    return k;
  };
  RedisStore store(rc);
  SolutionCache memory(keys, nullptr);
  std::vector<double> put_ms, redis_hit_ms, redis_miss_ms, memory_hit_ms, outage_ms;
  for (int i = 0; i < keys; ++i) {
    const auto t0 = Clock::now();
    store.put(key(i), s);
    put_ms.push_back(msSince(t0));
    memory.put(key(i), s);
  }
  for (int i = 0; i < ops; ++i) {
    auto t0 = Clock::now();
    if (!store.get(key(i % keys))) throw std::runtime_error("redis bench: a stored key missed");
    redis_hit_ms.push_back(msSince(t0));
    t0 = Clock::now();
    (void)store.get(key(keys + i));
    redis_miss_ms.push_back(msSince(t0));
    t0 = Clock::now();
    if (!memory.find(key(i % keys))) throw std::runtime_error("redis bench: memory missed");
    memory_hit_ms.push_back(msSince(t0));
  }
  RedisConfig down = rc;
  down.port = 1;  // nothing listens there
  RedisStore unreachable(down);
  for (int i = 0; i < ops; ++i) {
    const auto t0 = Clock::now();
    (void)unreachable.get(key(i % keys));
    outage_ms.push_back(msSince(t0));
  }
  const auto c = store.counters();
  return {{"redis", address},
          {"value_bytes", encodeRedisValue(key(0), s).size()},
          {"memory_hit", latencyJson(memory_hit_ms)},
          {"redis_hit", latencyJson(redis_hit_ms)},
          {"redis_miss", latencyJson(redis_miss_ms)},
          {"redis_put", latencyJson(put_ms)},
          {"outage_get", latencyJson(outage_ms)},
          {"read_errors", c.read_errors},
          {"outage_read_errors", unreachable.counters().read_errors}};
}

}  // namespace wj::server_bench
