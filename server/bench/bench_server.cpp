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

namespace {

namespace v1 = wheeljump::planner::v1;
using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;
using json = nlohmann::json;

double msSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, rank == 0 ? 0 : rank - 1)];
}

json latencyJson(const std::vector<double>& ms) {
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
         const std::string& name) {
    const auto config_path = dir / (name + ".yaml");
    std::ofstream(config_path) << config.toYaml();
    log_ = dir / (name + ".log");
    std::filesystem::remove(log_);
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      // As deployed (docs/planner.md, "Threads"): DE threads sleep at their barriers.
      ::setenv("OMP_WAIT_POLICY", "passive", 0);
      ::execl(WJ_PLANNER_SERVER_BIN, WJ_PLANNER_SERVER_BIN, "--config", config_path.c_str(),
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
    const auto until = Clock::now() + 120s;
    while (Clock::now() < until) {
      std::ifstream in(log_);
      std::stringstream ss;
      ss << in.rdbuf();
      const std::string text = ss.str();
      const auto at = text.find("listening on ");
      const auto eol = at == std::string::npos ? at : text.find('\n', at);
      if (eol != std::string::npos) {
        const std::string address = text.substr(at + 13, eol - at - 13);
        target_ = address;
        return;
      }
      int status = 0;
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("planner_server exited at start:\n" + text);
      }
      std::this_thread::sleep_for(20ms);
    }
    kill(SIGKILL);
    throw std::runtime_error("planner_server did not start");
  }
  ~Server() { kill(SIGKILL); }
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  const std::string& target() const { return target_; }
  /// Sends `signal` and waits for the exit; returns the exit code (128 + signal if killed).
  int kill(int signal) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, signal);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  /// CPU time (user + system, all threads) the process has used so far [ms], from /proc.
  double cpuMs() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/stat");
    std::string text;
    std::getline(in, text);
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    std::istringstream fields(text.substr(text.rfind(')') + 2));
    std::string field;
    double ticks = 0.0;
    for (int i = 3; i <= 15 && fields >> field; ++i)
      if (i >= 14) ticks += std::stod(field);
    return ticks * 1000.0 / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }
  /// Resident set size [MB] from /proc.
  double rssMb() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
    std::string line;
    while (std::getline(in, line))
      if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return -1.0;
  }

 private:
  pid_t pid_ = -1;
  std::filesystem::path log_;
  std::string target_;
};

// Trajectory format of every request (--format): compact knots, as the robot client asks, knots
// or dense.
v1::TrajectoryFormat g_format = v1::TRAJECTORY_FORMAT_COMPACT_KNOTS;

// What a client does with a response besides parsing it: compact knots are expanded to the
// TrajectoryKnots it interpolates (planner_client/compact_knots.h). False if they do not expand.
bool useResponse(const v1::PlanJumpResponse& response) {
  if (!response.plan().has_compact_knots()) return true;
  thread_local v1::TrajectoryKnots knots;
  return wj::client::expandKnots(response.plan().compact_knots(), &knots).empty();
}

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

v1::PlanJumpRequest standing(double v0, double height) {
  v1::PlanJumpRequest r;
  auto* s = r.mutable_state();
  s->mutable_base_orientation_w()->set_w(1.0);
  s->mutable_base_linear_velocity_w_m_s()->set_x(v0);
  for (int leg = 0; leg < 4; ++leg) {
    for (const double q : {0.0, 1.0, -2.0, 0.0}) s->add_joint_positions_rad(q);
    for (int j = 0; j < 4; ++j) s->add_joint_velocities_rad_s(0.0);
  }
  auto* t = r.mutable_task();
  t->set_target_height_m(height);
  t->set_event(v1::TARGET_EVENT_APEX);
  t->set_takeoff_mode(v1::TAKEOFF_MODE_SIMULTANEOUS);
  r.set_request_id("bench");
  r.set_trajectory_format(g_format);
  return r;
}

