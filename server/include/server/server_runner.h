#pragma once
/// @file planner_server's assembly: robot model, planner settings, verifier, cache and core from
/// the configuration; the gRPC server with TLS, message-size and keepalive limits, the standard
/// health service and server reflection; and the graceful shutdown.

#include <memory>
#include <string>

#include <grpcpp/server.h>

#include "server/config.h"
#include "server/grpc_service.h"
#include "server/planning_core.h"

namespace wj::server {

class PlannerServer {
 public:
  /// Builds everything and starts listening. Throws std::runtime_error (naming the file or
  /// setting) when the configuration cannot be served: unreadable models or settings, TLS files
  /// missing, the port taken.
  explicit PlannerServer(const ServerConfig& config);
  /// Shuts down if still running.
  ~PlannerServer();
  PlannerServer(const PlannerServer&) = delete;
  PlannerServer& operator=(const PlannerServer&) = delete;

  /// The bound port (the chosen one when the configuration asked for port 0).
  int port() const { return port_; }
  /// "host:port" actually listened on.
  std::string address() const;
  /// Graceful shutdown: the health service reports NOT_SERVING, new calls are refused, calls in
  /// flight get shutdown_grace_s to finish and are then cancelled, queued work is abandoned, the
  /// cache is flushed. Idempotent.
  void shutdown();
  PlanningCore& core() { return *core_; }
  /// One line describing the verifier, the cache and the TLS mode, for the start-up log.
  std::string describe() const;

 private:
  ServerConfig config_;
  std::unique_ptr<PlanningCore> core_;
  std::unique_ptr<JumpPlannerService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool stopped_ = false;
};

}  // namespace wj::server
