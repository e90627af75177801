// bench_server, part 1: cache hits (closed loops of clients, the gRPC floor, the hot tier) and
// the breakdown of one hit into its stages (bench_server_common.h).
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
namespace {

using namespace std::chrono_literals;

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
  std::vector<double> ms;                          ///< every round trip
  std::vector<double> round_p50_ms, round_p99_ms;  ///< each round's own (after append)
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
  if (!r.round_p50_ms.empty()) {
    j["round_p50_ms"] = r.round_p50_ms;
    j["round_p99_ms"] = r.round_p99_ms;
  }
  return j;
}

// The transport's own cost on this machine, the peer of the hit figures: the same clients on
// their own connections calling GetStats (answered in the service's reactor, no planning, a
// ~150-byte response) as fast as they can for `seconds`.
ClosedLoop runFloorSync(Server& server, int clients, double seconds) {
  return runClosedLoop(server, clients, seconds, "wj.bench.floor_client",
                       [](v1::JumpPlanner::Stub& stub, int) {
                         grpc::ClientContext ctx;
                         ctx.set_deadline(std::chrono::system_clock::now() + 5s);
                         thread_local ArenaResponse<v1::GetStatsResponse> response;
                         return stub.GetStats(&ctx, v1::GetStatsRequest{}, response.fresh()).ok();
                       });
}

// The same with callback-API clients (no client thread per call in flight).
ClosedLoop runFloorCallback(Server& server, int clients, double seconds) {
  std::vector<ArenaResponse<v1::GetStatsResponse>> responses(static_cast<std::size_t>(clients));
  const v1::GetStatsRequest request;
  return runCallbackLoop(
      server, clients, seconds, "wj.bench.floor_callback",
      [&](v1::JumpPlanner::Stub& stub, grpc::ClientContext* ctx, int i, auto done) {
        stub.async()->GetStats(ctx, &request, responses[static_cast<std::size_t>(i)].fresh(),
                               [done](const grpc::Status& s) { done(s.ok()); });
      });
}

// Appends one round's timed part to the loop's total.
void append(ClosedLoop& total, const ClosedLoop& round) {
  total.round_p50_ms.push_back(percentile(round.ms, 0.5));
  total.round_p99_ms.push_back(percentile(round.ms, 0.99));
  total.ms.insert(total.ms.end(), round.ms.begin(), round.ms.end());
  total.elapsed_s += round.elapsed_s;
  total.server_cpu_ms += round.server_cpu_ms;
  total.client_cpu_ms += round.client_cpu_ms;
  total.errors += round.errors;
}

}  // namespace

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
  const auto hitCall = [&](v1::JumpPlanner::Stub& stub, int i) {
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
  };
  std::atomic<long> callback_not_hits{0}, callback_ready{0};
  const auto hitCallback = [&](v1::JumpPlanner::Stub& stub, grpc::ClientContext* ctx, int i,
                               auto done) {
    v1::PlanJumpResponse* answer = responses[static_cast<std::size_t>(i)].fresh();
    stub.async()->PlanJump(
        ctx, &nextRequest(i), answer,
        [done, &response = *answer, &callback_not_hits, &callback_ready](const grpc::Status& s) {
          if (s.ok() && (response.source() != v1::PLAN_SOURCE_CACHE_HIT || !useResponse(response)))
            ++callback_not_hits;
          if (s.ok() && response.ready_response()) ++callback_ready;
          done(s.ok());
        });
  };
  // The hits and the empty RPC, from synchronous and from callback clients, alternate in
  // short rounds on the same server, so that the VM's steal and any other load land in
  // all four alike (one after the other, 5 s each, a callback ratio ranged 0.44-1.20 over three
  // idle runs). Each figure is over its rounds together. Session 17: a round of callback clients
  // settles in one of two regimes, for hits and GetStats alike (p50 0.5 ms, p99 1 ms and more CPU
  // per call; or p50 0.23 ms, p99 2.5 ms and less CPU), so ten rounds left the mix of regimes,
  // and the ratios, to chance (callback p99 ratio 0.58-2.31 over six idle runs); 30 shorter
  // rounds by default (`--hit-rounds`), each round's p50 and p99 in the JSON.
  const int rounds = g_hit_rounds;
  const double round_s = seconds / rounds;
  ClosedLoop loop, callback, floor_sync, floor_callback;
  for (int r = 0; r < rounds; ++r) {
    append(loop, runClosedLoop(server, clients, round_s, "wj.bench.client", hitCall));
    append(floor_sync, runFloorSync(server, clients, round_s));
    append(callback,
           runCallbackLoop(server, clients, round_s, "wj.bench.client_callback", hitCallback));
    append(floor_callback, runFloorCallback(server, clients, round_s));
  }
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
  j["callback_clients"] = loopJson(callback);
  j["callback_clients"]["not_hits"] = callback_not_hits.load();
  j["callback_clients"]["ready_responses"] = callback_ready.load();
  j["rounds"] = rounds;
  j["grpc_floor"] = loopJson(floor_sync);
  j["grpc_floor"]["rpc"] = "GetStats";
  j["grpc_floor"]["callback_clients"] = loopJson(floor_callback);
  return j;
}

namespace {

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

}  // namespace

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
      grpc::Slice parts[2] = {ready_slice, wj::server::readySuffix(r.request_id, 0.01)};
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

}  // namespace wj::server_bench