// Sample period of the returned trajectories of every server started here (--output-dt-s).
double g_output_dt_s = 0.002;
// cache.hot_responses_mb of the hit benchmark's server (0: every hit regenerated), by default
// the service's (64).
double g_hot_responses_mb = wj::server::CacheConfig{}.hot_responses_mb;
// Whether the hit part also measures the other path in the same run: the regenerated one
// (cache_hits_regenerated) with the hot tier on, the hot tier (cache_hits_hot_tier, 64 MB) with
// --hot-responses-mb 0.
bool g_both_hit_paths = true;

wj::server::ServerConfig baseConfig(const std::filesystem::path& dir) {
  wj::server::ServerConfig c;
  c.planner.output_dt_s = g_output_dt_s;
  c.listen = "127.0.0.1:0";
  c.log_level = "warn";
  c.cache.path = (dir / "cache.sqlite").string();
  return c;
}

std::filesystem::path writeFastPlannerSettings(const std::filesystem::path& dir) {
  const auto p = dir / "planner_fast.yaml";
  std::ofstream(p) << "de:\n  population_size: 16\n  max_generations: 40\n"
                      "  max_evaluations: 640\n  stagnation_generations: 15\n"
                      "polish:\n  enabled: false\n";
  return p;
}

// --- 1. cache hits ------------------------------------------------------------------------
// CPU time (user + system, all threads) of this process so far [ms].
double selfCpuMs() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  const auto ms = [](const timeval& t) { return t.tv_sec * 1e3 + t.tv_usec / 1e3; };
  return ms(u.ru_utime) + ms(u.ru_stime);
}

// A robot's requests for one jump, as it sends them: the state it measured when it asked, which
// differs from one request to the next, but stays inside one cache bin of the default bins
// (docs/service.md, "Cache"), so that each request is a hit and none is a copy of an earlier
// one. Inside the key, the run-up speed varies within +-0.48 of its bin around the bin centre,
// the pitch, pitch rate and HAA/HFE/KFE angles within +-0.45 of theirs; outside it, everything
// a real robot's state has varies freely: heading, position, roll, lateral and vertical speed,
// roll and yaw rates, the joint speeds (the wheels roll at v0 / r), the wheel angles, the time
// stamp and the request id. The task is the robot's command and does not vary.
class BinnedRequests {
 public:
  BinnedRequests(double v0_centre, double height, double wheel_radius, std::uint32_t seed)
      : v0_(v0_centre),
        wheel_radius_(wheel_radius),
        rng_(seed),
        id_("bench-" + std::to_string(seed)) {
    request_ = standing(v0_centre, height);
    centre_ = request_;
    centre_.set_request_id(id_ + "-centre");
  }
  /// The request at the centre of the bin (the one the cache is warmed with).
  const v1::PlanJumpRequest& centre() const { return centre_; }
  /// The next request: a new state inside the bin.
  const v1::PlanJumpRequest& next() {
    const wj::server::CacheConfig bins;  // the defaults, as the benchmark's servers use
    const auto inside = [&](double bin, double share) {
      return uniform(-share * bin, share * bin);
    };
    const double v0 = v0_ + inside(bins.v0_bin_m_s, 0.48);
    const double pitch = inside(bins.pitch_bin_rad, 0.45);
    const double pitch_rate = inside(bins.pitch_rate_bin_rad_s, 0.45);
    const double yaw = uniform(-M_PI, M_PI), roll = uniform(-0.01, 0.01);
    auto* s = request_.mutable_state();
    s->set_stamp_s(s->stamp_s() + 0.02);
    s->mutable_base_position_w_m()->set_x(uniform(-20.0, 20.0));
    s->mutable_base_position_w_m()->set_y(uniform(-20.0, 20.0));
    s->mutable_base_position_w_m()->set_z(uniform(0.40, 0.44));
    // Nose-up pitch is a rotation about -y of the base.
    const Eigen::Quaterniond q_WB = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
    auto* q = s->mutable_base_orientation_w();
    q->set_w(q_WB.w());
    q->set_x(q_WB.x());
    q->set_y(q_WB.y());
    q->set_z(q_WB.z());
    // v0 is the speed along the heading; a little sideways and vertical speed besides.
    const double side = uniform(-0.02, 0.02);
    auto* v = s->mutable_base_linear_velocity_w_m_s();
    v->set_x(std::cos(yaw) * v0 - std::sin(yaw) * side);
    v->set_y(std::sin(yaw) * v0 + std::cos(yaw) * side);
    v->set_z(uniform(-0.02, 0.02));
    auto* w = s->mutable_base_angular_velocity_b_rad_s();
    w->set_x(uniform(-0.05, 0.05));
    w->set_y(-pitch_rate);
    w->set_z(uniform(-0.05, 0.05));
    static constexpr std::array<double, 3> kStand = {0.0, 1.0, -2.0};  // HAA, HFE, KFE
    for (int leg = 0; leg < 4; ++leg) {
      for (int j = 0; j < 3; ++j) {
        s->set_joint_positions_rad(
            4 * leg + j, kStand[static_cast<std::size_t>(j)] + inside(bins.posture_bin_rad, 0.45));
        s->set_joint_velocities_rad_s(4 * leg + j, uniform(-0.05, 0.05));
      }
      s->set_joint_positions_rad(4 * leg + 3, uniform(-M_PI, M_PI));
      s->set_joint_velocities_rad_s(4 * leg + 3, v0 / wheel_radius_ + uniform(-0.2, 0.2));
    }
    request_.set_request_id(id_ + "-" + std::to_string(++count_));
    return request_;
  }

