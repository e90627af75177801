#pragma once
/// @file Asynchronous client of the jump planning service for the robot: every call returns at
/// once (a std::future, or a callback run on the client's own completion thread), carries a
/// deadline, and is retried with exponential backoff while the server is UNAVAILABLE (restart,
/// network blip) until the deadline. Depends on the contract (wheeljump.planner.v1) and gRPC
/// only, not on the server.
///
///   wj::client::PlannerClient client({.target = "127.0.0.1:50051"});
///   auto future = client.planJump(request, std::chrono::milliseconds(500));
///   ... // the control loop goes on
///   wj::client::PlanResult r = future.get();  // or poll future.wait_for(0s)
///
/// Callbacks run on the completion thread: they must be short and must not block.

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <string>

#include <grpcpp/support/status.h>

#include "wheeljump/planner/v1/jump_planner.pb.h"

namespace wj::client {

/// TLS material of the client. Files are PEM.
struct ClientTls {
  std::string root_ca_file;          ///< CA that signed the server certificate
  std::string cert_chain_file;       ///< client certificate, for mutual TLS ("" = none)
  std::string private_key_file;      ///< its key
  std::string target_name_override;  ///< expected server name if it differs from the target
};

/// How the channel spreads calls over the addresses its target resolves to.
enum class LoadBalancing {
  PickFirst,   ///< one connection to the first address that answers (gRPC's default)
  RoundRobin,  ///< a connection to every address, calls in turn (several replicas)
};

struct ClientOptions {
  /// gRPC target: "host:port" of one planner_server, or a name resolving to several replicas,
  /// e.g. "dns:///planner-headless.wheeljump.svc.cluster.local:50051" (a Kubernetes headless
  /// Service: one A record per ready pod) or "ipv4:127.0.0.1:50051,127.0.0.1:50052".
  std::string target = "127.0.0.1:50051";
  /// Policy over the resolved addresses, set in the channel's service config
  /// (loadBalancingConfig). Use RoundRobin with a target that resolves to several replicas;
  /// the DNS resolver re-resolves when a connection drops, so a scaled or rescheduled
  /// Deployment is picked up (docs/scaling.md).
  LoadBalancing load_balancing = LoadBalancing::PickFirst;
  std::chrono::milliseconds default_deadline{2000};  ///< for calls given no deadline
  int max_attempts = 5;  ///< attempts per call while the answer is UNAVAILABLE (>= 1)
  std::chrono::milliseconds initial_backoff{50};  ///< wait before the first retry
  std::chrono::milliseconds max_backoff{1000};    ///< longest wait between attempts
  double backoff_multiplier = 2.0;
  /// HTTP/2 keepalive, matching the server's defaults (docs/service.md): a ping every 20 s
  /// (the server allows one every 10 s), 10 s to answer it, also when no call is in flight.
  int keepalive_time_ms = 20000;
  int keepalive_timeout_ms = 10000;
  bool keepalive_permit_without_calls = true;
  int max_receive_message_bytes = 16 * 1024 * 1024;  ///< a plan is about 0.5 MB
  bool use_tls = false;  ///< false: plaintext (the server accepts it on loopback only)
  ClientTls tls;
};

/// The outcome of one call: the final status, the response if OK, and how many attempts it took.
template <typename Response>
struct CallResult {
  grpc::Status status;
  Response response;
  int attempts = 0;
  bool ok() const { return status.ok(); }
};
using PlanResult = CallResult<wheeljump::planner::v1::PlanJumpResponse>;
using StatsResult = CallResult<wheeljump::planner::v1::GetStatsResponse>;
/// The end of a WarmCache stream (the progress messages went to the progress callback).
using WarmResult = CallResult<wheeljump::planner::v1::WarmCacheProgress>;  ///< the last one

class PlannerClient {
 public:
  /// Creates the channel (it connects lazily) and starts the completion thread. Throws
  /// std::runtime_error if TLS files cannot be read.
  explicit PlannerClient(ClientOptions options);
  /// Cancels the calls in flight (their callbacks run with CANCELLED) and joins the thread.
  ~PlannerClient();
  PlannerClient(const PlannerClient&) = delete;
  PlannerClient& operator=(const PlannerClient&) = delete;

  /// Plans a jump; `done` runs on the completion thread.
  void planJump(wheeljump::planner::v1::PlanJumpRequest request,
                std::function<void(PlanResult)> done,
                std::optional<std::chrono::milliseconds> deadline = std::nullopt);
  /// Plans a jump; the future becomes ready when the call ends.
  std::future<PlanResult> planJump(
      wheeljump::planner::v1::PlanJumpRequest request,
      std::optional<std::chrono::milliseconds> deadline = std::nullopt);
  void getStats(std::function<void(StatsResult)> done,
                std::optional<std::chrono::milliseconds> deadline = std::nullopt);
  std::future<StatsResult> getStats(
      std::optional<std::chrono::milliseconds> deadline = std::nullopt);
  /// Precomputes a grid; `progress` runs once per grid point, `done` once at the end.
  void warmCache(wheeljump::planner::v1::WarmCacheRequest request,
                 std::function<void(const wheeljump::planner::v1::WarmCacheProgress&)> progress,
                 std::function<void(WarmResult)> done,
                 std::optional<std::chrono::milliseconds> deadline = std::nullopt);
  /// Cancels every call in flight; each ends with CANCELLED (or its result if it won the race).
  void cancelAll();
  /// Calls started and not yet ended.
  int inflight() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace wj::client
