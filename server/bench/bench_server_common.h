#pragma once
/// @file What the parts of bench_server share: the planner_server child process, the requests,
/// the response parsed on a reused arena, percentiles, the servers' base configuration and the
/// options that every part reads; and the parts themselves (bench_server_hits.cpp: cache hits
/// and the breakdown of one hit; bench_server_scenarios.cpp: cold plans, kill -9, memory, Redis).
/// bench_server.cpp parses the options, runs the parts asked for and prints the report.
#include <google/protobuf/arena.h>
#include <signal.h>
#include <sys/types.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "server/config.h"
#include "wheeljump/planner/v1/jump_planner.grpc.pb.h"

namespace wj::server_bench {

namespace v1 = wheeljump::planner::v1;
using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

inline double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, rank == 0 ? 0 : rank - 1)];
}

inline json latencyJson(const std::vector<double>& ms) {
  return {{"count", ms.size()},
          {"p50_ms", percentile(ms, 0.50)},
          {"p90_ms", percentile(ms, 0.90)},
          {"p99_ms", percentile(ms, 0.99)},
          {"max_ms", percentile(ms, 1.0)}};
}

// A planner_server child process.
class Server {
 public:
  Server(const wj::server::ServerConfig& config, const std::filesystem::path& dir,
         const std::string& name);
  ~Server() { kill(SIGKILL); }
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  const std::string& target() const { return target_; }
  /// Sends `signal` and waits for the exit; returns the exit code (128 + signal if killed).
  int kill(int signal);
  /// CPU time (user + system, all threads) the process has used so far [ms], from /proc.
  double cpuMs() const;
  /// Resident set size [MB] from /proc.
  double rssMb() const;

 private:
  pid_t pid_ = -1;
  std::filesystem::path log_;
  std::string target_;
};

// Trajectory format of every request (--format): compact knots, as the robot client asks, knots
// or dense.
extern v1::TrajectoryFormat g_format;

// What a client does with a response besides parsing it: compact knots are expanded to the
// TrajectoryKnots it interpolates (planner_client/compact_knots.h). False if they do not expand.
bool useResponse(const v1::PlanJumpResponse& response);

// A response message parsed on an arena whose first block is reused call after call, as a
// client that cares for its CPU parses: a plain message's Clear() (which every parse starts
// with) deletes its sub-messages and the parse allocates them again, 2-3 us per hit answer in
// `perf record` (docs/service.md, "Where a hot hit's CPU goes"). Used alike by the hit and the
// floor clients.
template <class Message>
class ArenaResponse {
 public:
  ArenaResponse() : block_(std::make_unique<char[]>(kBlockBytes)) {}
  /// An empty message on a fresh arena; the previous one is gone.
  Message* fresh() {
    arena_.reset();
    google::protobuf::ArenaOptions options;
    options.initial_block = block_.get();
    options.initial_block_size = kBlockBytes;
    arena_.emplace(options);
    message_ = google::protobuf::Arena::CreateMessage<Message>(&*arena_);
    return message_;
  }
  const Message& get() const { return *message_; }

 private:
  static constexpr std::size_t kBlockBytes = 64 * 1024;  // a compact or knots answer fits
  std::unique_ptr<char[]> block_;
  std::optional<google::protobuf::Arena> arena_;
  Message* message_ = nullptr;
};

v1::PlanJumpRequest standing(double v0, double height);

// Sample period of the returned trajectories of every server started here (--output-dt-s).
extern double g_output_dt_s;
// cache.hot_responses_mb of the hit benchmark's server (0: every hit regenerated), by default
// the service's (64).
extern double g_hot_responses_mb;
// Whether the hit part also measures the other path in the same run: the regenerated one
// (cache_hits_regenerated) with the hot tier on, the hot tier (cache_hits_hot_tier, 64 MB) with
// --hot-responses-mb 0.
extern bool g_both_hit_paths;
/// Rounds of the hit benchmark (`--hit-rounds`): the four loops alternate this many times.
extern int g_hit_rounds;

wj::server::ServerConfig baseConfig(const std::filesystem::path& dir);
std::filesystem::path writeFastPlannerSettings(const std::filesystem::path& dir);

// --- the parts (bench_server_hits.cpp) --------------------------------------------------------
// 1. Cache hits: N closed-loop clients against a warmed server, with `hot_mb` of hot tier.
json benchHits(const std::filesystem::path& dir, int clients, double seconds, double hot_mb);
// The stages of one cache hit, timed one by one on this thread.
json benchHitBreakdown(const std::filesystem::path& dir, int iterations);

// --- the parts (bench_server_scenarios.cpp) ---------------------------------------------------
// 2. Cold plans (verified unless `verification` is false) with `deadline`.
json benchCold(const std::filesystem::path& dir, int plans, std::chrono::milliseconds deadline,
               const std::string& name, bool verification = true, bool sagittal = true);
// 3. kill -9 during cache writes, `rounds` times.
json benchKill(const std::filesystem::path& dir, int rounds, std::uint32_t seed);
// 4. Resident memory with `entries` cached entries.
json benchMemory(const std::filesystem::path& dir, int entries);
// The second-level lookups against a running Redis at `host:port`.
json benchRedis(const std::string& address, int ops);

}  // namespace wj::server_bench