 private:
  double uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(rng_);
  }

  double v0_;
  double wheel_radius_;
  std::mt19937 rng_;
  std::string id_;
  std::uint64_t count_ = 0;
  v1::PlanJumpRequest request_;  ///< the last drawn
  v1::PlanJumpRequest centre_;
};

// The bin centres of the hit benchmark's clients: 0, 0.1, 0.2, ... m/s.
double clientV0(int i) {
  return 0.1 * i;
}

// What a closed loop of clients measured over its timed part.
struct ClosedLoop {
  std::vector<double> ms;  ///< every round trip
  double elapsed_s = 0.0, server_cpu_ms = 0.0, client_cpu_ms = 0.0;
  long errors = 0;
};

// CLOCK_MONOTONIC [s], the clock of `perf record -k CLOCK_MONOTONIC`.
double monotonicS() {
  timespec t{};
  ::clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) / 1e9;
}

// The timed part of a closed loop on stderr, as `perf report --time START,END` takes it, so that
// a profile of the whole benchmark can be cut to one loop (docs/service.md, "Profiling a hit").
void markPhase(const char* tag, double start_s, double end_s) {
  std::fprintf(stderr, "phase %s %.6f,%.6f\n", tag, start_s, end_s);
}

// Client `i`'s stub on its own connection (`tag` keeps gRPC from sharing one).
std::unique_ptr<v1::JumpPlanner::Stub> clientStub(Server& server, const char* tag, int i) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(16 * 1024 * 1024);
  args.SetInt(tag, i);
  return v1::JumpPlanner::NewStub(
      grpc::CreateCustomChannel(server.target(), grpc::InsecureChannelCredentials(), args));
}

// `clients` threads, each on its own connection (`tag` keeps gRPC from sharing one), call
// `call(stub, client)` back to back for `seconds` after one untimed call each; `call` returns
// false on an error. Round trips and the server's and the clients' CPU over the timed part.
template <class Call>
ClosedLoop runClosedLoop(Server& server, int clients, double seconds, const char* tag, Call call) {
  std::vector<std::vector<double>> per_thread(static_cast<std::size_t>(clients));
  std::atomic<int> ready{0};
  std::atomic<bool> go{false};
  std::atomic<long> errors{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back([&, i] {
      auto stub = clientStub(server, tag, i);
      (void)call(*stub, i);  // connect before the clock starts
      ++ready;
      while (!go.load()) std::this_thread::yield();
      const auto end = Clock::now() + std::chrono::duration<double>(seconds);
      auto& out = per_thread[static_cast<std::size_t>(i)];
      while (Clock::now() < end) {
        const auto t0 = Clock::now();
        const bool ok = call(*stub, i);
        out.push_back(msSince(t0));
        if (!ok) ++errors;
      }
    });
  }
  while (ready.load() < clients) std::this_thread::sleep_for(1ms);
  const double server_cpu0 = server.cpuMs(), client_cpu0 = selfCpuMs();
  const auto t0 = Clock::now();
  const double mark0 = monotonicS();
  go = true;
  for (auto& t : threads) t.join();
  markPhase(tag, mark0, monotonicS());
  ClosedLoop r;
  r.elapsed_s = msSince(t0) / 1e3;
  r.server_cpu_ms = server.cpuMs() - server_cpu0;
  r.client_cpu_ms = selfCpuMs() - client_cpu0;
  for (const auto& v : per_thread) r.ms.insert(r.ms.end(), v.begin(), v.end());
  r.errors = errors.load();
  return r;
}

