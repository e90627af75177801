// bench_server: end-to-end figures of planner_server on loopback, in one run, printed as JSON.
//   1. cache hits: round-trip percentiles with N concurrent clients (own connections) and the
//      hit throughput, the CPU time per hit of the server and of the clients, the response
//      size; every request carries a different robot state inside its client's cache bin, as a
//      robot's do, so that no answer can be a replay of an earlier one ("cache_hits", with
//      cache.hot_responses_mb = --hot-responses-mb, 0 by default as in the service); then the
//      same with the hot tier of 64 MB, whose later hits of a bin are the bin's first answer by
//      design ("cache_hits_hot_tier", unless --no-hot-tier); and ("hit_breakdown")
//      the stages of one hit timed one by one on one thread, and (hot_*) a hot hit's own work
//      in the service, the way of session 11 (copy and serialize) against the ready bytes;
//   2. cold plans with verification: latency percentiles with the default planner settings and
//      a generous deadline, and what a 150 ms deadline gets (with and without verification);
//   3. durability: repeated kill -9 during cache writes (WarmCache), then every committed entry
//      must be served from the cache and no row may be corrupted;
//   4. resident memory of a server holding 100,000 cached entries (and of an empty one).
// Every server is a real planner_server process started here with its own configuration.
// The parts are in bench_server_hits.cpp and bench_server_scenarios.cpp, what they share in
// bench_server_common.h; here: the options, the parts asked for, the report.
#include <malloc.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>

#include "bench_server_common.h"

using namespace wj::server_bench;
using namespace std::chrono_literals;

int main(int argc, char** argv) {
  CLI::App app{"End-to-end benchmark of planner_server on loopback; prints JSON."};
  int clients = 8, cold_plans = 10, kill_rounds = 10, entries = 100000;
  double hit_seconds = 5.0;
  std::uint32_t seed = 1;
  std::string only;
  app.add_option("--clients", clients, "concurrent clients of the hit benchmark")
      ->capture_default_str();
  app.add_option("--hit-seconds", hit_seconds, "duration of the hit benchmark")
      ->capture_default_str();
  app.add_option("--hit-rounds", g_hit_rounds,
                 "rounds of the hit benchmark: its four loops alternate this many times, "
                 "each for hit-seconds / hit-rounds")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  app.add_option("--cold-plans", cold_plans, "cold plans per deadline")->capture_default_str();
  app.add_option("--kill-rounds", kill_rounds, "kill -9 restarts")->capture_default_str();
  app.add_option("--entries", entries, "cached entries for the memory figure")
      ->capture_default_str();
  app.add_option("--output-dt-s", g_output_dt_s,
                 "planner.output_dt_s of the servers (0: the planner's own, 1 ms); the default is "
                 "config/planner_server.yaml's")
      ->capture_default_str();
  app.add_option("--hot-responses-mb", g_hot_responses_mb,
                 "cache.hot_responses_mb of the hit benchmark's server: > 0 answers a hit after "
                 "the first of its bin with the bin's ready response (docs/service.md, Hot tier)")
      ->capture_default_str();
  app.add_flag("!--no-other-hit-path,!--no-hot-tier", g_both_hit_paths,
               "do not also measure the other hit path in the same run (cache_hits_regenerated, "
               "or cache_hits_hot_tier with --hot-responses-mb 0)");
  std::string format = "compact_knots";
  app.add_option("--format", format,
                 "trajectory format of the requests: compact_knots (the robot client's) | knots | "
                 "dense")
      ->check(CLI::IsMember({"compact_knots", "knots", "dense"}))
      ->capture_default_str();
  int breakdown_iterations = 300;
  app.add_option("--breakdown-iterations", breakdown_iterations,
                 "requests of the single-thread breakdown of a hit")
      ->capture_default_str();
  app.add_option("--seed", seed, "seed of the kill instants")->capture_default_str();
  app.add_option("--only", only,
                 "run one part: hits (with breakdown), breakdown, cold, kill, memory, redis");
  std::string redis;
  int redis_ops = 5000;
  app.add_option("--redis", redis,
                 "host:port of a running Redis: also measure the shared-cache lookups (part "
                 "'redis'; its keys are written under a per-run prefix and expire after 10 min)");
  app.add_option("--redis-ops", redis_ops, "lookups per figure of the redis part")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  g_format = format == "dense"   ? v1::TRAJECTORY_FORMAT_DENSE
             : format == "knots" ? v1::TRAJECTORY_FORMAT_KNOTS
                                 : v1::TRAJECTORY_FORMAT_COMPACT_KNOTS;
  ::signal(SIGPIPE, SIG_IGN);
  // The clients' side keeps its freed memory as planner_server does (see its main): without
  // it, parsing each 0.2-0.3 MB response faults its buffers in again.
  ::mallopt(M_MMAP_THRESHOLD, 4 * 1024 * 1024);
  ::mallopt(M_TRIM_THRESHOLD, 64 * 1024 * 1024);

  std::string pattern =
      (std::filesystem::temp_directory_path() / "wj-bench-server-XXXXXX").string();
  if (!::mkdtemp(pattern.data())) return 1;
  const std::filesystem::path dir = pattern;
  json out;
  out["machine"] = {{"hardware_threads", std::thread::hardware_concurrency()}};
  out["trajectory_format"] = format;
  try {
    if (only.empty() || only == "hits") {
      out["cache_hits"] = benchHits(dir, clients, hit_seconds, g_hot_responses_mb);
      // Both paths in one run: the configured one and the other, each against the empty RPC
      // measured on its own server.
      if (g_both_hit_paths) {
        if (g_hot_responses_mb == 0.0)
          out["cache_hits_hot_tier"] = benchHits(dir, clients, hit_seconds, 64.0);
        else
          out["cache_hits_regenerated"] = benchHits(dir, clients, hit_seconds, 0.0);
      }
    }
    if (only.empty() || only == "hits" || only == "breakdown")
      out["hit_breakdown"] = benchHitBreakdown(dir, breakdown_iterations);
    if (only.empty() || only == "cold") {
      out["cold_plan_with_verification"] = benchCold(dir, cold_plans, 60s, "cold");
      out["cold_plan_with_verification_full_model"] =
          benchCold(dir, cold_plans, 60s, "coldfull", true, false);
      out["cold_plan_150ms_deadline"] = benchCold(dir, cold_plans, 150ms, "cold150");
      out["cold_plan_150ms_deadline_no_verification"] =
          benchCold(dir, cold_plans, 150ms, "cold150nv", false);
    }
    if (only.empty() || only == "kill") out["kill9_durability"] = benchKill(dir, kill_rounds, seed);
    if (only.empty() || only == "memory") out["memory"] = benchMemory(dir, entries);
    if (!redis.empty() && (only.empty() || only == "redis"))
      out["shared_cache"] = benchRedis(redis, redis_ops);
  } catch (const std::exception& e) {
    out["error"] = e.what();
    std::cout << out.dump(2) << std::endl;
    std::filesystem::remove_all(dir);
    return 1;
  }
  std::cout << out.dump(2) << std::endl;
  std::filesystem::remove_all(dir);
  return 0;
}