// The same closed loop without a client thread per call in flight: `clients` chains, each on
// its own connection, driven by gRPC's callback API; each chain issues its next call from the
// completion of the previous one. `start(stub, ctx, client, done)` starts one call and calls
// done(ok) when it completes.
template <class Start>
ClosedLoop runCallbackLoop(Server& server, int clients, double seconds, const char* tag,
                           Start start) {
  struct Chain {
    std::unique_ptr<v1::JumpPlanner::Stub> stub;
    std::unique_ptr<grpc::ClientContext> ctx;
    std::vector<double> ms;
    Clock::time_point t0;
  };
  std::vector<Chain> chains(static_cast<std::size_t>(clients));
  std::mutex mutex;
  std::condition_variable cv;
  int finished = 0;
  std::atomic<long> errors{0};
  std::atomic<bool> timed{false};
  // End of the timed part (written by this thread, read in the completions).
  std::atomic<Clock::rep> end{Clock::time_point::max().time_since_epoch().count()};
  auto before_end = [&end] { return Clock::now().time_since_epoch().count() < end.load(); };
  auto at = [](double s_from_now) {
    return (Clock::now() +
            std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s_from_now)))
        .time_since_epoch()
        .count();
  };
  std::function<void(int)> issue = [&](int i) {
    Chain& c = chains[static_cast<std::size_t>(i)];
    c.ctx = std::make_unique<grpc::ClientContext>();
    c.ctx->set_deadline(std::chrono::system_clock::now() + 5s);
    c.t0 = Clock::now();
    start(*c.stub, c.ctx.get(), i, [&, i](bool ok) {
      Chain& done = chains[static_cast<std::size_t>(i)];
      const bool counting = timed.load();
      if (counting) {
        done.ms.push_back(msSince(done.t0));
        if (!ok) ++errors;
      }
      if (!counting || before_end()) {
        issue(i);
      } else {
        const std::lock_guard<std::mutex> lock(mutex);
        ++finished;
        cv.notify_all();
      }
    });
  };
  for (int i = 0; i < clients; ++i) {
    chains[static_cast<std::size_t>(i)].stub = clientStub(server, tag, i);
  }
  // Untimed: every chain connects and runs for a moment before the clock starts.
  for (int i = 0; i < clients; ++i) issue(i);
  std::this_thread::sleep_for(300ms);
  const double server_cpu0 = server.cpuMs(), client_cpu0 = selfCpuMs();
  const auto t0 = Clock::now();
  const double mark0 = monotonicS();
  end = at(seconds);
  timed = true;
  {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait(lock, [&] { return finished == clients; });
  }
  markPhase(tag, mark0, monotonicS());
  ClosedLoop r;
  r.elapsed_s = msSince(t0) / 1e3;
  r.server_cpu_ms = server.cpuMs() - server_cpu0;
  r.client_cpu_ms = selfCpuMs() - client_cpu0;
  for (const auto& c : chains) r.ms.insert(r.ms.end(), c.ms.begin(), c.ms.end());
  r.errors = errors.load();
  return r;
}

// Throughput and CPU per request of a closed loop, with its latency percentiles.
json loopJson(const ClosedLoop& r) {
  const auto n = static_cast<double>(std::max<std::size_t>(r.ms.size(), 1));
  json j = latencyJson(r.ms);
  j["duration_s"] = r.elapsed_s;
  j["throughput_req_s"] = static_cast<double>(r.ms.size()) / r.elapsed_s;
  j["errors"] = r.errors;
  j["server_cpu_us_per_request"] = r.server_cpu_ms * 1e3 / n;
  j["client_cpu_us_per_request"] = r.client_cpu_ms * 1e3 / n;
  j["cpu_cores_busy"] = (r.server_cpu_ms + r.client_cpu_ms) / 1e3 / r.elapsed_s;
  return j;
}

// The transport's own cost on this machine, the peer of the hit figures: the same clients on
// their own connections calling GetStats (answered in the service's reactor, no planning, a
// ~150-byte response) as fast as they can for `seconds`.
json benchGrpcFloor(Server& server, int clients, double seconds) {
  json j = loopJson(runClosedLoop(
      server, clients, seconds, "wj.bench.floor_client", [](v1::JumpPlanner::Stub& stub, int) {
        grpc::ClientContext ctx;
        ctx.set_deadline(std::chrono::system_clock::now() + 5s);
        thread_local ArenaResponse<v1::GetStatsResponse> response;
        return stub.GetStats(&ctx, v1::GetStatsRequest{}, response.fresh()).ok();
      }));
  j["rpc"] = "GetStats";
  // The same with callback-API clients (no client thread per call in flight).
  std::vector<ArenaResponse<v1::GetStatsResponse>> responses(static_cast<std::size_t>(clients));
  const v1::GetStatsRequest request;
  j["callback_clients"] = loopJson(runCallbackLoop(
      server, clients, seconds, "wj.bench.floor_callback",
      [&](v1::JumpPlanner::Stub& stub, grpc::ClientContext* ctx, int i, auto done) {
        stub.async()->GetStats(ctx, &request, responses[static_cast<std::size_t>(i)].fresh(),
                               [done](const grpc::Status& s) { done(s.ok()); });
      }));
  return j;
}

json benchHits(const std::filesystem::path& dir, int clients, double seconds, double hot_mb) {
  auto config = baseConfig(dir);
  config.cache.path.clear();
  config.planner.settings_file = writeFastPlannerSettings(dir).string();
  config.verification.enabled = false;
  config.executor.hit_workers = 2;
  config.cache.hot_responses_mb = hot_mb;
  Server server(config, dir, "hits");
  const double wheel_radius = wj::model::RobotModel::loadDefault().wheelRadius();
  std::vector<BinnedRequests> generators;
  {
    wj::client::PlannerClient warm([&] {
      wj::client::ClientOptions o;
      o.target = server.target();
      return o;
    }());
    for (int i = 0; i < clients; ++i) {
      generators.emplace_back(clientV0(i), 0.8, wheel_radius, static_cast<std::uint32_t>(i + 1));
      const auto r = warm.planJump(generators.back().centre(), 60s).get();
      if (!r.ok()) throw std::runtime_error("warm-up plan failed: " + r.status.error_message());
    }
  }
  // Each client's requests, drawn before the clock starts: kRing new states inside its bin,
  // sent in turn, so that the timed loops measure what a robot client does per call (serialize
  // the request, parse the answer, check its source and expand its knots), not the generator's
  // random numbers and trigonometry (2-3 us per call in `perf record`).
  constexpr std::size_t kRing = 512;
  std::vector<std::vector<v1::PlanJumpRequest>> rings(static_cast<std::size_t>(clients));
  for (int i = 0; i < clients; ++i) {
    auto& ring = rings[static_cast<std::size_t>(i)];
    ring.reserve(kRing);
    for (std::size_t k = 0; k < kRing; ++k)
      ring.push_back(generators[static_cast<std::size_t>(i)].next());
  }
  std::vector<std::size_t> sent(static_cast<std::size_t>(clients), 0);
  const auto nextRequest = [&](int i) -> const v1::PlanJumpRequest& {
    const auto c = static_cast<std::size_t>(i);
    return rings[c][sent[c]++ % kRing];
  };
  std::atomic<long> not_hits{0}, ready{0}, sized{0}, bytes_total{0}, bytes_min{1L << 40},
      bytes_max{0};
  std::vector<long> answered(static_cast<std::size_t>(clients), 0);
  std::vector<ArenaResponse<v1::PlanJumpResponse>> responses(static_cast<std::size_t>(clients));
  const ClosedLoop loop = runClosedLoop(
      server, clients, seconds, "wj.bench.client", [&](v1::JumpPlanner::Stub& stub, int i) {
        auto& slot = responses[static_cast<std::size_t>(i)];
        grpc::ClientContext ctx;
        ctx.set_deadline(std::chrono::system_clock::now() + 5s);
        const bool first = answered[static_cast<std::size_t>(i)]++ == 0;
        const grpc::Status s = stub.PlanJump(
            &ctx, first ? generators[static_cast<std::size_t>(i)].centre() : nextRequest(i),
            slot.fresh());
        const v1::PlanJumpResponse& response = slot.get();
        if (!s.ok() || first) return s.ok();
        if (response.source() != v1::PLAN_SOURCE_CACHE_HIT || !useResponse(response)) ++not_hits;
        if (response.ready_response()) ++ready;
        if (answered[static_cast<std::size_t>(i)] % 16 != 2) return true;  // every 16th: sized
        ++sized;
        const auto n = static_cast<long>(response.ByteSizeLong());
        bytes_total += n;
        long seen = bytes_min.load();
        while (n < seen && !bytes_min.compare_exchange_weak(seen, n)) {
        }
        seen = bytes_max.load();
        while (n > seen && !bytes_max.compare_exchange_weak(seen, n)) {
        }
        return true;
      });
  const long sampled = sized.load();
  const double throughput = static_cast<double>(loop.ms.size()) / loop.elapsed_s;
  json j = loopJson(loop);
  j["clients"] = clients;
  j["output_dt_s"] = config.planner.output_dt_s;
  j["hot_responses_mb"] = hot_mb;
  j["not_hits"] = not_hits.load();
  j["ready_responses"] = ready.load();  // answered by the hot tier (ready_response)
  j["errors_or_not_hits"] = loop.errors + not_hits.load();
  j["response_bytes"] = sampled > 0 ? bytes_total.load() / sampled : 0;
  j["response_bytes_min"] = sampled > 0 ? bytes_min.load() : 0;
  j["response_bytes_max"] = bytes_max.load();
  j["target_p99_ms"] = 1.0;
  j["target_throughput_req_s"] = 10000.0;
  j["meets_p99_target"] = percentile(loop.ms, 0.99) <= 1.0;
  j["meets_throughput_target"] = throughput >= 10000.0;
  // The same hits from callback-API clients (no client thread per call in flight): what the
  // service answers when the clients cost less, against the floor's callback_clients.
  std::atomic<long> callback_not_hits{0}, callback_ready{0};
  const ClosedLoop callback = runCallbackLoop(
      server, clients, seconds, "wj.bench.client_callback",
      [&](v1::JumpPlanner::Stub& stub, grpc::ClientContext* ctx, int i, auto done) {
        v1::PlanJumpResponse* answer = responses[static_cast<std::size_t>(i)].fresh();
        stub.async()->PlanJump(ctx, &nextRequest(i), answer,
                               [done, &response = *answer, &callback_not_hits,
                                &callback_ready](const grpc::Status& s) {
                                 if (s.ok() && (response.source() != v1::PLAN_SOURCE_CACHE_HIT ||
                                                !useResponse(response)))
                                   ++callback_not_hits;
                                 if (s.ok() && response.ready_response()) ++callback_ready;
                                 done(s.ok());
                               });
      });
  j["callback_clients"] = loopJson(callback);
  j["callback_clients"]["not_hits"] = callback_not_hits.load();
  j["callback_clients"]["ready_responses"] = callback_ready.load();
  j["grpc_floor"] = benchGrpcFloor(server, clients, seconds);
  return j;
}

// CPU time of the calling thread [us] (immune to other processes sharing the cores).
double threadCpuUs() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e6 + static_cast<double>(t.tv_nsec) / 1e3;
}

// Where a response's bytes go: the serialized size of the fields that carry any (without the
// tag and length of each field, so the parts add up to a little less than the total).
json responseFieldBytes(const v1::PlanJumpResponse& r) {
  const auto& p = r.plan();
  const auto& k = p.knots();
  const auto packed = [](int n, long each) { return static_cast<long>(n) * each; };
  const auto sum = [](const auto& messages) {
    long n = 0;
    for (const auto& m : messages) n += static_cast<long>(m.ByteSizeLong());
    return n;
  };
  json j;
  j["total"] = r.ByteSizeLong();
  j["plan"] = p.ByteSizeLong();
  j["plan.phase_times"] = p.phase_times().ByteSizeLong();
  j["plan.force_phases"] = sum(p.force_phases());
  j["plan.decision_vector"] = packed(p.decision_vector_size(), 8);
  j["plan.joints"] = p.joints().ByteSizeLong();
  j["plan.centroidal_trajectory"] = sum(p.centroidal_trajectory());
  j["plan.knots"] = k.ByteSizeLong();
  j["plan.knots.t_s"] = packed(k.t_s_size(), 8);
  j["plan.knots.centroidal"] = packed(k.centroidal_size(), 4);
  j["plan.knots.positions_rad"] = packed(k.positions_rad_size(), 4);
  j["plan.knots.velocities_rad_s"] = packed(k.velocities_rad_s_size(), 4);
  j["plan.knots.torques_nm"] = packed(k.torques_nm_size(), 4);
  const auto& c = p.compact_knots();
  j["plan.compact_knots"] = c.ByteSizeLong();
  j["plan.compact_knots.t_s"] = packed(c.t_s_size(), 8);
  j["plan.compact_knots.centroidal"] = packed(c.centroidal_size(), 4);
  j["plan.compact_knots.positions_rad"] = c.positions_rad().ByteSizeLong();
  j["plan.compact_knots.velocities_rad_s"] = c.velocities_rad_s().ByteSizeLong();
  j["plan.compact_knots.torques_nm"] = c.torques_nm().ByteSizeLong();
  j["predicted"] = r.predicted().ByteSizeLong();
  j["feasibility"] = r.feasibility().ByteSizeLong();
  j["feasibility.margins"] = sum(r.feasibility().margins());
  j["feasibility.summary"] = r.feasibility().summary().size();
  j["verification"] = r.verification().ByteSizeLong();
  j["stats"] = r.stats().ByteSizeLong();
  j["request_id"] = r.request_id().size();
  return j;
}

// The stages of one cache hit, timed one by one on this thread in thread CPU time (median over
// `iterations` requests of one bin): what the server and the client spend apart from the
// transport.
json benchHitBreakdown(const std::filesystem::path& dir, int iterations) {
  namespace planner = wj::planner;
  const auto robot = wj::model::RobotModel::loadDefault();
  auto settings = planner::PlannerSettings::fromYaml(writeFastPlannerSettings(dir));
  if (g_output_dt_s > 0.0) settings.output_dt_s = g_output_dt_s;  // as the servers do
  const planner::JumpPlanner jump_planner(robot, settings);
  BinnedRequests generator(0.3, 0.8, robot.wheelRadius(), 7);
  // The cached solution: planned at the bin centre, as the warm-up of the hit benchmark does.
  const auto centre = wj::server::toPlanRequest(generator.centre(), robot);
  planner::PlanOptions options;
  options.threads = 1;
  const Eigen::VectorXd u = jump_planner.plan(centre.task, centre.initial, options).u;

  std::map<std::string, std::vector<double>> us;
  const auto time = [&](const std::string& stage, auto&& f) {
    const double t0 = threadCpuUs();
    f();
    us[stage].push_back(threadCpuUs() - t0);
  };
  v1::PlanJumpResponse parsed;  // the client's, reused as the benchmark's clients do
  long bytes = 0;
  for (int i = 0; i < iterations; ++i) {
    const std::string wire_request = generator.next().SerializeAsString();
    v1::PlanJumpRequest request;
    wj::server::PlanRequest r;
    time("request_parse_validate", [&] {
      request.ParseFromString(wire_request);
      r = wj::server::toPlanRequest(request, robot);
    });
    wj::server::PlanAnswer a;
    std::optional<planner::JumpModel> model;
    time("model", [&] { model.emplace(robot, settings, r.task, r.initial); });
    time("evaluate", [&] { model->evaluate(u, a.evaluation); });
    time("build_plan", [&] {
      a.plan = wj::server::asKnots(r.trajectory) ? model->buildKnots(u, &a.evaluation)
                                                 : model->buildPlan(u, &a.evaluation);
    });
    time("describe", [&] {
      wj::server::describeEvaluation(a.evaluation, settings.polish_backoff, a.binding, a.summary);
    });
    // On an arena with the server's block sizes (grpc_service.cpp), as the server builds it.
    google::protobuf::ArenaOptions arena_options;
    arena_options.start_block_size = 4 * 1024;
    arena_options.max_block_size = 64 * 1024;
    std::optional<google::protobuf::Arena> arena(std::in_place, arena_options);
    auto* response = google::protobuf::Arena::CreateMessage<v1::PlanJumpResponse>(&*arena);
    time("to_proto", [&] { wj::server::toProto(a, robot, r.request_id, r.trajectory, response); });
    std::string wire;
    time("serialize", [&] { response->SerializeToString(&wire); });
    time("free_response", [&] { arena.reset(); });
    time("free_plan", [&] { a = wj::server::PlanAnswer{}; });
    time("client_parse", [&] { parsed.ParseFromString(wire); });
    time("client_expand", [&] { (void)useResponse(parsed); });
    bytes = static_cast<long>(wire.size());
    // A hot hit's own work in the service, the way of session 11 (stamp the entry by encoding
    // it, copy the ready message onto the call's arena, set the caller's fields, serialize
    // into gRPC's buffer) against this one (ready bytes shared, a suffix of the caller's fields).
    wj::server::CachedSolution entry;
    std::copy(u.data(), u.data() + entry.u.size(), entry.u.begin());
    const v1::PlanJumpResponse ready = parsed;
    time("hot_stamp_encode_entry", [&] { wire = wj::server::encodeSolution(entry); });
    time("hot_copy_and_serialize", [&] {
      google::protobuf::Arena hot_arena(arena_options);
      auto* copy = google::protobuf::Arena::CreateMessage<v1::PlanJumpResponse>(&hot_arena);
      copy->CopyFrom(ready);
      copy->set_request_id(r.request_id);
      copy->mutable_stats()->set_total_ms(0.01);
      grpc::ByteBuffer buffer;
      bool own = false;
      (void)grpc::SerializationTraits<v1::PlanJumpResponse>::Serialize(*copy, &buffer, &own);
    });
    v1::PlanJumpResponse stripped = parsed;
    const grpc::Slice ready_slice(wj::server::readyBytes(stripped));
    time("hot_ready_bytes_and_suffix", [&] {
      const std::string suffix = wj::server::readySuffix(r.request_id, 0.01);
      grpc::Slice parts[2] = {ready_slice, grpc::Slice(suffix)};
      grpc::ByteBuffer buffer(parts, 2);
    });
  }
  json j;
  double total = 0.0;
  for (const auto& [stage, v] : us) {
    j["median_us"][stage] = percentile(v, 0.5);
    if (stage.rfind("hot_", 0) != 0) total += percentile(v, 0.5);
  }
  j["median_us_sum"] = total;  // the regenerated hit's stages (not the hot_ ones)
  j["iterations"] = iterations;
  j["response_bytes"] = bytes;
  j["samples"] = parsed.plan().joints().num_samples();
  j["knots"] = std::max(parsed.plan().knots().t_s_size(), parsed.plan().compact_knots().t_s_size());
  j["response_field_bytes"] = responseFieldBytes(parsed);
  j["sample_period_s"] = parsed.plan().joints().sample_period_s();
  return j;
}

// --- 2. cold plans with verification -------------------------------------------------------
json benchCold(const std::filesystem::path& dir, int plans, std::chrono::milliseconds deadline,
               const std::string& name, bool verification = true, bool sagittal = true) {
  auto config = baseConfig(dir);
  config.cache.path.clear();  // every request cold
  config.deadlines.max_s = 120.0;
  config.verification.enabled = verification;
  config.verification.sagittal_model = sagittal;
  Server server(config, dir, name);
  wj::client::ClientOptions o;
  o.target = server.target();
  wj::client::PlannerClient c(o);
  std::vector<double> ms, verify_ms, de_ms;
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
      // Disjoint grids per round, in 0.05 m/s steps over [-1, 4].
      const double lo = -1.0 + 0.05 * ((round * 13) % 90);
      w.set_v0_min_m_s(lo);
      w.set_v0_max_m_s(std::min(4.0, lo + 1.0));
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

}  // namespace

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
